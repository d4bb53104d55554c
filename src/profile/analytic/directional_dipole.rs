//! The directional dipole of Frisvad et al. 2014 (000 ch. 3.3, 001
//! appendix), reduced to a radial profile for normal incidence on a plane.
//!
//! Errata fixed (REFERENCE.md section 7): in 001 the last term of S'_d
//! belongs inside C_E(eta)(...); d_v = |x_o - x_v|. Checked against the
//! structure of 000 eq. 3.13 (where the bracket is right).
//!
//! At normal incidence the refracted ray is w_12 = -n, mu_0 = 1, the
//! modified tangent plane is the surface itself (n_i* = n), so with
//! x = x_o - x_i = (r, 0, 0):
//! - real source: x.w = 0, w.n = -1, x.n = 0, and
//!   d_r^2 = r^2 + D (D + 2 d_e r / sqrt(r^2 + d_e^2));
//! - virtual source at height z_v = 2 A d_e with w_v = +n: x.w = x.n = -z_v,
//!   w.n = 1, d_v^2 = r^2 + z_v^2.
//!
//! Integrating the outgoing Fresnel transmission over the hemisphere gives
//! 4 pi C_phi(1/eta), which cancels S_d's 1/(4 C_phi(1/eta)) (000 eq. 3.11):
//! R_d(r) = T_entry pi (S'_d(real) - S'_d(virtual)). The real source term
//! then reduces to C_phi phi(r), as in the standard dipole.

use crate::material::Medium;
use crate::profile::fresnel::FresnelMode;
use std::f64::consts::PI;

#[derive(Clone, Debug)]
pub struct DirectionalDipole {
    pub d: f64,
    pub sigma_tr: f64,
    /// Extrapolation distance d_e = 2.131 D / sqrt(alpha') (000 eq. after 3.15).
    pub d_e: f64,
    pub a: f64,
    pub c_phi: f64,
    pub c_e: f64,
    pub t_entry: f64,
}

impl DirectionalDipole {
    pub fn new(m: &Medium, mode: FresnelMode, t_entry: f64) -> DirectionalDipole {
        let alpha = m.reduced_albedo();
        let d = m.diffusion_coefficient();
        DirectionalDipole {
            d,
            sigma_tr: m.sigma_tr(),
            d_e: 2.131 * d / alpha.sqrt(),
            a: mode.boundary_a(m.eta),
            c_phi: mode.c_phi(m.eta),
            c_e: mode.c_e(m.eta),
            t_entry,
        }
    }

    /// S'_d of 000 eq. 3.13 without the 1/(4 C_phi(1/eta)) factor, for the
    /// scalar products x.w, w.n, x.n and distance `dist`.
    fn s_prime(&self, x_w: f64, w_n: f64, x_n: f64, dist: f64) -> f64 {
        let (d, tr) = (self.d, self.sigma_tr);
        let one = 1.0 + tr * dist;
        let r2 = dist * dist;
        let t0 = (-tr * dist).exp() / (4.0 * PI * PI * r2 * dist);
        let t1 = r2 / d + 3.0 * one * x_w;
        let t2 = 3.0 * d * one * w_n;
        let t3 = (one + 3.0 * d * (3.0 * one + (tr * dist).powi(2)) / r2 * x_w) * x_n;
        t0 * (self.c_phi * t1 - self.c_e * (t2 - t3))
    }

    /// Height of the virtual source above the surface, 2 A d_e.
    pub fn z_v(&self) -> f64 {
        2.0 * self.a * self.d_e
    }

    pub fn rd(&self, r: f64) -> f64 {
        let (d, d_e) = (self.d, self.d_e);
        // d_e |cos beta| = r / sqrt((r/d_e)^2 + 1): finite as alpha' -> 0,
        // where d_e -> inf, the virtual source leaves and the real one
        // stays (the model does not vanish without scattering).
        let de_cos_beta = r / ((r / d_e).powi(2) + 1.0).sqrt();
        let d_r = (r * r + d * (d + 2.0 * de_cos_beta)).sqrt();
        let real = self.s_prime(0.0, -1.0, 0.0, d_r);
        let z_v = self.z_v();
        let virt = if z_v.is_finite() {
            self.s_prime(-z_v, 1.0, -z_v, (r * r + z_v * z_v).sqrt())
        } else {
            0.0
        };
        // The flux terms can push the difference below zero far out; the
        // clamp is Frisvad's (and appleseed's) too.
        (self.t_entry * PI * (real - virt)).max(0.0)
    }
}
