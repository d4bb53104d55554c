//! `ssskit diff`'s PNG: the false-colour difference with its colour bar,
//! the ramp's top labelled in % of the reference's peak.

use super::colour_bar::{write_heat_png, ColourBar};
use super::kernel_plots::to_rgb8;
use crate::error::Result;
use crate::filter::diff::{false_colour, ramp_top};
use crate::filter::Image;
use std::path::Path;

/// Writes |A - B| (largest channel per pixel) through the heat ramp, white
/// at `scale` (default: the largest difference), with a colour bar in % of
/// A's peak (its largest channel).
pub fn write_diff_png(a: &Image, b: &Image, scale: Option<f64>, out: &Path) -> Result<()> {
    crate::io::check_extension(out, &["png"], "difference image")?;
    let top = ramp_top(a, b, scale);
    let img = false_colour(a, b, Some(top));
    let peak = a.peak().iter().cloned().fold(0.0f64, f64::max);
    let bar = if peak > 0.0 {
        ColourBar {
            white: 100.0 * top / peak,
            unit: "% of A's peak".into(),
            quantity: "|A - B|, largest channel".into(),
        }
    } else {
        ColourBar {
            white: top,
            unit: "(A is zero everywhere: absolute)".into(),
            quantity: "|A - B|, largest channel".into(),
        }
    };
    write_heat_png(&to_rgb8(&img, 1.0), (a.width, a.height), &bar, out)
}
