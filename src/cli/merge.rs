//! `ssskit merge`: combines the shards of one Monte Carlo run (written by
//! `simulate --shard K/N`) into the profile of the single run.

use super::args::{self, CsvArg, OutFile};
use anyhow::Context;
use ssskit::profile::{mc, Profile};
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(mut_arg("out", |a| args::required()(a).help(
    "Output file: the merged profile, .json, bit-identical to the single run \
     (except elapsed_s, the sum of the parts')"
)))]
pub struct Args {
    /// The N partial profiles of one run (any order).
    #[arg(required = true, value_name = "PART.json")]
    parts: Vec<PathBuf>,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    csv: CsvArg,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let out = args.out.path()?;
    ssskit::io::check_extension(out, &["json"], "profile")?;
    if let Some(csv) = &args.csv.csv {
        ssskit::io::check_extension(csv, &["csv"], "table")?;
    }
    // One shard in memory at a time.
    let mut merger = mc::ShardMerger::new();
    for path in &args.parts {
        let p = Profile::read(path)?;
        merger.add(&path.display().to_string(), p)?;
    }
    let profile = merger.finish()?;
    let mut outputs = ssskit::io::AtomicGroup::new();
    profile
        .write_into(&mut outputs, out)
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(csv) = &args.csv.csv {
        super::simulate::write_csv(&profile, csv, &mut outputs)?;
    }
    outputs.commit()?;
    super::simulate::print_summary(&profile, out)
}
