//! The full directional dipole S_d(x_i, w_i; x_o) (Frisvad et al. 2014),
//! `profile::analytic::directional_dipole`:
//!
//! - at normal incidence on a plane it is the radial profile ssskit had
//!   before the full model (the formula below, as that file held it), to
//!   round-off, at every preset's channels;
//! - its dependence on the angle of incidence against ssskit's
//!   angle-resolved Monte Carlo (the oblique pencil beam of the entry
//!   table, `profile::mc::angular::ahead_share`): the share of R_d that
//!   leaves ahead of the entry point along the plane of incidence at 30,
//!   60 and 80 degrees. Both must put more than half ahead, more as the
//!   beam tilts; the model must agree within 4 Monte Carlo standard errors
//!   plus [`MODEL_BIAS`], the model's own error at these angles, and carry
//!   at least [`MIN_CAPTURED`] of the measured asymmetry; that error is
//!   measured (not derived) and therefore pinned, with the numbers, in the
//!   record `directional-asymmetry` (docs/directional.md shows it).

use ssskit::material::{preset, preset_names, Channel, Medium};
use ssskit::numerics::gauss_legendre;
use ssskit::profile::analytic::directional_dipole::{DirectionalDipole, Incidence, Vec3};
use ssskit::profile::fresnel::FresnelMode;
use ssskit::profile::mc::angular::ahead_share;
use std::f64::consts::PI;

mod common;
use common::measured;

/// Photons per channel and angle of the oblique runs: standard errors of
/// about 0.002 on the share (skin1).
const PHOTONS: u64 = 100_000;
/// The Monte Carlo's seed.
const SEED: u64 = 46;
/// Incidence angles of the comparison, degrees (the issue's).
const ANGLES: [f64; 3] = [30.0, 60.0, 80.0];
/// Largest |model - Monte Carlo| of the ahead share the model may have
/// beyond 4 standard errors: the model's own error, measured (the record
/// `directional-asymmetry`), not derived. The directional dipole is a
/// diffusion model whose asymmetry comes from its refracted ray source
/// alone; it carries 34% to 59% of the asymmetry the Monte Carlo measures
/// for skin1 (differences 0.06 to 0.21 of R_d, the largest in blue at 80
/// degrees, reduced albedo 0.68, where light leaving after a few events,
/// which diffusion leaves out, runs furthest ahead; wholemilk, marble and
/// apple, reduced albedo above 0.99, show 55% to 60% in red). The bound
/// is the largest measured plus a fifth.
const MODEL_BIAS: f64 = 0.25;
/// The least share of the measured asymmetry (ahead share - 1/2) the
/// model must carry: the radial models carry none; the directional dipole
/// 0.34 at the least (skin1 blue, 30 degrees; the record).
const MIN_CAPTURED: f64 = 0.3;
/// Relative agreement of the reduction with the radial formula: round-off
/// of a few operations on values of order 1 (the formulas compute the
/// same terms in the same order except the refraction and the modified
/// normal, which are exact at normal incidence).
const ROUND_OFF: f64 = 1e-12;

/// The radial profile as src/profile/analytic/directional_dipole.rs held
/// it before the full S_d (Dal Corso 2014, eq. 3.13 at normal incidence;
/// the module's docs derive it): the oracle of the reduction.
fn radial_before(m: &Medium, mode: FresnelMode, t_entry: f64, r: f64) -> f64 {
    let alpha = m.reduced_albedo();
    let d = m.diffusion_coefficient();
    let tr = m.sigma_tr();
    let d_e = 2.131 * d / alpha.sqrt();
    let (a, c_phi, c_e) = (mode.boundary_a(m.eta), mode.c_phi(m.eta), mode.c_e(m.eta));
    // S'_d(x, w_12, r) of Dal Corso 2014, eq. 3.13, read off the printed
    // equation bracket by bracket (without its leading 1 / (4 C_phi(1/eta)),
    // which cancels here): e^{-sigma_tr r} / (4 pi^2 r^3) times
    // [C_phi(eta) (r^2/D + 3 (1 + sigma_tr r) x.w_12)
    //  - C_E(eta) (3 D (1 + sigma_tr r) w_12.n_o - q x.n_o)], where
    // q = (1 + sigma_tr r) + 3 D (3 (1 + sigma_tr r) + (sigma_tr r)^2) / r^2 x.w_12.
    let s_prime = |x_dot_w12: f64, w12_dot_n: f64, x_dot_n: f64, r: f64| {
        let sr = tr * r;
        let first = r * r / d + 3.0 * (1.0 + sr) * x_dot_w12;
        let q = (1.0 + sr) + 3.0 * d * (3.0 * (1.0 + sr) + sr * sr) / (r * r) * x_dot_w12;
        let second = 3.0 * d * (1.0 + sr) * w12_dot_n - q * x_dot_n;
        (-sr).exp() / (4.0 * PI * PI * (r * r) * r) * (c_phi * first - c_e * second)
    };
    let de_cos_beta = r / ((r / d_e).powi(2) + 1.0).sqrt();
    let d_r = (r * r + d * (d + 2.0 * de_cos_beta)).sqrt();
    let real = s_prime(0.0, -1.0, 0.0, d_r);
    let z_v = 2.0 * a * d_e;
    let virt = if z_v.is_finite() {
        s_prime(-z_v, 1.0, -z_v, (r * r + z_v * z_v).sqrt())
    } else {
        0.0
    };
    (t_entry * PI * (real - virt)).max(0.0)
}

/// Every preset's channels (half-spaces), both Fresnel modes, radii from
/// 0 to far out: the radial profile is the full S_d at normal incidence.
#[test]
fn normal_incidence_is_the_radial_model() {
    let mut checked = 0;
    for name in preset_names() {
        let m = preset(name).unwrap();
        if !m.is_half_space() {
            continue;
        }
        for ch in Channel::ALL {
            let med = m.top(ch);
            for mode in [FresnelMode::Fit, FresnelMode::Exact] {
                let dd = DirectionalDipole::new(&med, mode, 0.97);
                for r in [0.0, 1e-4, 0.01, 0.3, 1.0, 4.0, 17.0, 60.0] {
                    let (got, want) = (dd.rd(r), radial_before(&med, mode, 0.97, r));
                    assert!(
                        (got - want).abs() <= ROUND_OFF * want.abs().max(1e-300),
                        "{name} {} {mode:?} r = {r}: {got:e} vs {want:e}",
                        ch.name()
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 500, "{checked}");
}

/// The model's share of R_d ahead of the entry point (x > 0) for light at
/// `theta_deg` in the x-z plane, the beam running towards +x: polar
/// quadrature of S_d over the exit plane (S_d's exit normalisation
/// cancels in the ratio).
fn model_ahead(dd: &DirectionalDipole, theta_deg: f64) -> f64 {
    let t = theta_deg.to_radians();
    let w_i = Vec3::new(-t.sin(), 0.0, t.cos());
    let at = |rho: f64, phi: f64| {
        dd.s_d(&Incidence {
            x_i: Vec3::zeros(),
            n_i: Vec3::z(),
            w_i,
            x_o: Vec3::new(rho * phi.cos(), rho * phi.sin(), 0.0),
            n_o: Vec3::z(),
        })
    };
    // Radial panels in geometric progression out to 60 decay lengths (and
    // at least 60 D), 8-point Gauss-Legendre each; 720 angles.
    let reach = 60.0 * (1.0 / dd.sigma_tr).max(dd.d);
    let start = 1e-4 * dd.d;
    let edges: Vec<f64> = std::iter::once(0.0)
        .chain((0..=64).map(|i| start * (reach / start).powf(i as f64 / 64.0)))
        .collect();
    let n_phi = 720;
    let (mut ahead, mut all) = (0.0, 0.0);
    for k in 0..n_phi {
        let phi = (k as f64 + 0.5) * 2.0 * PI / n_phi as f64;
        let line: f64 = edges
            .windows(2)
            .map(|e| gauss_legendre(|rho| rho * at(rho, phi), e[0], e[1]))
            .sum();
        all += line;
        if phi.cos() > 0.0 {
            ahead += line;
        }
    }
    ahead / all
}

/// At 30, 60 and 80 degrees, skin1's three channels: the model and the
/// Monte Carlo both put more than half of R_d ahead of the entry point,
/// more as the beam tilts; they agree within 4 standard errors plus
/// [`MODEL_BIAS`], and the model carries at least [`MIN_CAPTURED`] of the
/// asymmetry; at normal incidence the model is symmetric (1/2 to the
/// quadrature's accuracy). Every number is pinned in the record.
#[test]
fn oblique_asymmetry_against_monte_carlo() {
    use measured::{check, table};
    let m = preset("skin1").unwrap();
    let (mut rows, mut data, mut checks) = (Vec::new(), Vec::new(), Vec::new());
    for ch in Channel::ALL {
        let dd = DirectionalDipole::new(&m.top(ch), FresnelMode::Exact, 1.0);
        let normal = model_ahead(&dd, 0.0);
        assert!((normal - 0.5).abs() < 1e-9, "{} {normal}", ch.name());
        for theta in ANGLES {
            let model = model_ahead(&dd, theta);
            let mc = ahead_share(&m, ch, theta, PHOTONS, SEED).unwrap();
            let (d, se) = (model - mc.ahead, mc.ahead_stderr);
            eprintln!(
                "skin1 {} {theta}: MC {:.4} +- {se:.4} (R_d {:.4}), model {model:.4}",
                ch.name(),
                mc.ahead,
                mc.rd
            );
            checks.push((
                format!("skin1 {} at {theta} degrees", ch.name()),
                model,
                mc.ahead,
                se,
            ));
            rows.push(vec![
                ch.name().to_string(),
                format!("{theta}"),
                format!("{:.4} +- {:.4}", mc.ahead, se),
                format!("{model:.4}"),
                format!("{d:+.4} ({:+.1} sigma)", d / se),
                format!("{:.2}", (model - 0.5) / (mc.ahead - 0.5)),
            ]);
            data.push(serde_json::json!({
                "channel": ch.name(), "incidence_deg": theta, "photons": PHOTONS,
                "mc_ahead": mc.ahead, "mc_ahead_stderr": se, "mc_rd": mc.rd,
                "model_ahead": model,
            }));
        }
    }
    // Per channel in angle order: both rise with the angle, and agree.
    for (i, (what, model, mc, se)) in checks.iter().enumerate() {
        let (last_model, last_mc) = if i % ANGLES.len() == 0 {
            (0.5, 0.5)
        } else {
            (checks[i - 1].1, checks[i - 1].2)
        };
        assert!(*se > 0.0 && *se < 0.01, "{what}: standard error {se}");
        assert!(*mc > last_mc + 4.0 * se, "{what}: Monte Carlo {mc}");
        assert!(*model > last_model, "{what}: model {model}");
        assert!(
            (model - mc).abs() <= 4.0 * se + MODEL_BIAS,
            "{what}: model {model:.4}, Monte Carlo {mc:.4} +- {se:.4}"
        );
        assert!(
            model - 0.5 >= MIN_CAPTURED * (mc - 0.5 - 4.0 * se),
            "{what}: the model carries too little of the asymmetry: {model:.4} against \
             {mc:.4} +- {se:.4}"
        );
    }
    let mut tables = std::collections::BTreeMap::new();
    tables.insert(
        "asymmetry".to_string(),
        table(
            &[
                "channel",
                "incidence (degrees)",
                "Monte Carlo: share of R_d ahead",
                "directional dipole",
                "model - Monte Carlo",
                "share of the asymmetry the model carries",
            ],
            rows,
        ),
    );
    check(
        "directional-asymmetry",
        "directional_dipole",
        "the directional dipole's share of R_d ahead of an oblique beam against ssskit's \
         oblique Monte Carlo (skin1, 1e5 photons per channel and angle, seed 46): the model's \
         own error is measured here, not derived, so the numbers are pinned",
        tables,
        serde_json::Value::Array(data),
    );
}
