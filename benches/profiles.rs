//! Time per analytic profile for each model (criterion), next to the time
//! the Monte Carlo reference needs for a given relative error on the same
//! grid; prints a markdown ratio table (docs/analytic.md).
//!
//! `cargo bench --bench profiles` (criterion statistics, then the table);
//! `SSSKIT_BENCH_MC_ERROR=0.01` sets the Monte Carlo target error (default
//! 0.02), `SSSKIT_BENCH_MATERIALS=marble,skin1` the materials.

use criterion::Criterion;
use ssskit::material::{preset, Channel};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::progress::NoProgress;
use std::hint::black_box;
use std::time::{Duration, Instant};

fn materials() -> Vec<String> {
    std::env::var("SSSKIT_BENCH_MATERIALS")
        .unwrap_or_else(|_| "marble,skin1,ketchup".into())
        .split(',')
        .map(|s| s.trim().to_string())
        .collect()
}

/// Median seconds per call over repeated runs filling about 0.3 s.
fn median_time(mut f: impl FnMut()) -> f64 {
    let mut times = Vec::new();
    let start = Instant::now();
    while times.len() < 5 || (start.elapsed() < Duration::from_millis(300) && times.len() < 2000) {
        let t = Instant::now();
        f();
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(|a, b| a.total_cmp(b));
    times[times.len() / 2]
}

fn main() {
    let mut c = Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .configure_from_args();
    let opts = Options::default();
    for name in materials() {
        let Some(mat) = preset(&name) else {
            eprintln!("unknown preset {name}");
            continue;
        };
        let grid = analytic::default_grid(&mat, &Channel::ALL).unwrap();
        for model in Model::ALL {
            c.bench_function(&format!("profile/{name}/{}", model.name()), |b| {
                b.iter(|| black_box(analytic::profile(&mat, model, &grid, &opts).unwrap()))
            });
        }
    }
    c.final_summary();

    let rel: f64 = std::env::var("SSSKIT_BENCH_MC_ERROR")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.02);
    println!("\n| material | bins | model | time per profile (3 channels) | Monte Carlo to {:.1}% error | MC / model |", rel * 100.0);
    println!("| --- | --- | --- | --- | --- | --- |");
    for name in materials() {
        let Some(mat) = preset(&name) else { continue };
        let grid = analytic::default_grid(&mat, &Channel::ALL).unwrap();
        let cfg = McConfig {
            budget: PhotonBudget::TargetError {
                rel,
                max_photons: 10_000_000,
            },
            seed: 1,
            threads: None,
            channels: Channel::ALL.to_vec(),
            grid: Some(grid.clone()),
        };
        let t = Instant::now();
        let mc = simulate(&mat, &cfg, &NoProgress).map(|p| {
            let photons = p.source.photons.unwrap_or_default();
            (
                t.elapsed().as_secs_f64(),
                photons.into_iter().max().unwrap_or(0),
            )
        });
        for model in Model::ALL {
            let s = median_time(|| {
                black_box(analytic::profile(&mat, model, &grid, &opts).unwrap());
            });
            let (mc_s, ratio) = match &mc {
                Ok((m, n)) => (
                    format!("{m:.2} s ({n} photons/ch)"),
                    format!("{:.0}x", m / s),
                ),
                Err(e) => (format!("unavailable ({e})"), "-".into()),
            };
            println!(
                "| {name} | {} | {} | {} | {mc_s} | {ratio} |",
                grid.len(),
                model.name(),
                if s < 1e-3 {
                    format!("{:.0} µs", s * 1e6)
                } else {
                    format!("{:.2} ms", s * 1e3)
                }
            );
        }
    }
}
