//! Guided optimization (Freude 2014, sec. 5.3):
//!   argmin_a  sum_xy Gamma(x, y; k) (R(x, y) - a(x) a(y))^2
//!   subject to ||a||_1^2 = ||R||_1                          (Freude 2014, eq. 5.19)
//!   Gamma = (x^2 + y^2)^{k/2} (1 - e^{-b x^2}) (1 - e^{-b y^2})  (eq. 5.20)
//! with x, y scaled to [-1, 1] over the kernel (Freude 2014: b = 50 refers to that
//! interval); b = 0 drops the exponential factors.
//!
//! Unlike Freude's soft penalty the constraint is exact by parametrisation:
//! a = sqrt(||R||_1) p / sum(p) for free, even-symmetric p, and the gradient
//! goes through the rescaling. Solved with argmin's L-BFGS (Nocedal 1980)
//! with the line search of Moré and Thuente 1994, started from the better of
//! pre-integration and rank-1 SVD.

use super::factors::Factors;
use super::kernel2d::multiplicity;
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
    /// |dF/dq| / F_start at the solution (L-BFGS stopping measure).
    pub gradient_norm: f64,
    pub start: &'static str,
    pub termination: String,
}

/// Gamma on the kernel grid (Freude 2014, eq. 5.20), row-major.
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

/// Rows of the gradient summed side by side: four AVX2 vectors.
const ROWS: usize = 16;

/// The weighted objective on the quadrant x, y >= 0 (R, Gamma and an even
/// factor are even in x and y: each quadrant cell stands for its mirrors,
/// counted by `w`), and its gradient with respect to the half-factor q
/// (q[m] is a at |offset| = m cells).
struct Problem {
    /// Quadrant of R, (h+1)^2.
    r: Vec<f64>,
    /// Gamma times the mirror multiplicities, (h+1)^2.
    w: Vec<f64>,
    /// `r` and `w` by columns (entry (iy, ix) at ix m + iy): the gradient's
    /// rows run side by side over them.
    rt: Vec<f64>,
    wt: Vec<f64>,
    /// h + 1.
    m: usize,
    /// sqrt(||R||_1): the factor's required sum.
    c: f64,
    /// Objective scale (the starting value), so tolerances are relative.
    scale: f64,
}

impl Problem {
    fn new(k: &Kernel2D, c: usize, gamma_full: &[f64]) -> Problem {
        let h = k.half();
        let n = k.size;
        let m = h + 1;
        let r = k.quadrant(c);
        let mut w = vec![0.0; m * m];
        for my in 0..m {
            for mx in 0..m {
                w[my * m + mx] =
                    gamma_full[(h + my) * n + h + mx] * multiplicity(mx) * multiplicity(my);
            }
        }
        let norm1: f64 = k.data[c].iter().map(|v| v.abs()).sum();
        let by_columns =
            |v: &[f64]| -> Vec<f64> { (0..m * m).map(|i| v[(i % m) * m + i / m]).collect() };
        Problem {
            rt: by_columns(&r),
            wt: by_columns(&w),
            r,
            w,
            m,
            c: norm1.sqrt(),
            scale: 1.0,
        }
    }

    /// Sum of the full factor for a half-factor.
    fn full_sum(&self, q: &[f64]) -> f64 {
        q.iter().enumerate().map(|(i, v)| multiplicity(i) * v).sum()
    }

    /// a = c q / sum(full p): the half of the constrained factor.
    fn factor(&self, q: &[f64]) -> (Vec<f64>, f64) {
        let s = self.full_sum(q);
        (q.iter().map(|v| self.c * v / s).collect(), s)
    }

    fn objective(&self, a: &[f64]) -> f64 {
        let m = self.m;
        let mut f = 0.0;
        for (iy, ay) in a.iter().enumerate() {
            let row = iy * m;
            for (ix, ax) in a.iter().enumerate() {
                let d = self.r[row + ix] - ax * ay;
                f += self.w[row + ix] * d * d;
            }
        }
        f
    }

    /// The objective (scaled) and its gradient with respect to q in one
    /// sweep (the tests' yardstick for [`Self::gradient_of`]).
    #[cfg(test)]
    fn cost_grad(&self, q: &[f64]) -> (f64, Vec<f64>) {
        let m = self.m;
        let (a, s) = self.factor(q);
        // dF/da_k = -4 sum_j W_kj (R_kj - a_k a_j) a_j (W, R symmetric).
        let mut ga = vec![0.0; m];
        let mut f = 0.0;
        for (iy, ay) in a.iter().enumerate() {
            let row = iy * m;
            let mut acc = 0.0;
            for (ix, ax) in a.iter().enumerate() {
                let d = self.r[row + ix] - ax * ay;
                let wd = self.w[row + ix] * d;
                f += wd * d;
                acc += wd * ax;
            }
            ga[iy] = -4.0 * acc;
        }
        (f * (1.0 / self.scale), self.through_factor(&a, s, ga))
    }

    /// The gradient with respect to q alone (the line search asks for the
    /// objective apart): each row's sum as `cost_grad` adds it, the rows
    /// side by side over the columns (independent sums, vector lanes in
    /// AVX2 where the CPU has it), the same bits.
    fn gradient_of(&self, q: &[f64]) -> Vec<f64> {
        let (a, s) = self.factor(q);
        let mut ga = vec![0.0; self.m];
        #[cfg(target_arch = "x86_64")]
        if crate::numerics::has_avx2() {
            // SAFETY: has_avx2 checked the CPU features.
            unsafe { self.da_avx2(&a, &mut ga) };
            return self.through_factor(&a, s, ga);
        }
        self.da_lanes(&a, &mut ga);
        self.through_factor(&a, s, ga)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn da_avx2(&self, a: &[f64], ga: &mut [f64]) {
        self.da_lanes(a, ga)
    }

    /// dF/da_k = -4 sum_j W_kj (R_kj - a_k a_j) a_j (W, R symmetric), into
    /// `ga`, [`ROWS`] rows at a time.
    #[inline(always)]
    fn da_lanes(&self, a: &[f64], ga: &mut [f64]) {
        let m = self.m;
        for iy0 in (0..m).step_by(ROWS) {
            let rows = ROWS.min(m - iy0);
            let ay = &a[iy0..iy0 + rows];
            let mut acc = [0.0f64; ROWS];
            for (ix, ax) in a.iter().enumerate() {
                let r = &self.rt[ix * m + iy0..ix * m + iy0 + rows];
                let w = &self.wt[ix * m + iy0..ix * m + iy0 + rows];
                for (((acc, r), w), ay) in acc.iter_mut().zip(r).zip(w).zip(ay) {
                    let d = r - ax * ay;
                    let wd = w * d;
                    *acc += wd * ax;
                }
            }
            for (g, acc) in ga[iy0..iy0 + rows].iter_mut().zip(acc) {
                *g = -4.0 * acc;
            }
        }
    }

    /// dF/dq from dF/da (`ga`) through a = c q / s, s = sum_k mult_k q_k:
    /// dF/dq_k = (c/s) (g_k - mult_k (g . a) / c), scaled.
    fn through_factor(&self, a: &[f64], s: f64, ga: Vec<f64>) -> Vec<f64> {
        let ga_dot_a: f64 = ga.iter().zip(a).map(|(g, a)| g * a).sum();
        let inv = 1.0 / self.scale;
        ga.iter()
            .enumerate()
            .map(|(k, g)| inv * self.c / s * (g - multiplicity(k) * ga_dot_a / self.c))
            .collect()
    }
}

impl CostFunction for Problem {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, q: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let (a, s) = self.factor(q);
        if !(s.abs() > 0.0) || !s.is_finite() {
            return Ok(f64::INFINITY);
        }
        Ok(self.objective(&a) / self.scale)
    }
}

impl Gradient for Problem {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, q: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        Ok(self.gradient_of(q))
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
        return Err(Error::invalid("guided", "k", params.k, "must be in [0, 8]"));
    }
    if !(params.b.is_finite() && params.b >= 0.0) {
        return Err(Error::invalid(
            "guided",
            "b",
            params.b,
            "must be finite and >= 0",
        ));
    }
    let n = k.size;
    let h = k.half();
    let gam = gamma(k, params.k, params.b);
    let mut factor: [Vec<f64>; 3] = Default::default();
    let mut reports = Vec::new();
    for c in 0..3 {
        let mut prob = Problem::new(k, c, &gam);
        let norm1 = prob.c * prob.c;
        // Start from the candidate with the lowest objective once rescaled.
        let (start_name, q0, f0) = starts
            .iter()
            .filter_map(|(name, f)| {
                let q: Vec<f64> = f[c][h..].to_vec();
                if !(prob.full_sum(&q) > 0.0) {
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
        let (a, fobj) = if fobj <= f0 {
            (a, fobj)
        } else {
            (prob.factor(&q0).0, f0)
        };
        let grad_norm = {
            let g = prob.gradient_of(&a);
            g.iter().map(|x| x * x).sum::<f64>().sqrt()
        };
        let full: Vec<f64> = (0..n).map(|i| a[i.abs_diff(h)]).collect();
        let sum: f64 = full.iter().sum();
        reports.push(GuidedReport {
            objective: fobj,
            objective_start: f0,
            iterations: iters,
            constraint_error: ((sum * sum - norm1) / norm1).abs(),
            gradient_norm: grad_norm,
            start: start_name,
            termination: term,
        });
        factor[c] = full;
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

impl CostFunction for &Problem {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, q: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        (*self).cost(q)
    }
}

impl Gradient for &Problem {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, q: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        (*self).gradient(q)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A kernel of `n` cells falling as e^(-r/2) from its centre.
    fn falling(n: usize) -> Kernel2D {
        let c = (n / 2) as f64;
        let r: Vec<f64> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f64 - c, (i / n) as f64 - c);
                (-(x * x + y * y).sqrt() / 2.0).exp()
            })
            .collect();
        Kernel2D {
            size: n,
            cell_mm: 1.0,
            data: [r.clone(), r.clone(), r],
            total_rd: [1.0; 3],
            captured: [1.0; 3],
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let k = falling(9);
        let gam = gamma(&k, 1.0, 3.0);
        let prob = Problem::new(&k, 0, &gam);
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

    /// The gradient alone is `cost_grad`'s bit for bit (rows of every
    /// remainder of the four-row blocks).
    #[test]
    fn the_gradient_alone_is_the_joint_sweeps_bit_for_bit() {
        for n in [9, 13, 41, 67] {
            let k = falling(n);
            let prob = Problem::new(&k, 0, &gamma(&k, 1.55, 50.0));
            let q: Vec<f64> = (0..=n / 2).map(|m| 1.0 / (1.0 + m as f64)).collect();
            let bits = |v: Vec<f64>| v.into_iter().map(f64::to_bits).collect::<Vec<_>>();
            assert_eq!(
                bits(prob.gradient_of(&q)),
                bits(prob.cost_grad(&q).1),
                "n {n}"
            );
        }
    }
}
