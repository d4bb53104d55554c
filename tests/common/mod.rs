//! Shared by the integration tests that run the real binary: how to run it,
//! what a clean failure looks like, reading back what it wrote.
//! Include with `mod common;` (from a test file) or
//! `#[path = "../common/mod.rs"] mod common;` (from a support module).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

pub mod half_space;

/// Path of the binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_ssskit");

/// The binary under test, ready for arguments.
pub fn bin() -> Command {
    Command::new(BIN)
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

/// Checks a success without a panic message; returns (stdout, stderr).
pub fn assert_ok(o: &Output, args: &[&str]) -> (String, String) {
    let e = stderr(o);
    assert!(o.status.success(), "ssskit {args:?} failed: {e}");
    assert!(!e.contains("panicked"), "ssskit {args:?} panicked: {e}");
    (stdout(o), e)
}

/// Runs a command that must succeed; returns its standard output.
pub fn ok(args: &[&str]) -> String {
    assert_ok(&run(args), args).0
}

/// `ok` in the working directory `dir`.
pub fn ok_in(dir: &Path, args: &[&str]) -> String {
    assert_ok(&run_in(dir, args), args).0
}

/// Runs a command that must succeed; returns (stdout, stderr).
pub fn ok_both(args: &[&str]) -> (String, String) {
    assert_ok(&run(args), args)
}

/// Checks a clean failure: exit code 2, no panic, a message containing
/// every `needle`. Returns the message.
pub fn assert_fails(o: &Output, args: &[&str], needles: &[&str]) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "ssskit {args:?} should fail: {e}");
    assert!(!e.contains("panicked"), "ssskit {args:?} panicked: {e}");
    for n in needles {
        assert!(e.contains(n), "ssskit {args:?}: message lacks '{n}': {e}");
    }
    e
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

/// README.md and docs/*.md (sorted): the files that hold generated blocks.
pub fn doc_markdown_files() -> Vec<std::path::PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut docs: Vec<_> = std::fs::read_dir(root.join("docs"))
        .expect("docs/ readable")
        .map(|e| e.expect("docs/ entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    let mut files = vec![root.join("README.md")];
    files.extend(docs);
    files
}

/// Monte Carlo test cases and checks shared by the CPU and GPU tracer
/// tests: materials with exact answers, a fixed-budget configuration,
/// 4-sigma agreement and the energy balance.
pub mod mc {
    use ssskit::material::{parse_material_toml, Channel, Material};
    use ssskit::profile::mc::{EnergyBalance, McConfig, PhotonBudget};
    use ssskit::profile::{Profile, RadialGrid};

    /// n = 1, sigma_a = 1, sigma_s = 9 /mm, g = 0.75, d = 0.2 mm: the
    /// adding-doubling R_d and T of van de Hulst 1980.
    pub const SLAB: &str =
        "unit = \"mm\"\nsigma_a = 1.0\nsigma_s = 9.0\ng = 0.75\neta = 1.0\nthickness = 0.2\n";
    pub const SLAB_RD: f64 = 0.09739;
    pub const SLAB_T: f64 = 0.66096;

    /// Isotropic half-space of albedo 0.9 (sigma_a = 0.1, sigma_s = 0.9 /mm)
    /// with exact (Chandrasekhar H-function) totals, as (eta, R_d,
    /// specular): n = 1, and n = 1.5 under air.
    pub const ALBEDO_09: [(f64, f64, f64); 2] = [(1.0, 0.41495, 0.0), (1.5, 0.21993, 0.04)];

    pub fn albedo_09(eta: f64) -> Material {
        material(&format!(
            "unit = \"mm\"\nsigma_a = 0.1\nsigma_s = 0.9\neta = {eta}\n"
        ))
    }

    pub fn material(toml: &str) -> Material {
        parse_material_toml(toml, "test.toml", "test").expect("valid test material")
    }

    /// `photons` per channel of channel `ch`, seed 2024.
    pub fn cfg(photons: u64, ch: Channel, grid: Option<RadialGrid>) -> McConfig {
        McConfig {
            budget: PhotonBudget::Fixed(photons),
            seed: 2024,
            threads: None,
            channels: vec![ch],
            grid,
        }
    }

    /// `x` within 4 standard errors `sigma` of `truth`.
    pub fn within(x: f64, truth: f64, sigma: f64, what: &str) {
        assert!(sigma > 0.0, "{what}: zero standard error");
        assert!(
            (x - truth).abs() <= 4.0 * sigma,
            "{what}: {x} vs {truth}, {:.2} sigma (sigma {sigma:.2e})",
            (x - truth) / sigma
        );
    }

    /// specular + R_d + T + absorbed + roulette/truncation residual = 1
    /// within `tol` in every channel.
    pub fn assert_balance(p: &Profile, tol: f64) {
        for &c in &p.channels {
            let d = EnergyBalance::of(p, c)
                .expect("a readable balance")
                .expect("balance recorded")
                .sum_minus_1;
            eprintln!("{} {}: balance - 1 = {d:.2e}", p.material.name, c.name());
            assert!(
                d.abs() < tol,
                "{} {}: energy balance off by {d}",
                p.material.name,
                c.name()
            );
        }
    }
}
