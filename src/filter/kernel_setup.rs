//! The settings of a separable kernel's pass on one image, as `apply` and
//! the Python binding make them: one home, so both filter alike.

use super::warnings::{scale_warnings, ScaleWarning};
use super::{check_kernel_fits, taps_for, Image, Scale, Setup, Which};
use crate::error::Result;
use crate::kernel::KernelFile;

/// `view` (scale and per-pixel planes, no passes yet) completed with the
/// kernel's taps: its stored real-time tap table (what an engine runs), or
/// with `full_factors` its full-resolution factors resampled to pixels
/// under a uniform scale; checked against
/// the caps and the image before anything is allocated. Returns the setup
/// and the scale warnings (taps that skip pixels, a kernel below a pixel).
pub fn kernel_setup(
    kernel: &KernelFile,
    full_factors: bool,
    view: Setup,
    image: &Image,
) -> Result<(Setup, Vec<ScaleWarning>)> {
    view.validate_view(image)?;
    let factors = if full_factors {
        Which::Full
    } else {
        Which::stored(kernel)
    };
    let uniform = match view.scale {
        Scale::MmPerPixel(m) if view.strength.is_none() => Some(m),
        _ => None,
    };
    check_kernel_fits(kernel, factors, uniform, image.width, image.height)?;
    let setup = Setup {
        passes: taps_for(kernel, factors, uniform)?,
        ..view
    };
    setup.validate(image)?;
    let largest_step = setup
        .steps_iter(image.width, image.height)
        .fold(0.0, f64::max);
    let sampled = factors != Which::Full || uniform.is_none();
    let warnings = scale_warnings(&setup.passes, largest_step, sampled);
    Ok((setup, warnings))
}
