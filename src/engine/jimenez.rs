//! Jimenez's separable skin model as a radial profile (Jimenez et al.
//! 2015, iryoku/separable-sss): R(r) = A [t P_s(r) + (1 - t) delta(r)], P_s
//! the sum of d'Eon's skin Gaussians (red weights, the narrowest left out as
//! in the reference code) with variances v_i s^2, normalised to 1; s =
//! width (0.001 + falloff) in mm, t the strength. The shader evaluates this
//! profile along each axis as its 1D factor; the profile itself is what it
//! approximates. The delta (light that does not scatter) lands in the
//! first bin.

use super::{minimise_log, Target};
use crate::error::{Error, Result};
use crate::kernel::gaussians::{DEON_SKIN_VARIANCES, DEON_SKIN_WEIGHTS};
use crate::numerics::bin_averages;
use crate::profile::{Profile, RadialGrid};
use std::f64::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Jimenez {
    /// Colour the blurred result is multiplied by (the diffuse albedo).
    pub albedo: [f64; 3],
    /// Strength t per channel, in [0, 1].
    pub strength: [f64; 3],
    /// Scale s = width (0.001 + falloff) per channel, mm.
    pub scale_mm: [f64; 3],
}

/// Iryoku's default strength of the red channel, the one Godot's
/// single-channel kernel uses for every channel.
pub const SKIN_STRENGTH_RED: f64 = 0.48;

/// P_s(r), mm^-2, unit mass.
pub fn gaussians(s: f64, r: f64) -> f64 {
    let pairs = DEON_SKIN_VARIANCES.iter().zip(&DEON_SKIN_WEIGHTS).skip(1);
    let total: f64 = pairs.clone().map(|(_, w)| w[0]).sum();
    pairs
        .map(|(v, w)| {
            let vs = v * s * s;
            w[0] * (-r * r / (2.0 * vs)).exp() / (2.0 * PI * vs)
        })
        .sum::<f64>()
        / total
}

fn delta_bins(grid: &RadialGrid) -> Vec<f64> {
    let mut d = vec![0.0; grid.len()];
    if let Some(a) = grid.areas().first() {
        d[0] = 1.0 / a;
    }
    d
}

impl Jimenez {
    pub fn bins(&self, c: usize, grid: &RadialGrid) -> Vec<f64> {
        let (a, t, s) = (self.albedo[c], self.strength[c], self.scale_mm[c]);
        let g = bin_averages(|r| gaussians(s, r), grid);
        let d = delta_bins(grid);
        g.iter()
            .zip(&d)
            .map(|(g, d)| a * (t * g + (1.0 - t) * d))
            .collect()
    }
}

/// Best (alpha, beta) >= 0 for alpha g + beta e0 against the target, and
/// the squared residual.
fn two_terms(t: &Target, g: &[f64], e0: &[f64]) -> (f64, f64, f64) {
    let dot =
        |a: &[f64], b: &[f64]| -> f64 { (0..t.bins).map(|i| t.weight[i] * a[i] * b[i]).sum() };
    let (gg, ee, ge) = (dot(g, g), dot(e0, e0), dot(g, e0));
    let (gy, ey, yy) = (dot(g, &t.value), dot(e0, &t.value), dot(&t.value, &t.value));
    let det = gg * ee - ge * ge;
    let residual = |a: f64, b: f64| {
        yy - 2.0 * a * gy - 2.0 * b * ey + a * a * gg + 2.0 * a * b * ge + b * b * ee
    };
    if det > 0.0 {
        let a = (gy * ee - ey * ge) / det;
        let b = (ey * gg - gy * ge) / det;
        if a >= 0.0 && b >= 0.0 {
            return (a, b, residual(a, b));
        }
    }
    let (a, _) = t.scale_of(g);
    let (b, _) = t.scale_of(e0);
    let (ra, rb) = (residual(a, 0.0), residual(0.0, b));
    if ra <= rb {
        (a, 0.0, ra)
    } else {
        (0.0, b, rb)
    }
}

/// Least squares on r R_d(r). Free per channel: albedo, strength, scale
/// (iryoku); or `shared`: one scale for all channels, the red strength
/// fixed and the albedo the profile's total (Godot's single-channel
/// kernel).
pub fn fit(p: &Profile, shared: bool) -> Result<Jimenez> {
    let targets: Vec<Target> = (0..3).map(|c| Target::new(p, c)).collect();
    let bins = targets.iter().map(|t| t.bins).max().unwrap_or(0);
    if bins == 0 {
        return Err(Error::Unsupported("no profile bins to fit".into()));
    }
    let grid = RadialGrid {
        edges: p.r_edges[..=bins].to_vec(),
    };
    let e0 = delta_bins(&grid);
    let r99 = p.r_edges[bins];
    let shape = |s: f64| bin_averages(|r| gaussians(s, r), &grid);
    let mut out = Jimenez {
        albedo: [0.0; 3],
        strength: [0.0; 3],
        scale_mm: [0.0; 3],
    };
    if shared {
        let t0 = SKIN_STRENGTH_RED;
        let mixed = |s: f64| -> Vec<f64> {
            shape(s)
                .iter()
                .zip(&e0)
                .map(|(g, d)| t0 * g + (1.0 - t0) * d)
                .collect()
        };
        // The albedo is the profile's total (Godot multiplies the material's
        // albedo after the blur); the width alone shapes the kernel.
        // Relative residuals, so that every channel counts alike.
        let cost = |s: f64| -> f64 {
            let m = mixed(s);
            targets
                .iter()
                .enumerate()
                .map(|(c, t)| t.residual_at(&m, p.total_rd[c]) / t.residual_at(&m, 0.0).max(1e-300))
                .sum()
        };
        let s = minimise_log(cost, 1e-4 * r99, 10.0 * r99, 41);
        for c in 0..3 {
            out.albedo[c] = p.total_rd[c];
            out.strength[c] = t0;
            out.scale_mm[c] = s;
        }
    } else {
        for (c, t) in targets.iter().enumerate() {
            let s = minimise_log(
                |s| two_terms(t, &shape(s), &e0).2,
                1e-4 * r99,
                10.0 * r99,
                41,
            );
            let (a, b, _) = two_terms(t, &shape(s), &e0);
            out.albedo[c] = a + b;
            out.strength[c] = if a + b > 0.0 { a / (a + b) } else { 1.0 };
            out.scale_mm[c] = s;
        }
    }
    Ok(out)
}
