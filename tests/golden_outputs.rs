//! Golden outputs besides the kernels (tests/reference_outputs.rs), in the
//! manner of resvg's reference images: one test per case, run alone by
//! name, a failure leaving what was produced and how it differs in
//! `target/golden-diffs/`.
//!
//! - `apply_*`: `ssskit apply` on a committed kernel
//!   (tests/golden/apply/kernel.json) and a generated signal against the
//!   committed image tests/golden/apply/<case>.exr, each case with a named
//!   threshold on max |A - B| / max |A| per channel.
//! - `simulate_fixed_seed`: `ssskit simulate` at a fixed seed equals
//!   tests/golden/simulate-skin1.json in every number but the elapsed
//!   time, at 1 and at 2 threads (bit-identical).
//! - `reference_profiles_record_todays_simulator`: each committed reference
//!   profile (profiles/reference/) records in `source` what today's
//!   `simulate` (or `profile`) records for the same material and seed, so
//!   the profiles can be reproduced by scripts/regen-kernels; a changed
//!   schema or default fails here until they are regenerated.
//!
//! After an intended change: `SSSKIT_BLESS=1 cargo test --release --test
//! golden_outputs [NAME]` rewrites the goldens that differ; review the diff.

mod common;

use serde_json::Value;
use ssskit::filter::image::read_image;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn golden_dir() -> PathBuf {
    root().join("tests/golden")
}

fn diff_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .expect("target/tmp has a parent")
        .join("golden-diffs");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// CPU filtering in f64, stored as f32 EXR: the same arithmetic gives the
/// same bits; 1e-6 of the peak leaves room for another libm or FMA
/// contraction and is far below anything a reader of the image could see.
const CPU_F64: f64 = 1e-6;

/// The wgpu pass (f32) against the CPU golden (f64): the tolerance the
/// filter documents for the GPU against its CPU twin.
const GPU_F32: f64 = 1e-4;

/// max over channels of max |a - b| / max |a|.
fn max_rel(a: &ssskit::filter::Image, b: &ssskit::filter::Image) -> f64 {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "image sizes differ"
    );
    (0..3)
        .map(|c| {
            let peak = a.rgb[c].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let d = a.rgb[c]
                .iter()
                .zip(&b.rgb[c])
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            if peak > 0.0 {
                d / peak
            } else {
                d
            }
        })
        .fold(0.0, f64::max)
}

/// A depth plane for the perspective case: 40 mm on the left half, 80 mm
/// on the right (a silhouette where the depth-aware lerp saturates), both
/// tilted by 2e-5 mm per pixel (where it lerps part way: the lerp's
/// constant times the depth step between taps is a fraction of 1), in the
/// R, G and B channels of an EXR.
fn write_depth(path: &Path, w: usize, h: usize) {
    let mut img = ssskit::filter::Image::new(w, h);
    for c in 0..3 {
        for (i, v) in img.rgb[c].iter_mut().enumerate() {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            *v = if i % w < w / 2 { 40.0 } else { 80.0 } + 2e-5 * (x + y);
        }
    }
    ssskit::filter::image::write_image(path, &img, ssskit::filter::image::PngDepth::Sixteen)
        .unwrap();
}

/// Runs `apply` on the committed kernel with `flags`, compares with
/// tests/golden/apply/<golden>.exr within `threshold`.
fn apply_case(name: &str, golden: &str, signal: &str, flags: &[&str], threshold: f64) {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.exr");
    common::ok(&[
        "signal",
        signal,
        "--image-size",
        "64x48",
        "--mm-per-pixel",
        "0.1",
        "--out",
        common::p(&input),
    ]);
    let depth = dir.path().join("depth.exr");
    write_depth(&depth, 64, 48);
    let out = dir.path().join("out.exr");
    let kernel = golden_dir().join("apply/kernel.json");
    let (kernel, input, out_path) = (common::p(&kernel), common::p(&input), common::p(&out));
    let mut args = vec![
        "apply", "--kernel", kernel, "--input", input, "--out", out_path,
    ];
    for f in flags {
        args.push(if *f == "DEPTH" { common::p(&depth) } else { f });
    }
    common::ok(&args);
    let want_path = golden_dir().join(format!("apply/{golden}.exr"));
    let (got, _) = read_image(&out, None).unwrap();
    let dev = match read_image(&want_path, None) {
        Ok((want, _)) => max_rel(&want, &got),
        Err(_) => f64::INFINITY,
    };
    eprintln!("{name}: max |golden - output| / peak = {dev:.2e} (threshold {threshold:e})");
    if dev <= threshold {
        return;
    }
    if common::bless() {
        std::fs::copy(&out, &want_path).unwrap();
        eprintln!("blessed {}", want_path.display());
        return;
    }
    let kept = diff_dir().join(format!("{name}.exr"));
    std::fs::copy(&out, &kept).unwrap();
    let picture = diff_dir().join(format!("{name}-diff.png"));
    if want_path.is_file() {
        common::ok(&[
            "diff",
            common::p(&want_path),
            common::p(&kept),
            "--out",
            common::p(&picture),
        ]);
    }
    panic!(
        "{name}: differs from {} by {dev:e} of the peak (threshold {threshold:e}); output in {}, \
         difference in {} (after an intended change: SSSKIT_BLESS=1 cargo test --release \
         --test golden_outputs {name})",
        want_path.display(),
        kept.display(),
        picture.display()
    );
}

/// Orthographic, 0.1 mm per pixel, on the CPU in f64.
const CPU_ORTHO: [&str; 6] = [
    "--mm-per-pixel",
    "0.1",
    "--backend",
    "cpu",
    "--precision",
    "f64",
];

#[test]
fn apply_full_factors_cpu() {
    let mut flags = CPU_ORTHO.to_vec();
    flags.push("--full-factors");
    apply_case(
        "apply_full_factors_cpu",
        "shapes-full",
        "shapes",
        &flags,
        CPU_F64,
    );
}

#[test]
fn apply_tap_table_cpu() {
    // The tap table is apply's default: no flag.
    apply_case(
        "apply_tap_table_cpu",
        "shapes-taps",
        "shapes",
        &CPU_ORTHO,
        CPU_F64,
    );
}

#[test]
fn apply_perspective_depth_aware_cpu() {
    let flags = [
        "--depth",
        "DEPTH",
        "--fov-y",
        "30",
        "--units-per-mm",
        "1",
        "--follow-surface-scene-units",
        "300",
        "--full-factors",
        "--backend",
        "cpu",
    ];
    apply_case(
        "apply_perspective_depth_aware_cpu",
        "shapes-perspective",
        "shapes",
        &flags,
        CPU_F64,
    );
}

/// The wgpu pass (lavapipe in CI) against the CPU golden of the same case.
#[test]
fn apply_full_factors_gpu() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let flags = [
        "--mm-per-pixel",
        "0.1",
        "--full-factors",
        "--backend",
        "gpu",
    ];
    apply_case(
        "apply_full_factors_gpu",
        "shapes-full",
        "shapes",
        &flags,
        GPU_F32,
    );
}

/// Walks two JSON values; lists every difference (numbers must be equal
/// to the bit: the run is deterministic), skipping keys in `skip`.
fn exact_diffs(path: &str, want: &Value, got: &Value, skip: &[&str], out: &mut Vec<String>) {
    match (want, got) {
        (Value::Object(a), Value::Object(b)) => {
            for k in a.keys().chain(b.keys().filter(|k| !a.contains_key(*k))) {
                if skip.contains(&k.as_str()) {
                    continue;
                }
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => exact_diffs(&format!("{path}.{k}"), x, y, skip, out),
                    _ => out.push(format!("{path}.{k}: present on one side only")),
                }
            }
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                exact_diffs(&format!("{path}[{i}]"), x, y, skip, out);
            }
        }
        (a, b) if a == b => {}
        (a, b) => {
            let s = |v: &Value| {
                let t = v.to_string();
                if t.len() > 60 {
                    format!("{}...", &t[..60])
                } else {
                    t
                }
            };
            out.push(format!("{path}: golden {}, now {}", s(a), s(b)));
        }
    }
}

#[test]
fn simulate_fixed_seed() {
    let golden = golden_dir().join("simulate-skin1.json");
    let dir = tempfile::tempdir().unwrap();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("skin1-{threads}.json"));
        let o = common::bin()
            .env("RAYON_NUM_THREADS", threads)
            .args(common::simulate_skin1_args("1", common::p(&out), &[]))
            .output()
            .unwrap();
        common::assert_ok(&o, &["simulate"]);
        let got = common::read_json(&out);
        let mut diffs = Vec::new();
        match std::fs::read_to_string(&golden) {
            Ok(text) => {
                let want: Value = serde_json::from_str(&text).unwrap();
                exact_diffs("", &want, &got, &["elapsed_s"], &mut diffs);
            }
            Err(e) => diffs.push(format!("no golden: {e}")),
        }
        if diffs.is_empty() {
            continue;
        }
        if common::bless() && threads == "1" {
            std::fs::copy(&out, &golden).unwrap();
            eprintln!("blessed {}", golden.display());
            continue;
        }
        let kept = diff_dir().join(format!("simulate_fixed_seed-{threads}-threads.json"));
        std::fs::copy(&out, &kept).unwrap();
        let report = diff_dir().join("simulate_fixed_seed.diff.txt");
        std::fs::write(&report, diffs.join("\n") + "\n").unwrap();
        panic!(
            "simulate at {threads} thread(s) differs from {} ({} differences, the first: {}); \
             output in {}, differences in {}",
            golden.display(),
            diffs.len(),
            diffs[0],
            kept.display(),
            report.display()
        );
    }
}

/// Today's provenance for a profile like `p`: the same subcommand, material
/// and seed, with a tiny photon count (the settings, not the numbers, are
/// compared).
fn fresh_source(p: &Value, dir: &Path) -> Value {
    let material = p["material"]["name"].as_str().unwrap();
    let out = dir.join(format!("{material}.json"));
    let src = &p["source"];
    let o = match src["kind"].as_str().unwrap() {
        "monte-carlo" => {
            let seed = src["seed"].as_u64().unwrap().to_string();
            common::run(&[
                "simulate",
                "--material",
                material,
                "--photons",
                "2000",
                "--seed",
                &seed,
                "--out",
                common::p(&out),
            ])
        }
        "analytic" => common::run(&[
            "profile",
            "--material",
            material,
            "--model",
            src["model"].as_str().unwrap(),
            "--out",
            common::p(&out),
        ]),
        k => panic!("profiles/reference/{material}.json: unknown source kind {k}"),
    };
    common::assert_ok(&o, &["reference profile provenance"]);
    common::read_json(&out)["source"].clone()
}

#[test]
fn reference_profiles_record_todays_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let mut checked = 0;
    let mut stale = Vec::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("profiles/reference"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for f in files {
        let p = common::read_json(&f);
        let mut fresh = fresh_source(&p, dir.path());
        // The photon count is the one thing chosen differently here.
        if fresh["kind"] == "monte-carlo" {
            fresh["photons"] = p["source"]["photons"].clone();
            fresh["params"]["budget"]["photons"] =
                p["source"]["params"]["budget"]["photons"].clone();
        }
        let mut diffs = Vec::new();
        exact_diffs("source", &p["source"], &fresh, &[], &mut diffs);
        checked += 1;
        if !diffs.is_empty() {
            stale.push(format!("{}:\n    {}", f.display(), diffs.join("\n    ")));
        }
    }
    assert_eq!(checked, 5, "the five materials of Freude 2014, table 6.3");
    assert!(
        stale.is_empty(),
        "reference profiles made by another simulator than today's (regenerate them and the \
         kernels with scripts/regen-kernels):\n{}",
        stale.join("\n")
    );
}
