//! Manual approximation (Freude 2014, sec. 5.4, Jimenez's artist model):
//! a_m(x) = w G(x, tau_n) + (1 - w) G(x, tau_f)   (Freude 2014, eq. 5.21)
//! with 1D Gaussians, per-channel variances and one w. Widths are given as
//! sqrt(tau) in mm like Freude 2014, table A.1. `fit` finds w, tau_n, tau_f by least
//! squares in kernel space (the kernel_rms metric of all channels).

use super::factors::Factors;
use super::gaussians::{gaussian_cells, gaussian_half_cells, half_dot, HalfQuad};
use super::Kernel2D;
use crate::error::{Error, Result};
use crate::numerics::nelder_mead;
use serde_json::json;

#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ManualParams {
    pub w: f64,
    /// sqrt(tau_n) per channel, mm.
    pub sqrt_tau_near: [f64; 3],
    /// sqrt(tau_f) per channel, mm.
    pub sqrt_tau_far: [f64; 3],
}

/// Parameters from w, sqrt(tau_n) and sqrt(tau_f) per channel (mm).
const fn params(w: f64, sqrt_tau_near: [f64; 3], sqrt_tau_far: [f64; 3]) -> ManualParams {
    ManualParams {
        w,
        sqrt_tau_near,
        sqrt_tau_far,
    }
}

/// Freude 2014, table A.1.
#[rustfmt::skip]
pub const PRESETS: [(&str, ManualParams); 5] = [
    ("apple", params(0.368, [0.0495, 0.0455, 0.0372], [1.1, 1.08, 0.926])),
    ("ketchup", params(0.665, [0.0907, 0.0331, 0.0331], [1.5, 0.118, 0.0966])),
    ("marble", params(0.234, [0.0371, 0.0207, 0.015], [0.663, 0.616, 0.558])),
    ("skin1", params(0.533, [0.429, 0.211, 0.03], [1.15, 0.69, 0.471])),
    ("wholemilk", params(0.407, [0.0846, 0.0846, 0.0583], [1.5, 1.39, 1.17])),
];

pub fn preset(name: &str) -> Result<ManualParams> {
    PRESETS
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|(_, p)| *p)
        .ok_or_else(|| {
            Error::invalid(
                "manual",
                "preset",
                name,
                format!(
                    "unknown; table A.1 has {}",
                    PRESETS.iter().map(|p| p.0).collect::<Vec<_>>().join(", ")
                ),
            )
        })
}

impl ManualParams {
    pub fn validate(&self) -> Result<()> {
        if !(self.w >= 0.0 && self.w <= 1.0) {
            return Err(Error::invalid("manual", "w", self.w, "must be in [0, 1]"));
        }
        for (param, v) in [
            ("sqrt_tau_near", self.sqrt_tau_near),
            ("sqrt_tau_far", self.sqrt_tau_far),
        ] {
            if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                return Err(Error::invalid(
                    "manual",
                    param,
                    x,
                    "widths sqrt(tau) must be finite and >= 0 (mm)",
                ));
            }
        }
        Ok(())
    }

    pub fn to_json(&self) -> serde_json::Value {
        json!({"w": self.w, "sqrt_tau_near": self.sqrt_tau_near, "sqrt_tau_far": self.sqrt_tau_far})
    }
}

/// The factor of one channel: cell integrals of a_m.
fn channel_factor(k: &Kernel2D, p: &ManualParams, c: usize) -> Vec<f64> {
    mixture(p, c, |tau| gaussian_cells(k, tau))
}

/// The two-Gaussian mixture w g_near + (1 - w) g_far of channel `c`, each
/// Gaussian's cells from `cells(variance)`.
fn mixture(p: &ManualParams, c: usize, cells: impl Fn(f64) -> Vec<f64>) -> Vec<f64> {
    let gn = cells(p.sqrt_tau_near[c].powi(2));
    let gf = cells(p.sqrt_tau_far[c].powi(2));
    gn.iter()
        .zip(&gf)
        .map(|(n, f)| p.w * n + (1.0 - p.w) * f)
        .collect()
}

pub fn manual(k: &Kernel2D, p: &ManualParams) -> Result<Factors> {
    p.validate()?;
    Ok(vec![std::array::from_fn(|c| channel_factor(k, p, c))])
}

/// ||R - a a^T||_F^2 up to the constant ||R||_F^2, for an even factor
/// given by its half `a` (cells m = 0..=h) and R by its quadrant `q`.
fn misfit(q: &HalfQuad, a: &[f64]) -> f64 {
    let aa = half_dot(a, a);
    aa * aa - 2.0 * q.form(a)
}

/// Half of the factor (cells m = 0..=h) of one channel.
fn channel_half(k: &Kernel2D, p: &ManualParams, c: usize) -> Vec<f64> {
    mixture(p, c, |tau| gaussian_half_cells(k, tau))
}

/// Finds w, tau_n, tau_f minimising the summed kernel-space squared error of
/// the three channels: Nelder-Mead over (logit w, log sqrt tau) from several
/// starts spread between the kernel's cell size and extent.
pub fn fit(k: &Kernel2D) -> Result<(ManualParams, serde_json::Value)> {
    let quadrants: Vec<HalfQuad> = (0..3)
        .map(|c| HalfQuad::new(&k.quadrant(c), k.half() + 1))
        .collect();
    let lo = (0.25 * k.cell_mm).ln();
    // A Gaussian much wider than the kernel would act as a constant floor
    // whose mass lies off the grid (and off any tap table): keep 3 sigma
    // inside the extent.
    let hi = (k.extent_mm() / 3.0).ln();
    let decode = |x: &[f64]| ManualParams {
        w: 1.0 / (1.0 + (-x[0]).exp()),
        sqrt_tau_near: [x[1].exp(), x[2].exp(), x[3].exp()],
        sqrt_tau_far: [x[4].exp(), x[5].exp(), x[6].exp()],
    };
    let cost = |x: &[f64]| -> f64 {
        let p = decode(x);
        (0..3)
            .map(|c| misfit(&quadrants[c], &channel_half(k, &p, c)))
            .sum()
    };
    let mut best: Option<(Vec<f64>, f64)> = None;
    for (near_t, far_t, w) in [(0.15, 0.6, 0.0), (0.3, 0.75, 0.0), (0.05, 0.45, 1.0)] {
        let ln = lo + near_t * (hi - lo);
        let lf = lo + far_t * (hi - lo);
        let x0 = vec![w, ln, ln, ln, lf, lf, lf];
        let mut x = x0;
        // Restarts shake the simplex out of early collapse.
        for _ in 0..3 {
            x = nelder_mead(cost, &x, 0.5, (lo.min(-12.0), hi), 1500);
        }
        let f = cost(&x);
        if best.as_ref().is_none_or(|b| f < b.1) {
            best = Some((x, f));
        }
    }
    let (x, f) = best
        .ok_or_else(|| Error::Unsupported("the manual two-Gaussian fit found no optimum".into()))?;
    let mut p = decode(&x);
    // Keep "near" the narrower Gaussian per channel (swap w is shared, so
    // only report; the model is symmetric in the roles when w = 1/2).
    p.w = p.w.clamp(0.0, 1.0);
    Ok((p, json!({"fit_objective": f})))
}
