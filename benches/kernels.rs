//! Fit time per kernel model for 201, 401 and 801 cells per side (skin1,
//! dipole profile), with ratios against the rank-1 SVD measured in the same
//! run. Criterion measures the 201-wide fits; the size sweep is timed by
//! median of repeats (the large fits take seconds) and printed as a table.
//!
//!   cargo bench --bench kernels            # everything
//!   cargo bench --bench kernels -- sweep   # only the size sweep table

use criterion::Criterion;
use ssskit::kernel::guided::GuidedParams;
use ssskit::kernel::jimenez::JimenezParams;
use ssskit::kernel::preintegrate::PreMethod;
use ssskit::kernel::reference::dipole_preset;
use ssskit::kernel::{fit_model, Kernel2D, Kernel2DSpec, Model};
use std::time::Instant;

fn models() -> Vec<(&'static str, Model)> {
    vec![
        (
            "svd1",
            Model::Svd {
                rank: 1,
                renormalize: false,
            },
        ),
        (
            "svd4",
            Model::Svd {
                rank: 4,
                renormalize: false,
            },
        ),
        (
            "preintegrate",
            Model::Preintegrate {
                method: PreMethod::Abel,
            },
        ),
        ("guided-k0", guided(0.0)),
        ("guided-k1", guided(1.0)),
        ("guided-k2", guided(2.0)),
        ("manual-preset", Model::ManualPreset("skin1".into())),
        ("manual-fit", Model::ManualFit),
        ("gaussians4", Model::Gaussians { count: 4 }),
        ("jimenez", Model::Jimenez(JimenezParams::default())),
    ]
}

fn guided(k: f64) -> Model {
    Model::Guided(GuidedParams {
        k,
        ..Default::default()
    })
}

fn kernel(p: &ssskit::profile::Profile, size: usize) -> Kernel2D {
    Kernel2D::from_profile(
        p,
        &Kernel2DSpec {
            size: Some(size),
            extent_mm: None,
        },
    )
    .expect("kernel")
}

fn median_seconds(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

fn sweep(p: &ssskit::profile::Profile) {
    println!("\nfit seconds (median of 3; ratio to svd1 of the same size)");
    println!("{:<14} {:>20} {:>20} {:>20}", "model", "201", "401", "801");
    let sizes = [201usize, 401, 801];
    let kernels: Vec<Kernel2D> = sizes.iter().map(|&n| kernel(p, n)).collect();
    let build: Vec<f64> = sizes
        .iter()
        .map(|&n| median_seconds(3, || drop(kernel(p, n))))
        .collect();
    let mut base = [0.0; 3];
    for (name, m) in models() {
        let mut cells = Vec::new();
        for (i, k) in kernels.iter().enumerate() {
            let t = median_seconds(3, || drop(fit_model(k, p, &m).expect("fit")));
            if name == "svd1" {
                base[i] = t;
            }
            cells.push(format!("{:.4} ({:>6.2}x)", t, t / base[i]));
        }
        println!(
            "{name:<14} {:>20} {:>20} {:>20}",
            cells[0], cells[1], cells[2]
        );
    }
    println!(
        "{:<14} {:>20} {:>20} {:>20}",
        "kernel2d",
        format!("{:.4} ({:>6.2}x)", build[0], build[0] / base[0]),
        format!("{:.4} ({:>6.2}x)", build[1], build[1] / base[1]),
        format!("{:.4} ({:>6.2}x)", build[2], build[2] / base[2]),
    );
}

fn main() {
    let p = dipole_preset("skin1").expect("profile");
    let only_sweep = std::env::args().any(|a| a == "sweep");
    if !only_sweep {
        let mut c = Criterion::default()
            .sample_size(10)
            .warm_up_time(std::time::Duration::from_millis(300))
            .measurement_time(std::time::Duration::from_secs(2))
            .configure_from_args();
        let k = kernel(&p, 201);
        let mut g = c.benchmark_group("fit-201");
        for (name, m) in models() {
            g.bench_function(name, |b| b.iter(|| fit_model(&k, &p, &m).expect("fit")));
        }
        g.finish();
        c.final_summary();
    }
    sweep(&p);
}
