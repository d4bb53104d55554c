//! Hostile and extreme inputs on the real binary, one regression per class:
//! bounded work and memory (every run under `prlimit --as` and a wall-clock
//! limit), no panic on output, nothing unreadable written, messages that
//! name the problem, no debris. Each run must end with a clear error or a
//! result ssskit reads back.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const TIME_LIMIT: Duration = Duration::from_secs(20);
const REPO: &str = env!("CARGO_MANIFEST_DIR");

mod common;

use common::args::{skin1_red_args, words};
use common::bounded::{capped, edited, run_with, MEMORY_BYTES};
use common::inputs::dipole_profile;

fn command(args: &[&str]) -> Command {
    capped(common::BIN, &[], args)
}

/// The cap is really in effect: a run blocked reading its profile from
/// standard input shows it in /proc/PID/limits once it is ssskit.
#[test]
fn every_run_is_under_the_memory_cap() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = command(&common::fit_args("/dev/stdin", "svd", "k.json", &[]))
        .current_dir(dir.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn ssskit");
    let pid = child.id();
    let bin = std::fs::canonicalize(common::BIN).unwrap();
    let start = Instant::now();
    // prlimit and sh set the limit, then exec ssskit in the same process.
    while std::fs::read_link(format!("/proc/{pid}/exe")).ok() != Some(bin.clone()) {
        assert!(start.elapsed() < TIME_LIMIT, "ssskit never started");
        std::thread::sleep(Duration::from_millis(5));
    }
    let limits = std::fs::read_to_string(format!("/proc/{pid}/limits")).unwrap();
    drop(child.stdin.take());
    let _ = wait_bounded(child, "fit from an empty standard input");
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))
        .expect("an address-space line");
    let soft: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(soft[3], MEMORY_BYTES.to_string(), "{line}");
}

/// Starts `ssskit args` in `dir`, bounded in memory, standard input closed.
fn spawn_in(dir: &Path, args: &[&str], stdout: Stdio, stderr: Stdio) -> Child {
    command(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .spawn()
        .expect("spawn ssskit")
}

/// Waits for `child` at most `TIME_LIMIT`; a run past it is killed and fails
/// the test.
fn wait_bounded(child: Child, what: &str) -> Output {
    common::bounded::wait_bounded(child, what, TIME_LIMIT)
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    let mut c = command(args);
    c.current_dir(dir).stdin(Stdio::null());
    run_with(c, &format!("ssskit {args:?}"), TIME_LIMIT)
}

fn ok_in(dir: &Path, args: &[&str]) -> String {
    common::assert_ok(&run_in(dir, args), args).0
}

/// Runs, expects exit 2 and every needle in stderr; returns stderr.
fn fails_in(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    common::assert_fails(&run_in(dir, args), args, needles)
}

fn kernel() -> String {
    format!("{REPO}/kernels/marble-svd1.json")
}

fn dirac(dir: &Path) -> PathBuf {
    let p = dir.join("d.png");
    ok_in(
        dir,
        &[
            "signal",
            "dirac",
            "--image-size",
            "128x96",
            "--out",
            "d.png",
        ],
    );
    p
}

/// `apply` of kernel `k` to the dirac `d.png` at `mm` per pixel into `o.exr`.
fn apply_dirac<'a>(k: &'a str, mm: &'a str) -> Vec<&'a str> {
    common::apply_args(k, "d.png", "o.exr", mm, &[])
}

fn temp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".ssskit-"))
        .collect()
}

// ---- 1. Caps derived from the inputs, checked before allocating ----------

#[test]
fn kernel_span_is_capped_by_the_image_on_both_backends() {
    let dir = tempfile::tempdir().unwrap();
    dirac(dir.path());
    let k = kernel();
    for mm in ["1e-9", "1e-6", "1e-4"] {
        for backend in ["cpu", "gpu"] {
            fails_in(
                dir.path(),
                &[&apply_dirac(&k, mm)[..], &["--backend", backend]].concat(),
                &["mm per pixel", "128x96", "use at least"],
            );
        }
    }
    assert!(!dir.path().join("o.exr").exists());
    // A kernel far below a pixel is the identity, not an index out of bounds.
    ok_in(
        dir.path(),
        &[&apply_dirac(&k, "1e30")[..], &["--backend", "cpu"]].concat(),
    );
    let (img, _) = ssskit::filter::image::read_image(&dir.path().join("o.exr"), None).unwrap();
    assert_eq!(img.non_finite().0, 0);
}

#[test]
fn absurd_kernel_offsets_are_refused_on_read() {
    let dir = tempfile::tempdir().unwrap();
    dirac(dir.path());
    let k = edited(&kernel(), dir.path(), "far.json", |v| {
        v["passes"][0]["offsets_mm"][0] = (-1e12).into();
    });
    for args in [vec!["fit", "--kernel", &k], apply_dirac(&k, "0.1")] {
        fails_in(
            dir.path(),
            &args,
            &["far.json", "passes[0]", "not a sampled kernel"],
        );
    }
}

#[test]
fn mci_header_counts_must_fit_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let run = |runs: &str, nr: &str, layers: &str| {
        format!(
            "1.0\n{runs}\nx.mco A\n100\n0.01 0.01\n1 {nr} 1\n{layers}\n1.0\n1.37 1 100 0.9 1E8\n1.0\n"
        )
    };
    for (name, text, needle) in [
        (
            "runs.mci",
            run("99999999999", "10", "1"),
            "number of runs is 99999999999",
        ),
        (
            "layers.mci",
            run("1", "10", "99999999999"),
            "number of layers is 99999999999",
        ),
        ("bins.mci", run("1", "99999999999", "1"), "nr = 99999999999"),
    ] {
        std::fs::write(dir.path().join(name), text).unwrap();
        fails_in(
            dir.path(),
            &["simulate", "--mci", name, "--out", "x.json"],
            &[name, needle],
        );
    }
}

#[test]
fn threads_are_capped_by_the_cores() {
    let dir = tempfile::tempdir().unwrap();
    fails_in(
        dir.path(),
        &[
            "simulate",
            "--material",
            "skin1",
            "--photons",
            "1000",
            "--threads",
            "100000",
            "--out",
            "x.json",
        ],
        &["--threads", "100000", "per available core"],
    );
}

#[test]
fn signal_size_is_capped_at_what_ssskit_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    fails_in(
        dir.path(),
        &[
            "signal",
            "edge",
            "--image-size",
            "16384x16384",
            "--out",
            "s.png",
        ],
        &["16384x16384", "use a smaller image"],
    );
    // A PNG whose header claims more pixels than the cap is refused before
    // its pixels are decoded: a 1-row, 20000-pixel-wide image.
    let wide = dir.path().join("wide.png");
    image::RgbImage::new(20000, 1).save(&wide).unwrap();
    fails_in(
        dir.path(),
        &["diff", "wide.png", "wide.png"],
        &["wide.png", "20000x1"],
    );
}

#[test]
fn absurd_photon_counts_are_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sim = |photons: &'static str, extra: &[&'static str]| {
        let mut v = vec!["simulate", "--material", "marble", "--out", "x.json"];
        v.extend_from_slice(&["--photons", photons]);
        v.extend_from_slice(extra);
        v
    };
    // Not a count of photons: the flag and the value are named.
    for bad in ["nan", "inf", "-5", "1.5", "1e300", "lots"] {
        let e = fails_in(d, &sim(bad, &[]), &["--photons"]);
        assert!(e.contains(&format!("invalid value {bad}")), "{bad}: {e}");
    }
    fails_in(d, &sim("1e300", &[]), &["beyond the largest count"]);
    // Each photon costs at least one event: a count above the work cap is
    // refused before any photon is traced, and the same with a cap raised
    // to it is not refused by that rule (it fails on its first round).
    let started = Instant::now();
    fails_in(
        d,
        &sim("1e15", &[]),
        &[
            "--photons",
            "1000000000000000 photons per channel",
            "work cap of 1500000000",
        ],
    );
    fails_in(
        d,
        &sim("100000000000", &["--max-work", "10"]),
        &["--photons", "work cap of 10 events"],
    );
    // Within the cap by count, beyond it by the events per photon that its
    // first round measures (marble: hundreds): refused after that round,
    // naming the estimate; the cap given as 1e9 is read as 1000000000.
    let e = fails_in(
        d,
        &sim("1e7", &["--max-work", "1e9", "--channels", "b"]),
        &[
            "--photons",
            "channel b",
            "events per photon over its first 16384 photons",
            "work cap of 1000000000",
        ],
    );
    assert!(e.contains("for 10000000 photons"), "{e}");
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "the refusals took {:?}",
        started.elapsed()
    );
    assert!(!d.join("x.json").exists());
    // Exponent notation is a count like any other.
    ok_in(d, &sim("2e3", &["--channels", "r"]));
    let p = common::read_json(&d.join("x.json"));
    assert_eq!(p["source"]["photons"][0], 2000);
    assert_eq!(
        p["source"]["params"]["budget"]["max_work"],
        1_500_000_000u64
    );
}

/// Runs with standard output going to `stdout`: (exit code, stderr).
fn run_to(dir: &Path, args: &[&str], stdout: Stdio) -> (Option<i32>, String) {
    let child = spawn_in(dir, args, stdout, Stdio::piped());
    let o = wait_bounded(child, &format!("ssskit {args:?}"));
    (o.status.code(), common::stderr(&o))
}

// ---- 2. No panic on output ----------------------------------------------

#[test]
fn closed_pipe_ends_quietly_with_141() {
    let dir = tempfile::tempdir().unwrap();
    let k = kernel();
    for args in [
        vec!["materials"],
        vec!["materials", "--json"],
        vec!["fit", "--kernel", &k, "--emit", "hlsl"],
    ] {
        // The read end is closed before the child starts: its first write
        // fails with EPIPE, deterministically.
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let (code, err) = run_to(dir.path(), &args, writer.into());
        assert_eq!(code, Some(141), "{args:?}: {err}");
        assert!(err.is_empty(), "{args:?} printed on a closed pipe: {err}");
    }
}

#[cfg(target_os = "linux")]
#[test]
fn full_disk_on_stdout_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    for args in [vec!["materials"], vec!["--help"]] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let (code, err) = run_to(dir.path(), &args, full.into());
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains("writing to standard output"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

// ---- 3. Nothing unreadable written --------------------------------------

#[test]
fn kernels_with_overflowing_or_zero_weights_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    dirac(dir.path());
    let huge = edited(&kernel(), dir.path(), "huge.json", |v| {
        v["passes"][0]["weights"][5] = serde_json::json!([1e308, 1e308, 1e308]);
    });
    let zero = edited(&kernel(), dir.path(), "zero.json", |v| {
        for key in ["passes", "taps"] {
            let passes = if key == "taps" {
                &mut v["taps"]["passes"]
            } else {
                &mut v["passes"]
            };
            for w in passes[0]["weights"].as_array_mut().unwrap() {
                *w = serde_json::json!([0.0, 0.0, 0.0]);
            }
        }
    });
    for (k, needle) in [
        (&huge, "absolute sum"),
        (&zero, "every weight of channel r is 0"),
    ] {
        fails_in(dir.path(), &apply_dirac(k, "0.1"), &[needle]);
    }
    assert!(!dir.path().join("o.exr").exists());
}

#[test]
fn output_format_comes_from_the_extension() {
    let dir = tempfile::tempdir().unwrap();
    dipole_profile(dir.path());
    for args in [
        vec!["plot", "profile", "p.json", "--out", "x.exr"],
        common::profile_args("skin1", "dipole", "x.exr", &[]),
        common::fit_args("p.json", "svd", "x.exr", &[]),
        vec![
            "simulate",
            "--material",
            "skin1",
            "--photons",
            "100",
            "--out",
            "x.exr",
        ],
        vec!["signal", "dirac", "--out", "x.jpg"],
    ] {
        fails_in(dir.path(), &args, &["x."]);
    }
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("x."))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn profiles_beyond_any_reflectance_are_refused_on_read() {
    let dir = tempfile::tempdir().unwrap();
    dipole_profile(dir.path());
    let p = dir.path().join("p.json").to_string_lossy().into_owned();
    let big = edited(&p, dir.path(), "big.json", |v| v["rd"][0][3] = 1e308.into());
    // plot used to hang on this file; fit and plot must name it.
    fails_in(
        dir.path(),
        &["plot", "profile", &big, "--out", "b.png"],
        &["big.json", "not a reflectance"],
    );
    fails_in(
        dir.path(),
        &common::fit_args(&big, "svd", "k.json", &[]),
        &["big.json", "not a reflectance"],
    );
    let zero = edited(&p, dir.path(), "zero.json", |v| {
        for row in v["rd"].as_array_mut().unwrap() {
            for x in row.as_array_mut().unwrap() {
                *x = 0.0.into();
            }
        }
    });
    fails_in(
        dir.path(),
        &common::fit_args(&zero, "svd", "k.json", &[]),
        &["zero.json", "zero"],
    );
}

#[test]
fn extreme_materials_give_a_readable_profile_or_an_error_before_work() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, sa: &str, ss: &str| {
        std::fs::write(
            dir.path().join(name),
            format!("unit = \"mm\"\nsigma_a = {sa}\nsigma_s = {ss}\neta = 1.3\n"),
        )
        .unwrap();
    };
    write("a_big.toml", "1e300", "1");
    write("s_big.toml", "0.1", "1e300");
    write("both_tiny.toml", "1e-300", "1e-300");
    write("a_tiny.toml", "1e-300", "1");
    for m in ["a_big.toml", "s_big.toml", "both_tiny.toml"] {
        let args = format!("simulate --material {m} --photons 1000 --out x.json");
        fails_in(dir.path(), &words(&args), &[m, "check the unit"]);
    }
    // Representable but extreme: a finite profile that every reader takes.
    let tiny = words("simulate --material a_tiny.toml --photons 2000 --out t.json");
    ok_in(dir.path(), &tiny);
    ok_in(dir.path(), &["plot", "profile", "t.json", "--out", "t.png"]);
    let fine =
        words("simulate --material skin1 --log-bins --dr 1e-300 --photons 1000 --out x.json");
    fails_in(dir.path(), &fine, &["dr", "1e-300"]);
}

// ---- 4. Messages that name the problem ----------------------------------

#[test]
fn material_file_errors_name_line_field_and_shape() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (value, needle) in [
        ("[0.1, 0.2]", "invalid length 2"),
        ("[0.1, 0.2, 0.3, 0.4]", "invalid length 4"),
        ("\"0.1\"", "invalid type: string"),
    ] {
        let text = format!("unit = \"mm\"\nsigma_a = {value}\nsigma_s = 1.0\neta = 1.3\n");
        std::fs::write(d.join("m.toml"), text).unwrap();
        fails_in(
            d,
            &["materials", "m.toml"],
            &[
                "m.toml",
                "line 2, field sigma_a",
                needle,
                "three numbers [r, g, b]",
            ],
        );
    }
    std::fs::write(
        d.join("t.toml"),
        "unit = \"mm\"\nsigma_a = 0.1\nsigma_s = 1.0\neta = 1.3\nthickness = \"0.2\"\n",
    )
    .unwrap();
    fails_in(
        d,
        &["materials", "t.toml"],
        &["t.toml", "line 5, field thickness"],
    );
}

#[test]
fn profile_grid_messages_name_the_flags_given() {
    let dir = tempfile::tempdir().unwrap();
    let base = common::profile_args("skin1", "dipole", "p.json", &[]);
    let fine = [&base[..], &["--dr", "1e-9"]].concat();
    let err = fails_in(dir.path(), &fine, &["--dr", "bins"]);
    assert!(
        !err.contains("--log-bins"),
        "profile has no --log-bins: {err}"
    );
    let wide = [&base[..], &["--dr", "100"]].concat();
    let err = fails_in(
        dir.path(),
        &wide,
        &["--dr: invalid value 100", "default radius"],
    );
    assert!(
        !err.contains("--rmax: invalid"),
        "no --rmax was given: {err}"
    );
}

#[test]
fn enumerated_flags_refuse_other_values_listing_theirs() {
    let dir = tempfile::tempdir().unwrap();
    dipole_profile(dir.path());
    dirac(dir.path());
    let k = kernel();
    let fit = |extra: &[&'static str]| {
        let mut v = vec!["fit", "--profile", "p.json", "--out", "k.json"];
        v.extend_from_slice(extra);
        v
    };
    for (args, values) in [
        (
            vec!["simulate", "--material", "skin1", "--boundary", "both"],
            "classic, split",
        ),
        (
            [&apply_dirac(&k, "0.1")[..], &["--png-bits", "12"]].concat(),
            "8, 16",
        ),
        (
            fit(&["--model", "svd", "--emit", "metal"]),
            "hlsl, glsl, wgsl",
        ),
        (fit(&["--model", "manual", "--preset", "milk"]), "skin1"),
        (
            vec!["engine", "--profile", "p.json", "--engine", "cryengine"],
            "unity-hdrp",
        ),
        (
            vec![
                "advise",
                "--profile",
                "p.json",
                "--mm-per-pixel",
                "0.1",
                "--models",
                "svd,foo",
            ],
            "svd, preintegrate, guided, manual, gaussians",
        ),
    ] {
        fails_in(
            dir.path(),
            &args,
            &["invalid value", "possible values", values],
        );
    }
    // A preset of the other model is named as such.
    fails_in(
        dir.path(),
        &fit(&["--model", "manual", "--preset", "deon-skin"]),
        &["deon-skin", "gaussians"],
    );
    fails_in(
        dir.path(),
        &fit(&["--model", "gaussians", "--preset", "skin1"]),
        &["skin1", "manual"],
    );
    assert!(!dir.path().join("k.json").exists());
}

// ---- 5. Debris -----------------------------------------------------------

#[test]
fn stale_temp_files_of_dead_processes_are_swept() {
    let dir = tempfile::tempdir().unwrap();
    let two_hours_ago = std::time::SystemTime::now() - Duration::from_secs(7200);
    let make = |name: &str, old: bool| {
        let f = std::fs::File::create(dir.path().join(name)).unwrap();
        if old {
            f.set_modified(two_hours_ago).unwrap();
        }
    };
    // pid 1 is alive; 4194304 is above Linux's pid_max (never a process).
    make(".ssskit-4194304-dead01.tmp", true);
    make(".ssskit-4194304-young1.tmp", false);
    make(".ssskit-1-alive1.tmp", true);
    make(".ssskit-notours.tmp", true);
    ok_in(
        dir.path(),
        &["signal", "dirac", "--image-size", "8x8", "--out", "s.png"],
    );
    let mut left = temp_files(dir.path());
    left.sort();
    let expect = if cfg!(target_os = "linux") {
        vec![
            ".ssskit-1-alive1.tmp",
            ".ssskit-4194304-young1.tmp",
            ".ssskit-notours.tmp",
        ]
    } else {
        vec![
            ".ssskit-1-alive1.tmp",
            ".ssskit-4194304-dead01.tmp",
            ".ssskit-4194304-young1.tmp",
            ".ssskit-notours.tmp",
        ]
    };
    assert_eq!(left, expect);
}

#[test]
fn concurrent_runs_leave_json_and_csv_of_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let children: Vec<Child> = (1..=4)
        .map(|seed| {
            let photons = 2000 * seed;
            let run = format!("--photons {photons} --seed {seed} --out o.json --csv o.csv");
            let args = skin1_red_args(&words(&run));
            let args = [&args[..], &["--threads", "1"]].concat();
            spawn_in(dir.path(), &args, Stdio::null(), Stdio::piped())
        })
        .collect();
    for c in children {
        let o = wait_bounded(c, "concurrent simulate");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let p = ssskit::profile::Profile::read(&dir.path().join("o.json")).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("o.csv")).unwrap();
    let first: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let rd: f64 = first[3].parse().unwrap();
    assert_eq!(rd, p.rd[0][0], "JSON and CSV come from different runs");
    assert!(temp_files(dir.path()).is_empty());
}
