//! Monte Carlo benchmark (plain main, not a timed test): photons per second
//! per core and efficiency 1 / (var(total R_d) x time) for skin1 red and
//! marble blue, split vs classic (MCML) boundaries, 1 and 2 threads, all
//! measured in the same run so the ratios are meaningful.
//!
//! `cargo bench --bench mc` (set SSSKIT_BENCH_SCALE=0.2 for a quick look).
//! Per-core figures divide by the process CPU time (robust to other load);
//! the 2-thread speed-up uses wall time and needs an otherwise idle machine.
//! Reference: MCML 1.2.2 (C, classic) traces about 2.0e5 photons/s on skin1
//! red and 3.3e4 photons/s on marble blue on one core of this machine class.

use ssskit::material::{preset, Channel};
use ssskit::profile::mc::{simulate_with, BoundaryMode, McConfig, McOptions, PhotonBudget};
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

fn measure(case: &Case, mode: BoundaryMode, threads: usize, photons: u64) -> Row {
    let m = preset(case.material).expect("preset exists");
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed: 7,
        threads: Some(threads),
        channels: vec![case.ch],
        grid: None,
    };
    let opts = McOptions {
        boundary: mode,
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
        "{:<8} {:>2} {:<8} {:>3} {:>12} {:>12} {:>9} {:>11} {:>11}",
        "material",
        "ch",
        "boundary",
        "thr",
        "wall ph/s",
        "ph/cpu-s",
        "vs MCML",
        "var/photon",
        "eff/cpu-s"
    );
    for case in &cases {
        let n = ((case.photons as f64 * scale) as u64).max(ssskit::profile::mc::CHUNK);
        // Warm-up (page faults, thread start).
        let _ = measure(case, BoundaryMode::Split, 1, n / 10);
        let mut eff = Vec::new();
        for mode in [BoundaryMode::Classic, BoundaryMode::Split] {
            for threads in [1, 2] {
                let r = measure(case, mode, threads, n);
                println!(
                    "{:<8} {:>2} {:<8} {:>3} {:>12.4e} {:>12.4e} {:>8.2}x {:>11.4e} {:>11.4e}",
                    case.material,
                    case.ch.name(),
                    mode.name(),
                    threads,
                    r.photons_per_s,
                    r.per_core,
                    r.per_core / case.mcml_per_core,
                    r.var,
                    r.efficiency
                );
                eff.push((mode, threads, r));
            }
        }
        let get = |m: BoundaryMode, t: usize| {
            eff.iter()
                .find(|(a, b, _)| *a == m && *b == t)
                .map(|(_, _, r)| r)
                .expect("measured")
        };
        let (c1, c2) = (get(BoundaryMode::Classic, 1), get(BoundaryMode::Classic, 2));
        let (s1, s2) = (get(BoundaryMode::Split, 1), get(BoundaryMode::Split, 2));
        println!(
            "  {} {}: 2-thread speed-up classic {:.2}, split {:.2}; efficiency split/classic {:.2} (1 thr), {:.2} (2 thr); split per-core speed vs MCML {:.2}x",
            case.material,
            case.ch.name(),
            c2.photons_per_s / c1.photons_per_s,
            s2.photons_per_s / s1.photons_per_s,
            s1.efficiency / c1.efficiency,
            s2.efficiency / c2.efficiency,
            s1.per_core / case.mcml_per_core
        );
    }
}
