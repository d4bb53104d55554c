//! Time per analytic profile for each model, next to the time the Monte
//! Carlo reference needs for a given relative error on the same grid, all in
//! one run; writes the record `docs/records/profiles.json` (tables `speed`
//! and `presets`, shown in docs/analytic.md) and prints the tables.
//!
//! `cargo bench --bench profiles` (a few minutes on 2 cores, most of it the
//! marble reference); `SSSKIT_BENCH_MC_ERROR=0.01` sets the Monte Carlo
//! target error (default 0.02), `SSSKIT_BENCH_MATERIALS=marble,skin1` the
//! materials of the Monte Carlo table. A run with other settings than the
//! defaults prints its tables but does not write the record.

mod docs_record;

use ssskit::material::{preset, preset_names, Channel};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::progress::NoProgress;
use ssskit::report::present::number::time;
use ssskit::report::present::record::{machine_line, Record};
use ssskit::report::present::table::Table;
use std::hint::black_box;
use std::time::{Duration, Instant};

const DEFAULT_MATERIALS: &str = "marble,skin1,ketchup";

/// Median seconds per call over repeated runs filling about 0.2 s.
fn median_time(mut f: impl FnMut()) -> f64 {
    let mut times = Vec::new();
    let start = Instant::now();
    while times.len() < 3 || (start.elapsed() < Duration::from_millis(200) && times.len() < 2000) {
        let t = Instant::now();
        f();
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(|a, b| a.total_cmp(b));
    times[times.len() / 2]
}

/// Two significant digits: "66 000×", "720×", "19×".
fn ratio(x: f64) -> String {
    if !x.is_finite() {
        return "-".into();
    }
    let mag = 10f64.powi((x.log10().floor() as i32 - 1).max(0));
    let r = ((x / mag).round() * mag) as u64;
    let s = r.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) && s.len() > 4 {
            out.push(' ');
        }
        out.push(ch);
    }
    format!("{out}×")
}

fn main() {
    let machine = machine_line();
    let env_materials = std::env::var("SSSKIT_BENCH_MATERIALS").ok();
    let env_error = std::env::var("SSSKIT_BENCH_MC_ERROR").ok();
    let defaults = env_materials.is_none() && env_error.is_none();
    let materials: Vec<String> = env_materials
        .unwrap_or_else(|| DEFAULT_MATERIALS.into())
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let rel: f64 = env_error.and_then(|s| s.parse().ok()).unwrap_or(0.02);
    let opts = Options::default();
    let mut data = serde_json::Map::new();

    // Every preset: time per profile of each model.
    let mut header = vec!["material", "bins"];
    let names: Vec<&str> = Model::ALL.iter().map(|m| m.name()).collect();
    header.extend(names.iter());
    let mut presets = Table::new(&header);
    let mut model_s = std::collections::BTreeMap::new();
    for name in preset_names() {
        let Some(mat) = preset(name) else { continue };
        let Ok(grid) = analytic::default_grid(&mat, &Channel::ALL) else {
            continue;
        };
        let mut row = vec![name.to_string(), grid.len().to_string()];
        let mut raw = serde_json::Map::new();
        for model in Model::ALL {
            let s = match analytic::profile(&mat, model, &grid, &opts) {
                Ok(_) => median_time(|| {
                    black_box(analytic::profile(&mat, model, &grid, &opts).unwrap());
                }),
                Err(_) => f64::NAN,
            };
            row.push(if s.is_finite() { time(s) } else { "-".into() });
            raw.insert(model.name().into(), s.into());
            model_s.insert((name.to_string(), model.name()), s);
        }
        data.insert(name.to_string(), raw.into());
        eprintln!("{}", row.join(" | "));
        presets.push(row);
    }

    // Monte Carlo to `rel` on the same grid, against each model.
    let mut speed = Table::new(&[
        "material",
        "bins",
        "model",
        "time per profile",
        &format!("Monte Carlo to {:.0}% error", rel * 100.0),
        "MC / model",
    ]);
    let mut mc_data = serde_json::Map::new();
    for name in &materials {
        let Some(mat) = preset(name) else {
            eprintln!("unknown preset {name}");
            continue;
        };
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
        for (i, model) in Model::ALL.iter().enumerate() {
            // Timed again, next to the simulation, so that both see the
            // same load.
            let s = median_time(|| {
                black_box(analytic::profile(&mat, *model, &grid, &opts).unwrap());
            });
            let (mc_s, r) = match &mc {
                Ok((m, n)) => (
                    if i == 0 {
                        format!("{} ({n} photons/ch)", time(*m))
                    } else {
                        time(*m)
                    },
                    ratio(m / s),
                ),
                Err(e) => (format!("unavailable ({e})"), "-".into()),
            };
            speed.push(vec![
                name.clone(),
                grid.len().to_string(),
                model.name().into(),
                time(s),
                mc_s,
                r,
            ]);
        }
        if let Ok((m, n)) = &mc {
            mc_data.insert(
                name.clone(),
                serde_json::json!({"mc_seconds": m, "photons_per_channel": n}),
            );
        }
    }
    println!("{}", speed.markdown());
    println!("{}", presets.markdown());
    if !defaults {
        eprintln!("not the default settings: record not written");
        return;
    }
    let record = Record::new("cargo bench --bench profiles", &machine);
    let data = serde_json::json!({
        "model_seconds_per_profile": data,
        "monte_carlo": mc_data,
        "mc_target_rel_error": rel,
    });
    let tables = [("speed", &speed), ("presets", &presets)];
    docs_record::write(record, "profiles", &tables, data);
}
