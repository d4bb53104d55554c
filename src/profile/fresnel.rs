//! Fresnel reflectance at a smooth dielectric boundary and its angular
//! moments (pbrt-v3 FresnelMoment1/2; d'Eon and Irving 2011).

/// Unpolarised Fresnel reflectance for light arriving with cosine `cos_i`
/// (>= 0) from a medium of index n_i onto one of index n_t, `eta = n_t / n_i`.
/// Returns 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    if eta == 1.0 {
        return 0.0;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Specular reflectance at normal incidence, ((n1 - n2)/(n1 + n2))^2.
pub fn specular_normal(n1: f64, n2: f64) -> f64 {
    let r = (n1 - n2) / (n1 + n2);
    r * r
}

/// First Fresnel moment, polynomial fit (pbrt-v3 FresnelMoment1), for light
/// inside a medium of relative index `eta` meeting its boundary. Equals Dal Corso's
/// 2 C_1 / 2 fit (d'Eon and Irving 2011).
fn fresnel_moment1(eta: f64) -> f64 {
    let (e, e2) = (eta, eta * eta);
    let (e3, e4, e5) = (e2 * e, e2 * e2, e2 * e2 * e);
    if eta < 1.0 {
        0.45966 - 1.73965 * e + 3.37668 * e2 - 3.904945 * e3 + 2.49277 * e4 - 0.68441 * e5
    } else {
        -4.61686 + 11.1136 * e - 10.4646 * e2 + 5.11455 * e3 - 1.27198 * e4 + 0.12746 * e5
    }
}

/// Second Fresnel moment, polynomial fit (pbrt-v3 FresnelMoment2).
fn fresnel_moment2(eta: f64) -> f64 {
    let (e, e2) = (eta, eta * eta);
    let (e3, e4, e5) = (e2 * e, e2 * e2, e2 * e2 * e);
    if eta < 1.0 {
        0.27614 - 0.87350 * e + 1.12077 * e2 - 0.65095 * e3 + 0.07883 * e4 + 0.04860 * e5
    } else {
        let r_eta = 1.0 / eta;
        let (r_eta2, r_eta3) = (r_eta * r_eta, r_eta * r_eta * r_eta);
        -547.033 + 45.3087 * r_eta3 - 218.725 * r_eta2 + 458.843 * r_eta + 404.557 * e
            - 189.519 * e2
            + 54.9327 * e3
            - 9.00603 * e4
            + 0.63942 * e5
    }
}

/// How the Fresnel moments are obtained: the polynomial fits (fast, but off
/// near eta = 1 and below 1) or numerical integration of the exact Fresnel
/// reflectance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FresnelMode {
    #[default]
    Fit,
    Exact,
}

impl FresnelMode {
    pub fn name(self) -> &'static str {
        match self {
            FresnelMode::Fit => "fit",
            FresnelMode::Exact => "exact",
        }
    }

    /// C_1 = int_0^1 R(mu) mu dmu for light inside a medium of relative index
    /// `eta` (Dal Corso 2014, eq. 3.15; pbrt-v3 FresnelMoment1).
    pub fn moment1(self, eta: f64) -> f64 {
        match self {
            FresnelMode::Fit => fresnel_moment1(eta),
            FresnelMode::Exact => fresnel_moment1_exact(eta),
        }
    }

    /// C_2 = int_0^1 R(mu) mu^2 dmu (pbrt-v3 FresnelMoment2).
    pub fn moment2(self, eta: f64) -> f64 {
        match self {
            FresnelMode::Fit => fresnel_moment2(eta),
            FresnelMode::Exact => fresnel_moment2_exact(eta),
        }
    }

    /// C_phi = (1 - 2 C_1) / 4 (Dal Corso 2014, eq. 3.15).
    pub fn c_phi(self, eta: f64) -> f64 {
        0.25 * (1.0 - 2.0 * self.moment1(eta))
    }

    /// C_E = (1 - 3 C_2) / 2 (Dal Corso 2014, eq. 3.15).
    pub fn c_e(self, eta: f64) -> f64 {
        0.5 * (1.0 - 3.0 * self.moment2(eta))
    }

    /// Boundary mismatch A = (1 - C_E) / (2 C_phi) (Dal Corso et al. 2017,
    /// appendix): the A of the directional dipole and of photon beam
    /// diffusion's extrapolated boundary. The standard dipole uses Jensen's
    /// (1 + F_dr) / (1 - F_dr) instead (`analytic::dipole::boundary_a`).
    pub fn boundary_a(self, eta: f64) -> f64 {
        (1.0 - self.c_e(eta)) / (2.0 * self.c_phi(eta))
    }
}

/// int_0^1 R(mu) mu^n dmu with R the reflectance met by light inside a medium
/// of relative index `eta` (so the Fresnel call sees n_t / n_i = 1 / eta).
/// For eta > 1 the integral splits at the critical cosine mu_c =
/// sqrt(1 - 1/eta^2): below it R = 1 exactly (total internal reflection),
/// above it R has a square-root edge at mu_c, removed by mu = mu_c +
/// (1 - mu_c) t^2, after which 32 Gauss-Legendre panels are exact to ~1e-12.
fn fresnel_moment_exact(eta: f64, n: i32) -> f64 {
    if !(eta > 0.0) || !eta.is_finite() || eta == 1.0 {
        return 0.0;
    }
    let mu_c = if eta > 1.0 {
        (1.0 - 1.0 / (eta * eta)).sqrt()
    } else {
        0.0
    };
    let tir = mu_c.powi(n + 1) / (n + 1) as f64;
    let w = 1.0 - mu_c;
    let g = |t: f64| {
        let mu = mu_c + w * t * t;
        fresnel_dielectric(mu, 1.0 / eta) * mu.powi(n) * 2.0 * w * t
    };
    const PANELS: usize = 32;
    let h = 1.0 / PANELS as f64;
    let smooth: f64 = (0..PANELS)
        .map(|k| crate::numerics::gauss_legendre(g, k as f64 * h, (k + 1) as f64 * h))
        .sum();
    tir + smooth
}

/// First Fresnel moment by numerical integration (see `fresnel_moment_exact`).
fn fresnel_moment1_exact(eta: f64) -> f64 {
    fresnel_moment_exact(eta, 1)
}

/// Second Fresnel moment by numerical integration.
fn fresnel_moment2_exact(eta: f64) -> f64 {
    fresnel_moment_exact(eta, 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_closed_form() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-12);
        assert!((specular_normal(1.0, 1.3) - 0.017013).abs() < 1e-6);
    }

    #[test]
    fn total_internal_reflection() {
        // From glass (1.5) to air: critical cosine sqrt(1 - 1/1.5^2) = 0.745.
        assert_eq!(fresnel_dielectric(0.7, 1.0 / 1.5), 1.0);
        assert!(fresnel_dielectric(0.8, 1.0 / 1.5) < 1.0);
        assert_eq!(fresnel_dielectric(0.3, 1.0), 0.0);
    }

    #[test]
    fn exact_moments_match_closed_limits() {
        // eta = 1: no reflection at all.
        assert_eq!(fresnel_moment1_exact(1.0), 0.0);
        // Huge eta: almost everything is totally internally reflected, so
        // C_1 -> 1/2 and C_2 -> 1/3.
        assert!((fresnel_moment1_exact(100.0) - 0.5).abs() < 1e-3);
        assert!((fresnel_moment2_exact(100.0) - 1.0 / 3.0).abs() < 1e-3);
        // Diffuse internal reflectance 2 C_1 at eta = 1.3 is 0.4446 (the
        // value Jensen's F_dr fit reproduces).
        let fdr = 2.0 * fresnel_moment1_exact(1.3);
        assert!((fdr - 0.4446).abs() < 2e-3, "{fdr}");
    }

    #[test]
    fn exact_moments_give_reference_constants() {
        // The fits (d'Eon and Irving 2011) at eta = 1.3 -> C_phi = 0.13868, C_E = 0.35128,
        // A = 2.3390, values of the polynomial fits. Quadrature differs from
        // the fits by their own error: 3e-4 on C_phi, 1.5e-3 on C_E, 1e-3 on A.
        let m = FresnelMode::Exact;
        assert!((m.c_phi(1.3) - 0.13868).abs() < 3e-4, "{}", m.c_phi(1.3));
        assert!((m.c_e(1.3) - 0.35128).abs() < 1.5e-3, "{}", m.c_e(1.3));
        assert!(
            (m.boundary_a(1.3) - 2.3390).abs() < 2e-3,
            "{}",
            m.boundary_a(1.3)
        );
        // eta = 1.5: the diffuse internal reflectance of glass, 2 C_1 = 0.5963
        // (Egan and Hilgeman's fit as used by Jensen et al. 2001 gives 0.5963 too).
        let fdr = 2.0 * fresnel_moment1_exact(1.5);
        assert!((fdr - 0.5963).abs() < 5e-4, "{fdr}");
        let fit = FresnelMode::Fit;
        assert!((fit.c_phi(1.5) - m.c_phi(1.5)).abs() < 2e-4);
        assert!((fit.c_e(1.5) - m.c_e(1.5)).abs() < 1.5e-3);
    }

    #[test]
    fn exact_moments_obey_reciprocity() {
        // Diffuse transmittance out of a medium times eta^2 equals diffuse
        // transmittance into it: (1 - 2 C_1(eta)) eta^2 = 1 - 2 C_1(1/eta).
        // An oracle independent of the critical-angle split.
        for eta in [1.1, 1.3, 1.5, 2.0] {
            let inside = (1.0 - 2.0 * fresnel_moment1_exact(eta)) * eta * eta;
            let outside = 1.0 - 2.0 * fresnel_moment1_exact(1.0 / eta);
            assert!(
                (inside - outside).abs() < 1e-9,
                "eta {eta}: {inside} vs {outside}"
            );
        }
    }

    #[test]
    fn fits_agree_with_exact_integration_in_their_range() {
        // Away from eta = 1 the fits match quadrature to 2e-3 absolute on the
        // moments over 0.5 <= eta <= 2 (measured worst case 1.5e-3 for C_2).
        for i in 0..=30 {
            let eta = 0.5 + 0.05 * i as f64;
            if (eta - 1.0).abs() < 0.04 {
                continue;
            }
            for (fit, exact) in [
                (fresnel_moment1(eta), fresnel_moment1_exact(eta)),
                (fresnel_moment2(eta), fresnel_moment2_exact(eta)),
            ] {
                assert!(
                    (fit - exact).abs() < 2e-3,
                    "eta {eta}: fit {fit} exact {exact}"
                );
            }
        }
    }

    #[test]
    fn fit_misbehaves_near_eta_one_and_above_two() {
        // At eta = 1 there is no interface: both exact moments are 0, while
        // the fits leave a residue (C_2 even goes negative).
        assert_eq!(fresnel_moment1_exact(1.0), 0.0);
        assert_eq!(fresnel_moment2_exact(1.0), 0.0);
        assert!(fresnel_moment2(1.0) < 0.0);
        // Far outside the fitted range the fit gives a negative C_phi.
        assert!(FresnelMode::Fit.c_phi(3.0) < 0.0);
        assert!(FresnelMode::Exact.c_phi(3.0) > 0.0);
    }
}
