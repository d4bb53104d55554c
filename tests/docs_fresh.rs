//! Generated documentation and the thesis's claims, from one set of runs.
//!
//! Runs every command of docs/compare-runs.txt once (the runs that
//! scripts/regen-docs makes: `ssskit compare`, `ssskit profiles compare`) and
//! - fails when a block `<!-- BEGIN compare:RUN/BLOCK -->` in README.md or
//!   docs/*.md differs from block BLOCK of the markdown RUN wrote (rerun
//!   scripts/regen-docs after changing a kernel, a profile or the code);
//! - checks the claims of Freude 2014 (tables 6.3, 6.4, 6.5, fig. 5.15) on
//!   the runs' compare.json rows, computed here independently of the
//!   report's own claim table. Where a claim does not reproduce the test
//!   says so and checks what holds instead.

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

mod common;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// Splits a command line on spaces, keeping "quoted words" (may be empty).
fn split_args(s: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let (mut quoted, mut any) = (false, false);
    for ch in s.chars() {
        match ch {
            '"' => {
                quoted = !quoted;
                any = true;
            }
            ' ' if !quoted => {
                if any {
                    out.push(std::mem::take(&mut cur));
                    any = false;
                }
            }
            c => {
                cur.push(c);
                any = true;
            }
        }
    }
    if any {
        out.push(cur);
    }
    out
}

struct Runs {
    _dir: tempfile::TempDir,
    /// Run name -> output folder.
    out: BTreeMap<String, PathBuf>,
}

fn runs() -> &'static Runs {
    static RUNS: OnceLock<Runs> = OnceLock::new();
    RUNS.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let spec = std::fs::read_to_string(Path::new(ROOT).join("docs/compare-runs.txt")).unwrap();
        let mut out = BTreeMap::new();
        for line in spec
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        {
            let (name, args) = line.split_once(':').unwrap();
            let o = dir.path().join(name);
            let words = split_args(args);
            let argv: Vec<String> = if words.first().is_some_and(|w| w.starts_with("--")) {
                let mut v = vec!["compare".to_string()];
                v.extend(words);
                v.extend(["--out-dir".to_string(), o.display().to_string()]);
                v
            } else {
                // Another subcommand: OUT stands for the run's folder.
                words
                    .into_iter()
                    .map(|w| {
                        if w == "OUT" {
                            o.display().to_string()
                        } else {
                            w
                        }
                    })
                    .collect()
            };
            common::output_ok(
                common::bin().current_dir(ROOT).args(&argv),
                &format!("run {name}"),
            );
            out.insert(name.to_string(), o);
        }
        Runs { _dir: dir, out }
    })
}

/// Every markdown file a run wrote (report.md of `compare`, compare.md of
/// `profiles compare`), concatenated.
fn run_markdown(dir: &Path) -> String {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    files.sort();
    files
        .iter()
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect()
}

/// (name, body) of every block in `text`.
fn blocks(text: &str) -> Vec<(String, String)> {
    ssskit::report::present::kernel_report::blocks(text)
}

#[test]
fn committed_tables_are_what_the_runs_produce() {
    let r = runs();
    let files = common::doc_markdown_files();
    let mut checked = 0;
    let mut stale = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (name, body) in blocks(&text) {
            let Some((run, block)) = name.split_once('/') else {
                continue;
            };
            let dir = r
                .out
                .get(run)
                .unwrap_or_else(|| panic!("{}: block {name}: no run '{run}'", f.display()));
            let fresh = blocks(&run_markdown(dir))
                .into_iter()
                .find(|(n, _)| n == block)
                .unwrap_or_else(|| panic!("{}: run {run} has no block {block}", f.display()))
                .1;
            checked += 1;
            if fresh != body {
                stale.push(format!(
                    "{}: {name}\n--- committed\n{body}--- produced now\n{fresh}",
                    f.display()
                ));
            }
        }
    }
    assert!(checked >= 9, "only {checked} generated blocks found");
    assert!(
        stale.is_empty(),
        "stale tables (run scripts/regen-docs):\n{}",
        stale.join("\n")
    );
}

/// Rows of a run: (material, label, channel) -> row.
fn rows(run: &str) -> BTreeMap<(String, String, String), Value> {
    let text = std::fs::read_to_string(runs().out[run].join("compare.json")).unwrap();
    let v: Vec<Value> = serde_json::from_str(&text).unwrap();
    v.into_iter()
        .map(|r| {
            let key = (
                r["material"].as_str().unwrap().to_string(),
                r["label"].as_str().unwrap().to_string(),
                r["channel"].as_str().unwrap().to_string(),
            );
            (key, r)
        })
        .collect()
}

const MATERIALS: [&str; 5] = ["apple", "ketchup", "marble", "skin1", "wholemilk"];
const CH: [&str; 3] = ["r", "g", "b"];

fn get<'a>(
    rows: &'a BTreeMap<(String, String, String), Value>,
    m: &str,
    l: &str,
    c: &str,
) -> &'a Value {
    rows.get(&(m.into(), l.into(), c.into()))
        .unwrap_or_else(|| panic!("no row {m} {l} {c}"))
}

/// Sum over R, G, B of the relative RMS of `signal` with `factor` ("full" or
/// a tap count).
fn image_sum(
    rows: &BTreeMap<(String, String, String), Value>,
    m: &str,
    l: &str,
    signal: &str,
    factor: &str,
) -> f64 {
    CH.iter()
        .map(|c| {
            let e = &get(rows, m, l, c)["image"][signal];
            let x = if factor == "full" {
                &e["full"]
            } else {
                &e["taps"][factor]
            };
            x["rel_rms"].as_f64().unwrap()
        })
        .sum()
}

/// Table 6.3: the unnormalised rank-1 SVD has the lowest kernel RMS of the
/// rank-1 models on every material and channel (reproduces); pre-integration
/// is 2-3x (reproduces; Freude 2014 prints 2.06-2.38); guided k = 1 is 2-3x
/// in Freude 2014: the lower end holds everywhere and is asserted, the upper
/// end does not (ketchup green and blue, whose kernels span a few cells of
/// a grid sized by the red channel, and others): the measured range is in
/// the generated claims table (docs/kernels.md), which
/// `committed_tables_are_what_the_runs_produce` pins.
#[test]
fn table_6_3_kernel_rms_ordering() {
    let rows = rows("kernels");
    for m in MATERIALS {
        for c in CH {
            let k = |l: &str| get(&rows, m, l, c)["kernel_rms"].as_f64().unwrap();
            let s = k("svd1");
            // Every rank-1 kernel the run made (one separable term: two
            // 1D passes, docs/kernels.md), as the rows say, not a list
            // typed here: a model added to the comparison joins the claim.
            let others: Vec<&str> = rows
                .iter()
                .filter(|((rm, l, rc), r)| {
                    rm == m && rc == c && l != "svd1" && r["passes"].as_u64() == Some(2)
                })
                .map(|((_, l, _), _)| l.as_str())
                .collect();
            // `--models all` makes eight other rank-1 variants or more
            // (renormalised SVD, pre-integration, two guided, manual and
            // its fit, a Gaussian, Jimenez).
            assert!(others.len() >= 8, "{m} {c}: rank-1 kernels {others:?}");
            for o in others {
                assert!(s < k(o), "{m} {c}: svd1 {s} >= {o} {}", k(o));
            }
            let pre = k("preintegrate") / s;
            assert!(
                (2.0..=3.0).contains(&pre),
                "{m} {c}: pre-integration / svd1 = {pre}"
            );
            let g = k("guided-k1") / s;
            assert!(g >= 2.0, "{m} {c}: guided k=1 / svd1 = {g}");
        }
    }
}

/// Table 6.4: the renormalised rank-1 SVD (Freude's renderer normalises every
/// kernel) has the largest image error of SVD, pre-integration, guided k = 1
/// and manual (table A.1) "in most cases": asserted as a majority, 3 of the
/// 5 materials, for both signals, with 17-tap tables and with full factors.
/// On the edge with full factors pre-integration is exact up to the
/// resampling of its grid to pixels (Freude 2014, sec. 5.2): better than
/// guided and manual on every material. "Pre-integration, guided and manual
/// comparable" has no number to test: the ratios are in the generated
/// claims table (pinned by `committed_tables_are_what_the_runs_produce`).
#[test]
fn table_6_4_image_space_ranking() {
    let rows = rows("kernels");
    for signal in ["edge", "shapes"] {
        for factor in ["17", "full"] {
            let mut worst = 0;
            for m in MATERIALS {
                let e = |l: &str| image_sum(&rows, m, l, signal, factor);
                let svd = e("svd1-renorm");
                let (pre, gui, man) = (e("preintegrate"), e("guided-k1"), e("manual"));
                if svd > pre && svd > gui && svd > man {
                    worst += 1;
                }
                // The unnormalised rank-1 SVD loses 40-90% of the energy:
                // worse still than its renormalised version.
                assert!(e("svd1") > svd, "{signal} {factor} {m}");
                if signal == "edge" && factor == "full" {
                    // Exact up to the resampling of the kernel grid to pixels.
                    assert!(pre < gui.min(man), "{m}: pre-integration {pre}");
                }
            }
            assert!(
                worst >= 3,
                "{signal} {factor}: renormalised svd1 worst on {worst} of 5"
            );
        }
    }
}

/// Table 6.5 on skin1: "SVD saves about one rank": the renormalised SVD of
/// rank N has at most the image error of N + 1 renormalised Gaussians
/// (reproduces for N = 1..5, both signals, full factors and 17 taps), and
/// always beats N Gaussians.
#[test]
fn table_6_5_svd_against_gaussians() {
    let rows = rows("ranks");
    for signal in ["edge", "shapes"] {
        for factor in ["full", "17"] {
            for n in 1..=6 {
                let svd = image_sum(&rows, "skin1", &format!("svd{n}-renorm"), signal, factor);
                let same = image_sum(
                    &rows,
                    "skin1",
                    &format!("gaussians{n}-renorm"),
                    signal,
                    factor,
                );
                assert!(
                    svd <= same,
                    "{signal} {factor} rank {n}: svd {svd} > gaussians {same}"
                );
                if n < 6 {
                    let next = image_sum(
                        &rows,
                        "skin1",
                        &format!("gaussians{}-renorm", n + 1),
                        signal,
                        factor,
                    );
                    assert!(
                        svd <= next,
                        "{signal} {factor}: svd rank {n} {svd} > {} Gaussians {next}",
                        n + 1
                    );
                }
            }
        }
    }
}

/// Fig. 5.15: guided k = 1.55, b = 50 close to pre-integration. b refers to
/// the kernel's interval scaled to [-1, 1], so the claim depends on the
/// extent: at the default extent (99.9% of R_d) k = 1 is closer to
/// pre-integration than k = 1.55, b = 50 on most materials and channels; on
/// kernels cut to +-2.5 mm, k = 1.55, b = 50 is the closer one on most.
#[test]
fn fig_5_15_depends_on_the_kernel_extent() {
    let count = |run: &str| -> (usize, usize) {
        let dir = &runs().out[run];
        let mut holds = 0;
        let mut total = 0;
        for m in MATERIALS {
            let read = |l: &str| -> ssskit::kernel::KernelFile {
                ssskit::kernel::KernelFile::read(&dir.join("kernels").join(format!("{m}-{l}.json")))
                    .unwrap()
            };
            let (p, g, g1) = (
                read("preintegrate"),
                read("guided-k1.55-b50"),
                read("guided-k1"),
            );
            for c in 0..3 {
                let d = |a: &ssskit::kernel::KernelFile| {
                    let (x, y) = (&a.passes[0].weights, &p.passes[0].weights);
                    let num: f64 = x.iter().zip(y).map(|(u, v)| (u[c] - v[c]).powi(2)).sum();
                    let den: f64 = y.iter().map(|v| v[c] * v[c]).sum();
                    (num / den).sqrt()
                };
                total += 1;
                holds += (d(&g) < d(&g1)) as usize;
            }
        }
        (holds, total)
    };
    let (default_holds, n) = count("kernels");
    let (small_holds, n2) = count("extent2.5");
    eprintln!(
        "fig. 5.15: closer at the default extent {default_holds}/{n}, at 2.5 mm {small_holds}/{n2}"
    );
    assert!(2 * default_holds < n, "{default_holds} of {n}");
    assert!(2 * small_holds > n2, "{small_holds} of {n2}");
}
