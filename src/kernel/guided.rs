//! Guided optimization (002 5.3):
//!   argmin_a  sum_xy Gamma(x, y; k) (R(x, y) - a(x) a(y))^2
//!   subject to ||a||_1^2 = ||R||_1                          (002 eq. 5.19)
//!   Gamma = (x^2 + y^2)^{k/2} (1 - e^{-b x^2}) (1 - e^{-b y^2})  (eq. 5.20)
//! with x, y scaled to [-1, 1] over the kernel (002: b = 50 refers to that
//! interval); b = 0 drops the exponential factors.
//!
//! Unlike 002's soft penalty the constraint is exact by parametrisation:
//! a = sqrt(||R||_1) p / sum(p) for free, even-symmetric p, and the gradient
//! goes through the rescaling. Solved with argmin's L-BFGS (More-Thuente line
//! search), started from the better of pre-integration and rank-1 SVD.

use super::model::Factors;
use super::Kernel2D;
use crate::error::{Error, Result};
use argmin::core::{CostFunction, Executor, Gradient, State};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use serde_json::json;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuidedParams {
    pub k: f64,
    pub b: f64,
    pub max_iters: u64,
}

impl Default for GuidedParams {
    fn default() -> Self {
        GuidedParams {
            k: 1.0,
            b: 0.0,
            max_iters: 2000,
        }
    }
}

/// Per-channel outcome of the optimisation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct GuidedReport {
    pub objective: f64,
    pub objective_start: f64,
    pub iterations: u64,
    pub constraint_error: f64,
    pub start: &'static str,
    pub termination: String,
}

/// Gamma on the kernel grid (002 eq. 5.20), row-major.
pub fn gamma(k: &Kernel2D, kexp: f64, b: f64) -> Vec<f64> {
    let n = k.size;
    let half = k.half().max(1) as f64;
    let u: Vec<f64> = (0..n)
        .map(|i| (i as f64 - k.half() as f64) / half)
        .collect();
    let edge: Vec<f64> = u
        .iter()
        .map(|x| {
            if b > 0.0 {
                1.0 - (-b * x * x).exp()
            } else {
                1.0
            }
        })
        .collect();
    let mut g = vec![0.0; n * n];
    for iy in 0..n {
        for ix in 0..n {
            let r2 = u[ix] * u[ix] + u[iy] * u[iy];
            let radial = if kexp == 0.0 {
                1.0
            } else {
                r2.powf(kexp / 2.0)
            };
            g[iy * n + ix] = radial * edge[ix] * edge[iy];
        }
    }
    g
}

/// The weighted objective and its gradient with respect to the half-factor
/// q (q[m] is a at |offset| = m cells).
struct Problem<'a> {
    r: &'a [f64],
    gamma: &'a [f64],
    n: usize,
    /// sqrt(||R||_1): the factor's required sum.
    c: f64,
    /// Objective scale (the starting value), so tolerances are relative.
    scale: f64,
}

impl Problem<'_> {
    fn expand(&self, q: &[f64]) -> Vec<f64> {
        let h = self.n / 2;
        (0..self.n).map(|i| q[i.abs_diff(h)]).collect()
    }

    /// a = c p / sum p.
    fn factor(&self, q: &[f64]) -> (Vec<f64>, f64) {
        let p = self.expand(q);
        let s: f64 = p.iter().sum();
        (p.iter().map(|v| self.c * v / s).collect(), s)
    }

    fn objective(&self, a: &[f64]) -> f64 {
        let n = self.n;
        let mut f = 0.0;
        for iy in 0..n {
            let row = iy * n;
            for ix in 0..n {
                let d = self.r[row + ix] - a[ix] * a[iy];
                f += self.gamma[row + ix] * d * d;
            }
        }
        f
    }

    fn cost_grad(&self, q: &[f64]) -> (f64, Vec<f64>) {
        let n = self.n;
        let h = n / 2;
        let (a, s) = self.factor(q);
        // dF/da_i = -4 sum_j Gamma_ij (R_ij - a_i a_j) a_j (Gamma, R symmetric).
        let mut ga = vec![0.0; n];
        let mut f = 0.0;
        for iy in 0..n {
            let row = iy * n;
            let mut acc = 0.0;
            for ix in 0..n {
                let d = self.r[row + ix] - a[ix] * a[iy];
                let gd = self.gamma[row + ix] * d;
                f += gd * d;
                acc += gd * a[ix];
            }
            ga[iy] = -4.0 * acc;
        }
        // Through a = c p / s: dF/dp_k = (c/s) (g_k - sum_i g_i a_i / c).
        let ga_dot_a: f64 = ga.iter().zip(&a).map(|(g, a)| g * a).sum();
        let mut gq = vec![0.0; h + 1];
        for (i, g) in ga.iter().enumerate() {
            gq[i.abs_diff(h)] += self.c / s * (g - ga_dot_a / self.c);
        }
        let inv = 1.0 / self.scale;
        (f * inv, gq.into_iter().map(|g| g * inv).collect())
    }
}

impl CostFunction for Problem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, q: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let (a, s) = self.factor(q);
        if !(s.abs() > 0.0) {
            return Ok(f64::INFINITY);
        }
        Ok(self.objective(&a) / self.scale)
    }
}

impl Gradient for Problem<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, q: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        Ok(self.cost_grad(q).1)
    }
}

/// Optimises every channel; `starts` are candidate initial factors per
/// channel with their names (pre-integration, rank-1 SVD).
pub fn guided(
    k: &Kernel2D,
    params: &GuidedParams,
    starts: &[(&'static str, [Vec<f64>; 3])],
) -> Result<(Factors, serde_json::Value)> {
    if !(params.k.is_finite() && params.k >= 0.0 && params.k <= 8.0) {
        return Err(Error::invalid(
            "guided",
            "--k",
            params.k,
            "must be in [0, 8]",
        ));
    }
    if !(params.b.is_finite() && params.b >= 0.0) {
        return Err(Error::invalid(
            "guided",
            "--b",
            params.b,
            "must be finite and >= 0",
        ));
    }
    let n = k.size;
    let gam = gamma(k, params.k, params.b);
    let mut factor: [Vec<f64>; 3] = Default::default();
    let mut reports = Vec::new();
    for c in 0..3 {
        let r = &k.data[c];
        let norm1: f64 = r.iter().map(|v| v.abs()).sum();
        let mut prob = Problem {
            r,
            gamma: &gam,
            n,
            c: norm1.sqrt(),
            scale: 1.0,
        };
        // Start from the candidate with the lowest objective once rescaled.
        let (start_name, q0, f0) = starts
            .iter()
            .filter_map(|(name, f)| {
                let q: Vec<f64> = f[c][n / 2..].to_vec();
                let s: f64 = prob.expand(&q).iter().sum();
                if !(s > 0.0) {
                    return None;
                }
                let (a, _) = prob.factor(&q);
                Some((*name, q, prob.objective(&a)))
            })
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .ok_or_else(|| Error::Unsupported("guided: no usable starting factor".into()))?;
        prob.scale = if f0 > 0.0 { f0 } else { 1.0 };
        let (q, iters, term) = if f0 > 0.0 && n > 1 {
            run_lbfgs(&prob, q0.clone(), params.max_iters)?
        } else {
            (q0.clone(), 0, "already optimal".to_string())
        };
        let (a, _) = prob.factor(&q);
        let fobj = prob.objective(&a);
        let (a, fobj, iters) = if fobj <= f0 {
            (a, fobj, iters)
        } else {
            (prob.factor(&q0).0, f0, iters)
        };
        let sum: f64 = a.iter().sum();
        reports.push(GuidedReport {
            objective: fobj,
            objective_start: f0,
            iterations: iters,
            constraint_error: ((sum * sum - norm1) / norm1).abs(),
            start: start_name,
            termination: term,
        });
        factor[c] = a;
    }
    let extra = json!({
        "objective": reports.iter().map(|r| r.objective).collect::<Vec<_>>(),
        "iterations": reports.iter().map(|r| r.iterations).collect::<Vec<_>>(),
        "constraint_error": reports.iter().map(|r| r.constraint_error).collect::<Vec<_>>(),
        "channels": reports,
    });
    Ok((vec![factor], extra))
}

fn run_lbfgs(prob: &Problem, q0: Vec<f64>, max_iters: u64) -> Result<(Vec<f64>, u64, String)> {
    let ls = MoreThuenteLineSearch::new();
    let solver = LBFGS::new(ls, 10)
        .with_tolerance_grad(1e-12)
        .and_then(|s| s.with_tolerance_cost(1e-15))
        .map_err(|e| Error::Unsupported(format!("guided: solver set-up: {e}")))?;
    let res = Executor::new(prob, solver)
        .configure(|s| s.param(q0).max_iters(max_iters))
        .run()
        .map_err(|e| Error::Unsupported(format!("guided: optimisation failed: {e}")))?;
    let st = res.state();
    let q = st
        .get_best_param()
        .cloned()
        .ok_or_else(|| Error::Unsupported("guided: optimiser returned no solution".into()))?;
    Ok((q, st.get_iter(), format!("{}", st.get_termination_status())))
}

impl CostFunction for &Problem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, q: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        (*self).cost(q)
    }
}

impl Gradient for &Problem<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, q: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        (*self).gradient(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_matches_finite_differences() {
        let n = 9;
        let r: Vec<f64> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f64 - 4.0, (i / n) as f64 - 4.0);
                (-(x * x + y * y).sqrt() / 2.0).exp()
            })
            .collect();
        let k = Kernel2D {
            size: n,
            cell_mm: 1.0,
            data: [r.clone(), r.clone(), r.clone()],
            total_rd: [1.0; 3],
            captured: [1.0; 3],
        };
        let gam = gamma(&k, 1.0, 3.0);
        let prob = Problem {
            r: &r,
            gamma: &gam,
            n,
            c: 2.0,
            scale: 1.0,
        };
        let q: Vec<f64> = (0..5).map(|m| 1.0 / (1.0 + m as f64)).collect();
        let (_, g) = prob.cost_grad(&q);
        for m in 0..5 {
            let h = 1e-6;
            let mut qp = q.clone();
            qp[m] += h;
            let mut qm = q.clone();
            qm[m] -= h;
            let fd = (prob.cost_grad(&qp).0 - prob.cost_grad(&qm).0) / (2.0 * h);
            assert!(
                (fd - g[m]).abs() < 1e-6 * g[m].abs().max(1e-3),
                "{m}: {fd} vs {}",
                g[m]
            );
        }
    }
}
