//! The standard dipole of Jensen et al. 2001 (REFERENCE.md section 4; seed
//! 000 ch. 3, with the sign erratum of eq. 3.7/3.10 fixed).

use crate::material::Medium;
use std::f64::consts::PI;

/// Diffuse Fresnel reflectance fit F_dr(eta) (Egan and Hilgeman).
pub fn diffuse_fresnel_fit(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0036 * eta
}

/// Boundary mismatch A = (1 + F_dr) / (1 - F_dr).
pub fn boundary_a(eta: f64) -> f64 {
    let f = diffuse_fresnel_fit(eta);
    (1.0 + f) / (1.0 - f)
}

/// R_d(r) of the standard dipole, mm^-2.
pub fn dipole_rd(m: &Medium, r: f64) -> f64 {
    let st = m.sigma_t_reduced();
    let alpha = m.reduced_albedo();
    let tr = m.sigma_tr();
    let z_r = 1.0 / st;
    let z_v = z_r + 4.0 * boundary_a(m.eta) * m.diffusion_coefficient();
    let d_r = (r * r + z_r * z_r).sqrt();
    let d_v = (r * r + z_v * z_v).sqrt();
    let pole = |z: f64, d: f64| z * (1.0 + tr * d) * (-tr * d).exp() / (d * d * d);
    alpha / (4.0 * PI) * (pole(z_r, d_r) + pole(z_v, d_v))
}

/// Closed-form total diffuse reflectance of the dipole.
pub fn dipole_total(m: &Medium) -> f64 {
    let alpha = m.reduced_albedo();
    let s = (3.0 * (1.0 - alpha)).sqrt();
    let a = boundary_a(m.eta);
    0.5 * alpha * (1.0 + (-(4.0 / 3.0) * a * s).exp()) * (-s).exp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{preset, Channel};
    use crate::profile::analytic::radial_total;

    #[test]
    fn integrated_profile_equals_closed_form_total() {
        for name in ["marble", "skin1", "ketchup", "wholemilk"] {
            for ch in Channel::ALL {
                let m = preset(name).unwrap().top(ch);
                let scale = 1.0 / m.sigma_tr();
                let num = radial_total(|r| dipole_rd(&m, r), scale);
                let exact = dipole_total(&m);
                assert!(
                    (num - exact).abs() < 1e-6 * exact.max(1e-3),
                    "{name} {ch:?}: {num} vs {exact}"
                );
            }
        }
    }
}
