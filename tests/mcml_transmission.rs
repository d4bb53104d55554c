//! ssskit's transmittance profile against MCML 1.2.2 (Wang, Jacques & Zheng
//! 1995), the oracle: `SSSKIT_MCML=<mcml> cargo bench --bench
//! mc_transmission` ran MCML (built from its public source, mcmlmain.c
//! `ShowVersion("Version 1.2.2, 2000")`) on two slabs and recorded its Tt_r
//! (per radial bin, 1/cm^2) and Tt_a (per exit bin, 1/sr) as the mean of
//! independent runs with the standard error of that mean, in
//! docs/records/mc-transmission.json (`data.cases`).
//!
//! This test reruns ssskit's side (`simulate --mci` on the same slab, fewer
//! photons, its own .mco) and requires the chi-square of the differences
//! over their combined standard errors to stay within `CHI2_SIGMAS` of its
//! degrees of freedom (the chi-square distribution's mean k and standard
//! deviation sqrt(2k)), for Tt_r (the last bin, where both put the light
//! beyond the grid, left out) and Tt_a; the bench's own recorded
//! comparison is held to the same bound. Its power: T_d off by
//! `POWER_SCALE` fails the same bound.

mod common;

use common::mcml::{floats, section};
use common::{ok_in, read_json};

/// Standard deviations of the chi-square distribution a statistic may
/// reach above its mean: 8 statistics checked, so a false failure has a
/// chance of well under 1e-3.
const CHI2_SIGMAS: f64 = 4.0;
/// Photons of this test's ssskit run per slab: standard errors of a few
/// percent per radial bin, about a second.
const PHOTONS: u64 = 200_000;
/// A T_d this far off (a 10% scale) must fail the bound on Tt_r.
const POWER_SCALE: f64 = 1.1;

fn chi2(ours: &[f64], ose: &[f64], theirs: &[f64], tse: &[f64]) -> (f64, f64) {
    let (mut c, mut k) = (0.0, 0.0);
    for i in 0..ours.len() {
        if ose[i] > 0.0 && tse[i] > 0.0 {
            c += (ours[i] - theirs[i]).powi(2) / (ose[i].powi(2) + tse[i].powi(2));
            k += 1.0;
        }
    }
    (c, k)
}

fn bound(k: f64) -> f64 {
    k + CHI2_SIGMAS * (2.0 * k).sqrt()
}

#[test]
fn tt_r_and_tt_a_match_mcml() {
    let rec = read_json(&ssskit::report::present::record::docs_path(
        "mc-transmission",
    ));
    let cases = rec["data"]["cases"]
        .as_array()
        .expect("the record holds MCML's arrays (run the bench with SSSKIT_MCML)");
    assert_eq!(cases.len(), 2);
    let dir = tempfile::tempdir().unwrap();
    let mut lines = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let f = |key: &str| case[key].as_f64().unwrap();
        let (nr, na) = (f("nr") as usize, f("na") as usize);
        // The bench's own comparison.
        for (c, dof) in [("chi2_tt_r", "dof_tt_r"), ("chi2_tt_a", "dof_tt_a")] {
            assert!(
                f(c) <= bound(f(dof)),
                "recorded {c} {} over {} bins",
                f(c),
                f(dof)
            );
        }
        assert!(
            f("z_tt").abs() <= CHI2_SIGMAS,
            "recorded total T z {}",
            f("z_tt")
        );
        let mci = format!(
            "1.0\n1\ns.mco A\n{PHOTONS}\n0.01 {}\n1 {nr} {na}\n1\n1.0\n{} {} {} {} {}\n1.0\n",
            f("dr_cm"),
            f("n"),
            f("mua"),
            f("mus"),
            f("g"),
            f("d")
        );
        let stem = format!("s{k}");
        std::fs::write(dir.path().join(format!("{stem}.mci")), mci).unwrap();
        ok_in(
            dir.path(),
            &[
                "simulate",
                "--mci",
                &format!("{stem}.mci"),
                "--out",
                &format!("{stem}.json"),
                "--mco",
                &format!("{stem}.mco"),
                "--seed",
                "9",
            ],
        );
        let p = ssskit::profile::Profile::read(&dir.path().join(format!("{stem}.json"))).unwrap();
        let tp = p.transmittance_profile().unwrap().unwrap();
        let text = std::fs::read_to_string(dir.path().join(format!("{stem}.mco"))).unwrap();
        // The .mco holds what the JSON holds, in MCML's units.
        let tt_r = section(&text, "Tt_r");
        assert_eq!(tt_r.len(), nr);
        let se_r: Vec<f64> = tp.td_stderr[0].iter().map(|v| v * 100.0).collect();
        let m_r = floats(&case["mcml_tt_r"]);
        let m_r_se = floats(&case["mcml_tt_r_stderr"]);
        let last = nr - 1;
        let (c_r, k_r) = chi2(&tt_r[..last], &se_r[..last], &m_r[..last], &m_r_se[..last]);
        let tt_a = section(&text, "Tt_a");
        let a = tp.angular.as_ref().unwrap();
        let da = std::f64::consts::PI / (2.0 * na as f64);
        let sr = |i: usize| 2.0 * std::f64::consts::PI * da * ((i as f64 + 0.5) * da).sin();
        let se_a: Vec<f64> = (0..na).map(|i| a.fraction_stderr[0][i] / sr(i)).collect();
        let (c_a, k_a) = chi2(
            &tt_a,
            &se_a,
            &floats(&case["mcml_tt_a"]),
            &floats(&case["mcml_tt_a_stderr"]),
        );
        lines.push(format!(
            "{}: Tt_r chi2 {c_r:.1} / {k_r}, Tt_a chi2 {c_a:.1} / {k_a}",
            case["label"]
        ));
        assert!(
            c_r <= bound(k_r),
            "{}: Tt_r chi2 {c_r} over {k_r} bins",
            case["label"]
        );
        assert!(
            c_a <= bound(k_a),
            "{}: Tt_a chi2 {c_a} over {k_a} bins",
            case["label"]
        );
        // A T_d 10% off fails.
        let off: Vec<f64> = tt_r.iter().map(|v| v * POWER_SCALE).collect();
        let (c_off, _) = chi2(&off[..last], &se_r[..last], &m_r[..last], &m_r_se[..last]);
        assert!(
            c_off > bound(k_r),
            "{}: a scaled T_d passes ({c_off})",
            case["label"]
        );
    }
    eprintln!("{}", lines.join("\n"));
}
