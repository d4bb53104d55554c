//! Integrals of a radial profile R_d(r) over the cells of a square grid
//! centred on the origin: cell averages (supersampled more finely where the
//! cell is wide against the profile's bins, the centre cell exact in r) and
//! tent-weighted pixel averages (moments on the half-shifted grid, the cells
//! near the origin exact in r). [`super::kernel2d`] normalises them into a
//! kernel.

use crate::numerics::{gauss_legendre, gauss_legendre_sqrt_start};
use crate::profile::RadialInterp;
use rayon::prelude::*;

/// Integrals of R_d over a cell of the shifted grid against 1, s, t and
/// s t, (s, t) in [0, 1]^2 the cell's own coordinates rising with x and y.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct CellMoments {
    m00: f64,
    m10: f64,
    m01: f64,
    m11: f64,
}

impl CellMoments {
    /// The moments of the mirror image across x (s -> 1 - s).
    fn mirror_x(self) -> CellMoments {
        CellMoments {
            m00: self.m00,
            m10: self.m00 - self.m10,
            m01: self.m01,
            m11: self.m01 - self.m11,
        }
    }

    fn transpose(self) -> CellMoments {
        CellMoments {
            m10: self.m01,
            m01: self.m10,
            ..self
        }
    }
}

/// Shifted cells up to this many cells from the origin are integrated
/// exactly in r (`polar_cell_moments`): R_d is steepest there, and a pixel
/// wide compared with the profile puts most of it in them.
const POLAR_RINGS: usize = 6;

/// The moments of the shifted cell [a p, (a+1) p] x [b p, (b+1) p] (a, b >=
/// 0) as int R(r) r A(r) dr: the arc of radius r inside the cell is the one
/// interval phi0 <= phi <= phi1 of the first quadrant with x = r cos phi in
/// [x0, x1] and y = r sin phi in [y0, y1], and the angular integrals of 1,
/// s = (x - x0)/p, t = (y - y0)/p and s t over it are closed forms. The arc
/// has square-root corners where r crosses x0, x1, y0 or y1 (each piece
/// starting there is integrated by r = start + h u^2) and kinks at the
/// corners' radii, all of them cuts, with the profile's nodes.
fn polar_cell_moments(interp: &RadialInterp, a: usize, b: usize, p: f64) -> CellMoments {
    let (x0, y0) = (a as f64 * p, b as f64 * p);
    let (x1, y1) = (x0 + p, y0 + p);
    let arc = |r: f64| -> Option<(f64, f64)> {
        let ac = |x: f64| (x / r).min(1.0).acos();
        let as_ = |y: f64| (y / r).min(1.0).asin();
        let lo = ac(x1).max(as_(y0));
        let hi = ac(x0).min(as_(y1));
        (hi > lo).then_some((lo, hi))
    };
    // The integrand of each moment at radius r: R(r) r times the angular
    // integral of 1, s, t, s t over the arc.
    let parts = |r: f64| -> [f64; 4] {
        let Some((f0, f1)) = arc(r) else {
            return [0.0; 4];
        };
        let (s0, c0) = f0.sin_cos();
        let (s1, c1) = f1.sin_cos();
        let d = f1 - f0;
        let ic = s1 - s0; // int cos
        let is = c0 - c1; // int sin
        let isc = 0.5 * (s1 * s1 - s0 * s0); // int sin cos
        let k = interp.eval(r) * r;
        [
            k * d,
            k * (r * ic - x0 * d) / p,
            k * (r * is - y0 * d) / p,
            k * (r * r * isc - r * y0 * ic - r * x0 * is + x0 * y0 * d) / (p * p),
        ]
    };
    let corners = [x0.hypot(y0), x1.hypot(y0), x0.hypot(y1), x1.hypot(y1)];
    let (r_lo, r_hi) = (corners[0], corners[3].min(interp.r_max()));
    if !(r_hi > r_lo) {
        return CellMoments::default();
    }
    let sqrt_at = [x0, x1, y0, y1];
    let mut cuts: Vec<f64> = [r_lo, r_hi]
        .into_iter()
        .chain(corners)
        .chain(sqrt_at)
        .chain(interp.nodes().iter().copied())
        .filter(|&r| r >= r_lo && r <= r_hi)
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut m = [0.0; 4];
    for w in cuts.windows(2) {
        for (k, mk) in m.iter_mut().enumerate() {
            let g = |r: f64| parts(r)[k];
            *mk += if sqrt_at.contains(&w[0]) {
                gauss_legendre_sqrt_start(&g, w[0], w[1])
            } else {
                gauss_legendre(g, w[0], w[1])
            };
        }
    }
    CellMoments {
        m00: m[0],
        m10: m[1],
        m01: m[2],
        m11: m[3],
    }
}

/// The moments of the shifted cell [a p, (a+1) p] x [b p, (b+1) p], a and b
/// >= 0, not the origin's, by midpoint supersampling.
fn shifted_cell_moments(
    interp: &RadialInterp,
    a: usize,
    b: usize,
    p: f64,
    bin_width: f64,
) -> CellMoments {
    let (x0, y0) = (a as f64 * p, b as f64 * p);
    let r_near = x0.hypot(y0);
    if r_near > interp.r_max() {
        return CellMoments::default();
    }
    let ss = supersampling(p, r_near, a.max(b), bin_width);
    let h = 1.0 / ss as f64;
    let mut m = CellMoments::default();
    for iy in 0..ss {
        let t = (iy as f64 + 0.5) * h;
        for ix in 0..ss {
            let s = (ix as f64 + 0.5) * h;
            let v = interp.eval((x0 + s * p).hypot(y0 + t * p));
            m.m00 += v;
            m.m10 += v * s;
            m.m01 += v * t;
            m.m11 += v * s * t;
        }
    }
    let area = p * p * h * h;
    CellMoments {
        m00: m.m00 * area,
        m10: m.m10 * area,
        m01: m.m01 * area,
        m11: m.m11 * area,
    }
}

/// The tent-weighted integrals of `Kernel2D::pixel_averaged` (before
/// normalisation), row-major, `size` x `size`.
pub(super) fn tent_integrals(interp: &RadialInterp, size: usize, p: f64) -> Vec<f64> {
    let half = size / 2;
    // Shifted cells [a, a+1] x [b, b+1] (in cells) for 0 <= a, b < half:
    // together the square the tents of the entries up to `half` reach.
    let n = half;
    let bin_width = narrowest_bin(interp, p);
    let octant: Vec<(usize, usize, CellMoments)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|a| {
            (0..=a).map(move |b| {
                let m = if a <= POLAR_RINGS {
                    polar_cell_moments(interp, a, b, p)
                } else {
                    shifted_cell_moments(interp, a, b, p, bin_width)
                };
                (a, b, m)
            })
        })
        .collect();
    let mut quad = vec![CellMoments::default(); n * n];
    for (a, b, m) in octant {
        quad[a * n + b] = m;
        quad[b * n + a] = m.transpose();
    }
    // Any shifted cell, by mirror symmetry: cell a < 0 is cell -a-1
    // mirrored (s -> 1 - s); outside the square nothing.
    let cell = |a: i64, b: i64| -> CellMoments {
        let (ua, ub) = (
            if a < 0 { -a - 1 } else { a },
            if b < 0 { -b - 1 } else { b },
        );
        if ua >= n as i64 || ub >= n as i64 {
            return CellMoments::default();
        }
        let mut m = quad[ua as usize * n + ub as usize];
        if a < 0 {
            m = m.mirror_x();
        }
        if b < 0 {
            m = m.transpose().mirror_x().transpose();
        }
        m
    };
    let mut d = vec![0.0; size * size];
    // The octant 0 <= j <= i, mirrored: exactly symmetric, as `from_profile`.
    for j in 0..=half {
        for i in j..=half {
            let (i, j) = (i as i64, j as i64);
            // The tent rises over the cell left of (below) its centre (s,
            // t) and falls over the one right of (above) it (1 - s, 1 - t).
            let ll = cell(i - 1, j - 1).m11;
            let lr = {
                let m = cell(i, j - 1);
                m.m01 - m.m11
            };
            let ul = {
                let m = cell(i - 1, j);
                m.m10 - m.m11
            };
            let ur = {
                let m = cell(i, j);
                m.m00 - m.m10 - m.m01 + m.m11
            };
            let v = ll + lr + ul + ur;
            let h = half as i64;
            for (a, b) in [(i, j), (j, i)] {
                for sx in [h - a, h + a] {
                    for sy in [h - b, h + b] {
                        d[sy as usize * size + sx as usize] = v;
                    }
                }
            }
        }
    }
    d
}

/// Supersampling factor for a cell whose nearest point to the origin is at
/// radius `r_near`: enough samples per profile bin and per cell near the peak.
fn supersampling(cell: f64, r_near: f64, ring: usize, bin_width: f64) -> usize {
    let by_bins = (2.0 * cell / bin_width).ceil() as usize;
    let by_peak = match ring {
        0..=1 => 24,
        2..=4 => 12,
        5..=12 => 6,
        _ => 3,
    };
    // Far from the peak a wide cell sees a slowly varying profile.
    let by_bins = if r_near > 20.0 * bin_width {
        by_bins.min(8)
    } else {
        by_bins
    };
    by_bins.max(by_peak).clamp(3, 64)
}

/// Integral of the reconstruction over the centre cell [-a, a]^2 as
/// int R(r) L(r) dr, with L(r) the length of the circle of radius r inside
/// the square: 2 pi r up to a, then r (2 pi - 8 acos(a / r)) up to the
/// corner a sqrt 2. The peak of R_d sits in this cell: supersampling it
/// undersamples a peak much narrower than the cell (a pixel wider than the
/// kernel), and misses a profile that ends inside the first sample spacing.
fn centre_cell_integral(interp: &RadialInterp, a: f64) -> f64 {
    use std::f64::consts::{PI, SQRT_2};
    let arc = |r: f64| {
        if r <= a {
            2.0 * PI * r
        } else {
            r * (2.0 * PI - 8.0 * (a / r).min(1.0).acos())
        }
    };
    let g = |r: f64| interp.eval(r) * arc(r);
    let end = (a * SQRT_2).min(interp.r_max());
    let mut cuts: Vec<f64> = std::iter::once(0.0)
        .chain(interp.nodes().iter().copied())
        .chain([a, end])
        .filter(|&r| r <= end)
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    cuts.windows(2)
        .map(|w| {
            if w[0] == a {
                // L(r) has a square-root corner at r = a.
                gauss_legendre_sqrt_start(&g, w[0], w[1])
            } else {
                gauss_legendre(g, w[0], w[1])
            }
        })
        .sum()
}

/// Integrals of the reconstruction over each cell (octant, then mirrored).
/// The narrowest spacing of the profile's nodes, the resolution the
/// supersampling must follow, but at least 1e-3 of the `cell` (a degenerate
/// grid does not ask for unbounded work).
fn narrowest_bin(interp: &RadialInterp, cell: f64) -> f64 {
    interp
        .nodes()
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min)
        .max(cell * 1e-3)
}

/// The cell integrals of each of `interps` (reconstructions on the same
/// nodes: [`RadialInterp::same_nodes`]), each `size` x `size` row-major:
/// the supersampled cells place each sample among the nodes once for all
/// of them, and each adds its values in the same order as alone.
pub(super) fn cell_integrals(interps: &[RadialInterp], size: usize, cell: f64) -> Vec<Vec<f64>> {
    let Some(lead) = interps.first() else {
        return Vec::new();
    };
    debug_assert!(interps.iter().all(|f| f.same_nodes(lead)));
    let k = interps.len();
    let half = size / 2;
    // Narrowest bin: the resolution the supersampling must follow.
    let bin_width = narrowest_bin(lead, cell);
    // Octant 0 <= dy <= dx <= half.
    let octant: Vec<(usize, usize, Vec<f64>)> = (0..=half)
        .into_par_iter()
        .flat_map_iter(|dx| {
            (0..=dx).map(move |dy| {
                let x0 = (dx as f64 - 0.5) * cell;
                let y0 = (dy as f64 - 0.5) * cell;
                let r_near = ((x0.max(0.0)).powi(2) + (y0.max(0.0)).powi(2)).sqrt();
                if r_near > lead.r_max() {
                    return (dx, dy, vec![0.0; k]);
                }
                if dx == 0 {
                    let c = interps
                        .iter()
                        .map(|f| centre_cell_integral(f, cell / 2.0))
                        .collect();
                    return (0, 0, c);
                }
                let ss = supersampling(cell, r_near, dx, bin_width);
                let h = cell / ss as f64;
                let mut s = vec![0.0; k];
                for sy in 0..ss {
                    let y = y0 + (sy as f64 + 0.5) * h;
                    for sx in 0..ss {
                        let x = x0 + (sx as f64 + 0.5) * h;
                        let r = (x * x + y * y).sqrt();
                        let place = lead.place(r);
                        for (s, f) in s.iter_mut().zip(interps) {
                            *s += f.eval_at(place, r);
                        }
                    }
                }
                (dx, dy, s.into_iter().map(|s| s * h * h).collect())
            })
        })
        .collect();
    let mut d = vec![vec![0.0; size * size]; k];
    for (dx, dy, v) in octant {
        for (a, b) in [(dx, dy), (dy, dx)] {
            for sx in [half - a, half + a] {
                for sy in [half - b, half + b] {
                    for (d, &v) in d.iter_mut().zip(&v) {
                        d[sy * size + sx] = v;
                    }
                }
            }
        }
    }
    d
}
