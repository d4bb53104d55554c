//! Jimenez's separable skin model (Freude 2014, eq. 4.8; iryoku/separable-sss):
//! a_s(x) = t p(x / (w (0.001 + f))) / ||p|| + (1 - t) delta(x), per channel,
//! p the red channel of d'Eon's skin Gaussians without the narrowest one
//! (the reference code drops 0.233 G(0.0064), whose role the strength term
//! takes), each Gaussian with the 2D normalisation 1/(2 pi v) as in the code.
//!
//! The width w scales the kernel (the shader multiplies tap offsets by it):
//! Freude 2014 prints p(w r / (0.001 + f)), which would narrow the kernel as w grows;
//! here w = 1 gives the profile in millimetres and larger w widens it.

use super::gaussians::{gaussian_cells, DEON_SKIN_VARIANCES, DEON_SKIN_WEIGHTS};
use super::model::Factors;
use super::Kernel2D;
use crate::error::{Error, Result};
use serde_json::json;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JimenezParams {
    pub width: f64,
    pub strength: [f64; 3],
    pub falloff: [f64; 3],
}

impl Default for JimenezParams {
    /// Public defaults of iryoku/separable-sss.
    fn default() -> Self {
        JimenezParams {
            width: 1.0,
            strength: [0.48, 0.41, 0.28],
            falloff: [1.0, 0.37, 0.3],
        }
    }
}

pub fn jimenez(k: &Kernel2D, p: &JimenezParams) -> Result<(Factors, serde_json::Value)> {
    if !(p.width.is_finite() && p.width > 0.0) {
        return Err(Error::invalid(
            "jimenez",
            "width",
            p.width,
            "must be > 0 (mm scale)",
        ));
    }
    if let Some(t) = p.strength.iter().find(|t| !(**t >= 0.0 && **t <= 1.0)) {
        return Err(Error::invalid(
            "jimenez",
            "strength",
            t,
            "each must be in [0, 1]",
        ));
    }
    if let Some(f) = p.falloff.iter().find(|f| !(f.is_finite() && **f >= 0.0)) {
        return Err(Error::invalid(
            "jimenez",
            "falloff",
            f,
            "each must be finite and >= 0",
        ));
    }
    let centre = k.half();
    let factor: [Vec<f64>; 3] = std::array::from_fn(|c| {
        let s = p.width * (0.001 + p.falloff[c]);
        let mut a = vec![0.0; k.size];
        for (v, w) in DEON_SKIN_VARIANCES.iter().zip(&DEON_SKIN_WEIGHTS).skip(1) {
            // G(r/s; v) = e^{-r^2/(2 v s^2)}/(2 pi v): a 1D Gaussian of
            // variance v s^2 with mass sqrt(2 pi v) s / (2 pi v).
            let vs = v * s * s;
            let mass =
                w[0] * (2.0 * std::f64::consts::PI * vs).sqrt() / (2.0 * std::f64::consts::PI * v);
            for (ai, g) in a.iter_mut().zip(gaussian_cells(k, vs)) {
                *ai += mass * g;
            }
        }
        let sum: f64 = a.iter().sum();
        let t = p.strength[c];
        a.iter_mut().for_each(|v| *v *= t / sum);
        a[centre] += 1.0 - t;
        a
    });
    Ok((
        vec![factor],
        json!({"width": p.width, "strength": p.strength, "falloff": p.falloff}),
    ))
}
