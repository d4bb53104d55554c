//! GPU Monte Carlo throughput (plain main, not a timed test): photons per
//! second of the wgpu tracer on the adapter wgpu picks and of the CPU tracer
//! (all cores) in the same run, for skin1 red and marble blue, with the
//! total R_d of both and their difference in combined standard errors.
//!
//! `cargo bench --bench mc_gpu` (SSSKIT_BENCH_SCALE=0.1 for a quick look).
//! A software rasteriser (lavapipe, llvmpipe, WARP) is reported as such: its
//! number is a correctness run, not a GPU throughput. docs/mc_gpu.md has the
//! command sequence for a machine with a real GPU.

use ssskit::material::{preset, Channel};
use ssskit::profile::mc::gpu::McGpu;
use ssskit::profile::mc::{simulate_with, McConfig, McOptions, PhotonBudget};
use ssskit::profile::Profile;
use ssskit::progress::NoProgress;
use std::time::Instant;

fn cfg(ch: Channel, photons: u64) -> McConfig {
    McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed: 7,
        threads: None,
        channels: vec![ch],
        grid: None,
    }
}

fn total(p: &Profile) -> (f64, f64) {
    (
        p.total_rd[0],
        p.total_rd_stderr.as_ref().map_or(0.0, |e| e[0]),
    )
}

fn main() {
    let scale: f64 = std::env::var("SSSKIT_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let gpu = match McGpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("no GPU adapter: {e}");
            std::process::exit(1);
        }
    };
    let software = gpu.is_software();
    let label = if software {
        "SOFTWARE RASTERISER: correctness only, not a GPU number"
    } else {
        "hardware GPU"
    };
    println!("adapter: {} [{label}]", gpu.describe());
    println!(
        "cpu: {} threads (rayon default)",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    // (material, channel, GPU photons on hardware, on software, CPU photons).
    let cases = [
        ("skin1", Channel::R, 100_000_000u64, 40_000u64, 2_000_000u64),
        ("marble", Channel::B, 20_000_000, 10_000, 200_000),
    ];
    println!(
        "{:<8} {:>2} {:>11} {:>12} {:>11} {:>12} {:>9} {:>10} {:>10} {:>7}",
        "material",
        "ch",
        "gpu photons",
        "gpu ph/s",
        "cpu photons",
        "cpu ph/s",
        "gpu/cpu",
        "R_d gpu",
        "R_d cpu",
        "diff/se"
    );
    // A throughput run: its photon counts are the point, not the work cap.
    let opts = McOptions {
        max_work: u64::MAX,
        ..McOptions::default()
    };
    for (name, ch, hw, sw, cpu_n) in cases {
        let m = preset(name).expect("preset exists");
        let n_gpu = ((if software { sw } else { hw }) as f64 * scale).max(1000.0) as u64;
        let n_cpu = (cpu_n as f64 * scale).max(1000.0) as u64;
        let d = gpu.default_dispatch();
        // Warm-up: shader compilation and first dispatch are not timed.
        gpu.simulate(&m, &cfg(ch, 1000), &opts, d, &NoProgress)
            .expect("GPU run");
        let t = Instant::now();
        let pg = gpu
            .simulate(&m, &cfg(ch, n_gpu), &opts, d, &NoProgress)
            .expect("GPU run");
        let gps = n_gpu as f64 / t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pc = simulate_with(&m, &cfg(ch, n_cpu), &opts, &NoProgress).expect("CPU run");
        let cps = n_cpu as f64 / t.elapsed().as_secs_f64();
        let ((rg, sg), (rc, sc)) = (total(&pg), total(&pc));
        println!(
            "{:<8} {:>2} {:>11} {:>12.3e} {:>11} {:>12.3e} {:>9.2} {:>10.6} {:>10.6} {:>7.2}",
            name,
            ch.name(),
            n_gpu,
            gps,
            n_cpu,
            cps,
            gps / cps,
            rg,
            rc,
            (rg - rc) / (sg * sg + sc * sc).sqrt()
        );
    }
    if software {
        println!("({label})");
    }
}
