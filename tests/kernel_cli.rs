//! `ssskit fit` as a user runs it: every model writes a kernel that reads
//! back, shader export, table A.1 presets in the JSON, and clear errors for
//! bad flags and malformed kernel files.

mod common;
use common::{fails_with as fails, ok, p, read_json as read};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn profile(dir: &Path, material: &str) -> PathBuf {
    let out = dir.join(format!("{material}.json"));
    ok(&common::profile_args(material, "dipole", p(&out), &[]));
    out
}

/// `name` in `dir`: a `model` kernel (with `extra`) fitted to `material`'s
/// dipole profile.
fn fitted(dir: &Path, material: &str, model: &str, extra: &[&str], name: &str) -> PathBuf {
    let out = dir.join(name);
    let prof = profile(dir, material);
    ok(&common::fit_args(p(&prof), model, p(&out), extra));
    out
}

#[test]
fn every_model_writes_a_kernel_that_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let prof = profile(dir.path(), "skin1");
    let models: [&[&str]; 9] = [
        &["svd", "--rank", "3"],
        &["svd", "--renormalize"],
        &["preintegrate"],
        &["guided", "--k", "1"],
        &[
            "manual",
            "--w",
            "0.5",
            "--near",
            "0.1,0.1,0.1",
            "--far",
            "1,0.8,0.5",
        ],
        &["manual", "--fit"],
        &["gaussians", "--count", "3"],
        &["gaussians", "--preset", "deon-skin"],
        &["jimenez", "--jimenez-strength", "0.5,0.4,0.3"],
    ];
    for m in models {
        let out = dir.path().join("k.json");
        let mut args = vec!["fit", "--profile", p(&prof), "--grid-size", "61"];
        args.extend_from_slice(&["--out", p(&out), "--taps", "11", "--model"]);
        args.extend_from_slice(m);
        ok(&args);
        let k = read(&out);
        assert_eq!(k["schema"], "ssskit.kernel/1");
        assert_eq!(k["units"], "mm");
        assert_eq!(k["model"]["name"], m[0]);
        assert_eq!(k["taps"]["count"], 11);
        let passes = k["passes"].as_array().unwrap().len();
        assert_eq!(k["metrics"]["passes"], 2 * passes as u64, "{m:?}");
        assert_eq!(k["passes"][0]["offsets_mm"].as_array().unwrap().len(), 61);
        for key in ["kernel_rms", "norm1_error", "asymmetry"] {
            assert_eq!(k["metrics"][key].as_array().unwrap().len(), 3);
        }
        // Read back through the binary and export.
        for lang in ["hlsl", "glsl", "wgsl"] {
            let text = ok(&["fit", "--kernel", p(&out), "--emit", lang]);
            // One array per separable term, `sss_kernel_0`... (the header
            // names them `sss_kernel_p`).
            let arrays = text
                .match_indices("sss_kernel_")
                .filter(|(i, m)| text[i + m.len()..].starts_with(|c: char| c.is_ascii_digit()))
                .count();
            assert_eq!(arrays, passes, "{lang}");
            let ctor = ["float4(", "vec4(", "vec4<f32>("][["hlsl", "glsl", "wgsl"]
                .iter()
                .position(|l| *l == lang)
                .unwrap()];
            assert_eq!(text.matches(ctor).count(), 11 * passes, "{lang}\n{text}");
        }
    }
}

#[test]
fn svd_reports_spectrum_and_energy() {
    let dir = tempfile::tempdir().unwrap();
    let flags = ["--rank", "2", "--grid-size", "51"];
    let out = fitted(dir.path(), "marble", "svd", &flags, "k.json");
    let k = read(&out);
    let extra = &k["metrics"]["extra"];
    for c in 0..3 {
        let s = extra["singular_values"][c].as_array().unwrap();
        assert!(s.windows(2).all(|w| w[0].as_f64() >= w[1].as_f64()));
        let e = extra["energy_captured"][c].as_f64().unwrap();
        assert!(e > 0.9 && e <= 1.0, "{e}");
        // The centre of each factor is positive (sign convention).
        let centre = k["passes"][0]["weights"][25][c].as_f64().unwrap();
        assert!(centre > 0.0);
    }
}

#[test]
fn manual_presets_reproduce_table_a1() {
    let dir = tempfile::tempdir().unwrap();
    let prof = profile(dir.path(), "apple");
    let table = [
        ("apple", 0.368, [0.0495, 0.0455, 0.0372], [1.1, 1.08, 0.926]),
        (
            "ketchup",
            0.665,
            [0.0907, 0.0331, 0.0331],
            [1.5, 0.118, 0.0966],
        ),
        (
            "marble",
            0.234,
            [0.0371, 0.0207, 0.015],
            [0.663, 0.616, 0.558],
        ),
        ("skin1", 0.533, [0.429, 0.211, 0.03], [1.15, 0.69, 0.471]),
        (
            "wholemilk",
            0.407,
            [0.0846, 0.0846, 0.0583],
            [1.5, 1.39, 1.17],
        ),
    ];
    for (name, w, near, far) in table {
        let out = dir.path().join(format!("{name}-manual.json"));
        ok(&common::fit_args(
            p(&prof),
            "manual",
            p(&out),
            &["--preset", name, "--grid-size", "31"],
        ));
        let k = read(&out);
        let params = &k["model"]["params"];
        assert_eq!(params["preset"], name);
        assert_eq!(params["w"].as_f64(), Some(w));
        for c in 0..3 {
            assert_eq!(params["sqrt_tau_near"][c].as_f64(), Some(near[c]), "{name}");
            assert_eq!(params["sqrt_tau_far"][c].as_f64(), Some(far[c]), "{name}");
        }
        // The kernel is what the table says, not only its record: each
        // cell of the full factor holds the integral over the cell of
        // a_m(x) = w G(x, tau_n) + (1 - w) G(x, tau_f) (Freude 2014, eq.
        // 5.21; G the 1D Gaussian of variance tau, tau = (sqrt tau)^2),
        // computed here from the table above.
        let pass = &k["passes"][0];
        let offsets: Vec<f64> = serde_json::from_value(pass["offsets_mm"].clone()).unwrap();
        let weights: Vec<[f64; 3]> = serde_json::from_value(pass["weights"].clone()).unwrap();
        assert_eq!(offsets.len(), 31);
        let h = offsets[1] - offsets[0];
        for c in 0..3 {
            for (x, got) in offsets.iter().zip(&weights) {
                let want = w * gaussian_mass(x - 0.5 * h, x + 0.5 * h, near[c])
                    + (1.0 - w) * gaussian_mass(x - 0.5 * h, x + 0.5 * h, far[c]);
                assert!(
                    (got[c] - want).abs() <= 1e-9,
                    "{name} channel {c} at {x} mm: {} vs eq. 5.21 {want}",
                    got[c]
                );
            }
        }
    }
}

/// int_a^b of the 1D Gaussian of standard deviation `sd`: Gauss-Legendre
/// on panels a quarter of `sd` wide (exact to round-off at that width).
fn gaussian_mass(a: f64, b: f64, sd: f64) -> f64 {
    let g = |x: f64| (-0.5 * (x / sd).powi(2)).exp() / (sd * (2.0 * std::f64::consts::PI).sqrt());
    let n = ((b - a) / (0.25 * sd)).ceil().max(1.0) as usize;
    let step = (b - a) / n as f64;
    (0..n)
        .map(|i| {
            ssskit::numerics::gauss_legendre(g, a + i as f64 * step, a + (i + 1) as f64 * step)
        })
        .sum()
}

#[test]
fn bad_flags_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let prof = profile(dir.path(), "ketchup");
    let out = dir.path().join("k.json");
    let (p, o) = (p(&prof), p(&out));
    fails(
        &common::fit_args(p, "svd", o, &["--grid-size", "20"]),
        &["--grid-size", "20", "odd"],
    );
    fails(
        &common::fit_args(p, "svd", o, &["--extent", "-1"]),
        &["--extent"],
    );
    fails(
        &common::fit_args(p, "svd", o, &["--rank", "0", "--grid-size", "11"]),
        &["--rank"],
    );
    fails(
        &common::fit_args(p, "svd", o, &["--taps", "4", "--grid-size", "11"]),
        &["--taps", "odd"],
    );
    fails(
        &common::fit_args(
            p,
            "manual",
            o,
            &["--w", "0.5", "--near", "1,2", "--far", "1,1,1"],
        ),
        &["--near", "three"],
    );
    fails(
        &common::fit_args(p, "manual", o, &["--preset", "cheese"]),
        &["cheese", "apple"],
    );
    fails(
        &common::fit_args(p, "guided", o, &["--k", "-1", "--grid-size", "11"]),
        &["--k"],
    );
    fails(
        &common::fit_args(
            p,
            "jimenez",
            o,
            &["--jimenez-strength", "2,0,0", "--grid-size", "11"],
        ),
        &["--jimenez-strength"],
    );
    fails(
        &common::fit_args(p, "svd", o, &["--emit", "metal"]),
        &["--emit", "metal", "possible values: hlsl, glsl, wgsl"],
    );
    fails(
        &common::fit_args("/no/such/file.json", "svd", o, &[]),
        &["/no/such/file.json"],
    );
    assert!(!out.exists(), "a failed fit left an output file");
}

#[test]
fn malformed_kernel_files_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let flags = ["--grid-size", "21"];
    let good = fitted(dir.path(), "skin1", "preintegrate", &flags, "good.json");
    let base = read(&good);
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "schema",
            Box::new(|k| k["schema"] = "ssskit.kernel/0".into()),
            "schema",
        ),
        ("units", Box::new(|k| k["units"] = "px".into()), "units"),
        (
            "no passes",
            Box::new(|k| k["passes"] = Value::Array(vec![])),
            "no passes",
        ),
        (
            "length",
            Box::new(|k| {
                k["passes"][0]["weights"].as_array_mut().unwrap().pop();
            }),
            "weights",
        ),
        (
            "order",
            Box::new(|k| k["passes"][0]["offsets_mm"][3] = 100.0.into()),
            "increase",
        ),
        (
            "taps count",
            Box::new(|k| k["taps"]["count"] = 16.into()),
            "taps",
        ),
        (
            "total_rd",
            Box::new(|k| k["total_rd"][1] = (-0.5).into()),
            "total_rd",
        ),
        (
            "missing",
            Box::new(|k| {
                k.as_object_mut().unwrap().remove("metrics");
            }),
            "metrics",
        ),
    ];
    for (what, edit, expect) in cases {
        let mut k = base.clone();
        edit(&mut k);
        let f = dir
            .path()
            .join(format!("bad-{}.json", what.replace(' ', "-")));
        std::fs::write(&f, serde_json::to_string(&k).unwrap()).unwrap();
        fails(
            &["fit", "--kernel", p(&f), "--emit", "glsl"],
            &[p(&f), expect],
        );
    }
    let f = dir.path().join("garbage.json");
    std::fs::write(&f, "{ not json").unwrap();
    fails(&["fit", "--kernel", p(&f)], &["malformed JSON"]);
}

#[test]
fn rank1_svd_is_lowest_on_a_monte_carlo_profile_too() {
    // A noisy simulated profile with its single-scattering peak at r = 0.
    let dir = tempfile::tempdir().unwrap();
    let prof = dir.path().join("skin1-mc.json");
    ok(&common::simulate_skin1_args("7", p(&prof), &[]));
    let rms = |model: &[&str]| -> Vec<f64> {
        let out = dir.path().join("k.json");
        let mut args = vec!["fit", "--profile", p(&prof), "--grid-size", "61"];
        args.extend_from_slice(&["--out", p(&out), "--model"]);
        args.extend_from_slice(model);
        ok(&args);
        common::mcml::floats(&read(&out)["metrics"]["kernel_rms"])
    };
    let svd1 = rms(&["svd"]);
    for m in [
        &["svd", "--renormalize"][..],
        &["preintegrate"],
        &["guided", "--k", "0"],
        &["guided", "--k", "1"],
        &["manual", "--fit"],
        &["jimenez"],
    ] {
        let e = rms(m);
        common::fit_order::assert_svd1_lowest(&svd1, &e, |c| {
            format!("{m:?} channel {c}: {} < svd1 {}", e[c], svd1[c])
        });
    }
}

/// docs/engines.md's sign convention, on the committed rank-3 kernels:
/// every SVD term sums to a positive value per channel (full factors and
/// tap table), and the terms after the first have negative taps (so an
/// engine needs a signed target); skin1's second term at its centre tap.
#[test]
fn committed_svd_terms_sum_positive_and_later_terms_go_negative() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("kernels");
    let mut checked = 0;
    for material in ["apple", "ketchup", "marble", "skin1", "wholemilk"] {
        let k = read(&dir.join(format!("{material}-svd3.json")));
        for table in [&k["passes"], &k["taps"]["passes"]] {
            let passes = table.as_array().unwrap();
            assert_eq!(passes.len(), 3, "{material}");
            for (i, p) in passes.iter().enumerate() {
                let w: Vec<[f64; 3]> = serde_json::from_value(p["weights"].clone()).unwrap();
                for c in 0..3 {
                    let s: f64 = w.iter().map(|x| x[c]).sum();
                    assert!(s > 0.0, "{material} term {i} channel {c} sums to {s}");
                }
                let negative = w.iter().flatten().any(|x| *x < 0.0);
                assert_eq!(negative, i > 0, "{material} term {i}");
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 5 * 2 * 3);
    let k = read(&dir.join("skin1-svd3.json"));
    let second = &k["taps"]["passes"][1]["weights"];
    let centre = second.as_array().unwrap().len() / 2;
    assert!(
        second[centre][0].as_f64().unwrap() < 0.0,
        "{}",
        second[centre]
    );
}
