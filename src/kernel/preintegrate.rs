//! Pre-integration (Freude 2014, sec. 5.2): a_p(x) = int R_d(x, y) dy, A_p = a_p(x) a_p(y) /
//! ||R_d||_1 (Freude 2014, eq. 5.17), exact for additively separable irradiance
//! (edges; Freude 2014, eq. 5.14-5.16) and energy-conserving by construction.
//!
//! For a radial profile a_p is the Abel projection
//! a_p(x) = 2 int_0^Y R_d(sqrt(x^2 + y^2)) dy (Freude 2014, sec. 5.2), here cut at the
//! kernel's extent Y so that it describes the same square as the 2D kernel,
//! and integrated over each cell in x. Quadrature: Gauss-Legendre panels
//! split at the profile's nodes (where the reconstruction has kinks).

use super::factors::Factors;
use super::kernel2d::rgb_indices;
use super::Kernel2D;
use crate::error::Result;
use crate::numerics::{gauss_legendre, gauss_legendre_sqrt_end, gauss_legendre_sqrt_start};
use crate::profile::Profile;
use crate::profile::RadialInterp;
use rayon::prelude::*;
use serde_json::json;

/// How a_p is obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PreMethod {
    /// Abel projection of the radial profile (continuous quadrature).
    Abel,
    /// Row sums of the discrete 2D kernel: exact on the grid.
    Grid,
}

/// Row sums of the discrete kernel: the discrete a_p.
pub fn grid_projection(k: &Kernel2D, c: usize) -> Vec<f64> {
    k.data[c]
        .chunks(k.size)
        .map(|row| row.iter().sum())
        .collect()
}

/// The pre-integrated factor of each channel, a = a_p / ||a_p||_1 so that
/// the kernel a a^T sums to 1 like the normalised ground truth.
pub fn preintegrate(
    k: &Kernel2D,
    profile: &Profile,
    method: PreMethod,
) -> Result<(Factors, serde_json::Value)> {
    let idx = rgb_indices(profile)?;
    let mut factor: [Vec<f64>; 3] = Default::default();
    let mut max_rel = [0.0f64; 3];
    for c in 0..3 {
        let grid = grid_projection(k, c);
        let ap = match method {
            PreMethod::Grid => grid.clone(),
            PreMethod::Abel => abel_cells(k, &RadialInterp::new(profile, idx[c])),
        };
        let s: f64 = ap.iter().sum();
        let a: Vec<f64> = ap.iter().map(|v| v / s).collect();
        // Check against summing the discrete 2D kernel, where it matters.
        let peak = grid.iter().cloned().fold(0.0, f64::max);
        max_rel[c] = a
            .iter()
            .zip(&grid)
            .filter(|(_, g)| **g > 1e-3 * peak)
            .map(|(a, g)| ((a - g) / g).abs())
            .fold(0.0, f64::max);
        factor[c] = a;
    }
    let extra = json!({
        "method": match method { PreMethod::Abel => "abel", PreMethod::Grid => "grid" },
        "abel_vs_grid_max_rel": max_rel,
    });
    Ok((vec![factor], extra))
}

/// int over each cell in x of 2 int_0^Y R(sqrt(x^2 + y^2)) dy, as
/// differences of the strip integral `strip(X)` over [0, X] x [-Y, Y].
pub fn abel_cells(k: &Kernel2D, f: &RadialInterp) -> Vec<f64> {
    let half = k.half();
    let ymax = k.extent_mm();
    // strip at the cell edges (j + 1/2) cell, j = 0..=half.
    let edges: Vec<f64> = (0..=half)
        .into_par_iter()
        .map(|j| strip(f, (j as f64 + 0.5) * k.cell_mm, ymax))
        .collect();
    let one_side: Vec<f64> = (0..=half)
        .map(|m| {
            if m == 0 {
                2.0 * edges[0]
            } else {
                edges[m] - edges[m - 1]
            }
        })
        .collect();
    (0..k.size).map(|i| one_side[i.abs_diff(half)]).collect()
}

/// int over [0, X] x [-Y, Y] of f(sqrt(x^2 + y^2)) in polar form:
/// int_0^sqrt(X^2+Y^2) f(r) r 2 theta(r) dr, theta(r) = max(0,
/// asin(min(1, Y/r)) - acos(min(1, X/r))) the angle of the circle of radius r
/// inside the quarter rectangle. theta has square-root corners at r = X, Y
/// and sqrt(X^2 + Y^2): panels end there and use r = a + (b - a) t^2 (or
/// its mirror) to stay smooth; elsewhere panels end at the profile's nodes.
pub fn strip(f: &RadialInterp, x: f64, y: f64) -> f64 {
    let rmax = (x * x + y * y).sqrt();
    let theta = |r: f64| -> f64 {
        let hi = (y / r).min(1.0).asin();
        let lo = (x / r).min(1.0).acos();
        (hi - lo).max(0.0)
    };
    let mut cuts: Vec<(f64, bool)> = f
        .nodes()
        .iter()
        .copied()
        .filter(|&r| r > 0.0 && r < rmax)
        .map(|r| (r, false))
        .collect();
    cuts.extend([
        (0.0, false),
        (x.min(rmax), true),
        (y.min(rmax), true),
        (rmax, true),
    ]);
    cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
    cuts.dedup_by(|b, a| {
        if (b.0 - a.0).abs() <= 1e-14 * rmax {
            a.1 |= b.1;
            true
        } else {
            false
        }
    });
    let mut s = 0.0;
    for w in cuts.windows(2) {
        let ((a, sa), (b, sb)) = (w[0], w[1]);
        if !(b > a) {
            continue;
        }
        let mid = 0.5 * (a + b);
        let seg = f.segment_of(mid);
        let g = |r: f64| f.eval_in(seg, r) * r * 2.0 * theta(r);
        s += match (sa, sb) {
            (false, false) => gauss_legendre(g, a, b),
            (true, false) => gauss_legendre_sqrt_start(&g, a, b),
            (false, true) => gauss_legendre_sqrt_end(&g, a, b),
            (true, true) => {
                gauss_legendre_sqrt_start(&g, a, mid) + gauss_legendre_sqrt_end(&g, mid, b)
            }
        };
    }
    s
}

/// 2 int_0^Y f(sqrt(x^2 + y^2)) dy, one Gauss-Legendre panel per segment
/// of the reconstruction that the line crosses.
pub fn abel_at(f: &RadialInterp, x: f64, ymax: f64) -> f64 {
    let ax = x.abs();
    let nodes = f.nodes();
    let rmax = (ax * ax + ymax * ymax).sqrt();
    let mut s = 0.0;
    // The constant part below the first node (r <= nodes[0]).
    let mut y_prev = 0.0;
    for (i, w) in nodes.windows(2).enumerate() {
        if w[1] <= ax {
            continue;
        }
        if w[0] >= rmax {
            break;
        }
        let y1 = if w[1] >= rmax {
            ymax
        } else {
            (w[1] * w[1] - ax * ax).sqrt()
        };
        if y1 > y_prev {
            s += gauss_legendre(|y| f.eval_segment(i, (ax * ax + y * y).sqrt()), y_prev, y1);
        }
        y_prev = y1;
    }
    2.0 * s
}
