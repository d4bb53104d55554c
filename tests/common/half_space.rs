//! Exact angular reflection of a semi-infinite, isotropically scattering
//! medium: Chandrasekhar's H-function (Chandrasekhar 1960, "Radiative
//! Transfer", chapters IV and V), and the same half-space under a smooth
//! Fresnel boundary by adding the interface to it (the interreflections
//! between the boundary and the medium summed by solving their integral
//! equation). Written from the equations, not from ssskit's tracer: the
//! oracle of the angle-resolved Monte Carlo tests.
//!
//! For isotropic scattering of albedo a the diffusely reflected radiance of
//! a collimated beam of irradiance E at cosine mu0 is
//! L(mu) = E (a / 4 pi) H(mu) H(mu0) / (mu + mu0), independent of azimuth,
//! so the power it sends upward per unit mu is
//! K(mu | mu0) = (a / 2) H(mu) H(mu0) mu / (mu + mu0) per unit power in,
//! and the plane albedo is 1 - sqrt(1 - a) H(mu0).

use std::f64::consts::PI;

/// Gauss-Legendre nodes and weights on [lo, hi] (n points, Newton on the
/// Legendre recurrence).
pub fn gauss(n: usize, lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let p = if n == 0 { 1.0 } else { p1 };
            dp = n as f64 * (x * p - p0) / (x * x - 1.0);
            let dx = p / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out.push((lo + (hi - lo) * (x + 1.0) / 2.0, w * (hi - lo) / 2.0));
    }
    out
}

/// Composite Gauss rule on [lo, hi], pieces graded geometrically toward
/// `lo` (halving 40 times): integrands with a log or square-root corner
/// there converge like smooth ones.
pub fn graded(lo: f64, hi: f64, points: usize) -> Vec<(f64, f64)> {
    let mut cuts = vec![lo];
    cuts.extend((0..=40).rev().map(|k| lo + (hi - lo) * 0.5f64.powi(k)));
    cuts.windows(2)
        .flat_map(|w| gauss(points, w[0], w[1]))
        .collect()
}

/// H(mu) for isotropic scattering of albedo `a` < 1 from Chandrasekhar's
/// closed form, ln H(mu) = -(mu / pi) int_0^{pi/2} ln(1 - a t cot t) /
/// (cos^2 t + mu^2 sin^2 t) dt.
pub fn h_closed(a: f64, mu: f64) -> f64 {
    let f = |t: f64| {
        // 1 - t cot t, by its series where the difference would cancel.
        let t2 = t * t;
        let one_minus_tc = if t < 0.05 {
            t2 * (1.0 / 3.0 + t2 * (1.0 / 45.0 + t2 * (2.0 / 945.0 + t2 / 4725.0)))
        } else {
            1.0 - t / t.tan()
        };
        ((1.0 - a) + a * one_minus_tc).ln() / (t.cos().powi(2) + mu * mu * t.sin().powi(2))
    };
    // Graded toward 0 (a log singularity for a = 1) and toward pi/2, where
    // the denominator is mu^2 for small mu.
    static RULE: std::sync::OnceLock<Vec<(f64, f64)>> = std::sync::OnceLock::new();
    let rule = RULE.get_or_init(|| graded(0.0, PI / 4.0, 12));
    let lo: f64 = rule.iter().map(|(x, w)| w * f(*x)).sum();
    let hi: f64 = rule.iter().map(|(x, w)| w * f(PI / 2.0 - x)).sum();
    (-(mu / PI) * (lo + hi)).exp()
}

/// H by its integral equation 1 / H(mu) = sqrt(1 - a) + (a/2) int_0^1
/// mu' H(mu') / (mu + mu') dmu' (Chandrasekhar 1960), iterated on a graded
/// rule for a < 1 (at a = 1 the iteration crawls); returns the rule and H at
/// its nodes.
pub fn h_iterated(a: f64) -> (Vec<(f64, f64)>, Vec<f64>) {
    let rule = graded(0.0, 1.0, 8);
    let h = super::fixed_point::iterate(vec![1.0; rule.len()], 5000, 1e-14, |h| {
        rule.iter()
            .map(|&(mu, _)| {
                let s: f64 = rule
                    .iter()
                    .zip(h)
                    .map(|(&(m, w), hv)| w * m * hv / (mu + m))
                    .sum();
                1.0 / ((1.0 - a).max(0.0).sqrt() + 0.5 * a * s)
            })
            .collect()
    });
    (rule, h)
}

/// Unpolarised Fresnel reflectance from index 1 into `eta` (or out of it
/// for `eta` < 1) at cosine `c`; 1 beyond the critical angle. Written in
/// the angles' form (Born and Wolf 1999, sec. 1.5.3:
/// R_s = sin^2(i - t) / sin^2(i + t), R_p = tan^2(i - t) / tan^2(i + t)),
/// not the cosines' form ssskit uses, so the two share no algebra.
pub fn fresnel(c: f64, eta: f64) -> f64 {
    let i = c.clamp(-1.0, 1.0).acos();
    let sin_t = i.sin() / eta;
    if sin_t >= 1.0 {
        return 1.0;
    }
    let t = sin_t.asin();
    if i == 0.0 {
        // Normal incidence, the limit of both ratios.
        return ((eta - 1.0) / (eta + 1.0)).powi(2);
    }
    let rs = ((i - t).sin() / (i + t).sin()).powi(2);
    // At i + t = 90 degrees (Brewster) tan(i + t) is infinite: R_p = 0.
    let rp = ((i - t).tan() / (i + t).tan()).powi(2);
    0.5 * (rs + rp)
}

/// The half-space of albedo `a` and relative index `n` under air, lit by a
/// collimated beam at cosine `mu0` in air.
pub struct HalfSpace {
    a: f64,
    n: f64,
    /// Cosine inside beyond which light escapes (0 for n = 1).
    mu_c: f64,
    /// Nystrom rule inside and the upward power density u at its nodes.
    rule: Vec<(f64, f64)>,
    /// H and u at the rule's nodes.
    h: Vec<f64>,
    u: Vec<f64>,
    /// Source term factors: (1 - F(mu0)) and the refracted cosine.
    t0: f64,
    mu_t: f64,
    h_mu_t: f64,
}

impl HalfSpace {
    /// Solves u(mu) = s(mu) + int K(mu | mu') F_in(mu') u(mu') dmu' (the
    /// upward power per unit mu just under the boundary, all
    /// interreflections), s = (1 - F(mu0)) K(mu | mu_t).
    pub fn new(a: f64, n: f64, mu0: f64) -> HalfSpace {
        let mu_c = (1.0 - 1.0 / (n * n)).max(0.0).sqrt();
        let mu_t = (1.0 - (1.0 - mu0 * mu0) / (n * n)).sqrt();
        let mut rule = if mu_c > 0.0 {
            graded(0.0, mu_c, 6)
        } else {
            vec![]
        };
        rule.extend(graded(mu_c, 1.0, 6));
        let mut hs = HalfSpace {
            a,
            n,
            mu_c,
            u: vec![],
            t0: 1.0 - fresnel(mu0, n),
            mu_t,
            h_mu_t: h_closed(a, mu_t),
            rule: vec![],
            h: vec![],
        };
        let h: Vec<f64> = rule.iter().map(|&(m, _)| h_closed(a, m)).collect();
        let m = rule.len();
        // (I - K F W) u = s, dense Gaussian elimination with pivoting.
        let mut mat = vec![0.0; m * m];
        let mut rhs = vec![0.0; m];
        for i in 0..m {
            let mi = rule[i].0;
            rhs[i] = hs.t0 * 0.5 * a * h[i] * hs.h_mu_t * mi / (mi + mu_t);
            for j in 0..m {
                let (mj, wj) = rule[j];
                let k = 0.5 * a * h[i] * h[j] * mi / (mi + mj);
                mat[i * m + j] = (i == j) as u8 as f64 - k * hs.f_in(mj) * wj;
            }
        }
        for col in 0..m {
            let p = (col..m)
                .max_by(|&x, &y| mat[x * m + col].abs().total_cmp(&mat[y * m + col].abs()))
                .unwrap();
            for k in 0..m {
                mat.swap(col * m + k, p * m + k);
            }
            rhs.swap(col, p);
            for r in col + 1..m {
                let f = mat[r * m + col] / mat[col * m + col];
                for k in col..m {
                    mat[r * m + k] -= f * mat[col * m + k];
                }
                rhs[r] -= f * rhs[col];
            }
        }
        let mut u = vec![0.0; m];
        for i in (0..m).rev() {
            let s: f64 = (i + 1..m).map(|k| mat[i * m + k] * u[k]).sum();
            u[i] = (rhs[i] - s) / mat[i * m + i];
        }
        hs.u = u;
        hs.rule = rule;
        hs.h = h;
        hs
    }

    /// Fresnel reflectance of the boundary for light inside at cosine mu.
    fn f_in(&self, mu: f64) -> f64 {
        if self.n == 1.0 {
            0.0
        } else {
            fresnel(mu, 1.0 / self.n)
        }
    }

    /// u at any mu by the Nystrom interpolation of the solved equation.
    fn u_at(&self, mu: f64) -> f64 {
        let (a, h) = (self.a, h_closed(self.a, mu));
        let s = self.t0 * 0.5 * a * h * self.h_mu_t * mu / (mu + self.mu_t);
        let k: f64 = self
            .rule
            .iter()
            .zip(self.h.iter().zip(&self.u))
            .map(|(&(m, w), (hm, u))| w * 0.5 * a * h * hm * mu / (mu + m) * self.f_in(m) * u)
            .sum();
        s + k
    }

    /// The cosine inside that refracts out at `theta_air` (radians).
    fn inside(&self, theta_air: f64) -> f64 {
        (1.0 - theta_air.sin().powi(2) / (self.n * self.n))
            .max(0.0)
            .sqrt()
    }

    /// Part of the incident power leaving into the air between the polar
    /// angles `lo` and `hi` (radians).
    pub fn fraction(&self, lo: f64, hi: f64) -> f64 {
        let (m_lo, m_hi) = (self.inside(hi), self.inside(lo));
        // Graded toward the grazing end, where 1 - F_in has a square-root
        // corner at the critical angle.
        graded(m_lo, m_hi, 8)
            .iter()
            .map(|&(m, w)| w * (1.0 - self.f_in(m)) * self.u_at(m))
            .sum()
    }

    /// The whole diffuse reflectance.
    pub fn total(&self) -> f64 {
        self.fraction(0.0, PI / 2.0)
    }

    /// The part reflected at entry.
    pub fn specular(&self) -> f64 {
        1.0 - self.t0
    }

    pub fn mu_c(&self) -> f64 {
        self.mu_c
    }
}
