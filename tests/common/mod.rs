//! Shared by the integration tests that run the real binary: how to run it,
//! what a clean failure looks like, reading back what it wrote.
//! Include with `mod common;` (from a test file) or
//! `#[path = "../common/mod.rs"] mod common;` (from a support module).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

pub mod adding_doubling;
pub mod args;
pub mod backlit_meshes;
pub mod bounded;
pub mod budgets;
pub mod burley;
pub mod fit_order;
pub mod fixed_point;
pub mod golden;
pub mod half_space;
pub mod inputs;
pub mod mcml;
pub mod scenes;
pub mod shader;
pub mod skin1;
pub mod srgb;

/// Standard errors a statistical check allows: a correct estimate with
/// normal errors lands beyond 4 sigma once in about 16,000 checks
/// (two-sided 6.3e-5); with fixed seeds a check that passes once always
/// passes.
pub const SIGMAS: f64 = 4.0;

/// Quantities equal in real arithmetic (the same formula evaluated twice, a
/// total against the sum of its parts, a number read back from JSON, which
/// serde_json writes to round-trip exactly): f64 round-off of a few hundred
/// operations on numbers of order 1 (each rounding by epsilon = 2.2e-16)
/// stays far below it. Absolute for numbers of order 1, else relative.
pub const EXACT: f64 = 1e-12;

/// The one bless switch of the suite: `SSSKIT_BLESS=1` rewrites goldens,
/// records and generated docs; unset, empty or `0` checks them. Any other
/// value is a typo that would otherwise check (or bless) silently, so it
/// fails the test that reads it.
pub fn bless() -> bool {
    match std::env::var("SSSKIT_BLESS") {
        Err(std::env::VarError::NotPresent) => false,
        Ok(v) if v.is_empty() || v == "0" => false,
        Ok(v) if v == "1" => true,
        Ok(v) => panic!("SSSKIT_BLESS={v:?}: use 1 to bless, 0 or unset to check"),
        Err(e) => panic!("SSSKIT_BLESS: {e}"),
    }
}

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

/// The sharded run the cluster tests split and merge: skin1, 60000
/// photons, seed 5.
pub const SHARDED_RUN: [&str; 7] = [
    "simulate",
    "--material",
    "skin1",
    "--photons",
    "60000",
    "--seed",
    "5",
];

/// The arguments of `ssskit simulate --material skin1 --photons 20000
/// --seed seed --out out` (a profile of seconds, noisy), then `extra`.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn simulate_skin1_args<'a>(seed: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let fixed = ["simulate", "--material", "skin1", "--photons", "20000", "--seed", seed];
    [&fixed[..], &["--out", out], extra].concat()
}

/// The arguments of `ssskit scene s.toml --out s.exr`, then `extra`: a
/// scene rendered in the working folder.
pub fn scene_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    [&["scene", "s.toml", "--out", "s.exr"][..], extra].concat()
}

/// The arguments of `ssskit cmd --material skin1 --profile-model pbd`
/// (`--materials` for `compare`), then `extra`: a command on skin1's
/// analytic profile (no Monte Carlo).
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn skin1_pbd_args<'a>(cmd: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let material = if cmd == "compare" { "--materials" } else { "--material" };
    [&[cmd, material, "skin1", "--profile-model", "pbd"][..], extra].concat()
}

/// The arguments of `ssskit profile --material material --profile-model
/// model --out out`, then `extra`.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn profile_args<'a>(material: &'a str, model: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&["profile", "--material", material, "--profile-model", model, "--out", out][..], extra].concat()
}

/// The arguments of `ssskit fit --profile profile --model model --out
/// out`, then `extra`.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn fit_args<'a>(profile: &'a str, model: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&["fit", "--profile", profile, "--model", model, "--out", out][..], extra].concat()
}

/// The arguments of `ssskit apply --kernel k --input input --out out
/// --mm-per-pixel mm`, then `extra`.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn apply_args<'a>(k: &'a str, input: &'a str, out: &'a str, mm: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let fixed = ["apply", "--kernel", k, "--input", input, "--out", out, "--mm-per-pixel", mm];
    [&fixed[..], extra].concat()
}

/// The one spelling of a plain filter `Setup` the tests and benches
/// share: `passes` at `mm_per_pixel`, no depth, strength, follow-surface,
/// specular or jitter (change a field with `Setup { .., ..plain_setup() }`).
pub fn plain_setup(passes: Vec<ssskit::filter::Taps>, mm_per_pixel: f64) -> ssskit::filter::Setup {
    ssskit::filter::Setup {
        passes,
        scale: ssskit::filter::Scale::MmPerPixel(mm_per_pixel),
        depth: None,
        strength: None,
        follow_surface: None,
        specular: None,
        jitter: false,
    }
}

/// A depth-aware `Setup`: `passes` under a perspective camera of vertical
/// field of view `fov_y_deg` and SSS width `sss_width` (scene units per
/// kernel mm), `depth` per pixel and the follow-surface lerp `follow`.
pub fn perspective_setup(
    passes: Vec<ssskit::filter::Taps>,
    (fov_y_deg, sss_width): (f64, f64),
    depth: ssskit::filter::Plane,
    follow: ssskit::filter::FollowSurface,
) -> ssskit::filter::Setup {
    ssskit::filter::Setup {
        scale: ssskit::filter::Scale::Perspective {
            fov_y_deg,
            sss_width,
        },
        depth: Some(depth),
        follow_surface: Some(follow),
        ..plain_setup(passes, 1.0)
    }
}

/// Runs `cmd` (any program; `what` names it in messages), which must
/// succeed; its output.
pub fn output_ok(cmd: &mut Command, what: &str) -> Output {
    let o = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what} does not run: {e}"));
    assert!(o.status.success(), "{what} failed: {}", stderr(&o));
    o
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

/// `ssskit transmission` of skin1 index-matched (`--eta 1`, as the
/// back-lit scenes' objects), 6 slabs from 0.5 to 10 mm, written to
/// DIR/t.json (its path); `extra` adds flags (photons, seed, engines).
pub fn skin1_table(dir: &Path, extra: &[&str]) -> std::path::PathBuf {
    let mut args = vec![
        "transmission",
        "--material",
        "skin1",
        "--eta",
        "1",
        "--thickness",
        "0.5..10",
        "--steps",
        "6",
        "--out",
        "t.json",
    ];
    args.extend_from_slice(extra);
    ok_in(dir, &args);
    dir.join("t.json")
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

/// A temporary folder holding `files` (name, text).
pub fn temp_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

pub fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).expect("readable file")).expect("valid JSON")
}

/// Replaces the body of the `<!-- BEGIN KIND:NAME -->` block of `text`
/// (as `blocks_of` reads it) with `body`: how the docs tests bless.
pub fn replace_block(text: &mut String, kind: &str, name: &str, body: &str) {
    let begin = format!("<!-- BEGIN {kind}:{name} -->\n");
    let end = format!("<!-- END {kind}:{name} -->");
    let i = text.find(&begin).unwrap() + begin.len();
    let j = i + text[i..].find(&end).unwrap();
    text.replace_range(i..j, body);
}

/// Every `<!-- BEGIN KIND:NAME -->` block of the docs' markdown of each of
/// `kinds`, against `fresh(kind, name, file)`: rewritten under
/// `SSSKIT_BLESS=1` (atomically), else listed as stale with both texts.
/// Returns how many blocks were checked and the stale ones.
pub fn check_doc_blocks(
    kinds: &[&str],
    fresh: impl Fn(&str, &str, &Path) -> String,
) -> (usize, Vec<String>) {
    use ssskit::report::present::kernel_report::blocks_of;
    let bless = bless();
    let (mut checked, mut stale) = (0, Vec::new());
    for f in doc_markdown_files() {
        let mut text = std::fs::read_to_string(&f).unwrap();
        let mut changed = false;
        for kind in kinds {
            for (name, body) in blocks_of(&text.clone(), kind) {
                let want = fresh(kind, &name, &f);
                checked += 1;
                if want == body {
                    continue;
                }
                if bless {
                    replace_block(&mut text, kind, &name, &want);
                    changed = true;
                } else {
                    stale.push(format!(
                        "{}: {kind}:{name}\n--- committed\n{body}--- now\n{want}",
                        f.display()
                    ));
                }
            }
        }
        if changed {
            ssskit::io::write_atomic(&f, text.as_bytes()).unwrap();
        }
    }
    (checked, stale)
}

/// Checks that two profiles are the same run, bit for bit, but for the
/// wall time; on a failure names the fields that differ (not the arrays).
pub fn assert_same_run(a: &Path, b: &Path) {
    let (mut x, mut y) = (read_json(a), read_json(b));
    x["elapsed_s"] = 0.0.into();
    y["elapsed_s"] = 0.0.into();
    let keys: Vec<&String> = x
        .as_object()
        .unwrap()
        .iter()
        .filter(|(k, v)| y.get(k.as_str()) != Some(v))
        .map(|(k, _)| k)
        .collect();
    assert!(
        x == y,
        "{} differs from {} in {keys:?}",
        a.display(),
        b.display()
    );
}

/// A path as a command-line argument.
pub fn p(path: &Path) -> &str {
    path.to_str().expect("UTF-8 path")
}

/// `ssskit profile --material M --profile-model pbd` into `dir`: an
/// analytic profile in milliseconds, without Monte Carlo noise.
pub fn pbd_profile(dir: &Path, material: &str) -> std::path::PathBuf {
    let out = dir.join(format!("{material}-pbd.json"));
    ok(&[
        "profile",
        "--material",
        material,
        "--profile-model",
        "pbd",
        "--out",
        p(&out),
    ]);
    out
}

/// `ssskit apply --reference PROFILE --reference-sampling centre`: the
/// exact image `compare` and `advise` score kernels against; its stderr.
pub fn centre_reference(profile: &Path, input: &Path, mm_per_pixel: &str, out: &Path) -> String {
    ok_both(&[
        "apply",
        "--reference",
        p(profile),
        "--reference-sampling",
        "centre",
        "--input",
        p(input),
        "--mm-per-pixel",
        mm_per_pixel,
        "--out",
        p(out),
    ])
    .1
}

/// A profile committed under profiles/reference/ (`material`.json).
pub fn committed_profile(material: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("profiles/reference/{material}.json"))
}

/// `ssskit diff A B --json`'s relative RMS per channel.
/// `ssskit advise --json` on the committed skin1 profile at
/// `mm_per_pixel`, 64-pixel signals, and `extra`: its answer and stderr.
pub fn advise_skin1_at(mm_per_pixel: &str, extra: &[&str]) -> (serde_json::Value, String) {
    let profile = committed_profile("skin1");
    let mut args = vec![
        "advise",
        "--profile",
        p(&profile),
        "--mm-per-pixel",
        mm_per_pixel,
        "--signal-size",
        "64",
        "--json",
    ];
    args.extend(extra);
    let (out, err) = ok_both(&args);
    (serde_json::from_str(&out).unwrap(), err)
}

pub fn diff_channels(a: &Path, b: &Path) -> [f64; 3] {
    let (out, _) = ok_both(&["diff", p(a), p(b), "--json"]);
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    std::array::from_fn(|c| v["rms_rel"][c].as_f64().unwrap())
}

/// The largest of `diff_channels`: the relative RMS a target bounds.
pub fn diff_rel(a: &Path, b: &Path) -> f64 {
    diff_channels(a, b).into_iter().fold(0.0, f64::max)
}

/// `ssskit kernels --material skin1 --profile-model pbd` (the analytic
/// profile: no Monte Carlo noise) into `out` with `size`-pixel signals and
/// `extra`; its stdout and stderr.
pub fn skin1_kernels(out: &Path, size: &str, extra: &[&str]) -> (String, String) {
    let mut args = vec![
        "kernels",
        "--material",
        "skin1",
        "--profile-model",
        "pbd",
        "--signal-size",
        size,
        "--out-dir",
        p(out),
    ];
    args.extend(extra);
    ok_both(&args)
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

    /// Total diffuse reflectance of an isotropically scattering half-space
    /// of single-scattering albedo `albedo` under a normal beam, index
    /// matched (n = 1): the plane albedo 1 - H(1) sqrt(1 - albedo)
    /// (Chandrasekhar 1960, ch. 5), with H solved from
    /// 1/H(mu) = sqrt(1 - albedo) + (albedo/2) int_0^1 mu' H(mu')/(mu + mu') dmu'
    /// by fixed-point iteration on 64 Gauss-Legendre nodes in t = sqrt(mu)
    /// (H has a mu ln mu term at 0). Reproduces `ALBEDO_09` to 3e-6.
    pub fn isotropic_half_space_total(albedo: f64) -> f64 {
        let (t, w) = gauss_legendre_nodes(64);
        let mu: Vec<f64> = t.iter().map(|t| 0.25 * (t + 1.0) * (t + 1.0)).collect();
        // dmu = 2 t' dt' with t' = (t + 1)/2 on [0, 1], dt' = dt/2.
        let wmu: Vec<f64> = t.iter().zip(&w).map(|(t, w)| 0.5 * w * (t + 1.0)).collect();
        let root = (1.0 - albedo).sqrt();
        let inv_h = |m: f64, h: &[f64]| {
            root + 0.5
                * albedo
                * mu.iter()
                    .zip(&wmu)
                    .zip(h)
                    .map(|((x, w), h)| w * x * h / (m + x))
                    .sum::<f64>()
        };
        let h = super::fixed_point::iterate(vec![1.0; mu.len()], 10_000, 1e-15, |h| {
            mu.iter().map(|&m| 1.0 / inv_h(m, h)).collect()
        });
        1.0 - root / inv_h(1.0, &h)
    }

    /// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre
    /// recurrence).
    fn gauss_legendre_nodes(n: usize) -> (Vec<f64>, Vec<f64>) {
        let (mut xs, mut ws) = (Vec::new(), Vec::new());
        for i in 1..=n {
            let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            xs.push(x);
            ws.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        (xs, ws)
    }

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

    /// The kernel-factor rule at 2% relative error, capped at 10^7 photons
    /// a channel, all channels, seed 3: the adaptive run the tests share.
    pub fn kernel_factor_cfg() -> McConfig {
        McConfig {
            budget: PhotonBudget::KernelFactor {
                rel: 0.02,
                max_photons: 10_000_000,
            },
            seed: 3,
            channels: Channel::ALL.to_vec(),
            ..cfg(0, Channel::R, None)
        }
    }

    /// `x` within 4 standard errors `sigma` of `truth`.
    pub fn within(x: f64, truth: f64, sigma: f64, what: &str) {
        assert!(sigma > 0.0, "{what}: zero standard error");
        assert!(
            (x - truth).abs() <= super::SIGMAS * sigma,
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

/// Measured numbers a test pins: kept in a record, `docs/records/NAME.json`
/// (shown in the docs by its `<!-- BEGIN record:NAME/TABLE -->` blocks),
/// with the rationale for pinning them, instead of in the test's code.
/// The runs behind them are deterministic (fixed seeds, any thread count),
/// so a number that moves is a change of the code: the test fails naming
/// it; `SSSKIT_BLESS=1 cargo test --release --test TEST` rewrites the
/// record (review `git diff docs/records/`), and scripts/regen-docs the
/// blocks.
pub mod measured {
    use ssskit::report::present::record::{docs_path, Record, RecordTable};
    use std::collections::BTreeMap;

    /// What a seeded measurement records as its machine: the platform it
    /// pins. Fixed seeds give the same numbers at any thread count, but
    /// `ln`, `exp` and `sin` come from the platform's maths library, so on
    /// another platform a Monte Carlo number may move within its standard
    /// error; the 1e-9 check ([`MOVED`]) holds on the platform recorded.
    pub fn machine() -> String {
        format!(
            "{} {}, {PINNED}",
            std::env::consts::ARCH,
            std::env::consts::OS
        )
    }

    /// The second half of [`machine`].
    pub const PINNED: &str = "pinned to that platform (fixed seeds: the same numbers at any \
                              thread count; another platform's maths library may move them \
                              within their standard errors)";

    /// Relative difference beyond which a recorded number has moved.
    pub const MOVED: f64 = 1e-9;

    fn walk(path: &str, want: &serde_json::Value, got: &serde_json::Value, out: &mut Vec<String>) {
        use serde_json::Value;
        match (want, got) {
            (Value::Number(a), Value::Number(b)) => {
                let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
                if (a - b).abs() > MOVED * a.abs().max(b.abs()) {
                    out.push(format!("{path}: recorded {a:e}, measured {b:e}"));
                }
            }
            (Value::Array(a), Value::Array(b)) if a.len() == b.len() => {
                for (i, (x, y)) in a.iter().zip(b).enumerate() {
                    walk(&format!("{path}[{i}]"), x, y, out);
                }
            }
            (Value::Object(a), Value::Object(b)) if a.len() == b.len() => {
                for (k, x) in a {
                    match b.get(k) {
                        Some(y) => walk(&format!("{path}.{k}"), x, y, out),
                        None => out.push(format!("{path}.{k}: not measured any more")),
                    }
                }
            }
            (a, b) if a == b => {}
            (a, b) => out.push(format!("{path}: recorded {a}, measured {b}")),
        }
    }

    /// Checks (or, under SSSKIT_BLESS=1, writes) record `name`: `tables`
    /// as shown in the docs, `data` the raw numbers, `rationale` why they
    /// are pinned; `test` names the test binary for the bless hint.
    pub fn check(
        name: &str,
        test: &str,
        rationale: &str,
        tables: BTreeMap<String, RecordTable>,
        data: serde_json::Value,
    ) {
        let path = docs_path(name);
        let data = serde_json::json!({ "rationale": rationale, "measured": data });
        let mut diffs = Vec::new();
        match Record::read(&path) {
            Ok(r) => {
                walk("data", &r.data, &data, &mut diffs);
                if r.tables != tables {
                    diffs.push("tables differ".to_string());
                }
            }
            Err(e) => diffs.push(format!("no record: {e}")),
        }
        if diffs.is_empty() {
            return;
        }
        if super::bless() {
            let mut r = Record::new(
                &format!("SSSKIT_BLESS=1 cargo test --release --test {test}"),
                &machine(),
            );
            r.tables = tables;
            r.data = data;
            r.write(&path).unwrap();
            eprintln!("blessed {}", path.display());
            return;
        }
        panic!(
            "{}: the measured numbers moved (after an intended change: SSSKIT_BLESS=1 \
             cargo test --release --test {test}, then scripts/regen-docs):\n  {}",
            path.display(),
            diffs
                .iter()
                .take(12)
                .cloned()
                .collect::<Vec<_>>()
                .join("\n  ")
        );
    }

    /// A table from a header and rows of cells.
    pub fn table(header: &[&str], rows: Vec<Vec<String>>) -> RecordTable {
        RecordTable {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows,
        }
    }
}

/// Every .rs file under `dir`, recursively (the source scanners of
/// tests/layers.rs and tests/sizes.rs).
pub fn rust_sources(dir: &Path) -> Vec<std::path::PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, &mut out);
    out.sort();
    out
}

/// `ssskit scene TOML --out EXR --spp SPP --profile-photons N EXTRA...`,
/// which must succeed; its stdout.
pub fn render_scene(toml: &Path, exr: &Path, spp: &str, photons: &str, extra: &[&str]) -> String {
    let mut args = vec![
        "scene",
        p(toml),
        "--out",
        p(exr),
        "--spp",
        spp,
        "--profile-photons",
        photons,
    ];
    args.extend_from_slice(extra);
    ok(&args)
}

/// `ssskit compare --scene TOML --render EXR --signal-size 32 --out-dir OUT
/// EXTRA...` (the small signals the tests use), which must succeed; its
/// stdout and stderr.
pub fn compare_scene(toml: &Path, exr: &Path, out: &Path, extra: &[&str]) -> (String, String) {
    let mut args = vec![
        "compare",
        "--scene",
        p(toml),
        "--render",
        p(exr),
        "--signal-size",
        "32",
        "--out-dir",
        p(out),
    ];
    args.extend_from_slice(extra);
    ok_both(&args)
}

/// The percentages of a ranking (`scene::score::ranking`'s numbered lines,
/// "  1.  21.30%  what") among `lines`, in their order, as fractions.
pub fn ranked_fractions<'a>(lines: impl IntoIterator<Item = &'a str>) -> Vec<f64> {
    lines
        .into_iter()
        .filter(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
        .filter_map(|l| {
            let v = l.split('%').next()?.split_whitespace().last()?;
            Some(v.parse::<f64>().ok()? / 100.0)
        })
        .collect()
}
