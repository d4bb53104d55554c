//! Transmittance profiles against MCML 1.2.2 (plain main, not a timed
//! test); writes the record `docs/records/mc-transmission.json`.
//!
//! With `SSSKIT_MCML=/path/to/mcml` (MCML 1.2.2 built from its public
//! source; Wang, Jacques & Zheng 1995), for each slab of `CASES` (MCML
//! units: cm, cm^-1; air above and below): MCML runs one .mci of
//! `MCML_RUNS` runs of `PER_RUN` photons (MCML seeds its generator once per
//! process, so the runs are independent batches and their spread gives
//! MCML's standard error of the mean), and ssskit runs `simulate --mci` on
//! the same slab with `MCML_RUNS` x `PER_RUN` photons and writes its own
//! .mco. Compared, from the two .mco files: Tt_r per radial bin (the last
//! bin, where both put the light beyond the grid, left out) and Tt_a per
//! exit bin, each as a chi-square of the differences over their combined
//! standard errors, and the total transmittance. tests/mcml_transmission.rs
//! reruns ssskit against the recorded MCML arrays. Without `SSSKIT_MCML`
//! the record says MCML was not run.
//!
//! `SSSKIT_MCML=... cargo bench --bench mc_transmission` takes about 2
//! minutes on 2 idle cores.

#[path = "../tests/common/mod.rs"]
mod common;
mod docs_record;
use common::mcml::section;
use ssskit::report::present::record::{machine_line, Record};
use ssskit::report::present::table::Table;
use std::path::Path;
use std::process::{Command, Stdio};

/// Runs of each MCML .mci (10: MCML's standard error is itself known to
/// about 25%).
const MCML_RUNS: u64 = 10;
/// Photons per MCML run (x `SSSKIT_BENCH_SCALE`).
const PER_RUN: f64 = 2e5;
/// Radial bins (dr = 0.01 cm) and exit-angle bins of every case.
const NR: usize = 40;
const NA: usize = 9;

/// A slab in MCML's units: (label, n, mua, mus, g, d in cm).
const CASES: [(&str, f64, f64, f64, f64, f64); 2] = [
    (
        "n 1.4, mua 1, mus 100, g 0.9, d 0.1 cm",
        1.4,
        1.0,
        100.0,
        0.9,
        0.1,
    ),
    (
        "n 1.0, mua 2, mus 50, g 0.8, d 0.2 cm",
        1.0,
        2.0,
        50.0,
        0.8,
        0.2,
    ),
];

fn mci(case: &(&str, f64, f64, f64, f64, f64), photons: u64, runs: u64, stem: &str) -> String {
    let (_, n, mua, mus, g, d) = *case;
    let mut s = format!("1.0\n{runs}\n");
    for k in 0..runs {
        s += &format!(
            "{stem}{k}.mco A\n{photons}\n0.01 0.01\n1 {NR} {NA}\n1\n1.0\n{n} {mua} {mus} {g} {d}\n1.0\n\n"
        );
    }
    s
}

fn value(text: &str, tag: &str) -> f64 {
    text.lines()
        .find(|l| l.contains(tag))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::NAN)
}

/// Mean and standard error of the mean, per entry, over runs.
fn mean_se(runs: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    let n = runs.len() as f64;
    let len = runs[0].len();
    let mean: Vec<f64> = (0..len)
        .map(|i| runs.iter().map(|r| r[i]).sum::<f64>() / n)
        .collect();
    let se = (0..len)
        .map(|i| {
            let ss: f64 = runs.iter().map(|r| (r[i] - mean[i]).powi(2)).sum();
            (ss / (n - 1.0) / n).sqrt()
        })
        .collect();
    (mean, se)
}

/// Chi-square of `ours` (+- `ose`) against `theirs` (+- `tse`) over the
/// entries where both have a standard error, and its degrees of freedom.
fn chi2(ours: &[f64], ose: &[f64], theirs: &[f64], tse: &[f64]) -> (f64, usize) {
    let mut c = 0.0;
    let mut dof = 0;
    for i in 0..ours.len() {
        let v = ose[i].powi(2) + tse[i].powi(2);
        if ose[i] > 0.0 && tse[i] > 0.0 {
            c += (ours[i] - theirs[i]).powi(2) / v;
            dof += 1;
        }
    }
    (c, dof)
}

fn main() {
    let scale = common::mcml::bench_scale();
    let machine = machine_line();
    let mut t = Table::new(&[
        "slab (MCML units, air above and below)",
        "T MCML 1.2.2",
        "T ssskit",
        "difference / combined stderr",
        "Tt_r chi-square / bins",
        "Tt_a chi-square / bins",
    ]);
    let mut data = serde_json::json!({});
    let command = match std::env::var_os("SSSKIT_MCML") {
        None => {
            t.push(vec![
                "not run (SSSKIT_MCML unset)".into(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
                String::new(),
            ]);
            "cargo bench --bench mc_transmission"
        }
        Some(bin) => {
            let per_run = ((PER_RUN * scale) as u64).max(ssskit::profile::mc::CHUNK);
            let mut cases = Vec::new();
            for case in &CASES {
                let (row, rec) = compare(&bin, case, per_run);
                t.push(row);
                cases.push(rec);
            }
            data["cases"] = serde_json::json!(cases);
            "SSSKIT_MCML=<MCML 1.2.2, gcc -O3> cargo bench --bench mc_transmission"
        }
    };
    eprintln!("{}", t.markdown());
    let r = Record::new(command, &machine);
    docs_record::write(r, "mc-transmission", &[("mcml", &t)], data);
}

/// One slab through MCML and ssskit: the table row and the record.
fn compare(
    bin: &std::ffi::OsStr,
    case: &(&str, f64, f64, f64, f64, f64),
    per_run: u64,
) -> (Vec<String>, serde_json::Value) {
    let dir = std::env::temp_dir().join(format!("ssskit-bench-tt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let ours_photons = per_run * MCML_RUNS;
    std::fs::write(dir.join("m.mci"), mci(case, per_run, MCML_RUNS, "m")).unwrap();
    std::fs::write(dir.join("s.mci"), mci(case, ours_photons, 1, "s")).unwrap();
    let ok = Command::new(bin)
        .arg("m.mci")
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "MCML at {} failed", Path::new(bin).display());
    let texts: Vec<String> = (0..MCML_RUNS)
        .map(|k| std::fs::read_to_string(dir.join(format!("m{k}.mco"))).unwrap())
        .collect();
    let arrays = |tag: &str| -> Vec<Vec<f64>> { texts.iter().map(|x| section(x, tag)).collect() };
    let (tt_r, tt_r_se) = mean_se(&arrays("Tt_r"));
    let (tt_a, tt_a_se) = mean_se(&arrays("Tt_a"));
    let totals: Vec<Vec<f64>> = texts
        .iter()
        .map(|x| vec![value(x, "#Transmittance")])
        .collect();
    let (tt, tt_se) = mean_se(&totals);
    common::ok_in(
        &dir,
        &[
            "simulate", "--mci", "s.mci", "--out", "s.json", "--mco", "s.mco", "--seed", "1",
        ],
    );
    let p = ssskit::profile::Profile::read(&dir.join("s.json")).unwrap();
    let tp = p
        .transmittance_profile()
        .unwrap()
        .expect("a transmittance profile");
    let a = tp.angular.as_ref().expect("transmitted exit angles");
    // Our arrays in MCML's units (cm^-2 on the bins, sr^-1 per angle bin).
    let ours_r: Vec<f64> = tp.td[0].iter().map(|v| v * 100.0).collect();
    let ours_r_se: Vec<f64> = tp.td_stderr[0].iter().map(|v| v * 100.0).collect();
    let da = std::f64::consts::PI / (2.0 * NA as f64);
    let sr = |i: usize| 2.0 * std::f64::consts::PI * da * ((i as f64 + 0.5) * da).sin();
    let ours_a: Vec<f64> = (0..NA).map(|i| a.fraction[0][i] / sr(i)).collect();
    let ours_a_se: Vec<f64> = (0..NA).map(|i| a.fraction_stderr[0][i] / sr(i)).collect();
    let last = NR - 1;
    let (c_r, dof_r) = chi2(
        &ours_r[..last],
        &ours_r_se[..last],
        &tt_r[..last],
        &tt_r_se[..last],
    );
    let (c_a, dof_a) = chi2(&ours_a, &ours_a_se, &tt_a, &tt_a_se);
    let t_ours = p.transmittance.as_ref().unwrap()[0];
    let t_se = p.transmittance_stderr.as_ref().unwrap()[0];
    let z = (t_ours - tt[0]) / (t_se.powi(2) + tt_se[0].powi(2)).sqrt();
    let row = vec![
        case.0.to_string(),
        format!("{:.5} +- {:.5}", tt[0], tt_se[0]),
        format!("{t_ours:.5} +- {t_se:.5}"),
        format!("{z:+.2}"),
        format!("{c_r:.1} / {dof_r}"),
        format!("{c_a:.1} / {dof_a}"),
    ];
    let (label, n, mua, mus, g, d) = *case;
    let rec = serde_json::json!({
        "label": label, "n": n, "mua": mua, "mus": mus, "g": g, "d": d,
        "nr": NR, "na": NA, "dr_cm": 0.01,
        "mcml_runs": MCML_RUNS, "mcml_photons_per_run": per_run,
        "mcml_tt_r": tt_r, "mcml_tt_r_stderr": tt_r_se,
        "mcml_tt_a": tt_a, "mcml_tt_a_stderr": tt_a_se,
        "mcml_tt": tt[0], "mcml_tt_stderr": tt_se[0],
        "ssskit_photons": ours_photons,
        "ssskit_tt_r": ours_r, "ssskit_tt_r_stderr": ours_r_se,
        "ssskit_tt_a": ours_a, "ssskit_tt_a_stderr": ours_a_se,
        "ssskit_tt": t_ours, "ssskit_tt_stderr": t_se,
        "chi2_tt_r": c_r, "dof_tt_r": dof_r, "chi2_tt_a": c_a, "dof_tt_a": dof_a, "z_tt": z,
    });
    let _ = std::fs::remove_dir_all(&dir);
    (row, rec)
}
