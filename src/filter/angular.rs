//! The angular factors around the blur (see [`crate::kernel::angular`]):
//! the irradiance weighted by the entry factor at each pixel's N.L before
//! the pass, the blurred result by the exit factor at its N.V after it.

use super::Image;
use crate::error::{Error, Result};
use crate::kernel::angular::AngularFactors;

/// `img` with each pixel's colour multiplied by `factor(cosines[i])`.
fn weighted(img: &Image, cosines: &[f64], factor: impl Fn(f64) -> [f64; 3]) -> Result<Image> {
    if cosines.len() != img.len() {
        return Err(Error::Unsupported(format!(
            "angular factors: {} cosines for a {}x{} image",
            cosines.len(),
            img.width,
            img.height
        )));
    }
    let mut out = img.clone();
    for (i, &mu) in cosines.iter().enumerate() {
        let f = factor(mu);
        for c in 0..3 {
            out.rgb[c][i] *= f[c];
        }
    }
    Ok(out)
}

/// The irradiance buffer weighted by the entry factor at N.L (`n_dot_l`
/// per pixel; values <= 0 receive no light, their irradiance is 0 anyway).
pub fn entry_weighted(irradiance: &Image, n_dot_l: &[f64], f: &AngularFactors) -> Result<Image> {
    weighted(irradiance, n_dot_l, |mu| f.entry_at(mu))
}

/// The blurred exitance weighted by the exit factor at N.V (`n_dot_v` per
/// pixel).
pub fn exit_weighted(blurred: &Image, n_dot_v: &[f64], f: &AngularFactors) -> Result<Image> {
    weighted(blurred, n_dot_v, |mu| f.exit_at(mu))
}
