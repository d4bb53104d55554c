//! `ssskit study`: the speed/accuracy trade of every knob for one material.

use super::errors::{between, positive};
use super::out::out;
use super::profile_source::{command_line, ProfileArgs, ProfileModelArg};
use anyhow::bail;
use ssskit::report::study::{self, Settings};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Reference profile: --profile FILE (e.g. profiles/reference/skin1.json)
    /// or made from --material (default Monte Carlo to --mc-error).
    #[command(flatten)]
    profile: ProfileArgs,
    /// Surface millimetres per pixel of the test images.
    #[arg(long, default_value_t = 0.1)]
    mm_per_pixel: f64,
    /// Side of the square test signals, pixels.
    #[arg(long, default_value_t = 128)]
    size: usize,
    /// Photon counts per channel of the Monte Carlo sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "10000,30000,100000,300000"
    )]
    photons: Vec<u64>,
    /// Skip the Pareto plot.
    #[arg(long)]
    no_plots: bool,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    positive("--mm-per-pixel", a.mm_per_pixel)?;
    between("--size", a.size, 8, 1024)?;
    if a.photons.is_empty() || a.photons.iter().any(|&n| n == 0 || n > 100_000_000) {
        bail!("--photons: each count must be between 1 and 1e8");
    }
    let t0 = std::time::Instant::now();
    let (reference, source) = a.profile.load(ProfileModelArg::Mc)?;
    eprintln!("{}: reference profile {source}", reference.material.name);
    let settings = Settings {
        mm_per_pixel: a.mm_per_pixel,
        size: a.size,
        photons: a.photons.clone(),
        ..Settings::default()
    };
    let s = study::run(&reference, &settings, &super::progress::Bar::new())?;
    let files = study::write(&s, &a.out, &command_line(&a.out), !a.no_plots)?;
    out!("{}", study::table(&s).markdown())?;
    eprintln!(
        "{} entries in {:.1} s -> {}/{}",
        s.entries.len(),
        t0.elapsed().as_secs_f64(),
        a.out.display(),
        files.join(", ")
    );
    Ok(())
}
