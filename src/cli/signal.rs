//! `ssskit signal`: test images for kernels in image space.

use super::errors::positive;
use ssskit::filter::image::{write_image, PngDepth};
use ssskit::filter::signals::{generate, Signal};
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Kind {
    /// Vertical white-black edge (white left half).
    Edge,
    /// A circle and two tilted adjacent squares (Freude 2014, figure 6.6).
    Shapes,
    /// One bright pixel at the centre.
    Dirac,
    /// A checker of --checker-mm cells.
    Checker,
}

impl From<Kind> for Signal {
    fn from(k: Kind) -> Signal {
        match k {
            Kind::Edge => Signal::Edge,
            Kind::Shapes => Signal::Shapes,
            Kind::Dirac => Signal::Dirac,
            Kind::Checker => Signal::Checker,
        }
    }
}

#[derive(clap::Args)]
pub struct Args {
    #[arg(value_enum)]
    kind: Kind,
    /// Image size, e.g. 512x256.
    #[arg(long, value_name = "WxH", default_value = "256x256", value_parser = parse_size)]
    size: (usize, usize),
    /// Surface millimetres per pixel (sets the checker cell in pixels).
    #[arg(long, default_value_t = 0.1)]
    mm_per_pixel: f64,
    /// Checker cell width in mm.
    #[arg(long, default_value_t = 1.0)]
    checker_mm: f64,
    /// Output image (.exr or .png).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let (w, h) = args.size;
    let mm_per_pixel = positive("--mm-per-pixel", args.mm_per_pixel)?;
    let checker_mm = positive("--checker-mm", args.checker_mm)?;
    let cell = (checker_mm / mm_per_pixel).round().max(1.0) as usize;
    let img = generate(args.kind.into(), w, h, cell)?;
    write_image(&args.out, &img, PngDepth::Sixteen)?;
    eprintln!("{w}x{h} {:?} -> {}", args.kind, args.out.display());
    Ok(())
}

/// "WIDTHxHEIGHT".
fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let bad = || "expected WIDTHxHEIGHT, e.g. 512x256".to_string();
    let (a, b) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    Ok((
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    ))
}
