//! Jimenez's separable skin model (Freude 2014, eq. 4.8; Jimenez et al.
//! 2015, iryoku/separable-sss): a_s(x) = t p(x / (w (0.001 + f))) / ||p|| +
//! (1 - t) delta(x), per channel, p the red channel of d'Eon's skin
//! Gaussians without the narrowest one (the reference code drops
//! 0.233 G(0.0064), whose role the strength term takes), each Gaussian with
//! the 2D normalisation 1/(2 pi v) as in the code.
//!
//! The width w scales the kernel (the shader multiplies tap offsets by it):
//! Freude 2014 prints p(w r / (0.001 + f)), which would narrow the kernel as
//! w grows; here w = 1 gives the profile in millimetres and larger w widens
//! it: w is the length (mm) of one unit of iryoku's kernel offsets.
//!
//! This file is the one home of the model: its defaults, the profile p
//! (`SeparableSSS::profile`), the real-time table (`calculateKernel`, which
//! the engines iryoku and Godot render) and the model's factor on the 2D
//! kernel grid.

use super::factors::Factors;
use super::gaussians::{gaussian_cells, DEON_SKIN_VARIANCES, DEON_SKIN_WEIGHTS};
use super::{taps, Kernel2D, Pass, TapTable};
use crate::error::{finite_positive, Error, Result};
use serde_json::json;
use std::f64::consts::PI;

/// iryoku's default strength per channel (the `SeparableSSS` constructor,
/// SeparableSSS.cpp; also the tables printed in SeparableSSS.h).
pub const IRYOKU_STRENGTH: [f64; 3] = [0.48, 0.41, 0.28];
/// iryoku's default falloff per channel (same source).
pub const IRYOKU_FALLOFF: [f64; 3] = [1.0, 0.37, 0.3];

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JimenezParams {
    /// Millimetres per unit of the kernel's offsets.
    pub width: f64,
    pub strength: [f64; 3],
    pub falloff: [f64; 3],
}

impl Default for JimenezParams {
    /// Public defaults of iryoku/separable-sss.
    fn default() -> Self {
        JimenezParams {
            width: 1.0,
            strength: IRYOKU_STRENGTH,
            falloff: IRYOKU_FALLOFF,
        }
    }
}

impl JimenezParams {
    pub fn check(&self) -> Result<()> {
        if !(self.width.is_finite() && self.width > 0.0) {
            return Err(Error::invalid(
                "jimenez",
                "width",
                self.width,
                "must be > 0 (mm scale)",
            ));
        }
        if let Some(t) = self.strength.iter().find(|t| !(**t >= 0.0 && **t <= 1.0)) {
            return Err(Error::invalid(
                "jimenez",
                "strength",
                t,
                "each must be in [0, 1]",
            ));
        }
        if let Some(f) = self.falloff.iter().find(|f| !(f.is_finite() && **f >= 0.0)) {
            return Err(Error::invalid(
                "jimenez",
                "falloff",
                f,
                "each must be finite and >= 0",
            ));
        }
        Ok(())
    }
}

/// The Gaussians of the profile: (variance in offset units^2, red weight),
/// the narrowest left out.
fn terms() -> impl Iterator<Item = (f64, f64)> + Clone {
    DEON_SKIN_VARIANCES
        .iter()
        .zip(&DEON_SKIN_WEIGHTS)
        .skip(1)
        .map(|(v, w)| (*v, w[0]))
}

/// iryoku's profile at `r` offset units for `falloff` (SeparableSSS.cpp,
/// `SeparableSSS::profile` and `gaussian`: sum of w_i
/// exp(-rr^2 / (2 v_i)) / (2 pi v_i), rr = r / (0.001 + falloff)). The code
/// writes 3.14 for pi; a common factor, which the table's normalisation
/// removes.
pub fn skin_profile(r: f64, falloff: f64) -> f64 {
    let rr = r / (0.001 + falloff);
    terms()
        .map(|(v, w)| w * (-rr * rr / (2.0 * v)).exp() / (2.0 * PI * v))
        .sum()
}

/// Tap offsets (mm, increasing, the middle one 0) of a table of `count`
/// taps spanning +-`extent_mm`: Jimenez's quadratic spacing
/// (`taps::unit_offsets`) scaled so the end taps sit at the extent.
pub fn offsets_mm(count: usize, extent_mm: f64) -> Vec<f64> {
    let r = taps::range(count);
    taps::unit_offsets(count)
        .iter()
        .map(|u| u * extent_mm / r)
        .collect()
}

/// The scattered part of the table (calculateKernel before the strength):
/// w_i = area_i p(x_i / width), area_i half the distance between its two
/// neighbours (half the one gap at an end tap), normalised to sum 1.
pub fn scattered_weights(offsets_mm: &[f64], width: f64, falloff: f64) -> Vec<f64> {
    let n = offsets_mm.len();
    let mut w: Vec<f64> = (0..n)
        .map(|i| {
            let x = offsets_mm[i];
            let w0 = if i > 0 { x - offsets_mm[i - 1] } else { 0.0 };
            let w1 = if i + 1 < n {
                offsets_mm[i + 1] - x
            } else {
                0.0
            };
            0.5 * (w0.abs() + w1.abs()) * skin_profile(x / width, falloff)
        })
        .collect();
    let sum: f64 = w.iter().sum();
    if sum > 0.0 {
        w.iter_mut().for_each(|v| *v /= sum);
    }
    w
}

/// calculateKernel's strength: lerp(1, w_0, t) at the centre tap and
/// t w_i elsewhere; the unscattered part (1 - t) is the centre tap's.
pub fn apply_strength(w: &mut [f64], centre: usize, t: f64) {
    w.iter_mut().for_each(|v| *v *= t);
    w[centre] += 1.0 - t;
}

/// The real-time table of `count` taps over +-`extent_mm`, as iryoku's
/// `SeparableSSS::calculateKernel` computes it (SeparableSSS.cpp): point
/// values of the profile times tap areas, normalised per channel, then the
/// strength mixed in at the centre tap. Offsets increasing (calculateKernel
/// moves the centre tap first for the shader; the order does not change the
/// kernel). With width 1 and `extent_mm` = RANGE (2 below 21 taps, 3 from
/// 21) it is iryoku's kernel in its offset units.
pub fn tap_table(p: &JimenezParams, count: usize, extent_mm: f64) -> Result<Pass> {
    p.check()?;
    taps::check_count(count)?;
    if count < 3 {
        return Err(Error::invalid(
            "taps",
            "count",
            count,
            "Jimenez's table needs at least 3 taps (its areas are gaps between taps)",
        ));
    }
    finite_positive("taps", "extent_mm", extent_mm, " (mm)")?;
    let offsets = offsets_mm(count, extent_mm);
    let centre = count / 2;
    let channels: [Vec<f64>; 3] = std::array::from_fn(|c| {
        let mut w = scattered_weights(&offsets, p.width, p.falloff[c]);
        apply_strength(&mut w, centre, p.strength[c]);
        w
    });
    Ok(Pass {
        weights: (0..count)
            .map(|i| std::array::from_fn(|c| channels[c][i]))
            .collect(),
        offsets_mm: offsets,
    })
}

/// The kernel file's table: [`tap_table`] over +-`extent_mm`, by default
/// iryoku's own span, RANGE offset units (RANGE x width mm).
pub fn table(p: &JimenezParams, count: usize, extent_mm: Option<f64>) -> Result<TapTable> {
    taps::check_count(count)?;
    let e = extent_mm.unwrap_or(taps::range(count) * p.width);
    Ok(TapTable {
        count,
        passes: vec![tap_table(p, count, e)?],
        extent_mm: Some(e),
    })
}

/// The model's factor on the kernel grid (cell integrals of the Gaussians,
/// untruncated, normalised to 1, the delta in the centre cell).
pub fn jimenez(k: &Kernel2D, p: &JimenezParams) -> Result<(Factors, serde_json::Value)> {
    p.check()?;
    let centre = k.half();
    let factor: [Vec<f64>; 3] = std::array::from_fn(|c| {
        let s = p.width * (0.001 + p.falloff[c]);
        let mut a = vec![0.0; k.size];
        for (v, w) in terms() {
            // G(r/s; v) = e^{-r^2/(2 v s^2)}/(2 pi v): a 1D Gaussian of
            // variance v s^2 with mass sqrt(2 pi v) s / (2 pi v).
            let vs = v * s * s;
            let mass = w * (2.0 * PI * vs).sqrt() / (2.0 * PI * v);
            for (ai, g) in a.iter_mut().zip(gaussian_cells(k, vs)) {
                *ai += mass * g;
            }
        }
        let sum: f64 = a.iter().sum();
        a.iter_mut().for_each(|v| *v /= sum);
        apply_strength(&mut a, centre, p.strength[c]);
        a
    });
    Ok((
        vec![factor],
        json!({"width": p.width, "strength": p.strength, "falloff": p.falloff}),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The strength lerp keeps the sum at 1 and puts 1 - t on the centre.
    #[test]
    fn strength_goes_to_the_centre_tap() {
        let p = JimenezParams::default();
        for n in [11, 17, 25] {
            let t = tap_table(&p, n, taps::range(n)).unwrap();
            let c = n / 2;
            for ch in 0..3 {
                let sum: f64 = t.weights.iter().map(|w| w[ch]).sum();
                assert!((sum - 1.0).abs() < 1e-12);
                let s = scattered_weights(&t.offsets_mm, 1.0, p.falloff[ch]);
                let want = p.strength[ch] * s[c] + 1.0 - p.strength[ch];
                assert!((t.weights[c][ch] - want).abs() < 1e-15);
            }
        }
        assert!(tap_table(&p, 1, 1.0).is_err());
        assert!(tap_table(&p, 17, 0.0).is_err());
    }
}
