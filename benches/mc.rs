//! Monte Carlo benchmark (plain main, not a timed test).
//!
//! 1. Photons per second per core and efficiency 1 / (var(total R_d) x time)
//!    for skin1 red and marble blue, one thread, for three settings measured
//!    in the same run: `mcml` (classic all-or-none boundaries, roulette at
//!    1e-4: the MCML 1.2.2 game), `split` (splitting at the ambient
//!    boundaries, roulette 1e-4) and `default` (classic, roulette 0.01).
//!    Efficiency ratios are against `mcml`.
//! 2. With `SSSKIT_BENCH_BASELINE=/path/to/older/ssskit`, the same cases
//!    traced by that binary (e.g. a build of an earlier commit) in the same
//!    run, as a child process: the speed-up of the tracer, per CPU-second.
//! 3. The default `simulate` (kernel-factor rule, all threads) on every
//!    preset: wall time, CPU time and photons per channel.
//!
//! `cargo bench --bench mc` (SSSKIT_BENCH_SCALE=0.2 for a quick look;
//! SSSKIT_BENCH_PRESETS=0 skips part 3). Per-core figures divide by the
//! process (or child) CPU time, so they survive a loaded machine; wall
//! times do not. Reference: MCML 1.2.2 (C, classic) traces about 2.0e5
//! photons/s on skin1 red and 3.3e4 photons/s on marble blue on one core of
//! this machine class (measured once, not rebuilt here).

use ssskit::material::{preset, preset_names, Channel};
use ssskit::profile::mc::{
    simulate, simulate_with, BoundaryMode, McConfig, McOptions, PhotonBudget, DEFAULT_KERNEL_ERROR,
    DEFAULT_ROULETTE_THRESHOLD, ROULETTE_THRESHOLD,
};
use ssskit::progress::NoProgress;

struct Case {
    material: &'static str,
    ch: Channel,
    photons: u64,
    mcml_per_core: f64,
}

/// (own, children) CPU seconds (user + system) from /proc/self/stat; None
/// off Linux.
fn cpu_seconds() -> Option<(f64, f64)> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name: utime, stime, cutime,
    // cstime are the 14th to 17th overall, in clock ticks (100 per second).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<f64> = rest
        .split_whitespace()
        .skip(11)
        .take(4)
        .map(|s| s.parse().unwrap_or(0.0))
        .collect();
    (f.len() == 4).then(|| ((f[0] + f[1]) / 100.0, (f[2] + f[3]) / 100.0))
}

struct Row {
    per_core: f64,
    var: f64,
    efficiency: f64,
}

#[derive(Clone, Copy, PartialEq)]
struct Setting {
    name: &'static str,
    mode: BoundaryMode,
    roulette: f64,
}

const SETTINGS: [Setting; 3] = [
    Setting {
        name: "mcml",
        mode: BoundaryMode::Classic,
        roulette: ROULETTE_THRESHOLD,
    },
    Setting {
        name: "split",
        mode: BoundaryMode::Split,
        roulette: ROULETTE_THRESHOLD,
    },
    Setting {
        name: "default",
        mode: BoundaryMode::Classic,
        roulette: DEFAULT_ROULETTE_THRESHOLD,
    },
];

fn measure(case: &Case, set: Setting, photons: u64) -> Row {
    let m = preset(case.material).expect("preset exists");
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed: 7,
        threads: Some(1),
        channels: vec![case.ch],
        grid: None,
    };
    let opts = McOptions {
        boundary: set.mode,
        roulette_threshold: set.roulette,
        ..McOptions::default()
    };
    let c0 = cpu_seconds();
    let t0 = std::time::Instant::now();
    let p = simulate_with(&m, &cfg, &opts, &NoProgress).expect("simulation runs");
    let secs = t0.elapsed().as_secs_f64();
    let cpu = match (c0, cpu_seconds()) {
        (Some(a), Some(b)) if b.0 > a.0 => b.0 - a.0,
        _ => secs,
    };
    let se = p.total_rd_stderr.as_ref().expect("stderr")[0];
    let var = se * se;
    Row {
        per_core: photons as f64 / cpu,
        // Per-photon variance of total R_d (independent of N).
        var: var * photons as f64,
        efficiency: 1.0 / (var * cpu),
    }
}

/// Photons per CPU-second of an older ssskit binary on the same case, run
/// as a child process with the same flags.
fn baseline(bin: &str, case: &Case, set: Setting, photons: u64) -> Option<f64> {
    let out = std::env::temp_dir().join(format!("ssskit-bench-{}.json", std::process::id()));
    let c0 = cpu_seconds()?;
    let status = std::process::Command::new(bin)
        .args([
            "simulate",
            "--material",
            case.material,
            "--channels",
            case.ch.name(),
            "--photons",
            &photons.to_string(),
            "--threads",
            "1",
            "--seed",
            "7",
            "--boundary",
            set.mode.name(),
            "--roulette",
            &set.roulette.to_string(),
            "--out",
        ])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .ok()?;
    let _ = std::fs::remove_file(&out);
    let c1 = cpu_seconds()?;
    (status.success() && c1.1 > c0.1).then(|| photons as f64 / (c1.1 - c0.1))
}

fn main() {
    let scale: f64 = std::env::var("SSSKIT_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let base_bin = std::env::var("SSSKIT_BENCH_BASELINE").ok();
    let cases = [
        Case {
            material: "skin1",
            ch: Channel::R,
            photons: 1_000_000,
            mcml_per_core: 2.0e5,
        },
        Case {
            material: "marble",
            ch: Channel::B,
            photons: 200_000,
            mcml_per_core: 3.3e4,
        },
    ];
    println!(
        "{:<8} {:>2} {:<8} {:>12} {:>9} {:>12} {:>9} {:>11} {:>11} {:>8}",
        "material",
        "ch",
        "setting",
        "ph/cpu-s",
        "vs MCML",
        "baseline",
        "vs base",
        "var/photon",
        "eff/cpu-s",
        "eff/mcml"
    );
    for case in &cases {
        let n = ((case.photons as f64 * scale) as u64).max(ssskit::profile::mc::CHUNK);
        // Warm-up (page faults, thread start).
        let _ = measure(case, SETTINGS[0], n / 10);
        let mut mcml_eff = None;
        for set in SETTINGS {
            let r = measure(case, set, n);
            let base = base_bin.as_deref().and_then(|b| baseline(b, case, set, n));
            let e0 = *mcml_eff.get_or_insert(r.efficiency);
            println!(
                "{:<8} {:>2} {:<8} {:>12.4e} {:>8.2}x {:>12} {:>9} {:>11.4e} {:>11.4e} {:>8.2}",
                case.material,
                case.ch.name(),
                set.name,
                r.per_core,
                r.per_core / case.mcml_per_core,
                base.map_or("-".into(), |b| format!("{b:.4e}")),
                base.map_or("-".into(), |b| format!("{:.2}x", r.per_core / b)),
                r.var,
                r.efficiency,
                r.efficiency / e0
            );
        }
    }
    if std::env::var("SSSKIT_BENCH_PRESETS").as_deref() == Ok("0") {
        return;
    }
    println!(
        "\ndefault simulate (kernel-factor rule, target {DEFAULT_KERNEL_ERROR}, all threads): wall and CPU seconds, photons per channel"
    );
    for name in preset_names() {
        let m = preset(name).expect("preset exists");
        let cfg = McConfig {
            budget: PhotonBudget::KernelFactor {
                rel: DEFAULT_KERNEL_ERROR,
                max_photons: 100_000_000,
            },
            seed: 1,
            threads: None,
            channels: Channel::ALL.to_vec(),
            grid: None,
        };
        let c0 = cpu_seconds();
        let t0 = std::time::Instant::now();
        let p = simulate(&m, &cfg, &NoProgress).expect("simulation runs");
        let wall = t0.elapsed().as_secs_f64();
        let cpu = match (c0, cpu_seconds()) {
            (Some(a), Some(b)) => b.0 - a.0,
            _ => f64::NAN,
        };
        println!(
            "{:<11} wall {:>6.2} s  cpu {:>6.2} s  photons {:?}  converged {}",
            name,
            wall,
            cpu,
            p.source.photons.unwrap_or_default(),
            p.extra["converged"]
        );
    }
}
