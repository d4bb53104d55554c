//! The third campaign's silent wrong answers on the real binary: a result
//! computed from too little to mean anything is refused or says so in its
//! output (standard output and the files it writes); work the caps would
//! stop is refused after one round; numbers print with bounded digits.

mod common;

use common::{assert_fails, assert_ok, p, read_json, run_in};

const REPO: &str = env!("CARGO_MANIFEST_DIR");

/// A small scene (16 x 12 pixels) that renders in a fraction of a second.
const SPHERE: &str = "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 60]\n\
look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 30\nsize = [16, 12]\n[[light]]\ntype = \
\"directional\"\ntoward = [0.6, 0, 0.8]\nirradiance = 2\n[[object]]\nshape = \"sphere\"\n\
center = [0, 0, 0]\nradius = 10\nmaterial = \"skin1\"\neta = 1.0\n";

/// The longest run of digits a printed number may hold: an f64 has 17
/// significant digits, so a longer run is fixed-point padding of a huge or
/// tiny value (1e300 printed as 301 digits).
const MAX_DIGIT_RUN: usize = 17;

fn longest_digit_run(text: &str) -> usize {
    text.split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0)
}

fn reference(name: &str) -> String {
    format!("{REPO}/profiles/reference/{name}.json")
}

#[test]
fn a_kernel_grid_that_does_not_resolve_the_profile_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let prof = reference("apple");
    for (flag, value) in [("--extent", "18446744073709551616"), ("--grid-size", "1")] {
        let args = common::fit_args(&prof, "svd", "k.json", &[flag, value]);
        let e = assert_fails(&run_in(d.path(), &args), &args, &[flag, "does not resolve"]);
        assert!(longest_digit_run(&e) <= MAX_DIGIT_RUN, "{e}");
        assert!(!d.path().join("k.json").exists());
    }
    // Three cells over the default extent still resolve it.
    let args = common::fit_args(&prof, "svd", "k.json", &["--grid-size", "3"]);
    assert_ok(&run_in(d.path(), &args), &args);
}

#[test]
fn engine_numbers_of_a_degenerate_profile_have_few_digits() {
    let d = tempfile::tempdir().unwrap();
    // skin1 with every reflectance scaled by 1e-300: the fitted engine
    // parameters are clamped, so its errors are about 1e300.
    let mut prof = read_json(std::path::Path::new(&reference("skin1")));
    for key in ["rd", "rd_stderr", "total_rd", "total_rd_stderr"] {
        let scale = |v: &mut serde_json::Value| {
            if let Some(x) = v.as_f64() {
                *v = serde_json::json!(x * 1e-300);
            }
        };
        match prof.get_mut(key) {
            Some(serde_json::Value::Array(a)) => {
                for v in a {
                    match v {
                        serde_json::Value::Array(row) => row.iter_mut().for_each(scale),
                        v => scale(v),
                    }
                }
            }
            _ => continue,
        }
    }
    let file = d.path().join("tiny.json");
    std::fs::write(&file, prof.to_string()).unwrap();
    let args = ["engine", "--engine", "unreal", "--profile", p(&file)];
    let (out, err) = assert_ok(&run_in(d.path(), &args), &args);
    assert!(out.contains("e30"), "no huge value to print: {out}");
    for line in out.lines().chain(err.lines()) {
        assert!(longest_digit_run(line) <= MAX_DIGIT_RUN, "{line}");
    }
}

#[test]
fn a_scene_from_one_photon_says_its_profile_is_noise() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("s.toml"), SPHERE).unwrap();
    let args = common::scene_args(&["--spp", "2", "--profile-photons", "1"]);
    let (out, _) = assert_ok(&run_in(d.path(), &args), &args);
    assert!(
        out.contains("warning: profile of skin1") && out.contains("no estimate of the noise"),
        "{out}"
    );
    let record = read_json(&d.path().join("s.json"));
    let warnings = record["profiles"][0]["extra"]["warnings"].to_string();
    assert!(warnings.contains("no estimate of the noise"), "{warnings}");
}

#[test]
fn a_comparison_against_one_photon_says_its_reference_is_noise() {
    let d = tempfile::tempdir().unwrap();
    let args = [
        "profiles",
        "compare",
        "--materials",
        "skin1",
        "--photons",
        "1",
        "--out-dir",
        "c",
    ];
    let (out, _) = assert_ok(&run_in(d.path(), &args), &args);
    assert!(
        out.contains("warning: Monte Carlo reference of skin1") && out.contains("no estimate"),
        "{out}"
    );
    let md = std::fs::read_to_string(d.path().join("c/compare.md")).unwrap();
    assert!(
        md.contains("## Warnings") && md.contains("no estimate"),
        "{md}"
    );
}

#[test]
fn a_render_target_beyond_the_work_cap_is_refused_after_one_round() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("s.toml"), SPHERE).unwrap();
    let args = common::scene_args(&[
        "--render-error",
        "1e-9",
        "--max-spp",
        "1e12",
        "--profile-photons",
        "1000",
    ]);
    assert_fails(
        &run_in(d.path(), &args),
        &args,
        &["--render-error", "work cap", "max_spp"],
    );
    assert!(!d.path().join("s.exr").exists());
}
