//! `ssskit diff`: image-space error between a reference A and an image B.

use super::args::{self, JsonArg, OutFile};
use super::out::outln;
use ssskit::filter::diff::{abs_difference, compare};
use ssskit::filter::image::{read_image, write_image, PngDepth};
use ssskit::report::present::diff_png::write_diff_png;
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(mut_arg(
    "out",
    args::help(
        "Output file: the difference image, .png in false colour with its colour bar, .exr per channel \
     [default: not written]"
    )
))]
pub struct Args {
    /// Reference image A (relative errors are relative to its peak).
    #[arg(value_name = "A")]
    a: PathBuf,
    /// Image B compared with A.
    #[arg(value_name = "B")]
    b: PathBuf,
    #[command(flatten)]
    json: JsonArg,
    #[command(flatten)]
    out: OutFile,
    /// Difference at the top of the colour ramp [default: the largest in the image].
    ///
    /// Give the same value to compare several images.
    #[arg(long, value_name = "DIFF", allow_negative_numbers = true, value_parser = args::real)]
    scale: Option<f64>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let (mut a, _) = read_image(&args.a, None)?;
    let (mut b, _) = read_image(&args.b, None)?;
    a.check_finite(&args.a.display().to_string(), false)?;
    b.check_finite(&args.b.display().to_string(), false)?;
    if let Some(s) = args.scale {
        super::errors::positive("--scale", s)?;
    }
    let stats = compare(&a, &b)?;
    if args.json.json {
        outln!("{}", serde_json::to_string(&stats)?)?;
    } else {
        outln!("{:<8} {:>12} {:>12} {:>12}", "", "R", "G", "B")?;
        let row = |name: &str, v: [f64; 3]| {
            outln!("{name:<8} {:>12.4e} {:>12.4e} {:>12.4e}", v[0], v[1], v[2])
        };
        row("rms", stats.rms)?;
        row("max_abs", stats.max_abs)?;
        row("rms_rel", stats.rms_rel)?;
        row("max_rel", stats.max_rel)?;
    }
    if let Some(out) = &args.out.out {
        let is_exr = out
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if is_exr {
            write_image(out, &abs_difference(&a, &b), PngDepth::Eight)?;
        } else {
            write_diff_png(&a, &b, args.scale, out)?;
        }
    }
    Ok(())
}
