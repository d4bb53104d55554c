//! `ssskit merge`: combines the shards of one Monte Carlo run (written by
//! `simulate --shard K/N`) into the profile of the single run.

use anyhow::Context;
use ssskit::profile::{mc, Profile};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The N partial profiles of one run (any order).
    #[arg(required = true, value_name = "PART.json")]
    parts: Vec<PathBuf>,
    /// Output profile JSON: bit-identical to the single run (except
    /// elapsed_s, the sum of the parts').
    #[arg(long, value_name = "FILE.json")]
    out: PathBuf,
    /// Also write the profile as CSV.
    #[arg(long, value_name = "FILE.csv")]
    csv: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    ssskit::io::check_extension(&args.out, &["json"], "profile")?;
    if let Some(csv) = &args.csv {
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
        .write_into(&mut outputs, &args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    if let Some(csv) = &args.csv {
        super::simulate::write_csv(&profile, csv, &mut outputs)?;
    }
    outputs.commit()?;
    super::simulate::print_summary(&profile, &args.out)
}
