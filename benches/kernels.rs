//! Fit time per kernel model for 201, 401 and 801 cells per side (skin1,
//! dipole profile), with ratios against the rank-1 SVD measured in the same
//! run (median of 3), and the wall time of the one-command pipeline and of
//! the full comparison run as a user runs them:
//! `ssskit kernels --material skin1` (Monte Carlo profile, defaults) and
//! `--profile-model pbd`, and `ssskit compare --profiles profiles/reference
//! --materials all --models all`. Writes the record
//! `docs/records/kernels.json` (tables `fit` and `commands`).
//!
//!   cargo bench --bench kernels            # everything, a few minutes
//!   cargo bench --bench kernels -- sweep   # only the fit table (no record)

#[path = "../tests/common/mod.rs"]
mod common;
mod docs_record;

use ssskit::kernel::guided::GuidedParams;
use ssskit::kernel::jimenez::JimenezParams;
use ssskit::kernel::preintegrate::PreMethod;
use ssskit::kernel::reference::dipole_preset;
use ssskit::kernel::{fit_model, Kernel2D, Kernel2DSpec, Model};
use ssskit::report::present::record::{machine_line, Record};
use ssskit::report::present::table::Table;
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

/// Fit seconds per model and size, ratios to svd1 of the same size.
fn sweep(p: &ssskit::profile::Profile) -> (Table, serde_json::Value) {
    let sizes = [201usize, 401, 801];
    let mut t = Table::new(&["model", "201", "401", "801"]);
    let kernels: Vec<Kernel2D> = sizes.iter().map(|&n| kernel(p, n)).collect();
    let build: Vec<f64> = sizes
        .iter()
        .map(|&n| median_seconds(3, || drop(kernel(p, n))))
        .collect();
    let mut base = [0.0; 3];
    let mut raw = serde_json::Map::new();
    let secs = |t: f64| {
        if t < 0.01 {
            format!("{t:.4} s")
        } else if t < 1.0 {
            format!("{t:.3} s")
        } else {
            format!("{t:.2} s")
        }
    };
    for (name, m) in models() {
        let mut cells = vec![name.to_string()];
        let mut v = Vec::new();
        for (i, k) in kernels.iter().enumerate() {
            let t = median_seconds(3, || drop(fit_model(k, p, &m).expect("fit")));
            if name == "svd1" {
                base[i] = t;
            }
            v.push(t);
            cells.push(format!("{} ({:.2}x)", secs(t), t / base[i]));
        }
        eprintln!("{}", cells.join(" | "));
        raw.insert(name.into(), v.into());
        t.push(cells);
    }
    let mut row = vec!["2D kernel build".to_string()];
    for i in 0..3 {
        row.push(format!("{} ({:.2}x)", secs(build[i]), build[i] / base[i]));
    }
    raw.insert("kernel2d".into(), build.into());
    t.push(row);
    (t, raw.into())
}

/// Wall seconds of one run of the binary with `args` (output to a fresh
/// temporary folder named by OUT).
fn wall(args: &[&str]) -> f64 {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let out = dir.path().join("out");
    let argv: Vec<String> = args
        .iter()
        .map(|a| {
            if *a == "OUT" {
                out.display().to_string()
            } else {
                a.to_string()
            }
        })
        .collect();
    let t0 = Instant::now();
    common::output_ok(
        common::bin()
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&argv),
        &format!("ssskit {argv:?}"),
    );
    t0.elapsed().as_secs_f64()
}

fn main() {
    let machine = machine_line();
    let p = dipole_preset("skin1").expect("profile");
    let only_sweep = std::env::args().any(|a| a == "sweep");
    let (fit, fit_raw) = sweep(&p);
    println!("{}", fit.markdown());
    if only_sweep {
        return;
    }
    let runs: [&[&str]; 3] = [
        &["kernels", "--material", "skin1", "--out-dir", "OUT"],
        &[
            "kernels",
            "--material",
            "skin1",
            "--profile-model",
            "pbd",
            "--out-dir",
            "OUT",
        ],
        &[
            "compare",
            "--profiles",
            "profiles/reference",
            "--materials",
            "all",
            "--models",
            "all",
            "--signal-size",
            "256",
            "--out-dir",
            "OUT",
        ],
    ];
    let mut commands = Table::new(&["command", "wall s"]);
    let mut raw = serde_json::Map::new();
    for args in runs {
        let t = wall(args);
        let line = format!("ssskit {}", args.join(" "));
        eprintln!("{line}: {t:.1} s");
        raw.insert(line.clone(), t.into());
        commands.push(vec![format!("`{line}`"), format!("{t:.1}")]);
    }
    println!("{}", commands.markdown());
    let record = Record::new("cargo bench --bench kernels", &machine);
    let data = serde_json::json!({
        "fit_seconds_201_401_801": fit_raw,
        "command_wall_seconds": raw,
    });
    let tables = [("fit", &fit), ("commands", &commands)];
    docs_record::write(record, "kernels", &tables, data);
}
