//! `ssskit simulate` as a user runs it: outputs that read back, MCML input
//! files, and a clear message (exit code 2, no panic) for every bad input.

use ssskit::profile::Profile;
mod common;
use common::args::{skin1_red_args, words};
use common::{fails_with_in as fails_with, run_in as ssskit, stderr};

#[test]
fn simulate_writes_json_and_csv_that_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let o = ssskit(
        dir.path(),
        &common::simulate_skin1_args("3", "s.json", &["--csv", "s.csv"]),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let p = Profile::read(&dir.path().join("s.json")).unwrap();
    assert_eq!(p.source.kind, "monte-carlo");
    assert_eq!(p.source.photons, Some(vec![20000; 3]));
    assert_eq!(p.source.seed, Some(3));
    assert!(p.elapsed_s > 0.0);
    assert_eq!(p.rd_stderr.as_ref().unwrap().len(), 3);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("s.json")).unwrap()).unwrap();
    for key in ["total_rd_stderr", "specular", "transmittance", "absorbed"] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    let csv = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "r_inner_mm,r_outer_mm,r_mm,rd_r,rd_r_stderr,rd_g,rd_g_stderr,rd_b,rd_b_stderr"
    );
    assert_eq!(lines.count(), p.r.len());
    // Default output name, single channel, log bins, split boundaries.
    let o = ssskit(
        dir.path(),
        &[
            "simulate",
            "--material",
            "marble",
            "--photons",
            "8192",
            "--channels",
            "b",
            "--log-bins",
            "--boundary",
            "split",
            "--threads",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let p = Profile::read(&dir.path().join("marble.json")).unwrap();
    assert_eq!(p.channels.len(), 1);
    assert!(p.r_edges[2] - p.r_edges[1] > p.r_edges[1] - p.r_edges[0]);
    assert_eq!(p.source.params["boundary"], "split");
}

#[test]
fn mci_file_runs_and_bad_mci_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    // The van de Hulst slab in MCML units (cm): mua 10, mus 90 /cm, d 0.02 cm.
    let mci = "1.0 # version\n2 # runs\nslab.mco A\n20000\n0.001 0.001\n10 100 1\n1\n1.0\n\
               1.0 10 90 0.75 0.02\n1.0\n\nhalf.mco A\n1000\n0.01 0.01\n1 50 1\n1\n1.0\n\
               1.4 1 100 0.9 1E8\n1.0\n";
    std::fs::write(dir.path().join("t.mci"), mci).unwrap();
    let o = ssskit(
        dir.path(),
        &["simulate", "--mci", "t.mci", "--out", "m.json"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let p = Profile::read(&dir.path().join("m.json")).unwrap();
    assert_eq!(p.source.photons, Some(vec![20000]));
    assert_eq!(p.r.len(), 100);
    assert!((p.r_edges[1] - 0.01).abs() < 1e-12);
    let t = p.transmittance.as_ref().unwrap()[0];
    let te = p.transmittance_stderr.as_ref().unwrap()[0];
    assert!((t - 0.66096).abs() < common::SIGMAS * te, "T {t} +- {te}");
    let o = ssskit(dir.path(), &sim("--mci t.mci --mci-run 2 --out h.json"));
    assert!(o.status.success(), "{}", stderr(&o));
    let p = Profile::read(&dir.path().join("h.json")).unwrap();
    assert!(p.material.is_half_space());
    fails_with(
        dir.path(),
        &["simulate", "--mci", "t.mci", "--mci-run", "3"],
        &["--mci-run 3", "2 run(s)"],
    );
    std::fs::write(
        dir.path().join("bad.mci"),
        mci.replace("1.0 10 90 0.75", "1.0 10 90 1.75"),
    )
    .unwrap();
    fails_with(
        dir.path(),
        &["simulate", "--mci", "bad.mci"],
        &["bad.mci run 1", "g", "1.75"],
    );
    std::fs::write(dir.path().join("short.mci"), "1.0\n1\nx.mco A\n100\n").unwrap();
    fails_with(
        dir.path(),
        &["simulate", "--mci", "short.mci"],
        &["short.mci", "unexpected end of file"],
    );
    fails_with(
        dir.path(),
        &["simulate", "--mci", "none.mci"],
        &["none.mci"],
    );
}

/// `ssskit simulate` with the flags `flags` (split at spaces).
fn sim(flags: &str) -> Vec<&str> {
    [&["simulate"][..], &words(flags)].concat()
}

#[test]
fn invalid_material_files_name_file_field_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let base = "unit = \"mm\"\nsigma_a = [0.032, 0.17, 0.48]\nsigma_s = [0.74, 0.88, 1.01]\ng = 0.0\neta = 1.3\n";
    let zero = "unit = \"mm\"\nsigma_a = 0.0\nsigma_s = [0.0, 1.0, 1.0]\neta = 1.3\n";
    #[rustfmt::skip] // one line a case: the table reads as one
    let cases: [(&str, String, &[&str]); 10] = [
        ("neg.toml", base.replace("0.032", "-0.032"), &["sigma_a[r]", "-0.032", ">= 0"]),
        ("nan.toml", base.replace("0.17", "nan"), &["sigma_a[g]", "NaN"]),
        ("inf.toml", base.replace("1.01", "inf"), &["sigma_s[b]", "inf"]),
        ("g.toml", base.replace("g = 0.0", "g = 1.0"), &["g[r]", "1", "|g| < 1"]),
        ("eta.toml", base.replace("eta = 1.3", "eta = 0.0"), &["eta", "0", "> 0"]),
        ("zero.toml", zero.into(), &["sigma_t[r]", "zero extinction"]),
        ("thick.toml", format!("{base}thickness = -1.0\n"), &["thickness", "-1"]),
        ("unit.toml", base.replace("\"mm\"", "\"inch\""), &["unit", "inch"]),
        ("nounit.toml", base.replace("unit = \"mm\"\n", ""), &["unit", "missing"]),
        ("syntax.toml", "unit = \"mm\"\nsigma_a = [1, 2\n".into(), &["malformed material TOML"]),
    ];
    for (file, text, needles) in cases.iter() {
        std::fs::write(dir.path().join(file), text).unwrap();
        let mut n: Vec<&str> = needles.to_vec();
        n.push(file);
        fails_with(
            dir.path(),
            &["simulate", "--material", file, "--photons", "100"],
            &n,
        );
    }
    // Names that are neither a preset nor a file.
    let unknown = ["unobtainium", "skin1"];
    fails_with(dir.path(), &sim("--material unobtainium"), &unknown);
    let missing = ["missing.toml"];
    fails_with(dir.path(), &sim("--material missing.toml"), &missing);
}

#[test]
fn invalid_flags_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    #[rustfmt::skip] // one line a case: the table reads as one
    let cases: [(&str, &[&str]); 15] = [
        ("--photons 0", &["--photons", "0"]),
        ("--photons -5", &["--photons"]),
        ("--mc-error 2", &["--mc-error: invalid value 2", "(0, 1)"]),
        // The old spelling: accepted, noted, named as typed.
        ("--target-error 2", &[
            "note: --target-error is deprecated: use --mc-error",
            "--target-error: invalid value 2",
            "(0, 1)",
        ]),
        ("--mc-error -0.1", &["--mc-error", "-0.1"]),
        ("--mc-error nan", &["--mc-error", "nan", "finite"]),
        ("--photons 10 --mc-error 0.1", &["cannot be used with"]),
        ("--channels rx", &["--channels", "x"]),
        ("--threads 0 --photons 10", &["--threads", "0"]),
        ("--dr -1 --photons 10", &["--dr", "-1"]),
        ("--rmax 0 --photons 10", &["--rmax", "0"]),
        ("--dr 1 --rmax 0.5 --photons 10", &["rmax", "0.5"]),
        ("--boundary maybe", &["--boundary", "maybe", "possible values: classic, split"]),
        ("--max-events 0 --photons 10", &["--max-events"]),
        ("--photons 10 --out no/such/dir/x.json", &["--out", "no/such/dir"]),
    ];
    for (flags, needles) in cases {
        fails_with(d, &sim(&format!("--material skin1 {flags}")), needles);
    }
    fails_with(d, &["simulate"], &["--material"]);
    fails_with(
        d,
        &["simulate", "--material", "skin1", "--mci", "x.mci"],
        &["cannot be used with"],
    );
}

#[test]
fn mco_output_follows_mcml() {
    // The van de Hulst slab in MCML units; a grid of 40 x 10 um that loses
    // some reflectance beyond it, which MCML puts in the last bin.
    let mci = "1.0\n1\nslab.mco A\n20000\n0.001 0.001\n10 40 1\n1\n1.0\n1.0 10 90 0.75 0.02\n1.0\n";
    let dir = common::temp_with(&[("t.mci", mci)]);
    let d = dir.path();
    let o = ssskit(
        d,
        &[
            "simulate", "--mci", "t.mci", "--out", "t.json", "--mco", "t.mco",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let p = Profile::read(&d.join("t.json")).unwrap();
    let text = std::fs::read_to_string(d.join("t.mco")).unwrap();
    assert!(text.starts_with("A1 "));
    let value = |tag: &str| -> f64 {
        let line = text.lines().find(|l| l.contains(tag)).unwrap();
        line.split_whitespace().next().unwrap().parse().unwrap()
    };
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs().max(1e-12);
    assert!(close(value("#Diffuse reflectance"), p.total_rd[0]));
    assert!(close(
        value("#Transmittance"),
        p.transmittance.as_ref().unwrap()[0]
    ));
    assert!(close(
        value("#Absorbed fraction"),
        p.absorbed.as_ref().unwrap()[0]
    ));
    assert_eq!(value("# No. of photons"), 20000.0);
    // Rd_r in 1/cm^2 on MCML's annuli 2 pi (i + 1/2) dr^2 integrates to the
    // whole R_d, the part beyond the grid included (4 significant digits).
    let start = text.lines().position(|l| l.starts_with("Rd_r")).unwrap();
    let rd_r: Vec<f64> = text
        .lines()
        .skip(start + 1)
        .take_while(|l| !l.trim().is_empty())
        .map(|l| l.trim().parse().unwrap())
        .collect();
    assert_eq!(rd_r.len(), 40);
    let dr = 0.001;
    let total: f64 = rd_r
        .iter()
        .enumerate()
        .map(|(i, v)| v * 2.0 * std::f64::consts::PI * (i as f64 + 0.5) * dr * dr)
        .sum();
    let beyond = p.extra["rd_beyond_rmax"][0].as_f64().unwrap();
    assert!(
        beyond > 0.01 * p.total_rd[0],
        "the grid should lose some R_d"
    );
    assert!(
        (total - p.total_rd[0]).abs() < 1e-3 * p.total_rd[0],
        "{total} vs {}",
        p.total_rd[0]
    );
    // One wavelength, uniform bins only.
    let bad = ssskit(
        d,
        &words("simulate --material skin1 --photons 100 --mco x.mco"),
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("--mco"));
    let bad = ssskit(
        d,
        &skin1_red_args(&words("--photons 100 --log-bins --mco x.mco")),
    );
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("uniform"), "{}", stderr(&bad));
    assert!(!d.join("x.mco").exists());
}

/// The work cap stops a fixed run whose first round underestimated its
/// cost, inside the round that would pass it: each chunk of a round gets an
/// equal share of the events left, and a round a chunk cannot finish within
/// its share is discarded whole. The rounds trace 2 chunks (16384
/// photons), then 2 more, then the rest; a seed where chunks 3-4 cost more
/// than chunks 1-2 and a cap at the first round's projection for 32769
/// photons lets the run pass its first round; its second would pass the
/// cap, so the run stops after the first, never over the cap.
#[test]
fn a_fixed_run_stops_at_the_work_cap_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = |photons: u64, seed: u64, max_work: Option<u64>| -> Profile {
        let (photons, seed) = (photons.to_string(), seed.to_string());
        let mut args = vec![
            "simulate",
            "--material",
            "skin1",
            "--channels",
            "b",
            "--photons",
            &photons,
            "--seed",
            &seed,
            "--out",
            "f.json",
        ];
        let cap = max_work.map(|w| w.to_string());
        if let Some(w) = &cap {
            args.extend(["--max-work", w.as_str()]);
        }
        let o = ssskit(d, &args);
        assert!(o.status.success(), "{}", stderr(&o));
        Profile::read(&d.join("f.json")).unwrap()
    };
    let events = |p: &Profile| {
        let per = p.extra["events_per_photon"][0].as_f64().unwrap();
        (per * p.source.photons.as_ref().unwrap()[0] as f64).round() as u64
    };
    for seed in 1..=20 {
        let first = events(&sim(16384, seed, None));
        let both = events(&sim(32768, seed, None));
        // The run's own projection after its first round.
        let cap = (first as f64 / 16384.0 * 32769.0).ceil() as u64;
        if both < cap {
            continue;
        }
        let p = sim(32769, seed, Some(cap));
        assert_eq!(p.source.photons, Some(vec![16384]));
        assert!(events(&p) <= cap, "{} events, cap {cap}", events(&p));
        assert_eq!(p.extra["stopped_by"][0], "work-cap");
        assert_eq!(p.extra["converged"][0], false);
        assert_eq!(p.source.params["budget"]["max_work"], cap);
        let w = p.extra["warnings"].to_string();
        assert!(
            w.contains("work cap") && w.contains("16384 of 32769 photons"),
            "{w}"
        );
        // The photons it did trace are those of the full run.
        let full = sim(16384, seed, None);
        assert_eq!(p.rd, full.rd);
        return;
    }
    panic!("no seed in 1..=20 where chunks 3-4 cost more than chunks 1-2");
}

/// A run cut short says so in the terms of where it is read: the profile
/// names the library parameter, the command line names the flag.
#[test]
fn warnings_name_the_parameter_in_the_file_and_the_flag_on_screen() {
    let dir = tempfile::tempdir().unwrap();
    let capped = words("--max-photons 2000 --threads 1 --out p.json");
    let o = ssskit(dir.path(), &skin1_red_args(&capped));
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("not reached within the cap of 2000 photons (--max-photons)"),
        "{err}"
    );
    let p = Profile::read(&dir.path().join("p.json")).unwrap();
    let w = p.warnings().unwrap().join("\n");
    assert!(w.contains("2000 photons (`max_photons`)"), "{w}");
    assert!(!w.contains("--"), "the library names no flags: {w}");
}
