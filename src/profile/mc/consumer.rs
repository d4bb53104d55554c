//! The Monte Carlo noise that reaches a kernel: the relative L2 standard
//! error of the pre-integrated 1D factor a = a_p / ||a_p||_1 (Freude 2014,
//! eq. 5.17) on the default kernel grid, estimated from the per-bin second
//! moments of the tally. This is what the default stopping rule bounds.
//!
//! Why this quantity: every separable model starts from the 2D kernel or its
//! projection, and the 1D factor is the part a renderer applies twice; its
//! relative L2 error is dominated by the cells that carry the energy, so a
//! bound on it is a bound on what a user can see, unlike the error of single
//! bins a few hundredths of an MFP wide out in the tail.
//!
//! Model: each bin's weight spreads evenly over its annulus (the kernel
//! interpolates between bins; for the error this is the same to first order),
//! so cell m of the factor is a_m = sum_i P_mi W_i, P_mi the fraction of
//! annulus i inside the strip of cell m (|y| <= extent). A packet leaves the
//! top once under the classic boundary game (the default), so its scores in
//! two bins never overlap and var(f_m) = sum_i (P_mi - f_m c_i)^2 <w_i^2> /
//! ((N - 1) S^2), with c_i = sum_m P_mi over the full row and S = sum_i c_i
//! <w_i> (delta method for the ratio a_m / S). Under splitting the
//! cross-bin terms of one packet are neglected.

use crate::material::{Channel, Material};
use crate::numerics::annulus_area;
use crate::profile::radius::{default_extent, default_kernel_size};
use crate::profile::{Profile, RadialGrid, Source, PROFILE_SCHEMA};

/// Cells per side and half-width (mm) of the default kernel grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KernelGeometry {
    pub extent_mm: f64,
    pub size: usize,
}

/// The grid `Kernel2D::from_profile` chooses for `p` by default (all of its
/// channels), or None if no channel holds reflectance.
pub fn kernel_geometry(p: &Profile) -> Option<KernelGeometry> {
    let extent = default_extent(
        p,
        (0..p.channels.len()).filter(|&c| p.tabulated_total(c) > 0.0),
    );
    (extent > 0.0 && extent.is_finite()).then(|| KernelGeometry {
        extent_mm: extent,
        size: default_kernel_size(p, extent),
    })
}

/// The default kernel grid of a run's tallies so far: a provisional
/// profile of densities `rd` (per channel, on `grid`) with totals `total`,
/// as `Kernel2D::from_profile` would see it.
pub(super) fn provisional_geometry(
    material: &Material,
    channels: &[Channel],
    grid: &RadialGrid,
    rd: Vec<Vec<f64>>,
    total: Vec<f64>,
) -> Option<KernelGeometry> {
    kernel_geometry(&Profile {
        schema: PROFILE_SCHEMA.into(),
        material: material.clone(),
        units: "mm".into(),
        source: Source {
            kind: "monte-carlo".into(),
            photons: None,
            seed: None,
            model: None,
            params: serde_json::Value::Null,
        },
        channels: channels.to_vec(),
        r_edges: grid.edges.clone(),
        r: grid.centres(),
        rd,
        rd_stderr: None,
        total_rd: total,
        total_rd_stderr: None,
        specular: vec![],
        transmittance: None,
        transmittance_stderr: None,
        absorbed: None,
        extra: serde_json::Value::Null,
        elapsed_s: 0.0,
    })
}

/// Area of {0 <= x <= xm, 0 <= y <= ym, x^2 + y^2 <= r^2}.
fn quarter_area(r: f64, xm: f64, ym: f64) -> f64 {
    if !(r > 0.0) {
        return 0.0;
    }
    let r2 = r * r;
    // int_0^t sqrt(r^2 - s^2) ds
    let f = |t: f64| 0.5 * (t * (r2 - t * t).max(0.0).sqrt() + r2 * (t / r).min(1.0).asin());
    let x = xm.min(r);
    if r <= ym {
        return f(x);
    }
    let xc = (r2 - ym * ym).sqrt();
    if x <= xc {
        ym * x
    } else {
        ym * xc + f(x) - f(xc)
    }
}

/// The projection P (cells 0..=half on one side, times bins) of a grid onto
/// the kernel's cells: P[m][i] is the fraction of annulus i in the strip of
/// cell m (one side for m > 0).
pub struct Projection {
    half: usize,
    bins: usize,
    p: Vec<f64>,
}

impl Projection {
    pub fn new(edges: &[f64], g: &KernelGeometry) -> Projection {
        let half = g.size / 2;
        let cell = 2.0 * g.extent_mm / g.size as f64;
        let y = g.extent_mm;
        // Annuli beyond the square's corner project nowhere.
        let corner = y * std::f64::consts::SQRT_2;
        let bins = edges
            .iter()
            .position(|&e| e >= corner)
            .unwrap_or(edges.len() - 1)
            .min(edges.len() - 1);
        let strip = |r: f64| -> Vec<f64> {
            let q: Vec<f64> = (0..=half)
                .map(|m| quarter_area(r, (m as f64 + 0.5) * cell, y))
                .collect();
            (0..=half)
                .map(|m| {
                    if m == 0 {
                        4.0 * q[0]
                    } else {
                        2.0 * (q[m] - q[m - 1])
                    }
                })
                .collect()
        };
        let mut p = vec![0.0; (half + 1) * bins];
        let mut inner = strip(edges[0]);
        for i in 0..bins {
            let outer = strip(edges[i + 1]);
            let area = annulus_area(edges[i], edges[i + 1]);
            for m in 0..=half {
                p[m * bins + i] = (outer[m] - inner[m]) / area;
            }
            inner = outer;
        }
        Projection { half, bins, p }
    }

    /// Relative L2 standard error of the normalised factor, from the per-bin
    /// sums and sums of squares of `n` photons (0 when nothing is scored).
    pub fn factor_rel_error(&self, sum: &[f64], sum_sq: &[f64], n: u64) -> f64 {
        if n < 2 {
            return f64::INFINITY;
        }
        let nf = n as f64;
        let b = self.bins;
        let mult = |m: usize| if m == 0 { 1.0 } else { 2.0 };
        let mean: Vec<f64> = sum[..b].iter().map(|s| s / nf).collect();
        let msq: Vec<f64> = sum_sq[..b].iter().map(|s| s / nf).collect();
        let mut c = vec![0.0; b];
        let mut a = vec![0.0; self.half + 1];
        for (m, am) in a.iter_mut().enumerate() {
            let row = &self.p[m * b..(m + 1) * b];
            *am = row.iter().zip(&mean).map(|(p, w)| p * w).sum();
            for (ci, p) in c.iter_mut().zip(row) {
                *ci += mult(m) * p;
            }
        }
        let s: f64 = c.iter().zip(&mean).map(|(c, w)| c * w).sum();
        if !(s > 0.0) {
            return 0.0;
        }
        let (mut var, mut norm) = (0.0, 0.0);
        for (m, am) in a.iter().enumerate() {
            let f = am / s;
            let row = &self.p[m * b..(m + 1) * b];
            let v: f64 = row
                .iter()
                .zip(&c)
                .zip(&msq)
                .map(|((p, c), q)| (p - f * c).powi(2) * q)
                .sum();
            var += mult(m) * v / ((nf - 1.0) * s * s);
            norm += mult(m) * f * f;
        }
        (var / norm).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_conserves_area() {
        // Inside the square every annulus projects fully; rows add up to the
        // fraction inside the square.
        let edges: Vec<f64> = (0..=40).map(|i| i as f64 * 0.1).collect();
        let g = KernelGeometry {
            extent_mm: 2.0,
            size: 21,
        };
        let pr = Projection::new(&edges, &g);
        for i in 0..pr.bins {
            let col: f64 = (0..=pr.half)
                .map(|m| pr.p[m * pr.bins + i] * if m == 0 { 1.0 } else { 2.0 })
                .sum();
            if edges[i + 1] <= 2.0 {
                assert!((col - 1.0).abs() < 1e-12, "bin {i}: {col}");
            } else {
                assert!((0.0..1.0).contains(&col), "bin {i}: {col}");
            }
        }
        // A quarter disc of radius 1 cut at x = 0.5.
        let q = quarter_area(1.0, 0.5, 2.0);
        let exact = 0.5 * (0.5 * (0.75f64).sqrt() + 0.5f64.asin());
        assert!((q - exact).abs() < 1e-15);
        assert!((quarter_area(1.0, 2.0, 2.0) - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
        assert!((quarter_area(2.0, 1.0, 1.0) - 1.0).abs() < 1e-15);
    }
}
