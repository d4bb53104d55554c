//! `ssskit kernels`: the main job in one command. Profile, every kernel
//! model, shader arrays, the comparison report with plots, and what to ship.

use super::args::{
    self, BudgetArgs, ImageErrorArg, ProfileModel, ProfileSourceArgs, ReportArgs, TapsArg,
};
use super::out::out;
use super::profile_source::command_line;
use ssskit::report::pipeline::{self, Settings};

#[derive(clap::Args)]
#[command(
    mut_args(args::profile_source(ProfileModel::Mc)),
    mut_args(args::report())
)]
#[command(mut_arg("image_error", args::alias("--target-error")))]
pub struct Args {
    #[command(flatten)]
    profile: ProfileSourceArgs,
    #[command(flatten)]
    report: ReportArgs,
    #[command(flatten)]
    taps: TapsArg,
    #[command(flatten)]
    target: ImageErrorArg,
    #[command(flatten)]
    budget: BudgetArgs,
    #[command(flatten)]
    factors: args::FactorsArg,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mm_per_pixel =
        super::errors::positive("--mm-per-pixel", a.report.mm_per_pixel.or_default())?;
    ssskit::kernel::taps::check_count(a.taps.taps)?;
    let target = a.target.fraction()?;
    let out_dir = a.report.out_dir.path()?;
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(out_dir)?;
    let t0 = std::time::Instant::now();
    let (profile, source) = a.profile.load_with_factors(&a.factors)?;
    eprintln!("{}: profile {source}", profile.material.name);
    let settings = Settings {
        mm_per_pixel,
        taps: a.taps.taps,
        target,
        budget: a.budget.budget(),
        size: a.report.signal_size.signal_size,
        plots: !a.report.no_plots.no_plots,
    };
    let outcome = pipeline::run(
        &profile,
        &settings,
        staged.path(),
        &command_line(out_dir),
        &super::progress::Bar::new(),
    )?;
    staged.commit()?;
    out!(
        "{}",
        pipeline::summary(&outcome, &settings, &source, out_dir)
    )?;
    eprintln!(
        "{} files in {:.1} s",
        outcome.files.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
