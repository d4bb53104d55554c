//! Shared by the integration tests that run the real binary: how to run it,
//! what a clean failure looks like, reading back what it wrote.
//! Include with `mod common;` (from a test file) or
//! `#[path = "../common/mod.rs"] mod common;` (from a support module).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The binary under test, ready for arguments.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ssskit"))
}

/// Runs `ssskit args...` and collects its output.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("the binary runs")
}

/// Runs `ssskit args...` in the working directory `dir`.
pub fn run_in(dir: &Path, args: &[&str]) -> Output {
    bin()
        .current_dir(dir)
        .args(args)
        .output()
        .expect("the binary runs")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs a command that must succeed; returns its standard output.
pub fn ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "ssskit {args:?} failed: {}", stderr(&o));
    stdout(&o)
}

/// Checks a clean failure: exit code 2, no panic, a message containing
/// every `needle`.
pub fn assert_fails(o: &Output, args: &[&str], needles: &[&str]) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "ssskit {args:?} should fail: {e}");
    assert!(!e.contains("panicked"), "ssskit {args:?} panicked: {e}");
    for n in needles {
        assert!(e.contains(n), "ssskit {args:?}: message lacks '{n}': {e}");
    }
}

/// Runs a command that must fail cleanly (see `assert_fails`).
pub fn fails_with(args: &[&str], needles: &[&str]) {
    assert_fails(&run(args), args, needles);
}

/// `fails_with` in the working directory `dir`.
pub fn fails_with_in(dir: &Path, args: &[&str], needles: &[&str]) {
    assert_fails(&run_in(dir, args), args, needles);
}

pub fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).expect("readable file")).expect("valid JSON")
}

/// A path as a command-line argument.
pub fn p(path: &Path) -> &str {
    path.to_str().expect("UTF-8 path")
}
