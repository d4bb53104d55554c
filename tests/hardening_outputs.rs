//! The third campaign's output classes on the real binary: a device node or
//! a named pipe at an output path is written in place and stays what it
//! was (never renamed over); a symbolic link to a file is written through;
//! the outputs of one command never replace its inputs or each other; a
//! render and its record are committed as one; a render is never written
//! that its own read-back refuses.

#![cfg(unix)]

mod common;

use common::args::{engine_args, words};
use common::{assert_fails, assert_ok, p, run_in};
use std::os::unix::fs::{FileTypeExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::process::Output;

const REPO: &str = env!("CARGO_MANIFEST_DIR");
/// The null device's numbers on Linux (major 1, minor 3): writes vanish.
const NULL_DEV: (u32, u32) = (1, 3);
/// The full device's numbers on Linux (major 1, minor 7): writes fail with
/// ENOSPC.
const FULL_DEV: (u32, u32) = (1, 7);

/// A small scene (16 x 12 pixels) that renders in a fraction of a second.
const SPHERE: &str = "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 60]\n\
look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 30\nsize = [16, 12]\n[[light]]\ntype = \
\"directional\"\ntoward = [0.6, 0, 0.8]\nirradiance = 2\n[[object]]\nshape = \"sphere\"\n\
center = [0, 0, 0]\nradius = 10\nmaterial = \"skin1\"\neta = 1.0\n";

/// `SPHERE` under a light of irradiance `irradiance`.
fn sphere_lit(irradiance: &str) -> String {
    SPHERE.replace("irradiance = 2", &format!("irradiance = {irradiance}"))
}

fn cstr(path: &Path) -> std::ffi::CString {
    std::ffi::CString::new(p(path)).unwrap()
}

/// Makes a character device node (`mknod`); false only when not root (the
/// node cannot be made, and the caller says so); as root a failure fails.
fn make_device(path: &Path, (major, minor): (u32, u32)) -> bool {
    // SAFETY: a NUL-terminated path; mknod and geteuid have no other inputs.
    let r = unsafe {
        libc::mknod(
            cstr(path).as_ptr(),
            libc::S_IFCHR | 0o666,
            libc::makedev(major, minor),
        )
    };
    if r == 0 {
        return true;
    }
    let err = std::io::Error::last_os_error();
    // SAFETY: no arguments.
    assert_ne!(
        unsafe { libc::geteuid() },
        0,
        "mknod {} failed as root: {err}",
        path.display()
    );
    eprintln!("not root: mknod is refused ({err}); the device cases are not run");
    false
}

fn make_fifo(path: &Path) {
    // SAFETY: a NUL-terminated path.
    let r = unsafe { libc::mkfifo(cstr(path).as_ptr(), 0o644) };
    assert_eq!(r, 0, "mkfifo: {}", std::io::Error::last_os_error());
}

fn assert_device(path: &Path, (major, minor): (u32, u32), what: &str) {
    let m = std::fs::symlink_metadata(path).unwrap_or_else(|e| panic!("{what}: node gone: {e}"));
    assert!(
        m.file_type().is_char_device(),
        "{what}: {} is no longer a character device: {:?}",
        path.display(),
        m.file_type()
    );
    assert_eq!(
        m.rdev(),
        libc::makedev(major, minor),
        "{what}: other device"
    );
}

/// A reader of the named pipe at `path`, returning what it read once
/// `done` is set and no writer is left. It opens without waiting (a pipe
/// opened for reading would wait for a writer, forever if the run replaced
/// the pipe instead of opening it) and polls.
fn reader(
    path: &Path,
    done: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> std::thread::JoinHandle<Vec<u8>> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .unwrap();
    std::thread::spawn(move || {
        use std::io::Read;
        let mut bytes = Vec::new();
        let mut buf = vec![0u8; 1 << 16];
        loop {
            match file.read(&mut buf) {
                Ok(0) if done.load(std::sync::atomic::Ordering::SeqCst) => return bytes,
                Ok(n) => bytes.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(e) => panic!("reading the pipe: {e}"),
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
    })
}

/// The outputs of every kind: a command with `@` where the output goes,
/// its extension, and the first bytes of what is written.
fn cases(d: &Path) -> Vec<(Vec<String>, &'static str, &'static [u8])> {
    let profile = format!("{REPO}/profiles/reference/skin1.json");
    let kernel = format!("{REPO}/kernels/marble-svd1.json");
    let image = p(&d.join("a.png")).to_string();
    let scene = p(&d.join("s.toml")).to_string();
    let exr: &[u8] = &[0x76, 0x2f, 0x31, 0x01];
    let png: &[u8] = b"\x89PNG";
    let dir = p(d).to_string();
    // The command with its placeholders filled, split at spaces.
    let c = |s: &str| {
        let s = s
            .replace("{profile}", &profile)
            .replace("{kernel}", &kernel);
        let s = s.replace("{image}", &image).replace("{scene}", &scene);
        let s = s.replace("{dir}", &dir);
        s.split(' ').map(str::to_string).collect::<Vec<_>>()
    };
    #[rustfmt::skip] // one line a case: the table reads as one
    let table: [(&str, &str, &[u8]); 9] = [
        ("simulate --material skin1 --photons 1000 --out @", "json", b"{"),
        ("simulate --material skin1 --photons 1000 --out {dir}/sim.json --csv @", "csv", b"r_inner_mm"),
        ("fit --profile {profile} --model svd --out @", "json", b"{"),
        ("engine --profile {profile} --engine unreal --out @", "json", b"{"),
        ("engine --profile {profile} --engine unreal --plot @", "png", png),
        ("apply --kernel {kernel} --input {image} --mm-per-pixel 0.1 --out @", "exr", exr),
        ("apply --kernel {kernel} --input {image} --mm-per-pixel 0.1 --out @", "png", png),
        ("diff {image} {image} --out @", "png", png),
        ("scene {scene} --out {dir}/r.exr --spp 2 --profile-photons 2000 --irradiance-out @", "exr", exr),
    ];
    table
        .iter()
        .map(|(cmd, ext, magic)| (c(cmd), *ext, *magic))
        .collect()
}

fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SPHERE).unwrap();
    let o = run_in(
        d,
        &["signal", "dirac", "--image-size", "64x48", "--out", "a.png"],
    );
    assert_ok(&o, &["signal"]);
    dir
}

fn with_output(args: &[String], out: &Path) -> Vec<String> {
    args.iter()
        .map(|a| {
            if a == "@" {
                p(out).to_string()
            } else {
                a.clone()
            }
        })
        .collect()
}

/// `cases` with their outputs at `d/{stem}{i}.{ext}`: each command, that
/// path and the first bytes written.
fn cases_writing_to(d: &Path, stem: &str) -> Vec<(Vec<String>, PathBuf, &'static [u8])> {
    let numbered = cases(d).into_iter().enumerate();
    numbered
        .map(|(i, (args, ext, magic))| {
            let out = d.join(format!("{stem}{i}.{ext}"));
            (with_output(&args, &out), out, magic)
        })
        .collect()
}

fn run_args(d: &Path, args: &[String]) -> Output {
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    run_in(d, &refs)
}

/// Every kind of file output written to a device node it finds at its
/// path: the run succeeds and the node is still the null device.
#[test]
fn device_nodes_at_output_paths_are_written_in_place() {
    let dir = setup();
    let d = dir.path();
    for (args, node, _) in cases_writing_to(d, "node") {
        if !make_device(&node, NULL_DEV) {
            return;
        }
        assert_ok(&run_args(d, &args), &[]);
        assert_device(&node, NULL_DEV, &args.join(" "));
    }
    // A full device says so and stays.
    let full = d.join("full.json");
    assert!(make_device(&full, FULL_DEV));
    let profile = format!("{REPO}/profiles/reference/skin1.json");
    let args = engine_args(&profile, "unreal", &["--out", p(&full)]);
    assert_fails(&run_in(d, &args), &args, &["full.json", "No space left"]);
    assert_device(&full, FULL_DEV, "engine --out full");
    // Standard output as a file (`/dev/stdout` is such a link; this one is
    // in the test's folder, so that a broken build replaces only it): the
    // JSON arrives in the pipe.
    std::os::unix::fs::symlink("/proc/self/fd/1", d.join("stdout")).unwrap();
    let args = engine_args(&profile, "unreal", &["--out", "stdout"]);
    let (out, _) = assert_ok(&run_in(d, &args), &args);
    assert!(out.contains("\"engine\""), "{out}");
    assert!(std::fs::symlink_metadata(d.join("stdout"))
        .unwrap()
        .file_type()
        .is_symlink());
}

/// Every kind of file output written into a named pipe it finds at its
/// path: a reader gets the whole file and the pipe stays a pipe.
#[test]
fn named_pipes_at_output_paths_are_written_in_place() {
    let dir = setup();
    let d = dir.path();
    for (args, fifo, magic) in cases_writing_to(d, "fifo") {
        make_fifo(&fifo);
        let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let got = reader(&fifo, done.clone());
        let o = run_args(d, &args);
        done.store(true, std::sync::atomic::Ordering::SeqCst);
        let bytes = got.join().unwrap();
        assert_ok(&o, &[]);
        let what = args.join(" ");
        assert!(
            std::fs::symlink_metadata(&fifo)
                .unwrap()
                .file_type()
                .is_fifo(),
            "{what}: the pipe was replaced"
        );
        assert!(
            bytes.starts_with(magic),
            "{what}: read {:?}",
            &bytes[..bytes.len().min(16)]
        );
    }
}

/// A folder replaced as a whole is refused when a pipe or a device sits in
/// it, even one an earlier run wrote (it holds the marker).
#[test]
fn output_folders_holding_a_pipe_or_a_device_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let k = d.join("k");
    std::fs::create_dir(&k).unwrap();
    std::fs::write(k.join(".ssskit-output"), "ssskit output folder\n").unwrap();
    make_fifo(&k.join("report.md"));
    let profile = format!("{REPO}/profiles/reference/skin1.json");
    let args = [
        "kernels",
        "--profile",
        &profile,
        "--no-plots",
        "--out-dir",
        p(&k),
    ];
    assert_fails(&run_in(d, &args), &args, &["report.md", "named pipe"]);
    assert!(std::fs::symlink_metadata(k.join("report.md"))
        .unwrap()
        .file_type()
        .is_fifo());
    std::fs::remove_file(k.join("report.md")).unwrap();
    if make_device(&k.join("profile.json"), NULL_DEV) {
        assert_fails(&run_in(d, &args), &args, &["profile.json", "device"]);
        assert_device(&k.join("profile.json"), NULL_DEV, "kernels --out-dir");
    }
}

/// A link to a file is written through: the file gets the output, the
/// link stays; a link to nothing and a socket are refused before the work.
#[test]
fn links_are_written_through_and_sockets_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let profile = format!("{REPO}/profiles/reference/skin1.json");
    let real = d.join("real.json");
    std::fs::write(&real, "old").unwrap();
    let link = d.join("link.json");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let args = engine_args(&profile, "unreal", &["--out", "link.json"]);
    assert_ok(&run_in(d, &args), &args);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&real)
        .unwrap()
        .contains("\"engine\""));
    std::os::unix::fs::symlink(d.join("nowhere"), d.join("gone.json")).unwrap();
    let args = engine_args(&profile, "unreal", &["--out", "gone.json"]);
    assert_fails(&run_in(d, &args), &args, &["gone.json", "link to nothing"]);
    let _sock = std::os::unix::net::UnixListener::bind(d.join("s.json")).unwrap();
    let args = engine_args(&profile, "unreal", &["--out", "s.json"]);
    assert_fails(&run_in(d, &args), &args, &["s.json", "socket"]);
    let args = engine_args(&profile, "unreal", &["--out", "e.txt"]);
    assert_fails(&run_in(d, &args), &args, &["e.txt", "must end in .json"]);
}

// ---- 2. Outputs never destroy inputs or each other ------------------------

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap()
}

/// Runs `args` in `d`, which must fail naming `needles` (see
/// `assert_fails`) within seconds, before any work; the message.
fn refused_before_the_work(d: &Path, args: &[&str], needles: &[&str]) -> String {
    let t = std::time::Instant::now();
    let e = assert_fails(&run_in(d, args), args, needles);
    assert!(
        t.elapsed().as_secs() < 5,
        "{args:?}: refused after the work"
    );
    e
}

/// Each refused before any work, every file as it was.
#[test]
fn outputs_never_replace_inputs_or_each_other() {
    let dir = setup();
    let d = dir.path();
    std::fs::copy(d.join("a.png"), d.join("b.png")).unwrap();
    std::fs::write(d.join("o.json"), SPHERE).unwrap();
    std::fs::write(d.join("skin1.json"), "{\"mine\": 1}").unwrap();
    let profile = d.join("p.json");
    std::fs::copy(format!("{REPO}/profiles/reference/skin1.json"), &profile).unwrap();
    let before: Vec<(PathBuf, Vec<u8>)> = ["a.png", "b.png", "o.json", "skin1.json", "p.json"]
        .iter()
        .map(|n| (d.join(n), bytes(&d.join(n))))
        .collect();
    #[rustfmt::skip] // one line a case: the table reads as one
    let cases: [(&str, &[&str]); 7] = [
        ("diff a.png b.png --out a.png", &["--out", "A reads"]),
        ("scene s.toml --out r.exr --irradiance-out r.exr --spp 2", &["--irradiance-out", "--out", "same file"]),
        ("engine --profile p.json --engine unreal --out p.json", &["--out", "--profile reads"]),
        ("scene o.json --out o.exr --spp 2", &["the record of --out", "SCENE.toml reads"]),
        ("scene s.toml --out r.exr --irradiance-out r.json --spp 2", &["same file"]),
        ("scene s.toml --out skin1.exr --spp 2", &["skin1.json", "not a render's record"]),
        ("kernels --profile k/p.json --out-dir k", &["--profile", "inside --out-dir"]),
    ];
    std::fs::create_dir(d.join("k")).unwrap();
    std::fs::copy(&profile, d.join("k/p.json")).unwrap();
    for (args, needles) in cases {
        refused_before_the_work(d, &words(args), needles);
    }
    for (path, old) in before {
        assert_eq!(bytes(&path), old, "{} changed", path.display());
    }
    assert!(d.join("k/p.json").exists());
    assert!(!d.join("o.exr").exists() && !d.join("r.exr").exists());
}

/// Two runs writing the same `--out` at once leave the image and the
/// record of one of them: two scenes that differ in their light only (so
/// the runs take the same time and race), each image known from a run of
/// its own (the same seed gives the same pixels).
#[test]
fn concurrent_renders_leave_one_runs_pair() {
    // Rounds of two racing runs: the mix the issue saw came 1 in 5 tries,
    // and the old code (image and record committed one after the other)
    // failed by round 7 in three runs of three.
    const ROUNDS: usize = 16;
    let dir = common::temp_with(&[("a.toml", SPHERE), ("b.toml", &sphere_lit("3"))]);
    let d = dir.path();
    let render = |toml: &str, out: &str| {
        common::bin()
            .current_dir(d)
            .args(["scene", toml, "--out", out, "--spp", "2"])
            .args(["--profile-photons", "2000", "--seed", "7"])
            .output_async()
    };
    let planes = |exr: &str| ssskit::filter::image::read_exr_channels(&d.join(exr)).unwrap();
    for (toml, exr) in [("a.toml", "a.exr"), ("b.toml", "b.exr")] {
        assert!(render(toml, exr)
            .wait_with_output()
            .unwrap()
            .status
            .success());
    }
    let (alone_a, alone_b) = (planes("a.exr"), planes("b.exr"));
    assert!(alone_a != alone_b, "the two scenes render alike");
    for round in 0..ROUNDS {
        let (a, b) = (render("a.toml", "r.exr"), render("b.toml", "r.exr"));
        let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
        for o in [&a, &b] {
            assert!(o.status.success(), "round {round}: {}", common::stderr(o));
        }
        let record = common::read_json(&d.join("r.json"));
        let scene = record["scene"].as_str().unwrap();
        let expected = if scene.contains("irradiance = 3") {
            &alone_b
        } else {
            &alone_a
        };
        assert!(
            planes("r.exr") == *expected,
            "round {round}: the image of one run with the record of the other"
        );
    }
}

trait Async {
    fn output_async(&mut self) -> std::process::Child;
}

impl Async for std::process::Command {
    fn output_async(&mut self) -> std::process::Child {
        self.stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    }
}

// ---- 4. Results that are always readable ----------------------------------

/// True when `text` holds a run of more digits than any message needs.
fn has_long_number(text: &str) -> bool {
    // More digits than a u64 (20) and the shortened form of any f64 (17).
    const TOO_MANY: usize = 24;
    text.split(|c: char| !c.is_ascii_digit())
        .any(|run| run.len() > TOO_MANY)
}

/// One sample per pixel (whose noise is undefined) and a light the f32
/// image cannot hold are refused before the render, with short numbers; a
/// render of two samples states its noise and is read back.
#[test]
fn renders_are_readable_or_refused_before_the_work() {
    let dir = common::temp_with(&[("s.toml", SPHERE), ("hot.toml", &sphere_lit("1e308"))]);
    let d = dir.path();
    #[rustfmt::skip] // one line a case: the table reads as one
    let cases: [(&str, &[&str]); 3] = [
        ("scene s.toml --out r.exr --spp 1", &["--spp", "must be >= 2"]),
        ("scene s.toml --out r.exr --max-spp 1", &["--max-spp", "must be >= 2"]),
        ("scene hot.toml --out r.exr --spp 2", &["irradiance", "1e308", "at most 1e30"]),
    ];
    for (args, needles) in cases {
        let e = refused_before_the_work(d, &words(args), needles);
        assert!(!has_long_number(&e), "{e}");
        assert!(!d.join("r.exr").exists() && !d.join("r.json").exists());
    }
    let args = words("scene s.toml --out r.exr --spp 2 --profile-photons 2000");
    assert_ok(&run_in(d, &args), &args);
    let record = common::read_json(&d.join("r.json"));
    let noise = record["info"]["noise"].as_array().unwrap();
    assert!(
        noise.iter().all(|v| v.as_f64().is_some_and(f64::is_finite)),
        "{noise:?}"
    );
}
