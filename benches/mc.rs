//! Monte Carlo benchmark (plain main, not a timed test); writes the records
//! `docs/records/mc-speed.json` and `docs/records/mc-presets.json`.
//!
//! 1. Speed against MCML 1.2.2 in the same run: skin1 red and marble blue,
//!    one core. With `SSSKIT_MCML=/path/to/mcml` (an MCML 1.2.2 binary built
//!    from its public source: OMLC; Wang, Jacques & Zheng 1995) the bench
//!    writes an equivalent `.mci` into a temporary directory (same optics in
//!    cm, a 1e8 cm layer for a semi-infinite medium, the same photons and
//!    radial bins; MCML's depth grid collapsed to one cell, its cheapest
//!    setting) and times MCML as a child process by its CPU time. ssskit is
//!    timed by this process's CPU time, one thread, for two games: `mcml`
//!    (all-or-none boundaries, roulette at 1e-4 with survival 1/10: MCML's
//!    game, so MCML's variance per photon) and `default` (roulette at 0.01).
//!    Each of the three is run `SSSKIT_BENCH_REPS` times (default 3),
//!    interleaved, and the fastest run counts (a loaded machine only slows).
//!    Efficiency is 1 / (variance of total R_d x CPU time); MCML reports no
//!    variance, so its game's variance per photon is ssskit's `mcml` game's.
//!    Without `SSSKIT_MCML` the record says MCML was not measured.
//! 2. With `SSSKIT_BENCH_BASELINE=/path/to/older/ssskit`, the same cases
//!    traced by that binary (e.g. a build of an earlier commit) in the same
//!    run: the speed-up of the tracer, per CPU-second (printed and in
//!    `data`).
//! 3. The default `simulate` (kernel-factor rule, all threads) on every
//!    preset: wall and CPU seconds, photons per channel, how each channel
//!    stopped. `SSSKIT_BENCH_PRESETS=0` skips it (and its record).
//!
//! `SSSKIT_MCML=... cargo bench --bench mc` takes about 1 minute for part 1
//! at the default `SSSKIT_BENCH_SCALE=1` (photons x scale) plus about as
//! much for part 3 on 2 idle cores.

use ssskit::material::{preset, preset_names, Channel, Material};
use ssskit::profile::mc::{
    simulate, simulate_with, BoundaryMode, McConfig, McOptions, PhotonBudget, DEFAULT_KERNEL_ERROR,
    DEFAULT_ROULETTE_THRESHOLD, ROULETTE_THRESHOLD,
};
use ssskit::profile::{Profile, RadialGrid};
use ssskit::progress::NoProgress;
use ssskit::report::present::record::{machine_line, Record};
use ssskit::report::present::table::Table;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

struct Case {
    material: &'static str,
    ch: Channel,
    photons: u64,
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

/// One timed run: CPU seconds, total R_d and its standard error.
#[derive(Clone, Copy)]
struct Run {
    cpu: f64,
    rd: f64,
    se: f64,
    events_per_photon: f64,
}

#[derive(Clone, Copy, PartialEq)]
struct Setting {
    name: &'static str,
    roulette: f64,
}

const SETTINGS: [Setting; 2] = [
    Setting {
        name: "mcml",
        roulette: ROULETTE_THRESHOLD,
    },
    Setting {
        name: "default",
        roulette: DEFAULT_ROULETTE_THRESHOLD,
    },
];

fn grid_of(m: &Material, ch: Channel) -> RadialGrid {
    RadialGrid::for_material_rule(m, &[ch], false).0
}

fn measure(m: &Material, case: &Case, set: Setting, photons: u64) -> Run {
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed: 7,
        threads: Some(1),
        channels: vec![case.ch],
        grid: Some(grid_of(m, case.ch)),
    };
    let opts = McOptions {
        boundary: BoundaryMode::Classic,
        roulette_threshold: set.roulette,
        ..McOptions::default()
    };
    let c0 = cpu_seconds();
    let t0 = std::time::Instant::now();
    let p = simulate_with(m, &cfg, &opts, &NoProgress).expect("simulation runs");
    let secs = t0.elapsed().as_secs_f64();
    let cpu = match (c0, cpu_seconds()) {
        (Some(a), Some(b)) if b.0 > a.0 => b.0 - a.0,
        _ => secs,
    };
    Run {
        cpu,
        rd: p.total_rd[0],
        se: p.total_rd_stderr.as_ref().expect("stderr")[0],
        events_per_photon: p.extra["events_per_photon"][0].as_f64().unwrap_or(f64::NAN),
    }
}

/// MCML 1.2.2 input (lengths in cm, coefficients in 1/cm) for one channel
/// of `m`, radial bins of `grid` (uniform), `photons` photons.
fn mci_text(m: &Material, ch: Channel, grid: &RadialGrid, photons: u64, out: &str) -> String {
    let c = ch.index();
    let dr_cm = (grid.edges[1] - grid.edges[0]) / 10.0;
    // MCML's bin counts are C shorts.
    let nr = grid.len().min(i16::MAX as usize);
    let mut s = format!(
        "1.0\n1\n{out} A\n{photons}\n{dr_cm:e} {dr_cm:e}\n1 {nr} 1\n{}\n{}\n",
        m.layers.len(),
        m.eta_above
    );
    for l in &m.layers {
        // A semi-infinite layer is 1e8 cm thick, as in MCML's template.
        let d = l.thickness.map_or(1e8, |t| t / 10.0);
        s += &format!(
            "{} {:e} {:e} {} {:e}\n",
            l.eta,
            l.sigma_a[c] * 10.0,
            l.sigma_s[c] * 10.0,
            l.g[c],
            d
        );
    }
    s + &format!("{}\n", m.eta_below)
}

/// Runs MCML on `case`; (CPU seconds of the child, its total R_d).
fn run_mcml(bin: &Path, dir: &Path, m: &Material, case: &Case, photons: u64) -> Option<(f64, f64)> {
    let mci = dir.join("bench.mci");
    let mco = dir.join("bench.mco");
    let _ = std::fs::remove_file(&mco);
    let grid = grid_of(m, case.ch);
    let text = mci_text(m, case.ch, &grid, photons, "bench.mco");
    // ssskit's own .mci reader must see the same case (optics to rounding,
    // photons, bins): the input MCML gets is the one ssskit traces.
    let run = &ssskit::profile::mc::mci::parse_mci(&text, "bench .mci").expect("valid .mci")[0];
    let (a, b) = (&run.material.layers, &m.layers);
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-300);
    let c = case.ch.index();
    assert!(
        run.photons == photons
            && run.grid.len() == grid.len()
            && a.len() == b.len()
            && a.iter().zip(b).all(|(x, y)| {
                close(x.sigma_a[0], y.sigma_a[c])
                    && close(x.sigma_s[0], y.sigma_s[c])
                    && x.g[0] == y.g[c]
                    && x.eta == y.eta
                    && x.thickness.is_none() == y.thickness.is_none()
            }),
        "the .mci written for MCML differs from the case: {text}"
    );
    std::fs::write(&mci, text).ok()?;
    let c0 = cpu_seconds()?;
    let status = Command::new(bin)
        .arg("bench.mci")
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .ok()?;
    let c1 = cpu_seconds()?;
    if !status.success() || c1.1 <= c0.1 {
        eprintln!("MCML at {} failed on {}", bin.display(), case.material);
        return None;
    }
    let out = std::fs::read_to_string(&mco).ok()?;
    let rd = out
        .lines()
        .find(|l| l.contains("#Diffuse reflectance"))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|v| v.parse().ok())?;
    Some((c1.1 - c0.1, rd))
}

/// Photons per CPU-second of an older ssskit binary on the same case, run
/// as a child process with the same flags.
fn baseline(bin: &str, case: &Case, set: Setting, photons: u64) -> Option<f64> {
    let out = std::env::temp_dir().join(format!("ssskit-bench-{}.json", std::process::id()));
    let c0 = cpu_seconds()?;
    let status = Command::new(bin)
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
            "classic",
            "--roulette",
            &set.roulette.to_string(),
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .ok()?;
    let _ = std::fs::remove_file(&out);
    let c1 = cpu_seconds()?;
    (status.success() && c1.1 > c0.1).then(|| photons as f64 / (c1.1 - c0.1))
}

fn env_f64(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

fn records_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/records")
}

fn best(runs: &[Run]) -> Run {
    *runs
        .iter()
        .min_by(|a, b| a.cpu.total_cmp(&b.cpu))
        .expect("at least one run")
}

fn sci(x: f64) -> String {
    format!("{x:.3e}")
}

fn speed(scale: f64, reps: usize) -> Record {
    let mcml = std::env::var_os("SSSKIT_MCML").map(PathBuf::from);
    let base_bin = std::env::var("SSSKIT_BENCH_BASELINE").ok();
    let dir = std::env::temp_dir().join(format!("ssskit-bench-mcml-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let cases = [
        Case {
            material: "skin1",
            ch: Channel::R,
            photons: 1_000_000,
        },
        Case {
            material: "marble",
            ch: Channel::B,
            photons: 200_000,
        },
    ];
    let mut table = Table::new(&[
        "case",
        "photons",
        "MCML 1.2.2, photons/s per core",
        "ssskit, MCML's game",
        "vs MCML",
        "ssskit default",
        "vs MCML",
        "variance per photon, MCML's game / default",
        "efficiency vs MCML, default",
        "ns per event: MCML / ssskit (MCML's game)",
        "total R_d: MCML / ssskit",
    ]);
    let mut data = Vec::new();
    let not = "not measured";
    for case in &cases {
        let m = preset(case.material).expect("preset exists");
        let n = ((case.photons as f64 * scale) as u64).max(ssskit::profile::mc::CHUNK);
        // Warm-up (page faults, thread start).
        let _ = measure(&m, case, SETTINGS[0], n / 10);
        let mut ours: Vec<Vec<Run>> = vec![Vec::new(); SETTINGS.len()];
        let mut theirs: Vec<(f64, f64)> = Vec::new();
        for _ in 0..reps {
            if let Some(bin) = &mcml {
                theirs.extend(run_mcml(bin, &dir, &m, case, n));
            }
            for (i, set) in SETTINGS.iter().enumerate() {
                ours[i].push(measure(&m, case, *set, n));
            }
        }
        let (game, def) = (best(&ours[0]), best(&ours[1]));
        let nf = n as f64;
        let rate = |cpu: f64| nf / cpu;
        // Per-photon variance of total R_d (independent of N).
        let var = |r: &Run| r.se * r.se * nf;
        let eff = |v: f64, cpu: f64| 1.0 / (v / nf * cpu);
        let mcml_best = theirs.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0));
        let ns_event = |cpu: f64| 1e9 * cpu / (nf * game.events_per_photon);
        let colour = match case.ch {
            Channel::R => "red",
            Channel::G => "green",
            Channel::B => "blue",
        };
        let label = format!("{} {colour}", case.material);
        let base: Vec<Option<f64>> = SETTINGS
            .iter()
            .map(|s| base_bin.as_deref().and_then(|b| baseline(b, case, *s, n)))
            .collect();
        println!(
            "{label}: {n} photons, best of {reps}: ssskit mcml game {:.4e}/s (R_d {:.5} +- {:.5}), \
             default {:.4e}/s; MCML {}; baseline binary {:?}",
            rate(game.cpu),
            game.rd,
            game.se,
            rate(def.cpu),
            mcml_best.map_or("not measured (SSSKIT_MCML unset)".into(), |(c, rd)| format!(
                "{:.4e}/s (R_d {rd:.5}): {:.2}x / {:.2}x",
                rate(c),
                c / game.cpu,
                c / def.cpu
            )),
            base
        );
        let (v_game, v_def) = (var(&game), var(&def));
        table.push(vec![
            label.clone(),
            format!("{n}"),
            mcml_best.map_or(not.into(), |(c, _)| sci(rate(c))),
            sci(rate(game.cpu)),
            mcml_best.map_or("-".into(), |(c, _)| format!("{:.2}x", c / game.cpu)),
            sci(rate(def.cpu)),
            mcml_best.map_or("-".into(), |(c, _)| format!("{:.2}x", c / def.cpu)),
            format!("{v_game:.4} / {v_def:.4}"),
            mcml_best.map_or("-".into(), |(c, _)| {
                format!("{:.2}x", eff(v_def, def.cpu) / eff(v_game, c))
            }),
            format!(
                "{} / {:.1}",
                mcml_best.map_or(not.into(), |(c, _)| format!("{:.1}", ns_event(c))),
                ns_event(game.cpu)
            ),
            format!(
                "{} / {:.4} ± {:.4}",
                mcml_best.map_or(not.into(), |(_, rd)| format!("{rd:.4}")),
                game.rd,
                game.se
            ),
        ]);
        data.push(serde_json::json!({
            "case": label,
            "photons": n,
            "mcml": mcml_best.map(|(c, rd)| serde_json::json!({"cpu_s": c, "rd": rd})),
            "mcml_runs_cpu_s": theirs.iter().map(|t| t.0).collect::<Vec<_>>(),
            "ssskit_mcml_game": {"cpu_s": game.cpu, "rd": game.rd, "rd_stderr": game.se,
                "var_per_photon": v_game, "events_per_photon": game.events_per_photon,
                "runs_cpu_s": ours[0].iter().map(|r| r.cpu).collect::<Vec<_>>()},
            "ssskit_default": {"cpu_s": def.cpu, "rd": def.rd, "rd_stderr": def.se,
                "var_per_photon": v_def, "events_per_photon": def.events_per_photon,
                "runs_cpu_s": ours[1].iter().map(|r| r.cpu).collect::<Vec<_>>()},
            "baseline_photons_per_cpu_s": base,
        }));
    }
    let _ = std::fs::remove_dir_all(&dir);
    let command = format!(
        "{}SSSKIT_BENCH_SCALE={scale} SSSKIT_BENCH_REPS={reps} cargo bench --bench mc",
        if mcml.is_some() {
            "SSSKIT_MCML=<MCML 1.2.2, gcc -O3> "
        } else {
            ""
        }
    );
    let mut r = Record::new(&command, &machine_line());
    r.tables.insert("speed".into(), (&table).into());
    r.data = serde_json::json!({
        "mcml_measured": mcml.is_some(),
        "timing": "CPU seconds (user + system) of the tracing process, one thread; best of the repetitions",
        "cases": data,
    });
    r
}

fn presets() -> Record {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut table = Table::new(&[
        "preset",
        "photons per channel (r, g, b)",
        "wall s",
        "CPU s",
        "stopped by (r, g, b)",
    ]);
    let mut data = Vec::new();
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
        let p: Profile = simulate(&m, &cfg, &NoProgress).expect("simulation runs");
        let wall = t0.elapsed().as_secs_f64();
        let cpu = match (c0, cpu_seconds()) {
            (Some(a), Some(b)) => b.0 - a.0,
            _ => f64::NAN,
        };
        let photons = p.source.photons.clone().unwrap_or_default();
        let stopped: Vec<String> =
            serde_json::from_value(p.extra["stopped_by"].clone()).unwrap_or_default();
        println!("{name:<11} wall {wall:>6.2} s  cpu {cpu:>6.2} s  photons {photons:?}  stopped by {stopped:?}");
        let short = |n: u64| {
            if n >= 1_000_000 {
                format!("{:.1}M", n as f64 / 1e6)
            } else {
                format!("{}k", (n as f64 / 1e3).round())
            }
        };
        table.push(vec![
            name.to_string(),
            photons
                .iter()
                .map(|&n| short(n))
                .collect::<Vec<_>>()
                .join(", "),
            format!("{wall:.2}"),
            format!("{cpu:.2}"),
            stopped.join(", "),
        ]);
        data.push(serde_json::json!({
            "preset": name, "photons": photons, "wall_s": wall, "cpu_s": cpu,
            "stopped_by": stopped, "converged": p.extra["converged"],
        }));
    }
    let mut r = Record::new(
        "cargo bench --bench mc (part 3)",
        &format!("{}, {threads} worker threads", machine_line()),
    );
    r.tables.insert("presets".into(), (&table).into());
    r.data = serde_json::json!({
        "rule": format!("kernel-factor, target {DEFAULT_KERNEL_ERROR}, default absolute floor; seed 1"),
        "threads": threads,
        "presets": data,
    });
    r
}

fn main() {
    let scale = env_f64("SSSKIT_BENCH_SCALE", 1.0);
    let reps = (env_f64("SSSKIT_BENCH_REPS", 3.0) as usize).max(1);
    let dir = records_dir();
    std::fs::create_dir_all(&dir).expect("docs/records");
    let r = speed(scale, reps);
    let path = dir.join("mc-speed.json");
    r.write(&path).expect("record written");
    println!("wrote {}", path.display());
    if std::env::var("SSSKIT_BENCH_PRESETS").as_deref() == Ok("0") {
        return;
    }
    println!(
        "\ndefault simulate (kernel-factor rule, target {DEFAULT_KERNEL_ERROR}, all threads): wall and CPU seconds, photons per channel"
    );
    let r = presets();
    let path = dir.join("mc-presets.json");
    r.write(&path).expect("record written");
    println!("wrote {}", path.display());
}
