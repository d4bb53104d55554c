//! `ssskit kernels`: the main job in one command. Profile, every kernel
//! model, shader arrays, the comparison report with plots, and what to ship.

use super::out::out;
use super::profile_source::{command_line, ProfileArgs, ProfileModelArg, ReportArgs};
use ssskit::report::advise::DEFAULT_TARGET;
use ssskit::report::pipeline::{self, Settings};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileArgs,
    #[command(flatten)]
    report: ReportArgs,
    /// Taps per pass of the stored tables (odd).
    #[arg(long, default_value_t = 17)]
    taps: usize,
    /// Target relative RMS of the recommendation (0.02 = 2%).
    #[arg(long, default_value_t = DEFAULT_TARGET)]
    target_error: f64,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    a.report.check()?;
    ssskit::kernel::taps::check_count(a.taps)?;
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(&a.report.out)?;
    let t0 = std::time::Instant::now();
    let (profile, source) = a.profile.load(ProfileModelArg::Mc)?;
    eprintln!("{}: profile {source}", profile.material.name);
    let settings = Settings {
        mm_per_pixel: a.report.mm_per_pixel,
        taps: a.taps,
        target: a.target_error,
        size: a.report.size,
        plots: !a.report.no_plots,
    };
    let outcome = pipeline::run(
        &profile,
        &settings,
        staged.path(),
        &command_line(&a.report.out),
        &super::progress::Bar::new(),
    )?;
    staged.commit()?;
    out!(
        "{}",
        pipeline::summary(&outcome, &settings, &source, &a.report.out)
    )?;
    eprintln!(
        "{} files in {:.1} s",
        outcome.files.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
