//! `ssskit profile`, `ssskit plot profile` and `ssskit profiles compare`
//! through the real binary: outputs, recorded parameters, error messages.

mod common;
use common::{fails_with, read_json, run as ssskit, stderr};

#[test]
fn profile_writes_a_valid_analytic_profile_for_every_model() {
    let dir = tempfile::tempdir().unwrap();
    for model in ["dipole", "pbd", "burley", "directional-dipole"] {
        let out = dir.path().join(format!("{model}.json"));
        let o = ssskit(&[
            "profile",
            "--material",
            "skin1",
            "--profile-model",
            model,
            "--dr",
            "0.05",
            "--rmax",
            "10",
            "--fresnel",
            "exact",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{model}: {}", stderr(&o));
        let p = ssskit::profile::Profile::read(&out).unwrap();
        assert_eq!(p.source.kind, "analytic");
        assert_eq!(p.source.model.as_deref(), Some(model));
        assert_eq!(p.r.len(), 200);
        assert!(p.rd_stderr.is_none());
        let v = read_json(&out);
        assert_eq!(v["source"]["params"]["fresnel"], "exact");
        assert!(
            v["source"]["params"]["entry_transmission"]
                .as_f64()
                .unwrap()
                > 0.98
        );
        assert!(v["source"]["params"]["channels"]["b"].is_object());
        // Whole-plane totals exceed the part tabulated inside 10 mm.
        for c in 0..3 {
            assert!(p.total_rd[c] >= p.tabulated_total(c) * (1.0 - 1e-9));
        }
    }
}

#[test]
fn profile_rejects_bad_input_with_a_clear_message_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.json");
    fails_with(
        &[
            "profile",
            "--material",
            "marble",
            "--profile-model",
            "dipole",
            "--dr",
            "-1",
            "--out",
            out.to_str().unwrap(),
        ],
        &["--dr"],
    );
    fails_with(
        &[
            "profile",
            "--material",
            "marble",
            "--profile-model",
            "nosuch",
            "--out",
            out.to_str().unwrap(),
        ],
        &["nosuch", "possible values"],
    );
    // Analytic models describe a half-space only, and eta = 3 is outside the
    // Fresnel fits: each material file is refused with a message naming why.
    let toml = dir.path().join("m.toml");
    for (extra, eta, expected) in [
        ("thickness = 1.0\n", "1.3", "semi-infinite"),
        ("", "3.0", "--fresnel exact"),
    ] {
        std::fs::write(
            &toml,
            format!(
                "unit = \"mm\"\nsigma_a = [0.1, 0.1, 0.1]\nsigma_s = [1.0, 1.0, 1.0]\ng = 0.0\neta = {eta}\n{extra}"
            ),
        )
        .unwrap();
        fails_with(
            &[
                "profile",
                "--material",
                toml.to_str().unwrap(),
                "--profile-model",
                "pbd",
                "--out",
                out.to_str().unwrap(),
            ],
            &[expected],
        );
    }
    assert!(!out.exists());
}

#[test]
fn plot_profile_writes_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.json");
    let b = dir.path().join("b.json");
    for (model, out) in [("dipole", &a), ("burley", &b)] {
        let o = ssskit(&[
            "profile",
            "--material",
            "wholemilk",
            "--profile-model",
            model,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let png = dir.path().join("p.png");
    // The page the CLI draws, pixel by pixel against its golden (curves,
    // axes, labels: a changed profile or plot fails here).
    let golden_name = "cli-plot-profile-wholemilk.png";
    common::golden::check_png(golden_name, |out| {
        let o = ssskit(&[
            "plot",
            "profile",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    });
    let img = image::open(common::golden::diff_dir().join(golden_name)).unwrap();
    assert!(img.width() >= 1000 && img.height() >= 1000);
    // Not blank: some pixels are drawn in a curve colour.
    let rgb = img.to_rgb8();
    assert!(rgb.pixels().filter(|p| p.0 != [255, 255, 255]).count() > 10_000);
    // A missing file is an error naming it.
    fails_with(
        &[
            "plot",
            "profile",
            "/nonexistent.json",
            "--out",
            png.to_str().unwrap(),
        ],
        &["nonexistent.json"],
    );
}

#[test]
fn compare_rejects_bad_flags() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    fails_with(
        &[
            "profiles",
            "compare",
            "--materials",
            "nosuch",
            "--out-dir",
            d,
        ],
        &["nosuch"],
    );
    fails_with(
        &[
            "profiles",
            "compare",
            "--materials",
            "marble",
            "--mc-error",
            "0",
            "--out-dir",
            d,
        ],
        &["--mc-error: invalid value 0"],
    );
}

#[test]
fn compare_writes_table_csv_and_plot_with_the_failures_visible() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let o = ssskit(&[
        "profiles",
        "compare",
        "--materials",
        "ketchup",
        "--photons",
        "5000",
        "--out-dir",
        d,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(dir.path().join("compare.md")).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("compare.csv")).unwrap();
    // Header + 4 models x 3 channels.
    assert_eq!(csv.lines().count(), 13);
    let all = ssskit::report::present::kernel_report::blocks(&md)
        .into_iter()
        .find(|(n, _)| n == "all")
        .expect("block 'all' in compare.md")
        .1;
    assert_eq!(all.lines().count(), 14, "{md}");
    let png = image::open(dir.path().join("compare_ketchup.png")).unwrap();
    assert!(png.width() > 1000);
    // The directional dipole's failure on ketchup blue shows as a relative
    // total error far above 100%.
    let dd_b = csv
        .lines()
        .find(|l| l.starts_with("ketchup,b,") && l.contains(",directional-dipole,"))
        .unwrap();
    let rel: f64 = dd_b.split(',').nth(7).unwrap().parse().unwrap();
    assert!(rel > 10.0, "{dd_b}");
}

#[test]
fn bad_values_are_reported_in_one_format_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let prof = dir.path().join("skin1.json");
    let out = dir.path().join("out.json");
    let (prof_s, out_s) = (prof.to_str().unwrap(), out.to_str().unwrap());
    let o = ssskit(&[
        "profile",
        "--material",
        "skin1",
        "--profile-model",
        "dipole",
        "--dr",
        "0.05",
        "--out",
        prof_s,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let profile = |extra: &[&'static str]| {
        let mut a = vec![
            "profile",
            "--material",
            "skin1",
            "--profile-model",
            "dipole",
        ];
        a.extend_from_slice(extra);
        a.extend_from_slice(&["--out", out_s]);
        a
    };
    let fit = |extra: &[&'static str]| {
        let mut a = vec!["fit", "--profile", prof_s, "--out", out_s, "--model"];
        a.extend_from_slice(extra);
        a
    };
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (profile(&["--dr", "-1"]), "--dr: invalid value -1: "),
        (
            profile(&["--dr", "0.1", "--rmax", "0.01"]),
            "--rmax: invalid value 0.01: ",
        ),
        (
            profile(&["--channels", "rx"]),
            "--channels: invalid value rx: ",
        ),
        (
            fit(&["svd", "--extent", "-2"]),
            "--extent: invalid value -2: ",
        ),
        (
            fit(&["svd", "--grid-size", "20"]),
            "--grid-size: invalid value 20: ",
        ),
        (
            fit(&["manual", "--w", "2", "--near", "1,1,1", "--far", "2,2,2"]),
            "--w: invalid value 2: ",
        ),
        (fit(&["guided", "--k", "9"]), "--k: invalid value 9: "),
        (
            fit(&["gaussians", "--count", "0"]),
            "--count: invalid value 0: ",
        ),
        (
            fit(&["jimenez", "--jimenez-width", "0"]),
            "--jimenez-width: invalid value 0: ",
        ),
    ];
    for (args, expect) in cases {
        common::fails_with(&args, &[expect]);
        assert!(!out.exists(), "{args:?} wrote {out_s}");
    }
}
