//! `ssskit advise`: the cheapest kernel configuration that meets a target
//! image-space error at a pixel scale.

use super::out::{out, outln};
use super::profile_source::{ProfileArgs, ProfileModelArg};
use anyhow::bail;
use ssskit::report::advise::{self, ViewScale, DEFAULT_TARGET};
use ssskit::report::kernel_report::sig;
use std::path::PathBuf;

/// The model families advise can try (`advise::FAMILIES`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Family {
    Svd,
    Preintegrate,
    Guided,
    Manual,
    Gaussians,
}

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileArgs,
    /// Orthographic scale: surface millimetres per pixel.
    #[arg(long, conflicts_with_all = ["fov", "depth", "height"], required_unless_present = "fov", allow_negative_numbers = true)]
    mm_per_pixel: Option<f64>,
    /// Vertical field of view in degrees (perspective scale, with --depth
    /// and --height; the filter's formula, Freude 2014, eq. 4.11).
    #[arg(long, requires_all = ["depth", "height"], allow_negative_numbers = true)]
    fov: Option<f64>,
    /// Linear view depth of the surface, scene units.
    #[arg(long, allow_negative_numbers = true)]
    depth: Option<f64>,
    /// Image height, pixels.
    #[arg(long)]
    height: Option<usize>,
    /// Scene units per millimetre (0.001: a scene in metres).
    #[arg(long, default_value_t = 0.001)]
    scene_units_per_mm: f64,
    /// Largest relative RMS accepted over channels and signals (0.02 = 2%).
    #[arg(long, default_value_t = DEFAULT_TARGET)]
    target_error: f64,
    /// Side of the square test signals, pixels.
    #[arg(long, default_value_t = 128)]
    size: usize,
    /// Model families to try, comma-separated; default all of them.
    #[arg(long, value_enum, value_delimiter = ',')]
    models: Vec<Family>,
    /// Print the answer as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Write the chosen kernel (ssskit.kernel/1).
    #[arg(long, value_name = "KERNEL.json")]
    out: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let view = match (a.mm_per_pixel, a.fov, a.depth, a.height) {
        (Some(m), _, _, _) => ViewScale::MmPerPixel(m),
        (None, Some(f), Some(d), Some(h)) => ViewScale::Perspective {
            fov_y_deg: f,
            depth: d,
            height: h,
            scene_units_per_mm: a.scene_units_per_mm,
        },
        _ => bail!("give --mm-per-pixel, or --fov with --depth and --height"),
    };
    let mm = view.mm_per_pixel()?;
    if !(8..=2048).contains(&a.size) {
        bail!(
            "--size: invalid value {}: must be between 8 and 2048",
            a.size
        );
    }
    let (profile, source) = a.profile.load(ProfileModelArg::Pbd)?;
    eprintln!(
        "{}: profile {source}; scale {} mm per pixel{}",
        profile.material.name,
        sig(mm),
        match view {
            ViewScale::Perspective { .. } => format!(
                " (fov {} deg, depth {}, height {} px, {} scene units per mm)",
                a.fov.unwrap_or(0.0),
                a.depth.unwrap_or(0.0),
                a.height.unwrap_or(0),
                a.scene_units_per_mm
            ),
            ViewScale::MmPerPixel(_) => String::new(),
        }
    );
    let mut cfg = advise::Config::new(mm, a.target_error);
    cfg.size = a.size;
    if !a.models.is_empty() {
        cfg.families = a.models.iter().map(super::flag_value).collect();
    }
    let advice = advise::advise(&profile, &cfg, &super::progress::Bar::new())?;
    if let Some(out) = &a.out {
        advice.kernel.write(out)?;
        ssskit::kernel::KernelFile::read(out)?;
    }
    let c = advice.chosen();
    let text = advise::explain(&advice);
    if a.json {
        eprint!("{text}");
        outln!("{}", serde_json::to_string_pretty(&advice.to_json())?)?;
    } else {
        out!("{text}")?;
    }
    for w in &advice.warnings {
        super::errors::warn(&w.to_string());
    }
    if let Some(out) = &a.out {
        eprintln!("kernel ({}) -> {}", c.describe(), out.display());
    }
    Ok(())
}
