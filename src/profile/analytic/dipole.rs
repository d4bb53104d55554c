//! The standard dipole of Jensen et al. 2001 (as in Dal Corso 2014,
//! ch. 3, with the sign erratum of eq. 3.7/3.10 fixed).

use crate::material::Medium;
use crate::profile::fresnel::FresnelMode;
use std::f64::consts::PI;

/// Diffuse Fresnel reflectance fit F_dr(eta) (Egan and Hilgeman 1979;
/// Jensen et al. 2001, eq. 5). A transcription of it prints the last coefficient as
/// 0.0036: an erratum. The published 0.0636 matches the exact diffuse internal
/// reflectance 2 C_1 (0.4446 at eta = 1.3, 0.5963 at 1.5; see
/// `FresnelMode::moment1`), while 0.0036 is off by 0.08 and changes A by 25%.
fn diffuse_fresnel_fit(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

/// F_dr for the chosen Fresnel mode: Jensen's fit, or 2 C_1 by quadrature.
pub fn diffuse_fresnel(eta: f64, mode: FresnelMode) -> f64 {
    match mode {
        FresnelMode::Fit => diffuse_fresnel_fit(eta),
        FresnelMode::Exact => 2.0 * FresnelMode::Exact.moment1(eta),
    }
}

/// Boundary mismatch A = (1 + F_dr) / (1 - F_dr) (Jensen et al. 2001, eq. 6) with
/// F_dr from the chosen Fresnel mode. This, not `FresnelMode::boundary_a`
/// (built from C_phi and C_E), is the A of the standard dipole.
pub fn boundary_a(eta: f64, mode: FresnelMode) -> f64 {
    let f = diffuse_fresnel(eta, mode);
    (1.0 + f) / (1.0 - f)
}

/// The dipole of one channel, with the entry transmission 1 - R_sp applied
/// so that it compares with Monte Carlo photons launched with that weight.
#[derive(Clone, Debug)]
pub struct Dipole {
    pub medium: Medium,
    pub a: f64,
    pub t_entry: f64,
}

impl Dipole {
    pub fn new(medium: &Medium, mode: FresnelMode, t_entry: f64) -> Dipole {
        Dipole {
            medium: *medium,
            a: boundary_a(medium.eta, mode),
            t_entry,
        }
    }

    /// Depth of the real source, one transport mean free path 1/sigma_t'.
    pub fn z_r(&self) -> f64 {
        self.medium.mfp()
    }

    /// Height of the virtual source above the surface: z_r + 4 A D.
    pub fn z_v(&self) -> f64 {
        self.z_r() + 4.0 * self.a * self.medium.diffusion_coefficient()
    }

    /// R_d(r), mm^-2, per unit incident flux (Jensen et al. 2001 eq. 4;
    /// Dal Corso 2014 eq. 3.8 with the sign of eq. 3.7 fixed).
    pub fn rd(&self, r: f64) -> f64 {
        let m = &self.medium;
        let alpha = m.reduced_albedo();
        let tr = m.sigma_tr();
        let (z_r, z_v) = (self.z_r(), self.z_v());
        let d_r = (r * r + z_r * z_r).sqrt();
        let d_v = (r * r + z_v * z_v).sqrt();
        let pole = |z: f64, d: f64| z * (1.0 + tr * d) * (-tr * d).exp() / (d * d * d);
        self.t_entry * (alpha / (4.0 * PI) * (pole(z_r, d_r) + pole(z_v, d_v)))
    }

    /// Closed-form total over the plane (Jensen et al. 2001, eq. 8):
    /// (alpha'/2) (1 + e^{-(4/3) A sqrt(3(1-alpha'))}) e^{-sqrt(3(1-alpha'))}.
    pub fn total(&self) -> f64 {
        let alpha = self.medium.reduced_albedo();
        let s = (3.0 * (1.0 - alpha)).max(0.0).sqrt();
        self.t_entry * (0.5 * alpha * (1.0 + (-(4.0 / 3.0) * self.a * s).exp()) * (-s).exp())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{preset, Channel};
    use crate::numerics::plane_total;

    #[test]
    fn integrated_profile_equals_closed_form_total() {
        for name in ["marble", "skin1", "ketchup", "wholemilk"] {
            for ch in Channel::ALL {
                let m = preset(name).unwrap().top(ch);
                let scale = 1.0 / m.sigma_tr();
                let d = Dipole::new(&m, FresnelMode::Fit, 1.0);
                let num = plane_total(|r| d.rd(r), m.mfp().min(scale), scale);
                let exact = d.total();
                assert!(
                    (num - exact).abs() < 1e-6 * exact.max(1e-3),
                    "{name} {ch:?}: {num} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn jensen_fit_matches_exact_diffuse_reflectance() {
        for eta in [1.2, 1.3, 1.4, 1.5] {
            let fit = diffuse_fresnel_fit(eta);
            let exact = diffuse_fresnel(eta, FresnelMode::Exact);
            assert!((fit - exact).abs() < 3e-3, "eta {eta}: {fit} vs {exact}");
            // The transcribed coefficient (0.0036) is 0.06 eta off.
            let printed = fit - 0.06 * eta;
            assert!((printed - exact).abs() > 0.05);
        }
    }
}
