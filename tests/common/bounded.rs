//! Runs of the binary bounded in memory and in time that must not crash:
//! the harness of the hardening tests.

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Address-space cap of every run: 4 GB, far above what any hostile input
/// needs once capped, far below what an uncapped one asks for.
pub const MEMORY_BYTES: u64 = 4_000_000_000;

/// `bin args` under the memory cap: `prlimit --as` (util-linux: Debian,
/// CI) with `limits` added; without it the POSIX shell's `ulimit -v` (KiB)
/// sets the same cap before exec (and `limits` are not set), so no run is
/// unbounded. `RUST_BACKTRACE=1`, so that a panic says so.
pub fn capped(bin: &str, limits: &[&str], args: &[&str]) -> Command {
    let mut c = if Path::new("/usr/bin/prlimit").exists() {
        let mut c = Command::new("/usr/bin/prlimit");
        c.arg(format!("--as={MEMORY_BYTES}"))
            .args(limits)
            .args(["--", bin]);
        c
    } else {
        let kib = MEMORY_BYTES / 1024;
        let mut c = Command::new("sh");
        c.args(["-c", &format!("ulimit -v {kib} && exec \"$0\" \"$@\""), bin]);
        c
    };
    c.args(args).env("RUST_BACKTRACE", "1");
    c
}

/// Waits for `child` at most `limit`; a run past it is killed and fails
/// the test.
pub fn wait_bounded(mut child: Child, what: &str, limit: Duration) -> Output {
    let start = Instant::now();
    loop {
        match child.try_wait().expect("wait") {
            Some(_) => return child.wait_with_output().expect("output"),
            None if start.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{what} ran past {limit:?}: unbounded work");
            }
            None => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

/// Runs `c` to the end (bounded by `limit`) and checks it did not crash:
/// no panic, no allocation failure, no death by a signal.
pub fn run_with(mut c: Command, what: &str, limit: Duration) -> Output {
    let child = c
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn ssskit");
    let out = wait_bounded(child, what, limit);
    let err = super::stderr(&out);
    assert!(
        out.status.code().is_some(),
        "{what} was killed by a signal ({:?}): {err}",
        out.status
    );
    assert!(
        !err.contains("panicked")
            && !err.contains("RUST_BACKTRACE")
            && !err.contains("memory allocation"),
        "{what} crashed: {err}"
    );
    out
}

/// The JSON of `path` with `edit` applied, written to `dir/name`: a
/// hostile variant of a good file.
pub fn edited(path: &str, dir: &Path, name: &str, edit: impl Fn(&mut serde_json::Value)) -> String {
    let mut v = super::read_json(Path::new(path));
    edit(&mut v);
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
    p.to_string_lossy().into_owned()
}
