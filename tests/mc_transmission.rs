//! Transmittance profiles of finite stacks: T_d(r) from `simulate`, its
//! totals against adding-doubling (tests/common/adding_doubling.rs, an
//! independent solver of the radiative transfer equation that reproduces
//! van de Hulst 1980's tabulated slab), its closure, its part in the
//! stopping rule and its MCML arrays in the .mco file.

mod common;

use common::adding_doubling::{radau, slab_totals};
use common::mc::{cfg, material, within, SLAB, SLAB_RD, SLAB_T};
use ssskit::material::Channel;
use ssskit::profile::mc::{simulate, simulate_with, McConfig, McOptions, PhotonBudget};
use ssskit::profile::Profile;
use ssskit::progress::NoProgress;

/// How close the adding-doubling solver must come to van de Hulst's
/// tabulated values, which are given to 5 decimals (half a unit in the
/// last place, and the solver's own quadrature error well below it).
const AD_TABLE_TOLERANCE: f64 = 1e-5;

#[test]
fn adding_doubling_reproduces_van_de_hulst() {
    // The quadrature integrates polynomials up to degree 2n - 2 exactly.
    let (mu, w) = radau(8);
    for k in 0..=14 {
        let q: f64 = mu.iter().zip(&w).map(|(m, w)| w * m.powi(k)).sum();
        assert!(
            (q - 1.0 / (k as f64 + 1.0)).abs() < 1e-13,
            "degree {k}: {q}"
        );
    }
    let (r, t) = slab_totals(0.9, 2.0, 0.75);
    eprintln!("adding-doubling: R {r:.6} T {t:.6} (van de Hulst {SLAB_RD}, {SLAB_T})");
    assert!((r - SLAB_RD).abs() < AD_TABLE_TOLERANCE, "R {r}");
    assert!((t - SLAB_T).abs() < AD_TABLE_TOLERANCE, "T {t}");
    // Conservative scattering loses nothing.
    let (r, t) = slab_totals(1.0, 3.0, 0.5);
    assert!((r + t - 1.0).abs() < 1e-9, "R + T = {}", r + t);
}

/// Photons per slab of `totals_match_adding_doubling`: standard errors of
/// about 0.1% of the light, each run under a second.
const AD_PHOTONS: u64 = 100_000;

/// Total T (and R_d) of slabs from thin to thick, isotropic to strongly
/// forward scattering, within 4 standard errors of adding-doubling.
#[test]
fn totals_match_adding_doubling() {
    let mut lines = Vec::new();
    // (sigma_a, sigma_s, g, thickness) in mm^-1 and mm, index 1.
    for (sa, ss, g, d) in [
        (0.1, 0.9, 0.0, 0.5),
        (0.05, 9.95, 0.9, 1.0),
        (0.5, 4.5, 0.75, 0.3),
        (0.02, 1.98, 0.8, 5.0),
        (1.0, 1.0, 0.0, 1.5),
    ] {
        let toml = format!(
            "unit = \"mm\"\nsigma_a = {sa}\nsigma_s = {ss}\ng = {g}\neta = 1.0\nthickness = {d}\n"
        );
        let m = material(&toml);
        let p = simulate(&m, &cfg(AD_PHOTONS, Channel::R, None), &NoProgress).unwrap();
        let (r, t) = slab_totals(ss / (sa + ss), (sa + ss) * d, g);
        let (mt, mte) = (
            p.transmittance.as_ref().unwrap()[0],
            p.transmittance_stderr.as_ref().unwrap()[0],
        );
        let (mr, mre) = (p.total_rd[0], p.total_rd_stderr.as_ref().unwrap()[0]);
        lines.push(format!(
            "albedo {:.3} tau {:.2} g {g}: T {mt:.5} +- {mte:.5} vs {t:.5} ({:+.2} sigma), R {mr:.5} vs {r:.5} ({:+.2} sigma)",
            ss / (sa + ss),
            (sa + ss) * d,
            (mt - t) / mte,
            (mr - r) / mre
        ));
        within(mt, t, mte, &format!("T of slab {toml}"));
        within(mr, r, mre, &format!("R of slab {toml}"));
    }
    eprintln!("{}", lines.join("\n"));
}

/// T_d(r) and the light beyond the grid add up to T; a clear slab passes
/// e^-(sigma_a d) straight through, all of it in the first bin.
#[test]
fn td_adds_up_to_the_total() {
    let m = material(SLAB);
    let grid = ssskit::profile::RadialGrid::uniform(0.01, 0.3).unwrap();
    let p = simulate(&m, &cfg(20_000, Channel::R, Some(grid)), &NoProgress).unwrap();
    let tp = p.transmittance_profile().unwrap().unwrap();
    let binned: f64 = tp.td[0]
        .iter()
        .zip(p.r_edges.windows(2))
        .map(|(v, e)| v * std::f64::consts::PI * (e[1] * e[1] - e[0] * e[0]))
        .sum();
    let t = p.transmittance.as_ref().unwrap()[0];
    assert!(tp.beyond_rmax[0] > 0.0, "the grid should lose some T");
    assert!((binned + tp.beyond_rmax[0] - t).abs() < 1e-12 * t.max(1.0));
    assert!(tp.td_stderr[0][0] > 0.0 && tp.rel_error_total[0] > 0.0);
    // The packets that cross without an interaction (probability e^-1)
    // leave on the axis; the others are absorbed where they interact.
    let clear =
        material("unit = \"mm\"\nsigma_a = 0.5\nsigma_s = 0.0\neta = 1.0\nthickness = 2.0\n");
    let p = simulate(&clear, &cfg(10_000, Channel::G, None), &NoProgress).unwrap();
    let tp = p.transmittance_profile().unwrap().unwrap();
    let area = std::f64::consts::PI * p.r_edges[1] * p.r_edges[1];
    within(
        tp.td[0][0] * area,
        (-1.0f64).exp(),
        tp.td_stderr[0][0] * area,
        "clear slab",
    );
    assert!(tp.td[0][1..].iter().all(|&v| v == 0.0));
    // A half-space transmits nothing and records no T_d.
    let half = material("unit = \"mm\"\nsigma_a = 0.1\nsigma_s = 1.0\neta = 1.0\n");
    let p = simulate(&half, &cfg(1000, Channel::R, None), &NoProgress).unwrap();
    assert!(p.transmittance_profile().unwrap().is_none());
}

/// The same seed gives the same T_d on 1 and 2 threads.
#[test]
fn td_does_not_depend_on_threads() {
    let m = material(SLAB);
    let run = |threads| {
        let c = McConfig {
            threads: Some(threads),
            ..cfg(40_000, Channel::B, None)
        };
        simulate(&m, &c, &NoProgress).unwrap()
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(
        a.extra["transmittance_profile"],
        b.extra["transmittance_profile"]
    );
}

/// A target-error run of a finite stack stops only when its transmitted
/// light meets the rule too: the reported relative errors of total T and
/// of T_d's 1D factor are at most the target.
#[test]
fn the_stopping_rule_covers_the_transmitted_light() {
    // A thick slab reflects a lot and transmits little: R_d alone would
    // stop long before T_d meets the target.
    let m = material(
        "unit = \"mm\"\nsigma_a = 0.02\nsigma_s = 2.0\ng = 0.0\neta = 1.0\nthickness = 4.0\n",
    );
    let target = 0.02;
    let c = McConfig {
        budget: PhotonBudget::KernelFactor {
            rel: target,
            max_photons: 10_000_000,
        },
        ..cfg(0, Channel::R, None)
    };
    let opts = McOptions {
        abs_floor: 0.0,
        ..McOptions::default()
    };
    let p = simulate_with(&m, &c, &opts, &NoProgress).unwrap();
    let tp = p.transmittance_profile().unwrap().unwrap();
    assert_eq!(p.extra["stopped_by"][0], "target");
    let rel_rd = p.extra["rel_error_kernel_factor"][0].as_f64().unwrap();
    assert!(tp.rel_error_total[0] <= target && tp.rel_error_kernel_factor[0] <= target);
    // The transmitted light decided: R_d's own errors are well inside.
    assert!(rel_rd < 0.7 * target, "R_d factor error {rel_rd}");
}

/// `simulate --mco` of a finite stack writes Tt_r (MCML's WriteTt_r: one
/// value a line, 1/cm^2, the light beyond the grid in the last bin), and
/// with exit angles Tt_a and Tt_ra in MCML's order and scale (MCML 1.2.2
/// mcmlio.c `WriteResult`, `ScaleRdTt`).
#[test]
fn mco_carries_tt_r_and_tt_a() {
    let mci = "1.0\n1\nt.mco A\n20000\n0.01 0.01\n1 20 6\n1\n1.0\n1.4 1 100 0.9 0.05\n1.0\n";
    let dir = common::temp_with(&[("t.mci", mci)]);
    let d = dir.path();
    common::ok_in(
        d,
        &[
            "simulate", "--mci", "t.mci", "--out", "t.json", "--mco", "t.mco",
        ],
    );
    let p = Profile::read(&d.join("t.json")).unwrap();
    let text = std::fs::read_to_string(d.join("t.mco")).unwrap();
    let tags: Vec<&str> = text
        .lines()
        .filter(|l| {
            ["Rd_r", "Rd_a", "Tt_r", "Tt_a", "Rd_ra", "Tt_ra"]
                .iter()
                .any(|t| l.starts_with(t))
        })
        .map(|l| &l[..l.find(' ').unwrap_or(l.len())])
        .collect();
    assert_eq!(tags, ["Rd_r", "Rd_a", "Tt_r", "Tt_a", "Rd_ra", "Tt_ra"]);
    let section = |tag: &str| -> Vec<f64> {
        text.lines()
            .skip_while(|l| !l.starts_with(tag))
            .skip(1)
            .take_while(|l| !l.trim().is_empty())
            .flat_map(|l| l.split_whitespace().map(|v| v.parse::<f64>().unwrap()))
            .collect()
    };
    let t = p.transmittance.as_ref().unwrap()[0];
    let (dr, da) = (0.01, std::f64::consts::FRAC_PI_2 / 6.0);
    let pi = std::f64::consts::PI;
    let tt_r = section("Tt_r");
    assert_eq!(tt_r.len(), 20);
    let sum_r: f64 = tt_r
        .iter()
        .enumerate()
        .map(|(i, v)| v * 2.0 * pi * (i as f64 + 0.5) * dr * dr)
        .sum();
    let tt_a = section("Tt_a");
    assert_eq!(tt_a.len(), 6);
    let sum_a: f64 = tt_a
        .iter()
        .enumerate()
        .map(|(i, v)| v * 2.0 * pi * da * ((i as f64 + 0.5) * da).sin())
        .sum();
    let tt_ra = section("Tt_ra");
    assert_eq!(tt_ra.len(), 120);
    let sum_ra: f64 = (0..20)
        .flat_map(|ir| (0..6).map(move |ia| (ir, ia)))
        .map(|(ir, ia)| {
            let a = (ia as f64 + 0.5) * da;
            tt_ra[ir * 6 + ia]
                * 2.0
                * pi
                * (ir as f64 + 0.5)
                * dr
                * dr
                * 4.0
                * pi
                * a.sin()
                * (da / 2.0).sin()
                * a.cos()
        })
        .sum();
    // Five significant digits are written; MCML's sin(a) da and its
    // annulus (i + 1/2) dr^2 are its own exact inverses here.
    for (what, s) in [("Tt_r", sum_r), ("Tt_a", sum_a), ("Tt_ra", sum_ra)] {
        assert!((s - t).abs() < 1e-4 * t, "{what} sums to {s}, T is {t}");
    }
}
