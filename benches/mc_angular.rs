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
//!
//! `cargo bench --bench mc_angular` takes about 1 minute on 2 idle cores.

use ssskit::material::{preset, Channel};
use ssskit::profile::mc::{simulate_with, AngularOptions, McConfig, McOptions, PhotonBudget};
use ssskit::progress::NoProgress;
use ssskit::report::present::record::{docs_path, machine_line, Record};
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

/// The numbers of a section of an .mco file (after its tag line up to the
/// next empty line).
fn section(text: &str, tag: &str) -> Vec<f64> {
    text.lines()
        .skip_while(|l| !l.starts_with(tag))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .flat_map(|l| l.split_whitespace().filter_map(|v| v.parse().ok()))
        .collect()
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
    let ok = Command::new(&bin)
        .arg("m.mci")
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    let ssskit = Path::new(env!("CARGO_BIN_EXE_ssskit"));
    let ours = Command::new(ssskit)
        .args([
            "simulate", "--mci", "s.mci", "--mco", "s.mco", "--out", "s.json",
        ])
        .current_dir(&dir)
        .output()
        .expect("ssskit runs");
    assert!(
        ours.status.success(),
        "{}",
        String::from_utf8_lossy(&ours.stderr)
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

fn main() {
    let scale: f64 = std::env::var("SSSKIT_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let machine = machine_line();
    let mut data = serde_json::json!({});
    let f = factors(scale, &mut data);
    eprintln!("{}", f.markdown());
    let m = mcml(scale, &mut data);
    eprintln!("{}", m.markdown());
    let mut r = Record::new(
        if std::env::var_os("SSSKIT_MCML").is_some() {
            "SSSKIT_MCML=<MCML 1.2.2, gcc -O3> cargo bench --bench mc_angular"
        } else {
            "cargo bench --bench mc_angular"
        },
        &machine,
    );
    r.tables.insert("factors".into(), (&f).into());
    r.tables.insert("mcml".into(), (&m).into());
    r.data = data;
    let path = docs_path("mc-angular");
    r.write(&path).expect("record written");
    eprintln!("wrote {}", path.display());
}
