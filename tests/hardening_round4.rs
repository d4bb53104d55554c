//! The fourth campaign's classes, on the real binary: what a kernel file
//! carries is held to its physics where the file is read (the reader the
//! CLI and Python share), budgets and flags that said nothing, messages
//! that name the real problem, inputs that are not files, the disk pass's
//! cap, and folder outputs that make nothing before they are committed.
//! The signal race of the folder swap is tested in the library
//! (`io::staged_dir` race tests), where the dangerous moment can be held.

mod common;

use common::args::words;
use common::{fails_with_in, ok_in, p, read_json, run_in};
use serde_json::{json, Value};
use ssskit::filter::image::write_exr;
use ssskit::filter::Image;
use std::path::{Path, PathBuf};

const REPO: &str = env!("CARGO_MANIFEST_DIR");

/// Fits a disk kernel of `samples` to the committed skin1 profile into
/// `d/d.json`.
fn disk_kernel_in(d: &Path, samples: &str) {
    let profile = Path::new(REPO).join("profiles/reference/skin1.json");
    let extra = ["--samples", samples, "--quiet"];
    ok_in(d, &common::fit_args(p(&profile), "disk", "d.json", &extra));
}

fn kernel_file(name: &str) -> PathBuf {
    Path::new(REPO).join("kernels").join(name)
}

/// The committed skin1 pre-integrated kernel, the file the cases edit.
fn preintegrate() -> Value {
    read_json(&kernel_file("skin1-preintegrate.json"))
}

/// `value` edited by `edit`, written to `dir/name`.
fn edited(value: &Value, dir: &Path, name: &str, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let mut v = value.clone();
    edit(&mut v);
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    path
}

/// Angular tables as the main job writes them: E(1) = 1, an entry factor
/// rising toward grazing, a Lambertian exit (factor 1, mean 1).
fn angular() -> Value {
    let mu: Vec<f64> = (0..9).map(|k| k as f64 / 8.0).collect();
    let entry: Vec<[f64; 3]> = mu.iter().map(|m| [1.0 + 0.3 * (1.0 - m); 3]).collect();
    json!({
        "mu": mu,
        "entry": entry,
        "entry_stderr": vec![[0.0; 3]; 9],
        "exit": vec![[1.0; 3]; 9],
        "exit_stderr": vec![[0.0; 3]; 9],
        "photons": 10000,
    })
}

/// An image of `w` x `h` pixels whose every pixel is `rgb`.
fn constant(path: &Path, w: usize, h: usize, rgb: [f64; 3]) {
    let mut img = Image::new(w, h);
    for (plane, v) in img.rgb.iter_mut().zip(rgb) {
        plane.iter_mut().for_each(|x| *x = v);
    }
    write_exr(path, &img, None).unwrap();
}

/// Reads `k` the way `fit --kernel` does (the library reader) and
/// expects a refusal with `needles`.
fn refused(dir: &Path, k: &Path, needles: &[&str]) {
    fails_with_in(dir, &["fit", "--kernel", p(k), "--emit", "hlsl"], needles);
}

/// Class 3: a kernel's angular tables and weights out of their physical
/// range are refused where the file is read, naming the field; the same
/// file within it is read.
#[test]
fn kernel_contents_are_held_to_their_physics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = preintegrate();
    let good = edited(&base, d, "good.json", |v| v["angular"] = angular());
    ok_in(d, &["fit", "--kernel", p(&good), "--emit", "hlsl"]);
    // An entry factor of 1e30: with total_rd 0.43, 4e29 of the light back.
    let k = edited(&base, d, "e30.json", |v| {
        v["angular"] = angular();
        v["angular"]["entry"][0][0] = json!(1e30);
    });
    refused(d, &k, &["e30.json", "angular.entry[0][0]", "at most 1"]);
    // An exit factor of 1e-300 everywhere: a black image.
    let k = edited(&base, d, "x300.json", |v| {
        v["angular"] = angular();
        v["angular"]["exit"] = json!(vec![[1e-300; 3]; 9]);
    });
    refused(d, &k, &["angular.exit", "averages", "1 by definition"]);
    // E(N.L = 1) is 1 by definition.
    let k = edited(&base, d, "e1.json", |v| {
        v["angular"] = angular();
        v["angular"]["entry"][8][1] = json!(5.0);
    });
    refused(d, &k, &["angular.entry[8][1] = 5", "1 by definition"]);
    // Tap weights scaled by 1.5 after the file was written: usage says
    // otherwise.
    let k = edited(&base, d, "taps15.json", |v| {
        for w in v["taps"]["passes"][0]["weights"].as_array_mut().unwrap() {
            for x in w.as_array_mut().unwrap() {
                *x = json!(x.as_f64().unwrap() * 1.5);
            }
        }
    });
    refused(d, &k, &["usage.pass_weight_sums[0][0]", "changed after"]);
    // total_rd against the profile the kernel came from.
    let k = edited(&base, d, "rd.json", |v| v["total_rd"][0] = json!(0.9));
    refused(d, &k, &["total_rd", "profile.total_rd"]);
}

/// Class 3 for disk kernels: weights that do not sum to 1, a raw weight
/// sum the radii cannot give, a wrong schema named as such.
#[test]
fn disk_kernel_sums_are_cross_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    disk_kernel_in(d, "8");
    let base = read_json(&d.join("d.json"));
    let k = edited(&base, d, "w15.json", |v| {
        for s in v["samples"].as_array_mut().unwrap() {
            let w = s["weight"][2].as_f64().unwrap();
            s["weight"][2] = json!(w * 1.5);
        }
    });
    refused(d, &k, &["w15.json", "channel b sums to 1.5", "sum to 1"]);
    let k = edited(&base, d, "raw.json", |v| {
        v["raw_weight_sum"] = json!([1.3, 1.2, 1.1]);
    });
    refused(d, &k, &["raw_weight_sum", "widest channel's is 1"]);
    let k = edited(&base, d, "rd.json", |v| v["total_rd"][1] = json!(0.99));
    refused(d, &k, &["profile.total_rd"]);
    let k = edited(&base, d, "e30.json", |v| {
        v["angular"] = angular();
        v["angular"]["entry"][3][2] = json!(1e30);
    });
    refused(d, &k, &["angular.entry[3][2]"]);
    // A disk kernel of another schema: named by its schema in `apply`
    // (which tells the kinds apart by it), not by a field it lacks.
    let k = edited(&base, d, "v2.json", |v| {
        v["schema"] = json!("ssskit.disk/2")
    });
    constant(&d.join("in.exr"), 8, 8, [1.0; 3]);
    let args = common::apply_args(p(&k), "in.exr", "o.exr", "0.1", &[]);
    let o = run_in(d, &args);
    let e = common::assert_fails(&o, &args, &["v2.json", "ssskit.disk/2", "ssskit.disk/1"]);
    assert!(!e.contains("missing field"), "{e}");
}

/// Class 6: budgets mean what they say, flags of one kind of kernel are
/// refused for the other, names with invisible format characters are
/// refused.
#[test]
fn budgets_and_flags_say_what_they_mean() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let advise = |extra: &[&str]| {
        let mut a = vec![
            "advise",
            "--material",
            "skin1",
            "--profile-model",
            "dipole",
            "--mm-per-pixel",
            "0.1",
            "--signal-size",
            "32",
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    // One pass: a disk kernel, which the advice then recommends.
    let a = advise(&["--max-passes", "1", "--json"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    let j: Value = serde_json::from_str(&ok_in(d, &a)).unwrap();
    assert_eq!(j["budget"]["max_passes"], 1, "{}", j["budget"]);
    for flag in ["--max-passes", "--max-samples", "--max-taps"] {
        let a = advise(&[flag, "0"]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        fails_with_in(d, &a, &[flag, "0 allows no kernel", "none for no limit"]);
    }
    let profile = Path::new(REPO).join("profiles/reference/skin1.json");
    for (flag, value) in [("--samples", "0"), ("--radii", "mean")] {
        let args = common::fit_args(p(&profile), "svd", "k.json", &[flag, value]);
        fails_with_in(d, &args, &[flag, "disk kernels", "--model svd"]);
    }
    assert!(!d.join("k.json").exists());
    for (name, code) in [
        ("a\u{061c}b", "U+061C"),
        ("soft\u{00ad}", "U+00AD"),
        ("w\u{2060}j", "U+2060"),
        ("m\u{180e}", "U+180E"),
        ("x\u{fff9}", "U+FFF9"),
        ("t\u{e0041}", "U+E0041"),
    ] {
        let toml = format!(
            "name = \"{name}\"\nunit = \"mm\"\nsigma_a = 0.1\nsigma_s = 1.0\ng = 0.0\neta = 1.3\n"
        );
        std::fs::write(d.join("m.toml"), toml).unwrap();
        fails_with_in(
            d,
            &["materials", "m.toml"],
            &["m.toml", code, "category Cf"],
        );
    }
}

/// N.L out of [-1, 1] is refused naming the N.L file, as is a NaN in it
/// (once blamed on the normals); a light direction whose squared length
/// overflows is taken.
#[test]
fn n_dot_l_and_the_light_are_checked_as_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let k = edited(&preintegrate(), d, "k.json", |v| v["angular"] = angular());
    constant(&d.join("in.exr"), 8, 8, [1.0; 3]);
    constant(&d.join("normals.exr"), 8, 8, [0.6, 0.0, 0.8]);
    let apply = |extra: &[&str]| {
        let mut a = vec![
            "apply",
            "--kernel",
            p(&k),
            "--input",
            "in.exr",
            "--normals",
            "normals.exr",
            "--mm-per-pixel",
            "0.1",
            "--backend",
            "cpu",
            "--out",
            "o.exr",
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    for (name, v, needle) in [
        ("two.exr", 2.0, "a cosine lies in [-1, 1]"),
        ("minus2.exr", -2.0, "a cosine lies in [-1, 1]"),
        ("nan.exr", f64::NAN, "must be finite"),
    ] {
        constant(&d.join(name), 8, 8, [v; 3]);
        let a = apply(&["--n-dot-l", name]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = run_in(d, &a);
        let e = common::assert_fails(&o, &a, &[name, "N.L at pixel (0, 0)", needle]);
        assert!(!e.contains("normals.exr"), "blames the normals: {e}");
    }
    // 1e200 along x is the direction of 1 along x: the same image (the
    // normal leans toward x, so N.L is 0.6, not the 0 of a lost
    // direction).
    let image = |toward: &str| {
        let a = apply(&["--light-toward", toward]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        ok_in(d, &a);
        std::fs::read(d.join("o.exr")).unwrap()
    };
    let (far, near, along) = (image("1e200,0,0"), image("1,0,0"), image("0,1,0"));
    assert!(far == near, "1e200,0,0 is not the direction of 1,0,0");
    assert!(near != along, "the light's direction changes nothing");
    let a = apply(&["--light-toward", "0,0,0"]);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    fails_with_in(d, &a, &["--light-toward", "all three are 0"]);
}

/// Class 8: each message names the real problem.
#[test]
fn messages_name_the_real_problem() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A target of 1 is a fraction of 100%, said with its range and unit.
    fails_with_in(
        d,
        &words("advise --material skin1 --mm-per-pixel 0.1 --image-error 1"),
        &["--image-error", "between 0 and 1", "100%", "0.01"],
    );
    // A row of four values where [r, g, b] takes three.
    let base = preintegrate();
    let k = edited(&base, d, "row4.json", |v| {
        v["taps"]["passes"][0]["weights"][0] = json!([0.1, 0.1, 0.1, 0.1]);
    });
    let o = run_in(d, &["fit", "--kernel", p(&k), "--emit", "hlsl"]);
    let e = common::assert_fails(&o, &["fit"], &["row4.json", "more entries than", "takes 3"]);
    assert!(!e.contains("trailing characters"), "{e}");
    // A negative count is a bad value of its flag, not an unknown flag.
    let profile = Path::new(REPO).join("profiles/reference/skin1.json");
    fails_with_in(
        d,
        &common::fit_args(p(&profile), "disk", "x.json", &["--samples", "-1"]),
        &["--samples: invalid value -1", "whole number"],
    );
    // A material that scatters over kilometres: the disk fit says so and
    // what to check, and the measure of a disk kernel's error names the
    // flag and the scale that fits (once "mm_per_pixel" and 18 spaces).
    std::fs::write(
        d.join("far.toml"),
        "unit = \"mm\"\nsigma_a = 1e-8\nsigma_s = 1e-6\ng = 0.0\neta = 1.3\n",
    )
    .unwrap();
    std::fs::write(
        d.join("wide.toml"),
        "unit = \"mm\"\nsigma_a = 1e-5\nsigma_s = 1e-3\ng = 0.0\neta = 1.3\n",
    )
    .unwrap();
    for m in ["far", "wide"] {
        ok_in(
            d,
            &common::profile_args(&format!("{m}.toml"), "dipole", &format!("{m}.json"), &[]),
        );
    }
    fails_with_in(
        d,
        &common::fit_args("far.json", "disk", "x.json", &[]),
        &[
            "samples reach",
            "a kilometre",
            "check its coefficients and their unit",
        ],
    );
    let o = run_in(
        d,
        &["engine", "--profile", "wide.json", "--engine", "unreal"],
    );
    let e = common::assert_fails(
        &o,
        &["engine"],
        &[
            "--mm-per-pixel: invalid value 0.1",
            "use a scale of at least",
        ],
    );
    let line = e.lines().find(|l| l.starts_with("error:")).unwrap();
    assert!(
        !line.contains("  ") && !line.contains("mm_per_pixel"),
        "{line}"
    );
    // A disk kernel given --taps-only: the flag given is named.
    disk_kernel_in(d, "8");
    constant(&d.join("in.exr"), 8, 8, [1.0; 3]);
    fails_with_in(
        d,
        &common::apply_args("d.json", "in.exr", "o.exr", "0.1", &["--taps-only"]),
        &["--taps-only applies to separable kernels"],
    );
    fails_with_in(
        d,
        &[
            "apply",
            "--reference",
            p(&profile),
            "--input",
            "in.exr",
            "--mm-per-pixel",
            "0.1",
            "--jitter",
            "--out",
            "o.exr",
        ],
        &["--jitter applies to a kernel"],
    );
}

/// Inputs that are not regular files are refused by what they are: a
/// pipe nobody writes to (once read as empty), a device, a folder.
#[cfg(unix)]
#[test]
fn inputs_that_are_not_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for name in ["p.json", "p.toml", "p.exr"] {
        let status = std::process::Command::new("mkfifo")
            .arg(d.join(name))
            .status()
            .unwrap();
        assert!(status.success());
    }
    let started = std::time::Instant::now();
    fails_with_in(
        d,
        &common::fit_args("p.json", "svd", "k.json", &[]),
        &["p.json", "pipe that nothing writes to"],
    );
    fails_with_in(
        d,
        &["materials", "p.toml"],
        &["p.toml", "pipe that nothing writes to"],
    );
    constant(&d.join("in.exr"), 8, 8, [1.0; 3]);
    let k = kernel_file("skin1-preintegrate.json");
    for (flag, needle) in [("--specular", "read twice"), ("--depth", "read twice")] {
        fails_with_in(
            d,
            &[
                "apply",
                "--kernel",
                p(&k),
                "--input",
                "in.exr",
                "--mm-per-pixel",
                "0.1",
                flag,
                "p.exr",
                "--out",
                "o.exr",
            ],
            &["p.exr", needle],
        );
    }
    std::os::unix::fs::symlink("/dev/null", d.join("null.exr")).unwrap();
    fails_with_in(
        d,
        &["diff", "in.exr", "null.exr"],
        &["null.exr", "is a device"],
    );
    std::fs::create_dir(d.join("f.json")).unwrap();
    fails_with_in(
        d,
        &common::fit_args("f.json", "svd", "k.json", &[]),
        &["f.json", "is a folder"],
    );
    assert!(started.elapsed() < std::time::Duration::from_secs(30));
}

/// Class 5: a disk pass beyond the CPU's cap is refused at once, saying
/// how many frames fit (4096 frames of a 32-sample kernel on 512 x 512
/// once ran for minutes without a word).
#[test]
fn a_long_disk_pass_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    disk_kernel_in(d, "32");
    constant(&d.join("in.exr"), 512, 512, [1.0; 3]);
    let started = std::time::Instant::now();
    fails_with_in(
        d,
        &common::apply_args(
            "d.json",
            "in.exr",
            "o.exr",
            "0.1",
            &["--backend", "cpu", "--frames", "4096"],
        ),
        &["--frames: invalid value 4096", "at most 238 frames fit"],
    );
    assert!(started.elapsed() < std::time::Duration::from_secs(20));
    assert!(!d.join("o.exr").exists());
}

/// Class 1 (the part a failing run shows): an output folder whose parents
/// are missing makes none of them when the run fails on its input.
#[test]
fn a_failed_run_makes_no_parent_folders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("bad.json"), "{}").unwrap();
    fails_with_in(
        d,
        &[
            "engine",
            "--profile",
            "bad.json",
            "--engine",
            "godot",
            "--out-dir",
            "new/deeper/out",
        ],
        &["bad.json"],
    );
    assert!(
        !d.join("new").exists(),
        "parent folders made by a failed run"
    );
    let names: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("bad.json")]);
}

/// No loader noise on a machine without a display
/// session (Mesa's device-select layer connected to Wayland for nothing
/// and its client library printed "error: XDG_RUNTIME_DIR" twice).
#[test]
fn apply_prints_no_loader_noise() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    constant(&d.join("in.exr"), 8, 8, [1.0; 3]);
    let k = kernel_file("skin1-preintegrate.json");
    let o = common::bin()
        .current_dir(d)
        .env_remove("NODEVICE_SELECT")
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .args(common::apply_args(p(&k), "in.exr", "o.exr", "0.1", &[]))
        .output()
        .unwrap();
    let (_, e) = common::assert_ok(&o, &["apply"]);
    assert!(
        !e.contains("XDG_RUNTIME_DIR") && !e.lines().any(|l| l.starts_with("error")),
        "{e}"
    );
}
