//! The absolute floor of the default kernel-factor rule: media that barely
//! scatter back (wine, beer: R_d 1e-6 to 1e-4) stop once the noise they bring
//! to a kernel is below `DEFAULT_ABS_FLOOR` of the incident light, instead
//! of chasing a 0.5% relative error with 1e8+ photons. The claim must hold
//! against a much longer run, and the floor must never stop a channel that
//! the relative rule would not have stopped (bit-identical runs with the
//! floor off).

mod common;
use common::budgets::{default_rule, kernel_factor};

use ssskit::material::{preset, Channel};
use ssskit::profile::mc::{
    simulate, simulate_with, McConfig, McOptions, PhotonBudget, DEFAULT_ABS_FLOOR,
    DEFAULT_KERNEL_ERROR,
};
use ssskit::profile::{Profile, RadialGrid};
use ssskit::progress::NoProgress;

fn vec_f64(p: &Profile, key: &str) -> Vec<f64> {
    serde_json::from_value(p.extra[key].clone()).unwrap()
}

fn stopped_by(p: &Profile) -> Vec<String> {
    serde_json::from_value(p.extra["stopped_by"].clone()).unwrap()
}

#[test]
fn wine_and_beer_stop_at_the_floor_and_the_claim_holds() {
    let floor = DEFAULT_ABS_FLOOR;
    let min_photons = (3.0 / floor) as u64;
    for name in ["wine", "beer"] {
        let m = preset(name).unwrap();
        let a = simulate(&m, &default_rule(5), &NoProgress).unwrap();
        let budget = &a.source.params["budget"];
        assert_eq!(budget["rule"], "kernel-factor");
        assert_eq!(budget["absolute_floor"]["floor"], floor);
        let photons = a.source.photons.clone().unwrap();
        let rd_se = a.total_rd_stderr.clone().unwrap();
        let rel_f = vec_f64(&a, "rel_error_kernel_factor");
        let by = stopped_by(&a);
        for c in 0..3 {
            assert_eq!(a.extra["converged"][c], true, "{name} {c}");
            // A channel with sigma_s = 0 returns nothing: exact at once.
            if a.total_rd[c] == 0.0 && rd_se[c] == 0.0 && by[c] == "target" {
                continue;
            }
            assert_eq!(by[c], "absolute-floor", "{name} channel {c}");
            assert!(photons[c] >= min_photons && photons[c] < 2 * min_photons);
            assert!(rd_se[c] <= floor && a.total_rd[c] * rel_f[c] <= floor);
        }
        // Against a run 4x longer with another seed on the same grid: the
        // total within 4 combined standard errors (the kernel factors:
        // tests/mc_kernel_rule.rs).
        let long = McConfig {
            budget: PhotonBudget::Fixed(4 * photons.iter().max().unwrap()),
            seed: 6,
            grid: Some(RadialGrid {
                edges: a.r_edges.clone(),
            }),
            ..default_rule(6)
        };
        let b = simulate(&m, &long, &NoProgress).unwrap();
        let b_se = b.total_rd_stderr.clone().unwrap();
        for c in 0..3 {
            let d = (a.total_rd[c] - b.total_rd[c]).abs();
            let s = (rd_se[c].powi(2) + b_se[c].powi(2)).sqrt();
            assert!(
                d <= 4.0 * s,
                "{name} {c}: R_d {} vs {}",
                a.total_rd[c],
                b.total_rd[c]
            );
        }
    }
}

#[test]
fn the_floor_never_stops_a_visible_channel_early() {
    // R_d >= floor / target in every channel here (ketchup b: 1.5e-3, the
    // darkest preset channel after wine and beer): the relative rule
    // decides, and the run is bit-identical with the floor off.
    for name in ["ketchup", "skin1"] {
        let m = preset(name).unwrap();
        let with = simulate(&m, &default_rule(2), &NoProgress).unwrap();
        let off = McOptions {
            abs_floor: 0.0,
            ..McOptions::default()
        };
        let without = simulate_with(&m, &default_rule(2), &off, &NoProgress).unwrap();
        assert_eq!(with.source.photons, without.source.photons, "{name}");
        assert_eq!(with.rd, without.rd, "{name}");
        assert!(stopped_by(&with).iter().all(|s| s == "target"));
    }
}

#[test]
fn without_the_floor_beer_does_not_converge_cheaply() {
    // The floor, not luck, is what stops beer: with it off the relative rule
    // is far from met at the floor's photon minimum.
    let m = preset("beer").unwrap();
    let cfg = McConfig {
        budget: kernel_factor(DEFAULT_KERNEL_ERROR, 1_500_000),
        channels: vec![Channel::R],
        ..default_rule(1)
    };
    let off = McOptions {
        abs_floor: 0.0,
        ..McOptions::default()
    };
    let p = simulate_with(&m, &cfg, &off, &NoProgress).unwrap();
    assert_eq!(p.extra["converged"][0], false);
    assert_eq!(stopped_by(&p)[0], "photons");
    let warnings = p.extra["warnings"].to_string();
    assert!(warnings.contains("not reached"), "{warnings}");
}

#[test]
fn bad_floors_are_refused() {
    let m = preset("beer").unwrap();
    for bad in [-1e-5, 1.0, f64::NAN, f64::INFINITY] {
        let o = McOptions {
            abs_floor: bad,
            ..McOptions::default()
        };
        let e = simulate_with(&m, &default_rule(1), &o, &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(e.contains("invalid abs_floor"), "{bad}: {e}");
    }
}

#[test]
fn the_cli_names_the_floor() {
    let help = common::ok(&["simulate", "--help"]);
    assert!(
        help.contains("--abs-floor") && help.contains("kernel-factor"),
        "{help}"
    );
    let dir = std::env::temp_dir().join(format!("ssskit-abs-floor-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("beer.json");
    let out_s = out.to_str().unwrap();
    common::fails_with(
        &[
            "simulate",
            "--material",
            "beer",
            "--abs-floor",
            "-1",
            "--out",
            out_s,
        ],
        &["--abs-floor"],
    );
    assert!(!out.exists());
    common::ok(&[
        "simulate",
        "--material",
        "beer",
        "--channels",
        "r",
        "--out",
        out_s,
    ]);
    let p = Profile::read(&out).unwrap();
    assert_eq!(p.extra["stopped_by"][0], "absolute-floor");
    assert_eq!(
        p.source.params["budget"]["absolute_floor"]["floor"],
        DEFAULT_ABS_FLOOR
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
