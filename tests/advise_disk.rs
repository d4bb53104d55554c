//! `ssskit advise` across both kernel families: disk kernels
//! (`kernel::disk`, one pass of N samples) beside separable ones at equal
//! samples per pixel, scored on their bias and their noise after
//! `--frames` frames, run as a user runs them.

use serde_json::Value;

mod common;
use common::{ok_both as ok, p as s, read_json as read};

/// The separable families alone (advise's default less `disk`).
const SEPARABLE: &str = "svd,preintegrate,guided,manual,gaussians";

/// The advice's target (its default, 5%).
const TARGET: f64 = 0.05;

/// `advise` on the committed skin1 profile at 0.1 mm per pixel, 64-pixel
/// signals, JSON.
fn advise(extra: &[&str]) -> (Value, String) {
    common::advise_skin1_at("0.1", extra)
}

/// The disk row among the answer's candidates.
fn disk_row(a: &Value) -> &Value {
    a["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["model"] == "disk")
        .unwrap_or_else(|| panic!("no disk row: {a}"))
}

/// At 32 samples per pixel (`--max-samples 32`, the issue's budget) both
/// families are searched and a disk row wins: no separable kernel of 32
/// samples meets 5% on skin1 at 0.1 mm per pixel (the two-pass record of
/// docs/kernels.md misses at 8%), the disk meets it after 8 frames. Its
/// score on each signal is the error of its first accumulation of 8
/// frames in the worst channel, the row's `error`, beside that channel's
/// bias and noise (8 frames averaging noise away). The kernel written is
/// the disk chosen, records the 8 frames, and
/// through `apply --frames 8` (other rotations than advise measured) on
/// signals advise never saw it meets the target against the exact
/// convolution.
#[test]
fn advise_chooses_a_disk_kernel_that_holds_through_apply() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let kernel = d.join("k.json");
    let (a, err) = advise(&["--max-samples", "32", "--out", s(&kernel)]);
    assert_eq!(a["model"], "disk", "{err}");
    assert_eq!(a["passes"], 1, "{a}");
    assert_eq!(a["frames"], 8, "{a}");
    assert_eq!(a["meets_target"], true, "{err}");
    let n = a["cost_samples_per_pixel"].as_u64().unwrap();
    assert!(n <= 32, "{a}");
    assert!(
        a["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c["model"] != "disk"),
        "both families in the table: {a}"
    );
    for needle in ["disk, ", "noise", "after 8 frames"] {
        assert!(err.contains(needle), "{needle}: {err}");
    }
    let row = disk_row(&a);
    for (sig, d) in row["disk"]["signals"].as_object().unwrap() {
        let (n1, n8) = (
            d["noise"].as_f64().unwrap(),
            d["noise_after"].as_f64().unwrap(),
        );
        let score = row["per_signal"][sig].as_f64().unwrap();
        assert_eq!(d["error"].as_f64(), Some(score), "{sig}: {d}");
        assert!(
            ["r", "g", "b"].contains(&d["channel"].as_str().unwrap()),
            "{d}"
        );
        assert!(n8 < n1, "8 frames average noise away: {sig}: {d}");
        // The +- holds the frame noise: at least the spread over starts.
        let sigma = row["per_signal_sigma"][sig].as_f64().unwrap();
        assert!(
            sigma >= d["error_sd"].as_f64().unwrap(),
            "{sig}: {d} {sigma}"
        );
    }
    let k = read(&kernel);
    assert_eq!(k["schema"], "ssskit.disk/1", "{k}");
    assert_eq!(k["accumulation"]["frames"], 8, "{k}");
    assert_eq!(k["samples"].as_array().unwrap().len() as u64, n);

    let profile = common::committed_profile("skin1");
    let held_out: [(&str, Vec<&str>); 3] = [
        ("shapes", vec!["shapes"]),
        ("checker5px", vec!["checker", "--checker-mm", "0.5"]),
        ("checker7px", vec!["checker", "--checker-mm", "0.7"]),
    ];
    for (name, signal) in held_out {
        let input = d.join(format!("{name}.exr"));
        let mut args = vec!["signal"];
        args.extend(signal);
        args.extend([
            "--mm-per-pixel",
            "0.1",
            "--image-size",
            "96x96",
            "--out",
            s(&input),
        ]);
        ok(&args);
        let exact = d.join(format!("exact-{name}.exr"));
        common::centre_reference(&profile, &input, "0.1", &exact);
        let blurred = d.join(format!("disk-{name}.exr"));
        ok(&common::apply_args(
            s(&kernel),
            s(&input),
            s(&blurred),
            "0.1",
            &["--frames", "8", "--frame-seed", "1000", "--backend", "cpu"],
        ));
        let e = common::diff_rel(&exact, &blurred);
        assert!(e <= TARGET, "{name}: {e} > {TARGET}: {a}");
    }
}

/// `--frames` is the frames the noise is scored after: with one frame the
/// noise after K frames is the one-frame noise (the same measurement), and
/// each disk row scores worse than after 8 frames; out of range it is
/// refused before any work.
#[test]
fn advise_scores_disk_noise_after_the_frames_given() {
    let (one, _) = advise(&["--models", "disk", "--max-samples", "8", "--frames", "1"]);
    let (eight, _) = advise(&["--models", "disk", "--max-samples", "8"]);
    let (r1, r8) = (disk_row(&one), disk_row(&eight));
    assert_eq!(r1["taps"], r8["taps"], "{one}\n{eight}");
    for (sig, d) in r1["disk"]["signals"].as_object().unwrap() {
        assert_eq!(d["noise"], d["noise_after"], "{sig}: {d}");
        let s1 = r1["per_signal"][sig].as_f64().unwrap();
        let s8 = r8["per_signal"][sig].as_f64().unwrap();
        assert!(s1 > s8, "{sig}: {s1} after 1 frame, {s8} after 8");
    }
    for bad in ["0", "65"] {
        common::fails_with(
            &[
                "advise",
                "--material",
                "skin1",
                "--mm-per-pixel",
                "0.1",
                "--frames",
                bad,
            ],
            &["--frames", bad],
        );
    }
}

/// Without the disk family the search is the separable one: the same
/// answer as before the disk rows existed (no candidate of model disk).
#[test]
fn advise_without_disk_searches_separable_kernels_only() {
    let (a, _) = advise(&["--models", SEPARABLE, "--max-samples", "32"]);
    assert_ne!(a["model"], "disk", "{a}");
    assert!(
        a["candidates"]
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c["model"] != "disk" && c.get("disk").is_none()),
        "{a}"
    );
}
