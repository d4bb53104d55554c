//! `ssskit compare` on the real binary: its image-space numbers are what
//! `apply --kernel`, `apply --reference` and `diff` give separately; the
//! rows do not depend on the thread count; the output has the documented
//! shape; bad flags are refused with the flag's name.

use serde_json::Value;
use std::path::Path;

mod common;
use common::{bin, ok, p};

const MM: &str = "0.25";

/// 2 materials (Monte Carlo reference profiles), 3 models (svd rank 1 raw
/// and renormalised, preintegrate, jimenez), 2 signals, 64x64 pixels.
fn small_compare(out: &Path, threads: &str) -> Vec<Value> {
    let o = bin()
        .env("RAYON_NUM_THREADS", threads)
        .args([
            "compare",
            "--profiles",
            concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/reference"),
            "--materials",
            "skin1,marble",
            "--models",
            "svd,preintegrate,jimenez",
            "--ranks",
            "1",
            "--signals",
            "edge,shapes",
            "--size",
            "64",
            "--mm-per-pixel",
            MM,
            "--taps",
            "17,9",
            "--out",
            p(out),
        ])
        .output()
        .unwrap();
    common::assert_ok(&o, &["compare"]);
    let text = std::fs::read_to_string(out.join("compare.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn compare_equals_apply_and_diff_and_ignores_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let rows = small_compare(&out, "2");
    // 2 materials x 4 kernels (svd1, svd1-renorm, preintegrate, jimenez) x 3.
    assert_eq!(rows.len(), 2 * 4 * 3);
    for r in &rows {
        for key in ["material", "model", "params", "channel", "kernel_rms"] {
            assert!(r.get(key).is_some(), "{key} missing in {r}");
        }
        assert!(["r", "g", "b"].contains(&r["channel"].as_str().unwrap()));
        for s in ["edge", "shapes"] {
            let e = &r["image"][s];
            assert!(e["full"]["rel_rms"].as_f64().unwrap() >= 0.0, "{r}");
            assert!(e["full"]["flip"].as_f64().unwrap() >= 0.0, "{r}");
            for t in ["17", "9"] {
                assert!(e["taps"][t]["rel_rms"].as_f64().is_some(), "{r}");
            }
        }
        if r["model"] == "svd" {
            assert_eq!(r["params"]["rank"], 1);
            assert!(r["params"]["renormalize"].is_boolean());
        }
    }
    for f in [
        "report.md",
        "compare.csv",
        "slices_skin1.png",
        "sheet_marble_shapes.png",
        "spectra.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // Separately: signal, the exact reference, the kernel, diff.
    for material in ["skin1", "marble"] {
        let profile = format!(
            "{}/profiles/reference/{material}.json",
            env!("CARGO_MANIFEST_DIR")
        );
        for signal in ["edge", "shapes"] {
            let input = dir.path().join(format!("{signal}.exr"));
            ok(&[
                "signal",
                signal,
                "--size",
                "64x64",
                "--mm-per-pixel",
                MM,
                "--out",
                p(&input),
            ]);
            let exact = dir.path().join(format!("exact-{material}-{signal}.exr"));
            ok(&[
                "apply",
                "--reference",
                &profile,
                "--reference-sampling",
                "centre",
                "--input",
                p(&input),
                "--mm-per-pixel",
                MM,
                "--backend",
                "cpu",
                "--out",
                p(&exact),
            ]);
            for label in ["svd1-renorm", "preintegrate", "jimenez"] {
                let kernel = out.join("kernels").join(format!("{material}-{label}.json"));
                for (factor, extra) in [("full", None), ("17", Some("--taps-only"))] {
                    let filtered = dir.path().join("k.exr");
                    let mut args = vec![
                        "apply",
                        "--kernel",
                        p(&kernel),
                        "--input",
                        p(&input),
                        "--mm-per-pixel",
                        MM,
                        "--backend",
                        "cpu",
                        "--precision",
                        "f64",
                        "--out",
                        p(&filtered),
                    ];
                    args.extend(extra);
                    ok(&args);
                    let d = ok(&["diff", p(&exact), p(&filtered), "--json"]);
                    let v: Value = serde_json::from_str(&d).unwrap();
                    for (c, ch) in ["r", "g", "b"].iter().enumerate() {
                        let row = rows
                            .iter()
                            .find(|r| {
                                r["material"] == material
                                    && r["label"] == label
                                    && r["channel"] == *ch
                            })
                            .unwrap();
                        let e = &row["image"][signal];
                        let mine = if factor == "full" {
                            e["full"]["rel_rms"].as_f64().unwrap()
                        } else {
                            e["taps"][factor]["rel_rms"].as_f64().unwrap()
                        };
                        let theirs = v["rms_rel"][c].as_f64().unwrap();
                        assert!(
                            rel(mine, theirs) < 1e-9,
                            "{material} {label} {signal} {factor} {ch}: compare {mine} vs \
                             apply + diff {theirs}"
                        );
                    }
                }
            }
        }
    }
    // One thread: the same rows but for the timings.
    let strip = |rows: &[Value]| -> Vec<Value> {
        rows.iter()
            .map(|r| {
                let mut r = r.clone();
                r["fit_seconds"] = Value::Null;
                for (_, s) in r["image"].as_object_mut().unwrap().iter_mut() {
                    s["full"]["ms_per_megapixel"] = Value::Null;
                    for (_, t) in s["taps"].as_object_mut().unwrap().iter_mut() {
                        t["ms_per_megapixel"] = Value::Null;
                    }
                }
                r
            })
            .collect()
    };
    let one = small_compare(&dir.path().join("one"), "1");
    assert_eq!(strip(&rows), strip(&one));
}

#[test]
fn bad_flags_are_refused_with_their_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let profiles = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/reference");
    for (flags, needle) in [
        (vec!["--models", "svd,nope"], "--models"),
        (vec!["--ranks", "3-1"], "--ranks"),
        (vec!["--taps", "16"], "--taps"),
        (vec!["--signals", "stripes"], "--signals"),
        (vec!["--mm-per-pixel", "-1"], "--mm-per-pixel"),
        (vec!["--materials", "unobtainium"], "unobtainium"),
    ] {
        let mut args = vec!["compare", "--profiles", profiles, "--out", p(&out)];
        args.extend(flags.iter().copied());
        common::fails_with(&args, &[needle]);
        assert!(!out.join("compare.json").exists());
    }
    common::fails_with(&["compare", "--out", p(&out)], &["--profiles"]);
}
