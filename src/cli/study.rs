//! `ssskit study`: the speed/accuracy trade of every knob for one material.

use super::out::out;
use super::profile_source::{command_line, ProfileArgs, ProfileModelArg, ReportArgs};
use anyhow::bail;
use ssskit::report::study::{self, Settings};

#[derive(clap::Args)]
pub struct Args {
    /// Reference profile: --profile FILE (e.g. profiles/reference/skin1.json)
    /// or made from --material (default Monte Carlo to --mc-error).
    #[command(flatten)]
    profile: ProfileArgs,
    #[command(flatten)]
    report: ReportArgs,
    /// Photon counts per channel of the Monte Carlo sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "10000,30000,100000,300000"
    )]
    photons: Vec<u64>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    a.report.check()?;
    if a.photons.is_empty() || a.photons.iter().any(|&n| n == 0 || n > 100_000_000) {
        bail!("--photons: each count must be between 1 and 1e8");
    }
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(&a.report.out)?;
    let t0 = std::time::Instant::now();
    let (reference, source) = a.profile.load(ProfileModelArg::Mc)?;
    eprintln!("{}: reference profile {source}", reference.material.name);
    let settings = Settings {
        mm_per_pixel: a.report.mm_per_pixel,
        size: a.report.size,
        photons: a.photons.clone(),
        ..Settings::default()
    };
    let s = study::run(&reference, &settings, &super::progress::Bar::new())?;
    let files = study::write(
        &s,
        staged.path(),
        &command_line(&a.report.out),
        !a.report.no_plots,
    )?;
    staged.commit()?;
    out!("{}", study::table(&s).markdown())?;
    eprintln!(
        "{} entries in {:.1} s -> {}/{}",
        s.entries.len(),
        t0.elapsed().as_secs_f64(),
        a.report.out.display(),
        files.join(", ")
    );
    Ok(())
}
