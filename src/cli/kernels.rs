//! `ssskit kernels`: the main job in one command. Profile, every kernel
//! model, shader arrays, the comparison report with plots, and what to ship.

use super::errors::{between, positive};
use super::out::out;
use super::profile_source::{command_line, ProfileArgs, ProfileModelArg};
use ssskit::report::advise::DEFAULT_TARGET;
use ssskit::report::pipeline::{self, Settings};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileArgs,
    /// Surface millimetres per pixel the recommendation and the image-space
    /// errors are for.
    #[arg(long, default_value_t = 0.1)]
    mm_per_pixel: f64,
    /// Taps per pass of the stored tables (odd).
    #[arg(long, default_value_t = 17)]
    taps: usize,
    /// Target relative RMS of the recommendation (0.02 = 2%).
    #[arg(long, default_value_t = DEFAULT_TARGET)]
    target_error: f64,
    /// Side of the square test signals, pixels.
    #[arg(long, default_value_t = 128)]
    size: usize,
    /// Skip the PNG plots.
    #[arg(long)]
    no_plots: bool,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    positive("--mm-per-pixel", a.mm_per_pixel)?;
    ssskit::kernel::taps::check_count(a.taps)?;
    between("--size", a.size, 8, 1024)?;
    let t0 = std::time::Instant::now();
    let (profile, source) = a.profile.load(ProfileModelArg::Mc)?;
    eprintln!("{}: profile {source}", profile.material.name);
    let settings = Settings {
        mm_per_pixel: a.mm_per_pixel,
        taps: a.taps,
        target: a.target_error,
        size: a.size,
        plots: !a.no_plots,
    };
    let outcome = pipeline::run(
        &profile,
        &settings,
        &a.out,
        &command_line(&a.out),
        &super::progress::Bar::new(),
    )?;
    out!(
        "{}",
        pipeline::summary(&outcome, &settings, &source, &a.out)
    )?;
    eprintln!(
        "{} files in {:.1} s",
        outcome.files.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
