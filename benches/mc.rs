//! Monte Carlo benchmark (plain main, not a timed test): photons per second
//! per core and efficiency 1 / (var(total R_d) x time) for skin1 red and
//! marble blue, 1 and 2 threads, for three settings measured in the same run:
//! `mcml` (classic all-or-none boundaries, roulette at 1e-4: the MCML 1.2.2
//! baseline), `split` (splitting at the ambient boundaries, roulette 1e-4) and
//! `default` (classic, roulette at 0.01). Ratios are against `mcml`.
//!
//! `cargo bench --bench mc` (set SSSKIT_BENCH_SCALE=0.2 for a quick look).
//! Per-core figures divide by the process CPU time (robust to other load);
//! the 2-thread speed-up uses wall time and needs an otherwise idle machine.
//! Reference: MCML 1.2.2 (C, classic) traces about 2.0e5 photons/s on skin1
//! red and 3.3e4 photons/s on marble blue on one core of this machine class.

use ssskit::material::{preset, Channel};
use ssskit::profile::mc::{
    simulate_with, BoundaryMode, McConfig, McOptions, PhotonBudget, DEFAULT_ROULETTE_THRESHOLD,
    ROULETTE_THRESHOLD,
};
use ssskit::progress::NoProgress;

struct Case {
    material: &'static str,
    ch: Channel,
    photons: u64,
    mcml_per_core: f64,
}

/// CPU seconds (user + system) of this process from /proc/self/stat, so
/// per-core figures survive a loaded machine; None off Linux.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th fields overall, in clock ticks (100 per second on Linux).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

struct Row {
    photons_per_s: f64,
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

fn measure(case: &Case, set: Setting, threads: usize, photons: u64) -> Row {
    let m = preset(case.material).expect("preset exists");
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed: 7,
        threads: Some(threads),
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
        (Some(a), Some(b)) if b > a => b - a,
        _ => secs * threads as f64,
    };
    let se = p.total_rd_stderr.as_ref().expect("stderr")[0];
    let var = se * se;
    Row {
        photons_per_s: photons as f64 / secs,
        per_core: photons as f64 / cpu,
        // Per-photon variance of total R_d (independent of N).
        var: var * photons as f64,
        // Per core: CPU time, so that it survives a loaded machine.
        efficiency: 1.0 / (var * cpu),
    }
}

fn main() {
    let scale: f64 = std::env::var("SSSKIT_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
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
        "{:<8} {:>2} {:<8} {:>3} {:>12} {:>12} {:>9} {:>11} {:>11} {:>8}",
        "material",
        "ch",
        "setting",
        "thr",
        "wall ph/s",
        "ph/cpu-s",
        "vs MCML",
        "var/photon",
        "eff/cpu-s",
        "eff/mcml"
    );
    for case in &cases {
        let n = ((case.photons as f64 * scale) as u64).max(ssskit::profile::mc::CHUNK);
        // Warm-up (page faults, thread start).
        let _ = measure(case, SETTINGS[0], 1, n / 10);
        let mut rows: Vec<(&str, usize, Row)> = Vec::new();
        for set in SETTINGS {
            for threads in [1, 2] {
                let r = measure(case, set, threads, n);
                let base = rows
                    .iter()
                    .find(|(s, t, _)| *s == "mcml" && *t == threads)
                    .map_or(r.efficiency, |(_, _, b)| b.efficiency);
                println!(
                    "{:<8} {:>2} {:<8} {:>3} {:>12.4e} {:>12.4e} {:>8.2}x {:>11.4e} {:>11.4e} {:>8.2}",
                    case.material,
                    case.ch.name(),
                    set.name,
                    threads,
                    r.photons_per_s,
                    r.per_core,
                    r.per_core / case.mcml_per_core,
                    r.var,
                    r.efficiency,
                    r.efficiency / base
                );
                rows.push((set.name, threads, r));
            }
        }
        let get = |name: &str, t: usize| {
            rows.iter()
                .find(|(a, b, _)| *a == name && *b == t)
                .map(|(_, _, r)| r)
                .expect("measured")
        };
        println!(
            "  {} {}: 2-thread wall speed-up mcml {:.2}, split {:.2}, default {:.2} (needs an idle machine)",
            case.material,
            case.ch.name(),
            get("mcml", 2).photons_per_s / get("mcml", 1).photons_per_s,
            get("split", 2).photons_per_s / get("split", 1).photons_per_s,
            get("default", 2).photons_per_s / get("default", 1).photons_per_s,
        );
    }
}
