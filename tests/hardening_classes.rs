//! The second campaign's eight classes of hostile input, one test (or a few)
//! per class, on the real binary under a memory cap (`prlimit --as`) and a
//! wall-clock limit: nothing written outside the named output, work bounded
//! inside a round, a merge that verifies its shards, no abort on any input,
//! bounded memory, no garbage accepted or written, no debris after a
//! signal, messages that name the input.
//!
//! `SSSKIT_TEST_BIN=/path/to/ssskit` runs these tests against another
//! build (e.g. an older one, to see which classes it fails).

mod common;

use common::args::{engine_args, skin1_red_args, words};
use common::bounded::{capped, edited, run_with};
use common::inputs::dipole_profile;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const TIME_LIMIT: Duration = Duration::from_secs(60);
const REPO: &str = env!("CARGO_MANIFEST_DIR");

fn binary() -> String {
    std::env::var("SSSKIT_TEST_BIN").unwrap_or_else(|_| common::BIN.to_string())
}

/// `ssskit args` in `dir` under the memory cap, standard input closed.
fn command_in(dir: &Path, limits: &[&str], args: &[&str]) -> Command {
    let mut c = capped(&binary(), limits, args);
    c.current_dir(dir).stdin(Stdio::null());
    c
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    run_with(
        command_in(dir, &[], args),
        &format!("ssskit {args:?}"),
        TIME_LIMIT,
    )
}

fn ok_in(dir: &Path, args: &[&str]) -> String {
    common::assert_ok(&run_in(dir, args), args).0
}

/// Runs, expects exit 2 and every needle in stderr; returns stderr.
fn fails_in(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    common::assert_fails(&run_in(dir, args), args, needles)
}

/// Every file and folder under `dir`, relative, sorted.
fn tree(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            out.push(p.strip_prefix(root).unwrap().to_string_lossy().into_owned());
            if p.is_dir() {
                walk(root, &p, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A half-space material TOML named `name` (TOML basic-string escapes
/// allowed in it).
fn material(name: &str) -> String {
    format!(
        "name = \"{name}\"\nunit = \"mm\"\nsigma_a = [0.032, 0.17, 0.48]\n\
         sigma_s = [0.74, 0.88, 1.01]\neta = 1.3\n"
    )
}

/// A comparison of seconds of `material`'s dipole into `out`: rank-1 SVD,
/// no signals, no plots.
fn quick_compare<'a>(material: &'a str, out: &'a str) -> Vec<&'a str> {
    let models = [
        "--models",
        "svd",
        "--ranks",
        "1",
        "--signals",
        "none",
        "--no-plots",
    ];
    let head = [
        "compare",
        "--materials",
        material,
        "--profile-model",
        "dipole",
    ];
    [&head[..], &models, &["--out-dir", out]].concat()
}

fn kernel() -> String {
    format!("{REPO}/kernels/marble-svd1.json")
}

fn temp_entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".ssskit-") && n != ".ssskit-output")
        .collect()
}

// ---- 1. Names are labels, never paths ------------------------------------

/// A material named like a path writes inside the folder it was asked to
/// write to, under a plain file name: `simulate` (default output name) and
/// `compare` (kernel files named after materials).
#[test]
fn material_names_never_leave_the_output_folder() {
    let root = tempfile::tempdir().unwrap();
    // root/a/b/work is the working folder: three levels a name could climb.
    let work = root.path().join("a/b/work");
    std::fs::create_dir_all(&work).unwrap();
    let outside = root.path().join("escaped");
    for (file, name) in [
        ("rel.toml", "../../../escaped"),
        ("abs.toml", &outside.to_string_lossy()),
    ] {
        write(&work, file, &material(name));
        ok_in(
            &work,
            &[
                "simulate",
                "--material",
                file,
                "--photons",
                "500",
                "--channels",
                "r",
            ],
        );
        ok_in(&work, &quick_compare(file, "cd"));
        // Nothing beside the working folder's own tree.
        let outside: Vec<String> = tree(root.path())
            .into_iter()
            .filter(|f| !f.starts_with("a/b/work/"))
            .collect();
        assert_eq!(outside, ["a", "a/b", "a/b/work"], "{name}");
        let kernels = tree(&work.join("cd/kernels"));
        assert_eq!(kernels.len(), 2, "{kernels:?}");
        for k in &kernels {
            assert!(!k.contains('/') && !k.starts_with('.'), "{k}");
        }
        let profiles: Vec<String> = tree(&work)
            .into_iter()
            .filter(|f| f.ends_with(".json") && !f.starts_with("cd"))
            .collect();
        assert_eq!(profiles.len(), 1, "{profiles:?}");
        std::fs::remove_dir_all(&work).unwrap();
        std::fs::create_dir_all(&work).unwrap();
    }
}

/// Control characters and direction overrides in a name are refused with
/// the character named, and never reach the terminal.
#[test]
fn names_with_control_characters_are_refused_and_not_echoed() {
    let dir = tempfile::tempdir().unwrap();
    for (name, code) in [
        ("a\\u001b[31mRED", "U+001B"),
        ("bell\\u0007", "U+0007"),
        ("rtl\\u202etxt", "U+202E"),
    ] {
        write(dir.path(), "m.toml", &material(name));
        for args in [
            vec!["materials", "m.toml"],
            vec!["simulate", "--material", "m.toml", "--photons", "100"],
        ] {
            let e = fails_in(dir.path(), &args, &["m.toml", "name", code]);
            assert!(
                !e.contains('\u{1b}') && !e.contains('\u{7}') && !e.contains('\u{202e}'),
                "{e:?}"
            );
        }
    }
    assert_eq!(tree(dir.path()), ["m.toml"]);
}

// ---- 2. Work bounded inside a round --------------------------------------

/// Albedo 1 and g = 0.9999999: a packet walks millions of events. A run of
/// 1000 photons (one round) stops at the work cap inside that round and
/// says so, for the fixed and the target-error rules alike.
#[test]
fn work_is_bounded_inside_the_first_round() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "slow.toml",
        "unit = \"mm\"\nsigma_a = 0\nsigma_s = 1\ng = 0.9999999\neta = 1.3\n",
    );
    let started = Instant::now();
    for rule in [
        vec!["--photons", "1000"],
        vec!["--mc-error", "0.01"],
        vec!["--kernel-error", "0.01"],
    ] {
        let mut args = vec![
            "simulate",
            "--material",
            "slow.toml",
            "--channels",
            "g",
            "--max-work",
            "1000000",
            "--out",
            "x.json",
        ];
        args.extend(rule);
        fails_in(dir.path(), &args, &["--max-work", "1000000", "channel g"]);
    }
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "three refusals took {:?}",
        started.elapsed()
    );
    assert!(!dir.path().join("x.json").exists());
}

/// A run that gets past its first round stops at the cap inside a later
/// one: the profile holds whole rounds only, with the work cap reported,
/// and the work never exceeds the cap.
#[test]
fn later_rounds_stop_at_the_cap() {
    let dir = tempfile::tempdir().unwrap();
    let sim = |extra: &[&'static str]| -> Vec<&'static str> {
        let mut v = vec![
            "simulate",
            "--material",
            "marble",
            "--channels",
            "g",
            "--seed",
            "3",
        ];
        v.extend_from_slice(extra);
        v
    };
    // The first round alone: two chunks of 8192 photons, E events.
    ok_in(
        dir.path(),
        &sim(&["--photons", "16384", "--out", "one.json"]),
    );
    let one = common::read_json(&dir.path().join("one.json"));
    let e = one["extra"]["events_per_photon"][0].as_f64().unwrap() * 16384.0;
    // A cap of 2.5 E: rounds of 2, 2 then 4 chunks (2 E) need 4 E in all;
    // the third round's chunks each get a quarter of the 0.5 E left.
    let cap = format!("{:.0}", 2.5 * e);
    ok_in(
        dir.path(),
        &[
            &sim(&["--mc-error", "0.00001", "--out", "m.json"])[..],
            &["--max-work", &cap],
        ]
        .concat(),
    );
    let p = common::read_json(&dir.path().join("m.json"));
    let photons = p["source"]["photons"][0].as_u64().unwrap();
    let spent = p["extra"]["events_per_photon"][0].as_f64().unwrap() * photons as f64;
    assert_eq!(p["extra"]["stopped_by"][0], "work-cap");
    assert_eq!(photons % 8192, 0, "whole chunks only: {photons}");
    assert!(spent <= 2.5 * e, "{spent} events, cap {cap}");
    assert_eq!(photons, 4 * 8192, "the third round was not discarded");
}

// ---- 3. merge verifies its shards ----------------------------------------

/// Shards changed after they were written are refused, naming the shard
/// and the field: a doubled tally, zeroed sums of squares, sums and event
/// counts at the edge of their range (which used to wrap).
#[test]
fn merge_refuses_tampered_shards() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for k in 1..=2 {
        let shard = format!("--photons 20000 --shard {k}/2 --out s{k}.json");
        ok_in(d, &skin1_red_args(&words(&shard)));
    }
    ok_in(d, &["merge", "s1.json", "s2.json", "--out", "m.json"]);
    let s2 = d.join("s2.json").to_string_lossy().into_owned();
    let tally = |v: &mut serde_json::Value| -> serde_json::Value {
        v["extra"]["shard"]["tallies"][0].clone()
    };
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "doubled.json",
            Box::new(move |v| {
                // Every sum of the tally doubled: R_d, T, absorbed, bins.
                let t = tally(v);
                let mut t2 = t.clone();
                for (i, x) in t["totals"].as_array().unwrap().iter().enumerate() {
                    let s = x.as_str().unwrap();
                    let (h, l) = s.split_once(':').unwrap_or((s, "0"));
                    let h = u128::from_str_radix(h, 16).unwrap() * 2;
                    let l = u64::from_str_radix(l, 16).unwrap() as u128 * 2;
                    t2["totals"][i] = format!("{:x}:{:x}", h + (l >> 64), l as u64).into();
                }
                v["extra"]["shard"]["tallies"][0] = t2;
            }),
        ),
        (
            "squares.json",
            Box::new(move |v| {
                let mut t = tally(v);
                for i in [2, 4, 6] {
                    t["totals"][i] = "0".into();
                }
                for x in t["rd_bins"]["sum_sq"].as_array_mut().unwrap() {
                    *x = "0".into();
                }
                v["extra"]["shard"]["tallies"][0] = t;
            }),
        ),
        (
            "wrap.json",
            Box::new(move |v| {
                let mut t = tally(v);
                t["totals"][1] = format!("{:x}", u128::MAX).into();
                t["events"] = u64::MAX.into();
                v["extra"]["shard"]["tallies"][0] = t;
            }),
        ),
        (
            "rehashed.json",
            Box::new(|v| {
                // The hash field alone changed.
                v["extra"]["shard"]["sha256"] = "00".repeat(32).into();
            }),
        ),
    ];
    for (name, edit) in cases {
        let bad = edited(&s2, d, name, edit);
        let args = ["merge", "s1.json", bad.as_str(), "--out", "x.json"];
        fails_in(d, &args, &[name, "extra.shard"]);
    }
    assert!(!d.join("x.json").exists());
}

// ---- 4. No abort on any input --------------------------------------------

/// A 2 GiB material file (sparse: no disk used) and /dev/zero are refused
/// after reading their first MiB, not parsed whole.
#[test]
fn huge_and_endless_inputs_are_refused_after_a_bounded_read() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.toml");
    std::fs::File::create(&big)
        .unwrap()
        .set_len(2 << 30)
        .unwrap();
    fails_in(
        dir.path(),
        &["materials", "big.toml"],
        &["big.toml", "larger than"],
    );
    fails_in(
        dir.path(),
        &["simulate", "--material", "big.toml", "--photons", "10"],
        &["big.toml", "larger than"],
    );
    #[cfg(unix)]
    {
        ok_in(
            dir.path(),
            &["signal", "dirac", "--image-size", "8x8", "--out", "x.png"],
        );
        for args in [
            common::fit_args("/dev/zero", "svd", "k.json", &[]),
            vec!["fit", "--kernel", "/dev/zero"],
            vec!["merge", "/dev/zero", "--out", "m.json"],
            vec!["materials", "/dev/zero"],
            vec!["simulate", "--mci", "/dev/zero", "--out", "x.json"],
            vec!["plot", "profile", "/dev/zero", "--out", "p.png"],
            vec!["engine", "--profile", "/dev/zero", "--engine", "unreal"],
            common::apply_args("/dev/zero", "x.png", "o.png", "0.1", &[]),
        ] {
            fails_in(dir.path(), &args, &["/dev/zero"]);
        }
    }
}

/// An EXR header only, as OpenEXR lays it out (magic, version, headers,
/// one offset table per part; OpenEXR "File Layout"), with zero offsets:
/// a few kB that declare what they like.
fn exr_header_only(path: &Path, parts: usize, channels: usize, w: usize, h: usize) {
    use exr::meta::attribute::{ChannelDescription, ChannelList, SampleType, Text};
    use exr::meta::header::Header;
    use exr::meta::BlockDescription;
    use exr::prelude::{Compression, LineOrder};
    let list: exr::prelude::SmallVec<[ChannelDescription; 5]> = (0..channels)
        .map(|i| {
            let name = if channels <= 4 {
                ["A", "B", "G", "R"][i].to_string()
            } else {
                format!("C{i:02}")
            };
            ChannelDescription::new(Text::from(name.as_str()), SampleType::F32, true)
        })
        .collect();
    let headers: Vec<Header> = (0..parts)
        .map(|p| {
            Header::new(
                Text::from(format!("part{p}").as_str()),
                (w, h),
                ChannelList::new(list.clone()).list,
            )
            .with_encoding(
                Compression::ZIP16,
                BlockDescription::ScanLines,
                LineOrder::Increasing,
            )
        })
        .collect();
    let mut out = Vec::new();
    exr::meta::magic_number::write(&mut out).unwrap();
    exr::meta::MetaData::validate(&headers, true)
        .unwrap()
        .write(&mut out)
        .unwrap();
    Header::write_all(&headers, &mut out, parts > 1).unwrap();
    for hd in &headers {
        out.extend(std::iter::repeat_n(0u8, 8 * hd.chunk_count));
    }
    std::fs::write(path, out).unwrap();
}

/// Headers declaring 64 channels of 8K, or 200 parts of 8K, pass the
/// per-layer size check; the total is refused before the decoder
/// allocates, naming the file and what it declares.
#[test]
fn exr_headers_declaring_too_much_are_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    exr_header_only(&dir.path().join("wide.exr"), 1, 64, 7680, 4320);
    exr_header_only(&dir.path().join("parts.exr"), 200, 4, 7680, 4320);
    for name in ["wide.exr", "parts.exr"] {
        let size = std::fs::metadata(dir.path().join(name)).unwrap().len();
        assert!(size < 1 << 20, "{name}: {size} bytes");
        let k = kernel();
        for args in [
            vec!["diff", name, name],
            common::apply_args(&k, name, "o.exr", "0.1", &[]),
        ] {
            fails_in(dir.path(), &args, &[name, "channel(s)"]);
        }
    }
}

/// Writes d.png into `dir`: a 64 x 48 Dirac signal, the input the apply
/// cases filter.
fn dirac_png(dir: &Path) {
    ok_in(dir, &words("signal dirac --image-size 64x48 --out d.png"));
}

/// RAYON_NUM_THREADS is capped like --threads, and a pool that cannot
/// start (every thread's stack refused) is an error, not a panic in the
/// first parallel loop.
#[test]
fn threads_are_capped_whatever_the_environment_says() {
    let dir = tempfile::tempdir().unwrap();
    dirac_png(dir.path());
    let k = kernel();
    let apply = common::apply_args(&k, "d.png", "o.png", "0.1", &["--backend", "cpu"]);
    let mut c = command_in(dir.path(), &[], &apply);
    c.env("RAYON_NUM_THREADS", "5000");
    let o = run_with(c, "RAYON_NUM_THREADS=5000", TIME_LIMIT);
    common::assert_fails(&o, &apply, &["RAYON_NUM_THREADS", "5000", "between 1 and"]);
    // A stack of 1 TiB per thread: no thread can start.
    let mut c = command_in(dir.path(), &[], &apply);
    c.env("RUST_MIN_STACK", "1099511627776");
    let o = run_with(c, "RUST_MIN_STACK=1T", TIME_LIMIT);
    common::assert_fails(&o, &apply, &["cannot start", "worker thread"]);
    assert!(!dir.path().join("o.png").exists());
}

// ---- 5. Memory bounded -------------------------------------------------

/// 10^7 radial bins are refused before a tally is allocated (they cost
/// 6 GB and a 1 GB file); the cap is said.
#[test]
fn radial_bins_are_capped_before_allocation() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        vec![
            "simulate",
            "--material",
            "skin1",
            "--photons",
            "2000",
            "--dr",
            "1e-6",
            "--rmax",
            "10",
            "--out",
            "x.json",
        ],
        common::profile_args(
            "skin1",
            "dipole",
            "x.json",
            &["--dr", "1e-6", "--rmax", "10"],
        ),
    ] {
        fails_in(dir.path(), &args, &["--dr", "1000000"]);
    }
    assert!(!dir.path().join("x.json").exists());
}

// ---- 6. Nothing garbage accepted or written ------------------------------

/// Tap offsets beyond f32 would be written as `inf` into shader arrays:
/// refused, naming the kernel file and the field.
#[test]
fn shader_arrays_hold_only_f32_values() {
    let dir = tempfile::tempdir().unwrap();
    let far = edited(&kernel(), dir.path(), "far.json", |v| {
        let n = v["taps"]["passes"][0]["offsets_mm"]
            .as_array()
            .unwrap()
            .len();
        v["taps"]["passes"][0]["offsets_mm"] = (0..n)
            .map(|i| 1e39 * (i + 1) as f64)
            .collect::<Vec<_>>()
            .into();
    });
    for lang in ["hlsl", "glsl", "wgsl"] {
        let o = run_in(dir.path(), &["fit", "--kernel", &far, "--emit", lang]);
        let out = common::stdout(&o);
        assert!(!out.contains("inf"), "{lang}: {out}");
        common::assert_fails(&o, &["fit"], &["far.json", "offsets_mm", "f32"]);
    }
}

/// Kernels whose weights cancel (sum 0) or are all tiny (1e-150) turn an
/// image black: refused on read like all-zero weights.
#[test]
fn kernels_that_would_turn_an_image_black_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // Weights +1 on one side, -1 on the other (0 in the middle of an odd
    // count): each pass sums to 0; or every weight 1e-150.
    let weights = |w: &mut Vec<serde_json::Value>, tiny: bool| {
        let n = w.len();
        for (i, x) in w.iter_mut().enumerate() {
            let s = match (tiny, i) {
                (true, _) => 1e-150,
                (false, i) if i < n / 2 => 1.0,
                (false, i) if i >= n - n / 2 => -1.0,
                _ => 0.0,
            };
            *x = serde_json::json!([s, s, s]);
        }
    };
    let make = |name: &str, tiny: bool| {
        edited(&kernel(), dir.path(), name, |v| {
            weights(v["passes"][0]["weights"].as_array_mut().unwrap(), tiny);
            weights(
                v["taps"]["passes"][0]["weights"].as_array_mut().unwrap(),
                tiny,
            );
        })
    };
    let cancel = make("cancel.json", false);
    let tiny = make("tiny.json", true);
    for k in [&cancel, &tiny] {
        fails_in(
            dir.path(),
            &["fit", "--kernel", k],
            &[k.rsplit('/').next().unwrap(), "turn the image black"],
        );
    }
}

/// A profile whose first bin is degenerate (1e-300 mm wide, R_d 1e290)
/// passes the profile's own checks (its tabulated total is 0) but the
/// kernel grid would hold 1e288 times it: refused, naming the profile.
#[test]
fn a_degenerate_first_bin_is_refused_not_fitted() {
    let dir = tempfile::tempdir().unwrap();
    dipole_profile(dir.path());
    let p = dir.path().join("p.json").to_string_lossy().into_owned();
    let bad = edited(&p, dir.path(), "bad.json", |v| {
        v["r_edges"][1] = 1e-300.into();
        v["r"][0] = 5e-301.into();
        for row in v["rd"].as_array_mut().unwrap() {
            row[0] = 1e290.into();
        }
    });
    fails_in(
        dir.path(),
        &common::fit_args(&bad, "svd", "k.json", &[]),
        &["skin1", "times the profile's tabulated reflectance"],
    );
    assert!(!dir.path().join("k.json").exists());
}

/// A strength image that scales the kernel so far that every tap but the
/// centre falls outside the image is refused, as the same scale is under a
/// uniform footprint.
#[test]
fn per_pixel_scales_beyond_the_image_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    dirac_png(dir.path());
    let mut img = ssskit::filter::Image::new(64, 48);
    for c in 0..3 {
        img.rgb[c].iter_mut().for_each(|v| *v = 1e6);
    }
    ssskit::filter::image::write_exr(&dir.path().join("s.exr"), &img, None).unwrap();
    let k = kernel();
    for backend in ["cpu", "gpu"] {
        let args = common::apply_args(
            &k,
            "d.png",
            "o.exr",
            "0.1",
            &["--strength", "s.exr", "--backend", backend],
        );
        fails_in(
            dir.path(),
            &args,
            &["per-pixel kernel scale", "strength 1000000"],
        );
    }
    assert!(!dir.path().join("o.exr").exists());
}

// ---- 7. Interrupted runs leave nothing behind ----------------------------

/// SIGTERM, SIGQUIT and SIGUSR1 (the terminating signals a process can
/// catch, not only SIGINT and SIGHUP) remove the temporary file of a write
/// in progress; a file size limit (SIGXFSZ) makes
/// the write fail cleanly, naming the file.
#[cfg(unix)]
#[test]
fn every_catchable_signal_cleans_up() {
    let dir = tempfile::tempdir().unwrap();
    let args = words("signal shapes --image-size 7680x4320 --out big.exr");
    for (sig, code) in [("TERM", 143), ("QUIT", 131), ("USR1", 138)] {
        let mut caught = false;
        for _attempt in 0..5 {
            let mut child = command_in(dir.path(), &[], &args)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
            let start = Instant::now();
            while temp_entries(dir.path()).is_empty() && start.elapsed() < TIME_LIMIT {
                if child.try_wait().unwrap().is_some() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(2));
            }
            if temp_entries(dir.path()).is_empty() {
                let _ = child.wait();
                let _ = std::fs::remove_file(dir.path().join("big.exr"));
                continue;
            }
            // prlimit execs the binary: the pid is ssskit's.
            Command::new("kill")
                .args([&format!("-{sig}"), &child.id().to_string()])
                .status()
                .unwrap();
            let status = child.wait().unwrap();
            let left = temp_entries(dir.path());
            assert!(left.is_empty(), "SIG{sig} left {left:?} ({status:?})");
            if !dir.path().join("big.exr").exists() {
                assert_eq!(status.code(), Some(code), "SIG{sig}: {status:?}");
            }
            caught = true;
            break;
        }
        assert!(caught, "SIG{sig}: never caught the write in progress");
        let _ = std::fs::remove_file(dir.path().join("big.exr"));
    }
    // 1 MB file size limit: the 8K EXR crosses it.
    let o = run_with(
        command_in(dir.path(), &["--fsize=1000000"], &args),
        "under a file size limit",
        TIME_LIMIT,
    );
    common::assert_fails(&o, &args, &["big.exr", "too large"]);
    assert!(temp_entries(dir.path()).is_empty());
    assert!(!dir.path().join("big.exr").exists());
}

/// An interrupted `kernels` leaves the folder of the previous run as it
/// was (never a mix of two runs) and no staging folder; a folder of other
/// files is refused before any work rather than replaced.
#[cfg(unix)]
#[test]
fn interrupted_folder_outputs_leave_the_previous_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let compare = quick_compare("skin1", "kd");
    ok_in(d, &compare);
    let snapshot = |root: &Path| -> Vec<(String, Vec<u8>)> {
        tree(root)
            .into_iter()
            .filter(|f| root.join(f).is_file())
            .map(|f| {
                let bytes = std::fs::read(root.join(&f)).unwrap();
                (f, bytes)
            })
            .collect()
    };
    let before = snapshot(&d.join("kd"));
    let kernels = words(concat!(
        "kernels --material skin1 --profile-model dipole",
        " --no-plots --signal-size 16 --out-dir kd"
    ));
    let mut child = command_in(d, &[], &kernels)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait for the run's first file: its profile, in the folder itself or
    // in a staging folder beside it.
    let start = Instant::now();
    let written = || {
        d.join("kd/profile.json").exists()
            || temp_entries(d)
                .iter()
                .any(|t| d.join(t).join("profile.json").exists())
    };
    while !written() && start.elapsed() < TIME_LIMIT {
        assert!(
            child.try_wait().unwrap().is_none(),
            "kernels ended too soon"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(143), "{status:?}");
    assert_eq!(snapshot(&d.join("kd")), before, "the folder mixes two runs");
    assert!(temp_entries(d).is_empty(), "{:?}", temp_entries(d));
    // Somebody's folder is not replaced: refused before the work.
    std::fs::create_dir(d.join("mine")).unwrap();
    write(&d.join("mine"), "notes.txt", "keep");
    let started = Instant::now();
    fails_in(
        d,
        &[&kernels[..kernels.len() - 1], &["mine"]].concat(),
        &["mine", "notes.txt", "new or empty folder"],
    );
    assert!(started.elapsed() < Duration::from_secs(10));
    assert_eq!(tree(&d.join("mine")), ["notes.txt"]);
}

// ---- 8. Messages that name the input -------------------------------------

/// `kernels --material wine` and `compare --profile-model pbd` over every
/// preset fail naming the material and the channel.
#[test]
fn failures_name_the_material_and_channel() {
    let dir = tempfile::tempdir().unwrap();
    fails_in(
        dir.path(),
        &[
            "kernels",
            "--material",
            "wine",
            "--profile-model",
            "pbd",
            "--no-plots",
            "--out-dir",
            "kw",
        ],
        &["'wine'", "channel 'g'"],
    );
    fails_in(
        dir.path(),
        &[
            "compare",
            "--materials",
            "all",
            "--profile-model",
            "pbd",
            "--signals",
            "none",
            "--no-plots",
            "--models",
            "svd",
            "--ranks",
            "1",
            "--out-dir",
            "cw",
        ],
        &["'wine'", "channel"],
    );
    assert!(temp_entries(dir.path()).is_empty());
}

/// A NaN in an alpha channel is found on read (naming the file, pixel and
/// channel A) and replaced by --sanitize like any other sample.
#[test]
fn nan_alpha_is_checked_on_read_and_sanitized() {
    let dir = tempfile::tempdir().unwrap();
    let mut img = ssskit::filter::Image::new(32, 24);
    img.rgb[0][5] = 1.0;
    let mut alpha = vec![1.0; 32 * 24];
    alpha[3 * 32 + 7] = f64::NAN;
    img.alpha = Some(alpha);
    ssskit::filter::image::write_exr(&dir.path().join("a.exr"), &img, None).unwrap();
    let k = kernel();
    let apply = |extra: &[&'static str]| {
        let mut v = common::apply_args(k.as_str(), "a.exr", "o.exr", "0.1", &["--backend", "cpu"]);
        v.extend_from_slice(extra);
        v
    };
    fails_in(
        dir.path(),
        &apply(&[]),
        &["a.exr", "pixel (7, 3) channel A", "--sanitize"],
    );
    ok_in(dir.path(), &apply(&["--sanitize"]));
    let (out, _) = ssskit::filter::image::read_image(&dir.path().join("o.exr"), None).unwrap();
    assert_eq!(out.non_finite().0, 0);
    assert_eq!(out.alpha.as_ref().unwrap()[3 * 32 + 7], 0.0);
}

/// A missing output folder is found before the work, named once, without
/// the internal temporary name.
#[test]
fn missing_output_folders_are_found_before_the_work() {
    let k = kernel();
    let dir = tempfile::tempdir().unwrap();
    dipole_profile(dir.path());
    dirac_png(dir.path());
    for args in [
        common::fit_args("p.json", "guided", "no/k.json", &[]),
        common::apply_args(&k, "d.png", "no/o.exr", "0.1", &[]),
        vec!["signal", "edge", "--out", "no/s.png"],
        common::profile_args("skin1", "pbd", "no/p.json", &[]),
        engine_args("p.json", "unreal", &["--out", "no/e.json"]),
    ] {
        let e = fails_in(dir.path(), &args, &["no", "does not exist"]);
        assert!(
            !e.contains(".ssskit-"),
            "temporary name in the message: {e}"
        );
        assert_eq!(e.matches("does not exist").count(), 1, "said twice: {e}");
    }
    assert!(!dir.path().join("no").exists());
}

// ---- Siblings the follow-up campaign found -------------------------------

/// A temporary folder holding a named pipe (mkfifo(1)) at each of `names`.
#[cfg(unix)]
fn with_pipes(names: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for name in names {
        let fifo = dir.path().join(name);
        let status = Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(status.success(), "mkfifo {}", fifo.display());
    }
    dir
}

/// Inputs that are named pipes nobody writes to are read as empty (a clear
/// error), not waited for; a kernel file's material is checked like a
/// material file (its name used to reach the terminal through the shader
/// comment); a folder output may not be the working folder.
#[cfg(unix)]
#[test]
fn pipes_kernel_names_and_the_working_folder() {
    let dir = with_pipes(&["p.json", "p.toml", "p.exr", "p.png"]);
    let d = dir.path();
    let started = Instant::now();
    for args in [
        common::fit_args("p.json", "svd", "k.json", &[]),
        vec!["materials", "p.toml"],
        vec!["diff", "p.exr", "p.png"],
        vec!["diff", "p.png", "p.exr"],
    ] {
        let pipe = args.iter().find(|a| a.starts_with("p.")).unwrap();
        fails_in(d, &args, &[pipe]);
    }
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "{:?}",
        started.elapsed()
    );
    let esc = edited(&kernel(), d, "esc.json", |v| {
        v["material"]["name"] = "\u{1b}[2J".into();
    });
    let o = run_in(d, &["fit", "--kernel", &esc, "--emit", "hlsl"]);
    assert!(!common::stdout(&o).contains('\u{1b}'));
    common::assert_fails(&o, &["fit"], &["esc.json", "U+001B"]);
    fails_in(d, &quick_compare("skin1", "."), &["not '.'"]);
}
