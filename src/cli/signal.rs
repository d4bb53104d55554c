//! `ssskit signal`: test images for kernels in image space.

use super::args::{self, ImageSizeArg, MmPerPixelArg, OutFile};
use super::errors::positive;
use ssskit::filter::image::{write_image, PngDepth};
use ssskit::filter::signals::{generate, Signal, DEFAULT_SIZE};
use ssskit::report::eval::evaluate;

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
#[command(
    mut_arg("image_size", |a| args::default(format!("{}x{}", DEFAULT_SIZE.0, DEFAULT_SIZE.1))(a).alias("size")),
    mut_arg("mm_per_pixel", |a| args::default(evaluate::DEFAULT_MM_PER_PIXEL)(a)
        .help("Scale: surface millimetres per pixel (sets the checker cell in pixels)")),
    mut_arg("out", |a| args::required()(a).help("Output file: the image, .exr or .png")),
)]
pub struct Args {
    /// The test signal.
    #[arg(value_enum, value_name = "SIGNAL")]
    kind: Kind,
    #[command(flatten)]
    image_size: ImageSizeArg,
    #[command(flatten)]
    mm_per_pixel: MmPerPixelArg,
    /// Checker cell width in mm.
    #[arg(long, value_name = "MM", default_value_t = evaluate::CHECKER_MM, allow_negative_numbers = true, value_parser = args::real)]
    checker_mm: f64,
    #[command(flatten)]
    out: OutFile,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let (w, h) = args.image_size.image_size;
    let out = args.out.path()?;
    let mm_per_pixel = positive("--mm-per-pixel", args.mm_per_pixel.or_default())?;
    let checker_mm = positive("--checker-mm", args.checker_mm)?;
    let cell = (checker_mm / mm_per_pixel).round().max(1.0) as usize;
    let img = generate(args.kind.into(), w, h, cell)?;
    write_image(out, &img, PngDepth::Sixteen)?;
    eprintln!("{w}x{h} {:?} -> {}", args.kind, out.display());
    Ok(())
}
