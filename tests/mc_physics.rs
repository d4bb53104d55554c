//! Monte Carlo simulator against independent truths (Wang et al. 1995;
//! van de Hulst 1980). Tolerances are 4 standard errors as reported by
//! the simulator itself, plus the stated error of the reference where it is
//! an approximation (dipole).

use ssskit::material::{preset, Channel};
use ssskit::numerics::{bin_averages, gauss_legendre};
use ssskit::profile::analytic::dipole::Dipole;
use ssskit::profile::fresnel::FresnelMode;
use ssskit::profile::mc::{
    simulate, simulate_with, BoundaryMode, McConfig, McOptions, PhotonBudget, ROULETTE_THRESHOLD,
};
use ssskit::profile::{Profile, RadialGrid};
use ssskit::progress::NoProgress;

mod common;
use common::budgets::target_error;
use common::mc::{self, cfg, material, within};
use common::EXACT;

/// The three settings the benchmark compares: default (classic, roulette
/// 0.01), MCML (classic, roulette 1e-4) and splitting (roulette 1e-4).
fn settings() -> [(&'static str, McOptions); 3] {
    let mcml = McOptions {
        roulette_threshold: ROULETTE_THRESHOLD,
        ..McOptions::default()
    };
    let split = McOptions {
        boundary: BoundaryMode::Split,
        ..mcml.clone()
    };
    [
        ("default", McOptions::default()),
        ("mcml", mcml),
        ("split", split),
    ]
}

/// specular + R_d + T + absorbed + roulette/truncation residual = 1: the
/// f64 tallies close it to rounding.
fn assert_balance(p: &Profile) {
    common::mc::assert_balance(p, 1e-9);
}

#[test]
fn van_de_hulst_slab_all_settings() {
    let m = material(mc::SLAB);
    for (mode, o) in settings() {
        let p = simulate_with(&m, &cfg(400_000, Channel::R, None), &o, &NoProgress).unwrap();
        let se = p.total_rd_stderr.as_ref().unwrap()[0];
        within(p.total_rd[0], mc::SLAB_RD, se, &format!("{mode:?} R_d"));
        let t = p.transmittance.as_ref().unwrap()[0];
        let te = p.transmittance_stderr.as_ref().unwrap()[0];
        within(t, mc::SLAB_T, te, &format!("{mode:?} T"));
        assert_eq!(p.specular[0], 0.0);
        assert_balance(&p);
    }
}

#[test]
fn semi_infinite_isotropic_albedo_09() {
    for (eta, truth, spec) in mc::ALBEDO_09 {
        let m = mc::albedo_09(eta);
        for (mode, o) in settings() {
            let p = simulate_with(&m, &cfg(200_000, Channel::G, None), &o, &NoProgress).unwrap();
            let se = p.total_rd_stderr.as_ref().unwrap()[0];
            within(p.total_rd[0], truth, se, &format!("eta {eta} {mode:?} R_d"));
            assert!(
                (p.specular[0] - spec).abs() < EXACT,
                "specular {}",
                p.specular[0]
            );
            assert_eq!(p.transmittance.as_ref().unwrap()[0], 0.0);
            assert_balance(&p);
            // The tally holds what the totals hold (minus what left beyond r_max).
            let beyond = p.extra["rd_beyond_rmax"][0].as_f64().unwrap();
            let tab = p.tabulated_total(0);
            assert!(((tab + beyond) - p.total_rd[0]).abs() < EXACT);
            assert!(
                beyond < GRID_TAIL * p.total_rd[0],
                "grid too small: {beyond}"
            );
        }
    }
}

#[test]
fn marble_profile_matches_dipole_in_diffusion_regime() {
    // The standard dipole (with Jensen's published F_dr fit, 0.0636 eta) is
    // an approximation that holds far from the source; the near field is
    // where diffusion theory is known to fail (d'Eon 2012, "A better
    // dipole"). The test therefore checks the far field, [6, 48) MFP, to 12%
    // of the dipole plus 4 MC standard errors; the MC/dipole ratios of every
    // annulus, near field included, are pinned in the record
    // mc-dipole-far-field (docs/mc.md shows it).
    let m = preset("marble").unwrap();
    let p = simulate(&m, &cfg(100_000, Channel::B, None), &NoProgress).unwrap();
    assert_balance(&p);
    let md = m.top(Channel::B);
    let mfp = md.mfp();
    let grid = RadialGrid {
        edges: p.r_edges.clone(),
    };
    // Photons enter with weight 1 - R_sp; the dipole is per entering flux.
    let t_entry = 1.0 - p.specular[0];
    let dipole = Dipole::new(&md, FresnelMode::Fit, t_entry);
    let dip = bin_averages(|r| dipole.rd(r), &grid.edges);
    let areas = grid.areas();
    let err = &p.rd_stderr.as_ref().unwrap()[0];
    let (mut table, mut data) = (Vec::new(), Vec::new());
    for (a, b) in [
        (1.0, 3.0),
        (3.0, 6.0),
        (6.0, 12.0),
        (12.0, 24.0),
        (24.0, 48.0),
    ] {
        let (mut mc, mut var, mut d) = (0.0, 0.0, 0.0);
        for i in 0..p.r.len() {
            if p.r[i] >= a * mfp && p.r[i] < b * mfp {
                mc += p.rd[0][i] * areas[i];
                // Bins of one photon population are nearly independent at
                // this resolution; adding variances is what the bins report.
                var += (err[i] * areas[i]).powi(2);
                d += dip[i] * areas[i];
            }
        }
        let tol = 0.12 * d + 4.0 * var.sqrt();
        eprintln!(
            "[{a}, {b}) MFP: MC/dipole = {:.4} (MC rel. stderr {:.4})",
            mc / d,
            var.sqrt() / mc
        );
        table.push(vec![
            format!("[{a}, {b})"),
            format!("{:.3}", mc / d),
            format!("{:.3}", var.sqrt() / mc),
            if a >= 6.0 { "yes" } else { "no (near field)" }.to_string(),
        ]);
        data.push(serde_json::json!({"from_mfp": a, "to_mfp": b, "mc": mc, "mc_stderr": var.sqrt(), "dipole": d}));
        if a < 6.0 {
            continue;
        }
        assert!(
            (mc - d).abs() <= tol,
            "[{a}, {b}) MFP: MC {mc:.5e} dipole {d:.5e} tol {tol:.2e}"
        );
    }
    common::measured::check(
        "mc-dipole-far-field",
        "mc_physics",
        "marble blue, 1e5 photons, seed 2024: annular integrals of R_d, Monte Carlo over the \
         standard dipole; diffusion theory has no exact error to test against, so the ratios \
         are pinned",
        [(
            "ratios".to_string(),
            common::measured::table(
                &[
                    "annulus, MFP",
                    "MC / dipole",
                    "MC rel. stderr",
                    "asserted within 12% + 4 sigma",
                ],
                table,
            ),
        )]
        .into_iter()
        .collect(),
        serde_json::Value::Array(data),
    );
}

/// Exact single-scattering R_d(r) of an isotropic half-space at n = 1 under a
/// normal pencil beam: a packet reaching depth z (density sigma_t e^{-sigma_t z})
/// scatters with weight sigma_s/sigma_t into 4 pi and crosses the surface
/// element at distance d = sqrt(r^2 + z^2) with cosine z/d, uncollided:
/// R_ss(r) = sigma_s/(4 pi) int_0^inf e^{-sigma_t (z + d)} z / d^3 dz.
fn single_scatter_rd(sigma_a: f64, sigma_s: f64, r: f64) -> f64 {
    let st = sigma_a + sigma_s;
    let f = |z: f64| {
        let d = (r * r + z * z).sqrt();
        (-st * (z + d)).exp() * z / (d * d * d)
    };
    // Geometric panels resolve the peak at z ~ r and the decay at 1/sigma_t.
    let mut s = gauss_legendre(f, 0.0, 1e-3 * r);
    let (mut a, mut b) = (1e-3 * r, 2e-3 * r);
    while a < 60.0 / st + 60.0 * r {
        s += gauss_legendre(f, a, b);
        a = b;
        b *= 1.25;
    }
    sigma_s / (4.0 * std::f64::consts::PI) * s
}

#[test]
fn single_scattering_of_strong_absorber_is_exact() {
    // sigma_a = 10, sigma_s = 1 /mm, g = 0, n = 1: packets scattered exactly
    // once are tallied apart and compared with the closed form above, bin by
    // bin, and in total with R_ss = (albedo/2)(1 - ln 2).
    let (sa, ss) = (10.0, 1.0);
    let m = material(&format!(
        "unit = \"mm\"\nsigma_a = {sa}\nsigma_s = {ss}\neta = 1.0\n"
    ));
    let grid = RadialGrid::uniform(0.02, 0.6).unwrap();
    let o = McOptions {
        single_scatter: true,
        ..McOptions::default()
    };
    let p = simulate_with(
        &m,
        &cfg(1_000_000, Channel::R, Some(grid.clone())),
        &o,
        &NoProgress,
    )
    .unwrap();
    assert_balance(&p);
    let s = &p.extra["single_scatter"][0];
    let total = s["total"].as_f64().unwrap();
    let total_se = s["total_stderr"].as_f64().unwrap();
    let albedo = ss / (sa + ss);
    within(
        total,
        0.5 * albedo * (1.0 - std::f64::consts::LN_2),
        total_se,
        "single-scatter total",
    );
    let rd: Vec<f64> = serde_json::from_value(s["rd"].clone()).unwrap();
    let se: Vec<f64> = serde_json::from_value(s["rd_stderr"].clone()).unwrap();
    let exact = bin_averages(|r| single_scatter_rd(sa, ss, r), &grid.edges);
    // Bins where the exact profile expects at least 10 scoring packets (each
    // carries the weight albedo): below that the count is Poisson, not
    // Gaussian, and a bin may rightly hold none (zero standard error).
    let areas = grid.areas();
    let n = 1_000_000.0;
    let (mut chi2, mut bins) = (0.0, 0);
    for i in 0..grid.len() {
        if exact[i] * areas[i] * n / albedo < 10.0 {
            continue;
        }
        within(rd[i], exact[i], se[i], &format!("single-scatter bin {i}"));
        chi2 += ((rd[i] - exact[i]) / se[i]).powi(2);
        bins += 1;
    }
    assert!(bins >= 20, "only {bins} bins resolved");
    // chi^2 above 2x its mean would flag a systematic error.
    assert!(
        chi2 < CHI2_OVER_MEAN * bins as f64,
        "chi2 = {chi2} over {bins} bins"
    );
    // The whole (single + multiple) against the exact half-space total
    // (Chandrasekhar's H-function). Multiple scattering, the exact total
    // minus the exact single-scattering one, is asserted to exceed 10
    // standard errors, so a tracer that lost it fails the 4-sigma check.
    let exact_total = mc::isotropic_half_space_total(albedo);
    let se_total = p.total_rd_stderr.as_ref().unwrap()[0];
    eprintln!(
        "albedo {albedo:.4}: R_d {} +- {se_total:.1e}, exact {exact_total}, single {total}",
        p.total_rd[0]
    );
    within(
        p.total_rd[0],
        exact_total,
        se_total,
        "single + multiple total",
    );
    let exact_single = 0.5 * albedo * (1.0 - std::f64::consts::LN_2);
    assert!(exact_total - exact_single > 10.0 * se_total);
}

/// `ALBEDO_09`'s totals are published to 5 decimals: exact to half a unit
/// of the last digit.
const FIVE_DECIMALS: f64 = 5e-6;

/// The share of R_d a tally grid may leave beyond r_max: the 1e-4 goal of
/// `RadialGrid::for_material`'s tail rule, which its documentation states.
const GRID_TAIL: f64 = 1e-4;

/// chi^2 over k >= 20 bins has mean k and standard deviation sqrt(2 k):
/// twice the mean is at least 3.2 standard deviations above it (at k = 20,
/// more for more bins), where a systematic error shows.
const CHI2_OVER_MEAN: f64 = 2.0;

/// Standard error of R_d + specular at albedo 1 with 24,576 photons: the
/// Russian roulette alone makes it non-zero, and a weight rule that broke
/// energy conservation per photon would raise it well past 1e-2 (a claim
/// checked, not derived from the roulette's variance).
const ROULETTE_STDERR: f64 = 0.01;

/// The relative error the target-error run asks for, and so must report
/// meeting.
const TARGET_REL: f64 = 0.05;

#[test]
fn h_function_total_reproduces_the_published_half_space_value() {
    // The oracle above, checked on the case with a published 5-digit total
    // (albedo 0.9, n = 1) and at the limits: no light back without
    // scattering, and all of it at albedo 1.
    let (eta, rd, _) = mc::ALBEDO_09[0];
    assert_eq!(eta, 1.0);
    let r = mc::isotropic_half_space_total(0.9);
    assert!((r - rd).abs() < FIVE_DECIMALS, "{r} vs {rd}");
    // 1 - sqrt(1 - a) / (1 / H(1)): at a = 0, H = 1 and 1 - 1 / 1 is 0
    // exactly; at a = 1 the root is 0 and the total 1 exactly, in floats too.
    assert_eq!(mc::isotropic_half_space_total(0.0), 0.0);
    assert_eq!(mc::isotropic_half_space_total(1.0), 1.0);
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let m = preset("skin1").unwrap();
    let run = |threads, budget: PhotonBudget| {
        let c = McConfig {
            budget,
            seed: 11,
            threads: Some(threads),
            channels: vec![Channel::R, Channel::B],
            grid: None,
        };
        let mut p = simulate(&m, &c, &NoProgress).unwrap();
        p.elapsed_s = 0.0;
        serde_json::to_string(&p).unwrap()
    };
    for budget in [
        PhotonBudget::Fixed(40_000),
        PhotonBudget::TargetError {
            rel: 0.05,
            max_photons: 400_000,
        },
        PhotonBudget::KernelFactor {
            rel: 0.03,
            max_photons: 400_000,
        },
    ] {
        assert_eq!(run(1, budget.clone()), run(2, budget.clone()), "{budget:?}");
    }
}

#[test]
fn different_seeds_differ_but_agree_statistically() {
    let m = preset("skin1").unwrap();
    let run = |seed| {
        let c = McConfig {
            seed,
            ..cfg(100_000, Channel::G, None)
        };
        simulate(&m, &c, &NoProgress).unwrap()
    };
    let (a, b) = (run(1), run(2));
    assert_ne!(a.rd, b.rd);
    let (sa, sb) = (a.total_rd_stderr.unwrap()[0], b.total_rd_stderr.unwrap()[0]);
    within(
        a.total_rd[0],
        b.total_rd[0],
        (sa * sa + sb * sb).sqrt(),
        "seed 1 vs 2",
    );
    // Bin by bin: the normalised differences behave like N(0, 1).
    let (ea, eb) = (a.rd_stderr.unwrap(), b.rd_stderr.unwrap());
    let (mut chi2, mut n) = (0.0, 0);
    for i in 0..a.r.len() {
        let s2 = ea[0][i].powi(2) + eb[0][i].powi(2);
        if s2 > 0.0 && a.r[i] < 5.0 {
            chi2 += (a.rd[0][i] - b.rd[0][i]).powi(2) / s2;
            n += 1;
        }
    }
    assert!(n > 50);
    // chi^2 with n degrees of freedom: mean n, sd sqrt(2n); 4 sd.
    let nf = n as f64;
    assert!(
        (chi2 - nf).abs() < common::SIGMAS * (2.0 * nf).sqrt(),
        "chi2 {chi2} over {n} bins"
    );
}

#[test]
fn layered_stack_closes_the_energy_balance() {
    let m = material(
        "unit = \"mm\"\neta_above = 1.0\neta_below = 1.4\n\
         [[layer]]\nsigma_a = 0.5\nsigma_s = 5.0\ng = 0.8\neta = 1.37\nthickness = 0.1\n\
         [[layer]]\nsigma_a = 0.2\nsigma_s = 20.0\ng = 0.9\neta = 1.5\nthickness = 0.4\n\
         [[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\ng = -0.5\neta = 1.33\nthickness = 1.0\n",
    );
    for (_, o) in settings() {
        let p = simulate_with(&m, &cfg(50_000, Channel::R, None), &o, &NoProgress).unwrap();
        assert_balance(&p);
        let t = p.transmittance.as_ref().unwrap()[0];
        assert!(t > 0.0 && p.total_rd[0] > 0.0);
        assert!((p.specular[0] - (0.37f64 / 2.37).powi(2)).abs() < EXACT);
    }
}

#[test]
fn a_matched_stack_equals_one_layer() {
    // Two layers with identical optics and index are one slab: R_d and T
    // agree with the single 0.2 mm slab (van de Hulst case) within 4 sigma.
    let m = material(
        "unit = \"mm\"\n[[layer]]\nsigma_a = 1.0\nsigma_s = 9.0\ng = 0.75\neta = 1.0\nthickness = 0.05\n\
         [[layer]]\nsigma_a = 1.0\nsigma_s = 9.0\ng = 0.75\neta = 1.0\nthickness = 0.15\n",
    );
    let p = simulate(&m, &cfg(200_000, Channel::R, None), &NoProgress).unwrap();
    rd_within(&p, 0.09739);
    within(
        p.transmittance.as_ref().unwrap()[0],
        0.66096,
        p.transmittance_stderr.as_ref().unwrap()[0],
        "T",
    );
}

/// The first channel's R_d of `p` within 4 of its standard errors of
/// `truth`.
fn rd_within(p: &Profile, truth: f64) {
    let se = p.total_rd_stderr.as_ref().unwrap()[0];
    within(p.total_rd[0], truth, se, "R_d");
}

#[test]
fn a_split_half_space_equals_the_half_space() {
    // A 0.3 mm layer over a semi-infinite layer of the same optics and index
    // (n = 1.5 under air) is the albedo-0.9 half-space: R_d = 0.21993.
    let layer = "sigma_a = 0.1\nsigma_s = 0.9\neta = 1.5\n";
    let m = material(&format!(
        "unit = \"mm\"\n[[layer]]\n{layer}thickness = 0.3\n[[layer]]\n{layer}"
    ));
    let p = simulate(&m, &cfg(200_000, Channel::B, None), &NoProgress).unwrap();
    rd_within(&p, 0.21993);
    assert_eq!(p.transmittance.as_ref().unwrap()[0], 0.0);
    assert_balance(&p);
}

#[test]
fn extremes_terminate_and_report() {
    let cases: [(&str, String); 8] = [
        (
            "albedo 1",
            "unit = \"mm\"\nsigma_a = 0.0\nsigma_s = 10.0\neta = 1.3\n".into(),
        ),
        (
            "albedo ~0",
            "unit = \"mm\"\nsigma_a = 10.0\nsigma_s = 1e-6\neta = 1.3\n".into(),
        ),
        (
            "no scattering",
            "unit = \"mm\"\nsigma_a = 1.0\nsigma_s = 0.0\neta = 1.3\n".into(),
        ),
        (
            "g = 0.99",
            "unit = \"mm\"\nsigma_a = 0.01\nsigma_s = 10.0\ng = 0.99\neta = 1.3\n".into(),
        ),
        (
            "g = -0.99",
            "unit = \"mm\"\nsigma_a = 0.01\nsigma_s = 10.0\ng = -0.99\neta = 1.3\n".into(),
        ),
        (
            "eta = 1",
            "unit = \"mm\"\nsigma_a = 0.01\nsigma_s = 1.0\neta = 1.0\n".into(),
        ),
        (
            "thin",
            "unit = \"mm\"\nsigma_a = 0.1\nsigma_s = 1.0\neta = 1.4\nthickness = 1e-7\n".into(),
        ),
        (
            "thick",
            "unit = \"mm\"\nsigma_a = 0.1\nsigma_s = 1.0\neta = 1.4\nthickness = 1e7\n".into(),
        ),
    ];
    for (name, toml) in &cases {
        let m = material(toml);
        let o = McOptions::default();
        let t0 = std::time::Instant::now();
        let p = simulate_with(&m, &cfg(8192, Channel::R, None), &o, &NoProgress).unwrap();
        assert!(t0.elapsed().as_secs_f64() < 60.0, "{name} too slow");
        assert_balance(&p);
        p.validate(name).unwrap();
        let warnings = p.warnings().unwrap().join("\n");
        match *name {
            "albedo 1" => {
                // Nothing is absorbed or truncated: the event-count roulette
                // ends every walk without a cap.
                assert_eq!(p.absorbed.as_ref().unwrap()[0], 0.0);
                assert_eq!(p.extra["truncated_photons"][0], 0);
                assert!(warnings.contains("power-law"), "{warnings}");
                assert!(!warnings.contains("truncated"), "{warnings}");
                // A hard cap, when asked for, is booked and reported.
                let capped = McOptions {
                    max_events: 2_000,
                    ..McOptions::default()
                };
                let p =
                    simulate_with(&m, &cfg(8192, Channel::R, None), &capped, &NoProgress).unwrap();
                assert_balance(&p);
                assert!(p.extra["truncated_photons"][0].as_u64().unwrap() > 0);
                assert!(p.warnings().unwrap().join("\n").contains("truncated"));
            }
            "no scattering" => {
                assert_eq!(p.total_rd[0], 0.0);
                assert!(warnings.contains("no diffuse reflectance"), "{warnings}");
            }
            "thin" => {
                // A 1e-7 mm slab is nearly transparent: T = (1 - R_sp)^2-ish.
                let t = p.transmittance.as_ref().unwrap()[0];
                assert!(t > 0.9, "thin slab T = {t}");
            }
            "thick" => assert_eq!(p.transmittance.as_ref().unwrap()[0], 0.0),
            _ => {}
        }
    }
}

#[test]
fn albedo_one_returns_everything_without_bias() {
    // A non-absorbing half-space returns every packet through the top (its
    // depth is a recurrent walk), so R_d + specular = 1 exactly in
    // expectation. The old hard cap of 10^6 events left 0.24% behind; the
    // event-count roulette must be unbiased: 4 of its own standard errors.
    for eta in [1.0, 1.3] {
        let m = material(&format!(
            "unit = \"mm\"\nsigma_a = 0.0\nsigma_s = 10.0\neta = {eta}\n"
        ));
        let p = simulate(&m, &cfg(24_576, Channel::R, None), &NoProgress).unwrap();
        assert_balance(&p);
        assert_eq!(p.extra["truncated_photons"][0], 0);
        let se = p.total_rd_stderr.as_ref().unwrap()[0];
        within(
            p.total_rd[0] + p.specular[0],
            1.0,
            se,
            &format!("eta {eta}: R_d + specular"),
        );
        // The roulette is what makes sigma non-zero, and it stays small.
        assert!(se < ROULETTE_STDERR, "eta {eta}: stderr {se}");
    }
}

#[test]
fn target_error_is_met_or_reported() {
    let m = preset("skin1").unwrap();
    let c = McConfig {
        budget: target_error(TARGET_REL, 2_000_000),
        ..cfg(1, Channel::B, None)
    };
    let p = simulate(&m, &c, &NoProgress).unwrap();
    let rel_t = p.extra["rel_error_total_rd"][0].as_f64().unwrap();
    let rel_p = p.extra["rel_error_profile"][0].as_f64().unwrap();
    assert!(
        rel_t <= TARGET_REL && rel_p <= TARGET_REL,
        "{rel_t} {rel_p}"
    );
    assert_eq!(p.extra["converged"][0], true);
    let n = p.source.photons.as_ref().unwrap()[0];
    assert!(n < 2_000_000 && n.is_multiple_of(ssskit::profile::mc::CHUNK));
    // A cap that is too small is reported, not hidden.
    let c = McConfig {
        budget: target_error(1e-4, 10_000),
        ..c
    };
    let p = simulate(&m, &c, &NoProgress).unwrap();
    assert_eq!(p.source.photons.as_ref().unwrap()[0], 10_000);
    assert_eq!(p.extra["converged"][0], false);
    assert!(p.warnings().unwrap().join("\n").contains("not reached"));
}

#[test]
fn automatic_grid_holds_the_dipole_tail() {
    // dr = min MFP/20 and the dipole's R_d beyond r_max is under 1e-4 of its
    // total, for every preset channel with sigma_a > 0 (scaled dipole tail
    // integrated numerically).
    for name in ssskit::material::preset_names() {
        let m = preset(name).unwrap();
        let g = RadialGrid::for_material(&m, &Channel::ALL);
        let mfp_min = Channel::ALL
            .iter()
            .map(|&c| m.top(c).mfp())
            .fold(f64::INFINITY, f64::min);
        let dr = g.edges[1];
        assert!(
            (dr - mfp_min / 20.0).abs() < EXACT * dr || g.len() == 200_000,
            "{name}"
        );
        for c in Channel::ALL {
            let md = m.top(c);
            if md.sigma_a == 0.0 || md.sigma_s == 0.0 {
                continue;
            }
            let rmax = g.r_max();
            let dipole = Dipole::new(&md, FresnelMode::Fit, 1.0);
            let f = |r: f64| dipole.rd(r) * 2.0 * std::f64::consts::PI * r;
            let (mut tail, mut a) = (0.0, rmax);
            while a < rmax + 200.0 / md.sigma_tr() {
                tail += gauss_legendre(f, a, a + 0.5 / md.sigma_tr());
                a += 0.5 / md.sigma_tr();
            }
            let total = dipole.total();
            assert!(
                tail < GRID_TAIL * total,
                "{name} {c:?}: tail {tail:e} of {total}"
            );
        }
    }
}
