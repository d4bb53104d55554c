//! Photon beam diffusion (Habel et al. 2013) as in pbrt-v3 bssrdf.cpp
//! (BeamDiffusionMS / BeamDiffusionSS): the incident
//! beam is a line of dipoles sampled along its exponential depth
//! distribution, plus single scattering along the refracted beam.

use crate::material::Medium;
use crate::profile::fresnel::{fresnel_dielectric, FresnelMode};
use std::f64::consts::PI;

/// Samples along the beam, as pbrt-v3.
pub const BEAM_SAMPLES: usize = 100;

/// Henyey-Greenstein phase function of the scattering cosine (Henyey and Greenstein 1941).
pub fn phase_hg(cos_theta: f64, g: f64) -> f64 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

/// Grosjean's diffusion coefficient D_g = (2 sigma_a + sigma_s') /
/// (3 sigma_t'^2), which pbrt-v3's BeamDiffusionMS uses instead of the
/// classical 1 / (3 sigma_t').
pub fn grosjean_diffusion_coefficient(m: &Medium) -> f64 {
    let spt = m.sigma_t_reduced();
    (2.0 * m.sigma_a + m.sigma_s_reduced()) / (3.0 * spt * spt)
}

/// Depth along the refracted beam below which light scattered towards the
/// exit point at distance `r` is totally internally reflected:
/// t_crit = r sqrt(eta^2 - 1); none for eta <= 1.
pub fn t_crit(eta: f64, r: f64) -> f64 {
    if eta > 1.0 {
        r * (eta * eta - 1.0).sqrt()
    } else {
        0.0
    }
}

/// The photon beam diffusion profile of one channel.
#[derive(Clone, Debug)]
pub struct BeamDiffusion {
    pub medium: Medium,
    /// Fresnel moments C_1, C_2 at the medium's eta.
    pub fm1: f64,
    pub fm2: f64,
    /// Exitance weights C_phi = (1 - 2 C_1) / 4, C_E = (1 - 3 C_2) / 2 and
    /// the boundary mismatch A = (1 - C_E) / (2 C_phi) of the extrapolated
    /// boundary, from `FresnelMode` (the constants `check_fresnel` checks).
    pub c_phi: f64,
    pub c_e: f64,
    pub a: f64,
    pub t_entry: f64,
    /// -ln(1 - (i + 1/2)/N): the beam's depth quantiles in units of the
    /// mean free path, computed once.
    quantiles: [f64; BEAM_SAMPLES],
}

impl BeamDiffusion {
    pub fn new(medium: &Medium, mode: FresnelMode, t_entry: f64) -> BeamDiffusion {
        BeamDiffusion {
            medium: *medium,
            fm1: mode.moment1(medium.eta),
            fm2: mode.moment2(medium.eta),
            c_phi: mode.c_phi(medium.eta),
            c_e: mode.c_e(medium.eta),
            a: mode.boundary_a(medium.eta),
            t_entry,
            quantiles: std::array::from_fn(|i| {
                -(1.0 - (i as f64 + 0.5) / BEAM_SAMPLES as f64).ln()
            }),
        }
    }

    /// Multiple plus single scattering, per unit incident flux, mm^-2.
    pub fn rd(&self, r: f64) -> f64 {
        let ms = self.multiple(r);
        // Far out single scattering (decay sigma_t) is negligible next to
        // diffusion (decay sigma_tr); skip its loop when a bound on it is
        // below 1e-15 of the multiple-scattering value.
        let ss = if ms > 0.0 && self.single_bound(r) < 1e-15 * ms {
            0.0
        } else {
            self.single(r)
        };
        self.t_entry * (ms + ss)
    }

    /// Upper bound of `single(r)`: every sample has d >= r and d >= t_crit
    /// + its depth, phase function <= its forward peak, transmission <= 1.
    fn single_bound(&self, r: f64) -> f64 {
        let m = &self.medium;
        let st = m.sigma_t();
        let rho = m.sigma_s / st;
        let t_crit = t_crit(m.eta, r);
        let g = m.g.abs();
        let p_max = (1.0 + g) / (4.0 * PI * (1.0 - g).powi(2));
        rho * (-st * (r + t_crit)).exp() / (r * r) * p_max
    }

    /// Multiple scattering: a line of dipoles with Grosjean's diffusion
    /// coefficient (Grosjean 1956; pbrt-v3 BeamDiffusionMS).
    pub fn multiple(&self, r: f64) -> f64 {
        let m = &self.medium;
        let sps = m.sigma_s_reduced();
        let spt = m.sigma_t_reduced();
        let rhop = sps / spt;
        if !(rhop > 0.0) {
            return 0.0;
        }
        let d_g = grosjean_diffusion_coefficient(m);
        let tr = (m.sigma_a / d_g).sqrt();
        // Extrapolated boundary z_e = -2 A D_g (pbrt-v3 writes A out as
        // (1 + 3 C_2) / (1 - 2 C_1), the same number).
        let z_e = -2.0 * self.a * d_g;
        let (c_phi, c_e) = (self.c_phi, self.c_e);
        let n = BEAM_SAMPLES as f64;
        let mut sum = 0.0;
        for q in &self.quantiles {
            // Depth sampled from the beam's exponential attenuation.
            let z_r = q / spt;
            let z_v = -z_r + 2.0 * z_e;
            let d_r = (r * r + z_r * z_r).sqrt();
            let d_v = (r * r + z_v * z_v).sqrt();
            let (e_r, e_v) = ((-tr * d_r).exp(), (-tr * d_v).exp());
            // Fluence of the dipole and its normal derivative (flux).
            let phi_d = (e_r / d_r - e_v / d_v) / (4.0 * PI * d_g);
            let e_dn = (z_r * (1.0 + tr * d_r) * e_r / (d_r * d_r * d_r)
                - z_v * (1.0 + tr * d_v) * e_v / (d_v * d_v * d_v))
                / (4.0 * PI);
            let e = phi_d * c_phi + e_dn * c_e;
            // Correction for photons that leave before diffusing (Habel).
            let kappa = 1.0 - (-2.0 * spt * (d_r + z_r)).exp();
            sum += kappa * rhop * rhop * e;
        }
        (sum / n).max(0.0)
    }

    /// Single scattering along the refracted beam (pbrt-v3 BeamDiffusionSS),
    /// from depth `t_crit` down.
    pub fn single(&self, r: f64) -> f64 {
        let m = &self.medium;
        let st = m.sigma_t();
        let rho = m.sigma_s / st;
        if !(rho > 0.0) {
            return 0.0;
        }
        let eta = m.eta;
        let t_crit = t_crit(eta, r);
        let n = BEAM_SAMPLES as f64;
        let mut sum = 0.0;
        for q in &self.quantiles {
            let t = t_crit + q / st;
            let d = (r * r + t * t).sqrt();
            let cos_o = t / d;
            // The beam goes down and the scattered light up to the exit
            // point, so the scattering cosine is -cos_o (pbrt's PhaseHG
            // flips the sign by its direction convention; Habel et al. 2013 write
            // p_HG(cos_o), which is wrong for g != 0).
            let transmit = 1.0 - fresnel_dielectric(cos_o, 1.0 / eta);
            sum += rho * (-st * (d + t_crit)).exp() / (d * d)
                * phase_hg(-cos_o, m.g)
                * transmit
                * cos_o.abs();
        }
        (sum / n).max(0.0)
    }
}
