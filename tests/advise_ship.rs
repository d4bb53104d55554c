//! What the advice predicts is what a user measures: for every kernel
//! family advise can choose, the kernel it writes, run by `apply` with no
//! flag beyond the scale and measured by `diff` against the exact image
//! `compare` and `advise` score against (`apply --reference
//! --reference-sampling centre`), gives the relative RMS advice.json
//! predicts on a signal it scored; a disk kernel's other start frames
//! within the frame noise the advice states.

use serde_json::Value;
use std::path::{Path, PathBuf};

mod common;
use common::{ok_both as ok, p as s, read_json as read};

/// The families advise chooses from by default
/// (`ssskit::report::eval::advise::ADVISED_FAMILIES`), each alone, with the budget
/// it needs: a sum of Gaussians has two terms at least (advise leaves the
/// single Gaussian out), four passes.
const FAMILIES: [(&str, &str); 6] = [
    ("svd", "2"),
    ("preintegrate", "2"),
    ("guided", "2"),
    ("manual", "2"),
    ("gaussians", "4"),
    ("disk", "2"),
];

/// Scale and signal side of the runs: skin1's kernel spans about a
/// hundred pixels, the signals are small enough to keep each run short.
const MM: &str = "0.1";
const SIZE: usize = 48;

/// `apply`'s default CPU precision sums the passes in f32: each output
/// pixel is within about taps x 2^-24 of the peak of the f64 sum advise
/// predicts from (`apply --precision`'s help), so a relative RMS moves by
/// at most that much of the peak: 65 taps (the widest advise searches:
/// 33 taps, full factors up to 65 pixels) x 6e-8, rounded up. A disk
/// kernel runs in f64 and meets it with room.
const F32_SWEEP: f64 = 1e-5;

/// Standard deviations of a disk kernel's frame noise (its `error_sd`,
/// the spread over the 4 accumulations advise measured) an accumulation
/// that starts on another frame may lie from the prediction: 4, as the
/// Monte Carlo tests' 4 sigma.
const FRAME_SIGMAS: f64 = 4.0;

/// `signal` as advise makes its test image `name` (a checker's cells in
/// pixels become --checker-mm at the scale).
fn signal(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(format!("{name}.exr"));
    let size = format!("{SIZE}x{SIZE}");
    let mut args = vec!["signal"];
    let cell;
    match name
        .strip_prefix("checker")
        .and_then(|c| c.strip_suffix("px"))
    {
        Some(px) => {
            cell = format!(
                "{}",
                px.parse::<f64>().unwrap() * MM.parse::<f64>().unwrap()
            );
            args.extend(["checker", "--checker-mm", &cell]);
        }
        None => args.push(name),
    }
    args.extend([
        "--mm-per-pixel",
        MM,
        "--image-size",
        &size,
        "--out",
        s(&path),
    ]);
    ok(&args);
    path
}

/// `apply --kernel K` with no flag beyond the scale, and `extra`.
fn apply(kernel: &Path, input: &Path, out: &Path, extra: &[&str]) -> String {
    let mut args = common::apply_args(s(kernel), s(input), s(out), MM, &[]);
    args.extend(extra);
    ok(&args).1
}

/// For each family alone: advise writes its kernel; on the worst signal
/// and on shapes, `apply` + `diff` of that file give advice.json's
/// predicted relative RMS in every channel (a disk kernel its recorded
/// frames, said on stderr), and the worst case advice.json names is its
/// row's predicted figure.
#[test]
fn every_family_measures_what_the_advice_predicts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let profile = common::pbd_profile(d, "skin1");
    let size = SIZE.to_string();
    for (family, passes) in FAMILIES {
        let kernel = d.join(format!("{family}.json"));
        #[rustfmt::skip] // one line a part: the command reads as typed
        let extra = ["--signal-size", &size, "--models", family, "--max-passes", passes, "--json", "--out", s(&kernel)];
        let (out, _) = ok(&common::args::advise_profile(s(&profile), MM, &extra));
        let a: Value = serde_json::from_str(&out).unwrap();
        let worst = a["worst_case"]["signal"].as_str().unwrap().to_string();
        let largest = |v: &Value| -> f64 {
            (0..3)
                .map(|c| v["rel_rms"][c].as_f64().unwrap())
                .fold(0.0, f64::max)
        };
        assert_eq!(
            a["worst_case"]["rel_rms"].as_f64().unwrap(),
            largest(&a["predicted"]["signals"][&worst]),
            "{family}: the worst case is its row's figure: {a}"
        );
        for name in [worst.as_str(), "shapes"] {
            let input = signal(d, name);
            let exact = d.join(format!("exact-{name}.exr"));
            common::centre_reference(&profile, &input, MM, &exact);
            let blurred = d.join(format!("{family}-{name}.exr"));
            let err = apply(&kernel, &input, &blurred, &[]);
            let measured = common::diff_channels(&exact, &blurred);
            let predicted = &a["predicted"]["signals"][name]["rel_rms"];
            for (c, m) in measured.iter().enumerate() {
                let p = predicted[c].as_f64().unwrap();
                assert!(
                    (m - p).abs() <= F32_SWEEP,
                    "{family} ({}) on {name}, channel {c}: predicted {p}, apply + diff {m}",
                    a["label"]
                );
            }
            if family != "disk" {
                continue;
            }
            assert!(
                err.contains("frames: 8 from frame seed 0: the plain mean of 8 frames"),
                "{err}"
            );
            // Another start: within the frame noise the advice states.
            let row = &a["disk"]["signals"][name];
            let c = ["r", "g", "b"]
                .iter()
                .position(|x| row["channel"] == *x)
                .unwrap();
            let sd = row["error_sd"].as_f64().unwrap();
            assert!(sd > 0.0, "{row}");
            let later = d.join(format!("disk-{name}-later.exr"));
            apply(&kernel, &input, &later, &["--frame-seed", "1000"]);
            let m = common::diff_channels(&exact, &later)[c];
            let p = row["error"].as_f64().unwrap();
            assert!(
                (m - p).abs() <= FRAME_SIGMAS * sd,
                "disk on {name}: predicted {p} +- {sd}, from frame 1000 {m}"
            );
        }
    }
}

/// A default `kernels` run ships what its advice.json predicts: the
/// summary's worst case is the row of the signal it names, and
/// recommended.json, applied with no flag beyond the scale, measures the
/// predicted relative RMS on that signal. `--frames` and `--models` choose
/// as advise does: the disk kernel scored on one frame records one frame.
#[test]
fn kernels_ships_what_it_predicts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("k");
    let size = SIZE.to_string();
    let stdout = common::skin1_kernels(&out, &size, &["--no-plots"]).0;
    let a = read(&out.join("advice.json"));
    let worst = a["worst_case"]["signal"].as_str().unwrap();
    // "  worst case 3.47% +- 0.01% on checker3px, ..." and the row
    // "  checker3px  3.47% relative RMS (largest channel), ...".
    let figure = |line: &str, after: &str| -> String {
        line.split_once(after).unwrap().1.trim_start()[..]
            .split('%')
            .next()
            .unwrap()
            .to_string()
    };
    let worst_line = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("worst case "))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(worst_line.contains(&format!("on {worst},")), "{worst_line}");
    let row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{worst} ")) && l.contains("relative RMS"))
        .unwrap_or_else(|| panic!("no row {worst}: {stdout}"));
    assert_eq!(
        figure(worst_line, "worst case"),
        figure(row, worst),
        "{worst_line}\n{row}"
    );
    let profile = out.join("profile.json");
    let input = signal(d, worst);
    let exact = d.join("exact.exr");
    common::centre_reference(&profile, &input, MM, &exact);
    let blurred = d.join("shipped.exr");
    apply(&out.join("recommended.json"), &input, &blurred, &[]);
    let measured = common::diff_channels(&exact, &blurred);
    for (c, m) in measured.iter().enumerate() {
        let p = a["predicted"]["signals"][worst]["rel_rms"][c]
            .as_f64()
            .unwrap();
        assert!((m - p).abs() <= F32_SWEEP, "{worst} {c}: {p} vs {m}");
    }

    let one = d.join("one");
    common::skin1_kernels(
        &one,
        "32",
        &["--no-plots", "--models", "disk", "--frames", "1"],
    );
    let a = read(&one.join("advice.json"));
    assert_eq!(
        (a["model"].as_str(), a["frames"].as_u64()),
        (Some("disk"), Some(1))
    );
    let rec = read(&one.join("recommended.json"));
    assert_eq!(rec["accumulation"]["frames"], 1, "{}", rec["accumulation"]);
    assert!(a["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .all(|c| c["model"] == "disk"));
}
