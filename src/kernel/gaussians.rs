//! Sums of radially symmetric 2D Gaussians (d'Eon and Luebke 2007):
//! each Gaussian is separable, so N Gaussians are N separable
//! terms (2N one-dimensional passes). Fitted to the 2D kernel by variable
//! projection: non-negative weights by least squares for given variances,
//! log-variances by Nelder-Mead.

use super::factors::Factors;
use super::kernel2d::multiplicity;
use super::Kernel2D;
use crate::error::{count_up_to, Result};
use crate::numerics::{erf, erfc, nelder_mead, nnls};
use serde_json::json;

/// Gaussians in a sum by default: four, the sum of the reference kernels
/// (kernels/*-gaussians4.json).
pub const DEFAULT_COUNT: usize = 4;

/// d'Eon's six-Gaussian skin profile: variances (mm^2) and RGB weights
/// (d'Eon and Luebke 2007).
pub const DEON_SKIN_VARIANCES: [f64; 6] = [0.0064, 0.0484, 0.187, 0.567, 1.99, 7.41];
pub const DEON_SKIN_WEIGHTS: [[f64; 3]; 6] = [
    [0.233, 0.455, 0.649],
    [0.100, 0.336, 0.344],
    [0.118, 0.198, 0.0],
    [0.113, 0.007, 0.007],
    [0.358, 0.004, 0.0],
    [0.078, 0.0, 0.0],
];

/// Integral over [a, b] of the unit-mass 1D Gaussian of variance `v`.
pub fn gaussian_mass(a: f64, b: f64, v: f64) -> f64 {
    if v <= 0.0 {
        return if a <= 0.0 && 0.0 < b { 1.0 } else { 0.0 };
    }
    let s = (2.0 * v).sqrt();
    // Use the tail on the far side to keep precision for cells far out.
    if a >= 0.0 {
        0.5 * (erfc(a / s) - erfc(b / s))
    } else if b <= 0.0 {
        0.5 * (erfc(-b / s) - erfc(-a / s))
    } else {
        0.5 * (erf(b / s) - erf(a / s))
    }
}

/// Cell integrals of a unit-mass 1D Gaussian of variance `v` on the kernel's
/// grid (a Dirac, v = 0, lands in the centre cell).
pub fn gaussian_cells(k: &Kernel2D, v: f64) -> Vec<f64> {
    (0..k.size)
        .map(|i| {
            let x = k.offset(i);
            gaussian_mass(x - 0.5 * k.cell_mm, x + 0.5 * k.cell_mm, v)
        })
        .collect()
}

/// The half h..n of `gaussian_cells` (cells at m = 0..=h from the centre),
/// from one erfc per cell edge.
pub fn gaussian_half_cells(k: &Kernel2D, v: f64) -> Vec<f64> {
    let h = k.half();
    if v <= 0.0 {
        let mut g = vec![0.0; h + 1];
        g[0] = 1.0;
        return g;
    }
    let s = (2.0 * v).sqrt();
    let tail: Vec<f64> = (1..=h + 1)
        .map(|j| erfc((j as f64 - 0.5) * k.cell_mm / s))
        .collect();
    (0..=h)
        .map(|m| {
            if m == 0 {
                1.0 - tail[0]
            } else {
                0.5 * (tail[m - 1] - tail[m])
            }
        })
        .collect()
}

/// a^T R a for an even factor given by its half (cells m = 0..=h) and R by
/// its quadrant (`Kernel2D::quadrant`).
pub fn half_quad_form(q: &[f64], a: &[f64]) -> f64 {
    HalfQuad::new(q, a.len()).form(a)
}

/// A quadrant prepared for many [`half_quad_form`]s (a fit evaluates one
/// per step): stored by columns, each column times its multiplicity (1 or
/// 2: exact), so that the rows' sums advance side by side over the columns
/// instead of one row after the other; each row's sum adds the same
/// products in the same order, so the form is the same bit for bit.
pub struct HalfQuad {
    m: usize,
    /// `m(ix) R[iy][ix]` at `ix * m + iy`.
    columns: Vec<f64>,
}

impl HalfQuad {
    /// The quadrant `q` of `m` x `m` cells, row-major.
    pub fn new(q: &[f64], m: usize) -> HalfQuad {
        let mut columns = vec![0.0; m * m];
        for (iy, row) in q.chunks(m).take(m).enumerate() {
            for (ix, r) in row.iter().enumerate() {
                columns[ix * m + iy] = multiplicity(ix) * r;
            }
        }
        HalfQuad { m, columns }
    }

    /// a^T R a, `a` the half factor (m cells), in AVX2 where the CPU has
    /// it ([`crate::numerics::has_avx2`]).
    pub fn form(&self, a: &[f64]) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if crate::numerics::has_avx2() {
            // SAFETY: has_avx2 checked the CPU features.
            return unsafe { self.form_avx2(a) };
        }
        self.form_lanes(a)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn form_avx2(&self, a: &[f64]) -> f64 {
        self.form_lanes(a)
    }

    #[inline(always)]
    fn form_lanes(&self, a: &[f64]) -> f64 {
        // -0.0: the start of a float sum, as `Iterator::sum` takes it.
        let mut rows = vec![-0.0f64; self.m];
        for (column, ax) in self.columns.chunks_exact(self.m).zip(a) {
            for (s, r) in rows.iter_mut().zip(column) {
                *s += r * ax;
            }
        }
        rows.iter()
            .zip(a)
            .enumerate()
            .map(|(iy, (s, ay))| multiplicity(iy) * ay * s)
            .sum()
    }
}

/// a . b for even factors given by their halves.
pub fn half_dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(i, (x, y))| multiplicity(i) * x * y)
        .sum()
}

/// A mixture of 2D Gaussians as separable terms: term i of channel c is
/// sqrt(w_ic) g(x; v_ic), so that the 2D kernel is sum_i w_ic G(x, y; v_ic).
pub fn mixture_factors(k: &Kernel2D, variances: &[[f64; 3]], weights: &[[f64; 3]]) -> Factors {
    variances
        .iter()
        .zip(weights)
        .map(|(v, w)| {
            std::array::from_fn(|c| {
                let s = w[c].max(0.0).sqrt();
                gaussian_cells(k, v[c]).into_iter().map(|g| s * g).collect()
            })
        })
        .collect()
}

/// The published skin profile (weights as printed; they sum to 1.000, 1.000,
/// 1.000 per channel).
pub fn deon_skin(k: &Kernel2D) -> (Factors, serde_json::Value) {
    let vars: Vec<[f64; 3]> = DEON_SKIN_VARIANCES.iter().map(|&v| [v; 3]).collect();
    let f = mixture_factors(k, &vars, &DEON_SKIN_WEIGHTS);
    let params = json!({
        "preset": "deon-skin",
        "variances_mm2": DEON_SKIN_VARIANCES,
        "weights": DEON_SKIN_WEIGHTS,
    });
    (f, params)
}

/// Least squares over non-negative w of || R - sum_i w_i g_i g_i^T ||_F^2
/// given the Gaussians' cell vectors: the normal equations have Gram
/// M_ij = (g_i . g_j)^2 and right side b_i = g_i^T R g_i (Lawson and
/// Hanson 1974).
/// `q` is R's quadrant and `g` the Gaussians' half vectors.
fn nnls_weights(q: &HalfQuad, g: &[Vec<f64>]) -> (Vec<f64>, f64) {
    let m = g.len();
    let mut gram = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            let d = half_dot(&g[i], &g[j]);
            gram[i * m + j] = d * d;
        }
    }
    let b: Vec<f64> = g.iter().map(|gi| q.form(gi)).collect();
    let w = nnls(&gram, &b, m);
    // ||R - A||^2 = ||R||^2 - 2 w.b + w^T M w; ||R||^2 is constant.
    let mut obj = 0.0;
    for i in 0..m {
        obj -= 2.0 * w[i] * b[i];
        for j in 0..m {
            obj += w[i] * gram[i * m + j] * w[j];
        }
    }
    (w, obj)
}

/// Fits `count` 2D Gaussians per channel to the kernel (kernel-space least
/// squares, the kernel_rms metric), weights >= 0.
pub fn fit_gaussians(k: &Kernel2D, count: usize) -> Result<(Factors, serde_json::Value)> {
    count_up_to("gaussians", "count", count, 12)?;
    // Variances from a cell's width to the extent, in log space.
    let vmin = (0.5 * k.cell_mm).powi(2);
    let vmax = (0.7 * k.extent_mm()).powi(2);
    let mut variances = Vec::new();
    let mut weights = Vec::new();
    let mut objs = Vec::new();
    for c in 0..3 {
        let q = HalfQuad::new(&k.quadrant(c), k.half() + 1);
        let eval = |lv: &[f64]| -> (Vec<f64>, f64) {
            let g: Vec<Vec<f64>> = lv.iter().map(|l| gaussian_half_cells(k, l.exp())).collect();
            nnls_weights(&q, &g)
        };
        let ladder: Vec<f64> = (0..count)
            .map(|i| {
                let t = if count == 1 {
                    0.5
                } else {
                    i as f64 / (count - 1) as f64
                };
                (vmin.ln() * (1.0 - t) + vmax.ln() * t).max(vmin.ln())
            })
            .collect();
        let bounds = (vmin.ln() - 4.0, vmax.ln() + 1.0);
        let best = nelder_mead(|lv| eval(lv).1, &ladder, 0.7, bounds, 150 * count + 200);
        let mut lv = best;
        lv.sort_by(f64::total_cmp);
        let (w, obj) = eval(&lv);
        variances.push(lv.iter().map(|l| l.exp()).collect::<Vec<_>>());
        weights.push(w);
        objs.push(obj);
    }
    let v3: Vec<[f64; 3]> = (0..count)
        .map(|i| std::array::from_fn(|c| variances[c][i]))
        .collect();
    let w3: Vec<[f64; 3]> = (0..count)
        .map(|i| std::array::from_fn(|c| weights[c][i]))
        .collect();
    let f = mixture_factors(k, &v3, &w3);
    Ok((
        f,
        json!({"count": count, "variances_mm2": v3, "weights": w3}),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_cells_match_full_cells() {
        let k = Kernel2D {
            size: 41,
            cell_mm: 0.3,
            data: Default::default(),
            total_rd: [1.0; 3],
            captured: [1.0; 3],
        };
        for v in [0.0, 1e-4, 0.05, 1.0, 30.0] {
            let full = gaussian_cells(&k, v);
            let half = gaussian_half_cells(&k, v);
            for (m, h) in half.iter().enumerate() {
                assert!((full[20 + m] - h).abs() <= 1e-15, "v {v} m {m}");
            }
            let total: f64 = full.iter().sum();
            assert!(total <= 1.0 + 1e-15);
        }
    }

    #[test]
    fn deon_skin_weights_sum_to_one() {
        for c in 0..3 {
            let s: f64 = DEON_SKIN_WEIGHTS.iter().map(|w| w[c]).sum();
            assert!((s - 1.0).abs() < 2e-3, "channel {c}: {s}");
        }
    }

    /// The prepared form is the plain double sum bit for bit (rows in
    /// order, each row's products in order).
    #[test]
    fn the_prepared_form_is_the_plain_sum_bit_for_bit() {
        let m = 9;
        let q: Vec<f64> = (0..m * m)
            .map(|i| ((i * 7919) % 101) as f64 / 37.0)
            .collect();
        let a: Vec<f64> = (0..m)
            .map(|i| ((i * 31) % 17) as f64 / 13.0 - 0.4)
            .collect();
        let plain: f64 = q
            .chunks(m)
            .zip(&a)
            .enumerate()
            .map(|(iy, (row, ay))| {
                multiplicity(iy)
                    * ay
                    * row
                        .iter()
                        .zip(&a)
                        .enumerate()
                        .map(|(ix, (r, ax))| multiplicity(ix) * r * ax)
                        .sum::<f64>()
            })
            .sum();
        assert_eq!(HalfQuad::new(&q, m).form(&a).to_bits(), plain.to_bits());
        assert_eq!(
            HalfQuad::new(&q, m).form_lanes(&a).to_bits(),
            plain.to_bits()
        );
        assert_eq!(half_quad_form(&q, &a).to_bits(), plain.to_bits());
    }
}
