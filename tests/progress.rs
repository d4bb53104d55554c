//! Progress as a user sees it when stderr is not a terminal (a pipe, as
//! here, or a log file): one line per stage when it ends, naming the work,
//! its units done and its seconds (src/cli/progress.rs); and the work a
//! Monte Carlo run announces, the units an ETA is taken from.

mod common;

use common::{ok_both, read_json};
use ssskit::material::preset;
use ssskit::profile::mc::{simulate, PhotonBudget, CHUNK, FIRST_ROUND};
use ssskit::progress::Progress;
use std::sync::Mutex;

/// The stage lines of `stderr` whose work is `what`: (units done, total
/// when it is not all of them).
fn stage_lines(stderr: &str, what: &str) -> Vec<(u64, Option<u64>)> {
    let prefix = format!("{what}: ");
    stderr
        .lines()
        .filter_map(|l| l.strip_prefix(&prefix))
        .map(|rest| {
            let (count, secs) = rest.split_once(" in ").expect("'N in S s'");
            let secs = secs.strip_suffix(" s").expect("seconds");
            assert!(secs.parse::<f64>().unwrap() >= 0.0, "{rest}");
            match count.split_once(" of ") {
                Some((done, total)) => (done.parse().unwrap(), Some(total.parse().unwrap())),
                None => (count.parse().unwrap(), None),
            }
        })
        .collect()
}

/// `simulate --material skin1` with `budget` (a flag and its value):
/// its stderr and the profile it wrote.
fn simulate_skin1(budget: [&str; 2]) -> (String, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.json");
    let out = out.to_str().unwrap();
    let args = ["simulate", "--material", "skin1", budget[0], budget[1]];
    let (_, err) = ok_both(&[&args[..], &["--out", out]].concat());
    (err, read_json(std::path::Path::new(out)))
}

/// A fixed run of 20000 photons per channel: one line, 60000 photons, and
/// nothing else on stderr.
#[test]
fn a_fixed_simulation_prints_one_line_with_its_photons() {
    let (err, _) = simulate_skin1(["--photons", "2e4"]);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(
        stage_lines(&err, "skin1 photons"),
        [(60_000, None)],
        "{err}"
    );
}

/// A run to a target error: its line counts the photons the profile
/// records, all of the work it announced by the end (not the cap of 10^8
/// per channel it will not reach).
#[test]
fn a_run_to_a_target_counts_the_photons_it_traced() {
    let (err, p) = simulate_skin1(["--kernel-error", "0.02"]);
    let traced: u64 = p["source"]["photons"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(
        stage_lines(&err, "skin1 photons"),
        [(traced, None)],
        "{err}"
    );
}

/// `advise` from an analytic profile: the advice's stage, one line, one
/// unit per kernel model searched and one for the disk kernels.
#[test]
fn advise_prints_one_line_for_its_search() {
    let (_, err) = ok_both(&common::skin1_pbd_args(
        "advise",
        &["--mm-per-pixel", "0.2", "--signal-size", "48"],
    ));
    let lines = stage_lines(&err, "advice: kernel models searched");
    assert_eq!(lines.len(), 1, "{err}");
    let (done, of) = lines[0];
    assert!(done > 1 && of.is_none(), "{err}");
}

/// The main job from an analytic profile: a line for each of its stages
/// after the profile, in order, each once: the fits and images, the
/// advice, the files (the files' count is what it wrote).
#[test]
fn the_main_job_prints_one_line_per_stage() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("k");
    let (_, err) = ok_both(&common::skin1_pbd_args(
        "kernels",
        &[
            "--signal-size",
            "32",
            "--no-plots",
            "--out-dir",
            out.to_str().unwrap(),
        ],
    ));
    let stages = [
        "material x model",
        "advice: kernel models searched",
        "report and files",
    ];
    let at: Vec<usize> = stages
        .iter()
        .map(|s| {
            assert_eq!(stage_lines(&err, s).len(), 1, "{s}: {err}");
            err.find(&format!("{s}: ")).unwrap()
        })
        .collect();
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{err}");
    let files = walk(&out);
    assert_eq!(
        stage_lines(&err, "report and files"),
        [(files, None)],
        "{err}"
    );
}

/// Regular files under `dir`, at any depth, but the output folder's own
/// hidden marker (`io::StagedDir`), which no stage writes.
fn walk(dir: &std::path::Path) -> u64 {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p)
            } else {
                u64::from(!p.file_name().unwrap().to_string_lossy().starts_with('.'))
            }
        })
        .sum()
}

/// Records what a run announces and does.
#[derive(Default)]
struct Recorder {
    starts: Mutex<Vec<u64>>,
    totals: Mutex<Vec<(u64, u64)>>,
    done: Mutex<u64>,
}

impl Progress for Recorder {
    fn start(&self, total: u64, _what: &str) {
        self.starts.lock().unwrap().push(total);
    }
    fn advance(&self, n: u64) {
        *self.done.lock().unwrap() += n;
    }
    fn set_total(&self, total: u64) {
        let done = *self.done.lock().unwrap();
        self.totals.lock().unwrap().push((done, total));
    }
}

/// A Monte Carlo run to a target announces its first round (the work it
/// can see), then after each round what it projects, never less than it
/// has done, never more than its cap; the last total is the work done.
/// A fixed run announces all of it once.
#[test]
fn a_monte_carlo_run_announces_the_work_it_will_do() {
    let m = preset("skin1").unwrap();
    let mut cfg = common::mc::kernel_factor_cfg();
    let rec = Recorder::default();
    simulate(&m, &cfg, &rec).unwrap();
    let starts = rec.starts.lock().unwrap().clone();
    assert_eq!(starts, [3 * FIRST_ROUND * CHUNK]);
    let totals = rec.totals.lock().unwrap().clone();
    assert!(totals.len() >= 2, "{totals:?}");
    for &(done, total) in &totals {
        assert!(done <= total && total <= 3 * 10_000_000, "{totals:?}");
    }
    let done = *rec.done.lock().unwrap();
    assert_eq!(totals.last().unwrap().1, done);

    cfg.budget = PhotonBudget::Fixed(20_000);
    let rec = Recorder::default();
    simulate(&m, &cfg, &rec).unwrap();
    assert_eq!(rec.starts.lock().unwrap().clone(), [60_000]);
    assert!(rec.totals.lock().unwrap().is_empty());
    assert_eq!(*rec.done.lock().unwrap(), 60_000);
}
