//! Angle-resolved Monte Carlo (plain main, not a timed test); writes the
//! record `docs/records/mc-angular.json`.
//!
//! 1. `factors`: skin1 as the preset (index 1.3 under air) and with an
//!    index-matched boundary (1.0), every channel, 1e6 photons per channel
//!    and incidence (x `SSSKIT_BENCH_SCALE`), 9 exit-angle bins (10
//!    degrees), incidences 30, 60 and 80 degrees: total R_d, the exit factor
//!    pi L / M in three exit bins and the entry factor R_d(theta) / R_d(0),
//!    each +- its standard error.
//! 2. `mcml`: with `SSSKIT_MCML=/path/to/mcml` (MCML 1.2.2 built from its
//!    public source; Wang, Jacques & Zheng 1995), MCML's three-layer sample
//!    (its sample.mci: n 1.37, g 0.9 / 0 / 0.7) with na = 9, run by MCML and
//!    by ssskit from the same .mci, 1e6 photons each: Rd_a per exit bin from
//!    both .mco files and their difference in combined standard errors
//!    (MCML reports none; its noise is taken as ssskit's, the same photon
//!    count). Without `SSSKIT_MCML` the table says MCML was not run.
//! 3. `mcml-exit`: with `SSSKIT_MCML`, the exit factor pi L / M at normal
//!    incidence per 10-degree exit bin on a semi-infinite medium (MCML's
//!    sample layer 1: mua 1, mus 100 cm^-1, g 0.9, 1E8 cm thick) under air at
//!    index 1.0, 1.33 and 1.4: MCML's from its Rd_a and Rd (the bin's share
//!    of R_d over its Lambertian share sin^2(hi) - sin^2(lo)), mean of
//!    `MCML_RUNS` runs of one .mci (MCML seeds its generator once per
//!    process, so the runs are independent batches) with the standard error
//!    of that mean; ssskit's from `simulate --mci` on the same layer with
//!    its own standard error. tests/mcml_exit.rs reruns ssskit against the
//!    recorded MCML factors.
//!
//! `cargo bench --bench mc_angular` takes about 1 minute on 2 idle cores.

#[path = "../tests/common/mod.rs"]
mod common;
mod docs_record;
use common::mcml::section;
use ssskit::material::{preset, Channel};
use ssskit::profile::mc::{simulate_with, AngularOptions, McConfig, McOptions, PhotonBudget};
use ssskit::progress::NoProgress;
use ssskit::report::present::record::{machine_line, Record};
use ssskit::report::present::table::Table;
use std::path::Path;
use std::process::{Command, Stdio};

const INCIDENCES: [f64; 3] = [30.0, 60.0, 80.0];
const BINS: usize = 9;

fn pm(v: f64, e: f64) -> String {
    format!("{v:.4} +- {e:.4}")
}

fn factors(scale: f64, data: &mut serde_json::Value) -> Table {
    let mut t = Table::new(&[
        "material (index)",
        "channel",
        "R_d",
        "exit factor 0-10 deg",
        "40-50 deg",
        "80-90 deg",
        "entry factor 30 deg",
        "60 deg",
        "80 deg",
    ]);
    let photons = ((1e6 * scale) as u64).max(ssskit::profile::mc::CHUNK);
    let skin = preset("skin1").expect("preset");
    let mut matched = skin.clone();
    matched.layers[0].eta = 1.0;
    for (label, m) in [("skin1 (1.3)", &skin), ("skin1 (1.0)", &matched)] {
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(photons),
            seed: 1,
            threads: None,
            channels: Channel::ALL.to_vec(),
            grid: None,
        };
        let opts = McOptions {
            angular: Some(AngularOptions {
                angle_bins: BINS,
                incidence_deg: INCIDENCES.to_vec(),
            }),
            ..McOptions::default()
        };
        let p = simulate_with(m, &cfg, &opts, &NoProgress).expect("simulation");
        let a = p.angular().expect("readable").expect("recorded");
        let (x, e) = (a.exit.as_ref().unwrap(), a.entry.as_ref().unwrap());
        for (c, ch) in p.channels.iter().enumerate() {
            let rd_se = p.total_rd_stderr.as_ref().unwrap()[c];
            let xf = |b: usize| pm(x.factor[c][b], x.factor_stderr[c][b]);
            let ef = |k: usize| pm(e.factor[c][k], e.factor_stderr[c][k]);
            t.push(vec![
                label.to_string(),
                ch.name().to_string(),
                pm(p.total_rd[c], rd_se),
                xf(0),
                xf(4),
                xf(8),
                ef(1),
                ef(2),
                ef(3),
            ]);
        }
        // The radiance profile pi L(r, theta) is the profile's own data
        // (`simulate --angle-bins`), megabytes per material: the record
        // keeps the factors it reports.
        let mut a = serde_json::to_value(&a).expect("angular tables serialise");
        if let Some(exit) = a.get_mut("exit").and_then(|x| x.as_object_mut()) {
            exit.remove("radiance");
            exit.remove("radiance_stderr");
        }
        data[label] = serde_json::json!({"photons": photons, "angular": a});
    }
    t
}

/// MCML's sample.mci (MCML 1.2.2, sample/): three layers, here with
/// na = 9 and one depth bin.
fn layered_mci(photons: u64, out: &str) -> String {
    format!(
        "1.0\n1\n{out} A\n{photons}\n0.01 0.01\n1 50 {BINS}\n3\n1.0\n\
         1.37 1 100 0.90 0.1\n1.37 1 10 0 0.1\n1.37 2 10 0.70 0.2\n1.0\n"
    )
}

fn mcml(scale: f64, data: &mut serde_json::Value) -> Table {
    let mut t = Table::new(&[
        "exit bin (deg)",
        "Rd_a MCML 1.2.2 (1/sr)",
        "Rd_a ssskit",
        "difference / combined stderr",
    ]);
    let Some(bin) = std::env::var_os("SSSKIT_MCML") else {
        t.push(vec![
            "not run (SSSKIT_MCML unset)".into(),
            String::new(),
            String::new(),
            String::new(),
        ]);
        return t;
    };
    let photons = ((1e6 * scale) as u64).max(ssskit::profile::mc::CHUNK);
    let dir = std::env::temp_dir().join(format!("ssskit-bench-angular-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    std::fs::write(dir.join("m.mci"), layered_mci(photons, "m.mco")).unwrap();
    std::fs::write(dir.join("s.mci"), layered_mci(photons, "s.mco")).unwrap();
    let ok = run_mcml(&bin, &dir);
    common::ok_in(
        &dir,
        &[
            "simulate", "--mci", "s.mci", "--mco", "s.mco", "--out", "s.json",
        ],
    );
    let theirs = ok
        .then(|| std::fs::read_to_string(dir.join("m.mco")).ok())
        .flatten();
    let Some(theirs) = theirs else {
        eprintln!("MCML at {} failed", Path::new(&bin).display());
        t.push(vec![
            "MCML failed".into(),
            String::new(),
            String::new(),
            String::new(),
        ]);
        return t;
    };
    let mine = std::fs::read_to_string(dir.join("s.mco")).unwrap();
    let p = ssskit::profile::Profile::read(&dir.join("s.json")).unwrap();
    let x = p.angular().unwrap().unwrap().exit.unwrap();
    let (a_m, a_s) = (section(&theirs, "Rd_a"), section(&mine, "Rd_a"));
    let da = std::f64::consts::PI / (2.0 * BINS as f64);
    let mut z = Vec::new();
    for i in 0..BINS {
        // MCML's Rd_a: the bin's part of R_d over 2 pi da sin(a).
        let sr = 2.0 * std::f64::consts::PI * da * ((i as f64 + 0.5) * da).sin();
        let se = x.fraction_stderr[0][i] / sr * 2f64.sqrt();
        let zi = (a_m[i] - a_s[i]) / se;
        z.push(zi);
        t.push(vec![
            format!("{}-{}", 10 * i, 10 * i + 10),
            format!("{:.4e}", a_m[i]),
            format!("{:.4e}", a_s[i]),
            format!("{zi:+.2}"),
        ]);
    }
    let rd = |text: &str| -> f64 {
        text.lines()
            .find(|l| l.contains("#Diffuse reflectance"))
            .and_then(|l| l.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::NAN)
    };
    t.push(vec![
        "total R_d".into(),
        format!("{:.6}", rd(&theirs)),
        format!("{:.6}", rd(&mine)),
        format!(
            "{:+.2}",
            (rd(&theirs) - rd(&mine)) / (p.total_rd_stderr.as_ref().unwrap()[0] * 2f64.sqrt())
        ),
    ]);
    data["mcml"] = serde_json::json!({"photons": photons, "z": z});
    let _ = std::fs::remove_dir_all(&dir);
    t
}

/// Runs of each MCML .mci in `mcml_exit`: independent batches whose spread
/// gives MCML's standard error (10 runs: that error is itself known to
/// about 25%).
const MCML_RUNS: u64 = 10;
/// Indices of refraction of `mcml_exit`'s medium (air above).
const EXIT_ETAS: [f64; 3] = [1.0, 1.33, 1.4];

/// The semi-infinite layer of `mcml_exit` at index `eta`, `runs` runs of
/// `photons` each, written to `{stem}{k}.mco` (tests/mcml_exit.rs writes the
/// same layer).
fn exit_mci(eta: f64, photons: u64, runs: u64, stem: &str) -> String {
    let mut s = format!("1.0\n{runs}\n");
    for k in 0..runs {
        s += &format!(
            "{stem}{k}.mco A\n{photons}\n0.01 0.01\n1 50 {BINS}\n1\n1.0\n\
             {eta} 1 100 0.9 1E8\n1.0\n\n"
        );
    }
    s
}

/// MCML's exit factor per angle bin from one .mco: the bin's share of the
/// diffuse reflectance (Rd_a times MCML's solid angle 2 pi sin(a) da, the
/// inverse of its `ScaleRdTt`) over the bin's Lambertian share.
fn mcml_factor(text: &str) -> Vec<f64> {
    let a = section(text, "Rd_a");
    let rd: f64 = text
        .lines()
        .find(|l| l.contains("#Diffuse reflectance"))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::NAN);
    let da = std::f64::consts::PI / (2.0 * BINS as f64);
    let shares = ssskit::profile::mc::angular::lambert_shares(BINS);
    (0..BINS)
        .map(|i| {
            let sr = 2.0 * std::f64::consts::PI * da * ((i as f64 + 0.5) * da).sin();
            a[i] * sr / (rd * shares[i])
        })
        .collect()
}

fn mcml_exit(scale: f64, data: &mut serde_json::Value) -> Table {
    let mut t = Table::new(&[
        "index",
        "exit bin (deg)",
        "exit factor MCML 1.2.2",
        "exit factor ssskit",
        "difference / combined stderr",
    ]);
    let Some(bin) = std::env::var_os("SSSKIT_MCML") else {
        let mut row = vec![String::new(); 5];
        row[0] = "not run (SSSKIT_MCML unset)".into();
        t.push(row);
        return t;
    };
    let per_run = ((1e5 * scale) as u64).max(ssskit::profile::mc::CHUNK);
    let ours_photons = per_run * MCML_RUNS;
    let dir = std::env::temp_dir().join(format!("ssskit-bench-exit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let mut record = Vec::new();
    for eta in EXIT_ETAS {
        std::fs::write(dir.join("m.mci"), exit_mci(eta, per_run, MCML_RUNS, "m")).unwrap();
        std::fs::write(dir.join("s.mci"), exit_mci(eta, ours_photons, 1, "s")).unwrap();
        let ok = run_mcml(&bin, &dir);
        assert!(ok, "MCML at {} failed", Path::new(&bin).display());
        let runs: Vec<Vec<f64>> = (0..MCML_RUNS)
            .map(|k| mcml_factor(&std::fs::read_to_string(dir.join(format!("m{k}.mco"))).unwrap()))
            .collect();
        let n = MCML_RUNS as f64;
        let mean: Vec<f64> = (0..BINS)
            .map(|i| runs.iter().map(|r| r[i]).sum::<f64>() / n)
            .collect();
        let se: Vec<f64> = (0..BINS)
            .map(|i| {
                let ss: f64 = runs.iter().map(|r| (r[i] - mean[i]).powi(2)).sum();
                (ss / (n - 1.0) / n).sqrt()
            })
            .collect();
        common::ok_in(
            &dir,
            &[
                "simulate", "--mci", "s.mci", "--out", "s.json", "--seed", "1",
            ],
        );
        let p = ssskit::profile::Profile::read(&dir.join("s.json")).unwrap();
        let x = p.angular().unwrap().unwrap().exit.unwrap();
        let mut z = Vec::new();
        for i in 0..BINS {
            let (f, fe) = (x.factor[0][i], x.factor_stderr[0][i]);
            let zi = (f - mean[i]) / (se[i].powi(2) + fe.powi(2)).sqrt();
            z.push(zi);
            t.push(vec![
                format!("{eta}"),
                format!("{}-{}", 10 * i, 10 * i + 10),
                pm(mean[i], se[i]),
                pm(f, fe),
                format!("{zi:+.2}"),
            ]);
        }
        record.push(serde_json::json!({
            "eta": eta, "mcml_factor": mean, "mcml_stderr": se,
            "mcml_runs": MCML_RUNS, "mcml_photons_per_run": per_run,
            "ssskit_factor": x.factor[0], "ssskit_stderr": x.factor_stderr[0],
            "ssskit_photons": ours_photons, "z": z,
        }));
    }
    data["mcml_exit"] = serde_json::json!(record);
    let _ = std::fs::remove_dir_all(&dir);
    t
}

fn main() {
    let scale = common::mcml::bench_scale();
    let machine = machine_line();
    let mut data = serde_json::json!({});
    let f = factors(scale, &mut data);
    eprintln!("{}", f.markdown());
    let m = mcml(scale, &mut data);
    eprintln!("{}", m.markdown());
    let x = mcml_exit(scale, &mut data);
    eprintln!("{}", x.markdown());
    let r = Record::new(
        if std::env::var_os("SSSKIT_MCML").is_some() {
            "SSSKIT_MCML=<MCML 1.2.2, gcc -O3> cargo bench --bench mc_angular"
        } else {
            "cargo bench --bench mc_angular"
        },
        &machine,
    );
    let tables = [("factors", &f), ("mcml", &m), ("mcml-exit", &x)];
    docs_record::write(r, "mc-angular", &tables, data);
}

/// MCML 1.2.2 on `dir`/m.mci, run in `dir`: whether it ran and succeeded.
fn run_mcml(bin: &std::ffi::OsStr, dir: &Path) -> bool {
    Command::new(bin)
        .arg("m.mci")
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}
