//! One figure for one thing in the advice's words
//! (`report::present::advice_text::explain`, what `advise` prints and
//! report.md shows): the worst case is the figure of the row it names, in
//! the table and in the predicted errors; the disk line's score is its
//! row's; every arithmetic the text prints evaluates to the value it
//! prints. Computed from real advice (a dipole profile, small signals), so
//! a change to how a figure is measured or printed fails here.

use ssskit::kernel::reference::dipole_profile;
use ssskit::material::preset;
use ssskit::profile::RadialGrid;
use ssskit::progress::NoProgress;
use ssskit::report::eval::advise::{advise, Advice, Config, DEFAULT_TARGET};
use ssskit::report::present::advice_text::explain;

/// Scale and signal side: skin1's kernel spans a few dozen pixels, enough
/// for every layout, few enough for a test of seconds.
const MM: f64 = 0.25;
const SIZE: usize = 32;

fn advice(families: &[&str], target: f64) -> Advice {
    let m = preset("skin1").unwrap();
    let grid = RadialGrid::uniform(0.02, 8.0).unwrap();
    let profile = dipole_profile(&m, &grid).unwrap();
    let mut cfg = Config::new(MM, target);
    cfg.size = SIZE;
    cfg.families = families.iter().map(|f| f.to_string()).collect();
    advise(&profile, &cfg, &NoProgress).unwrap()
}

/// The number after `after` on `line`, up to the next character that is
/// not part of a number.
fn number_after(line: &str, after: &str) -> Option<f64> {
    let rest = line.split_once(after)?.1.trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
        .unwrap_or(rest.len());
    rest[..end].trim_end_matches('.').parse().ok()
}

/// The text's worst case ("worst case 3.474% +- 0.006% on checker3px")
/// is the chosen row's column for that signal and the largest channel of
/// "predicted on checker3px", to the digits printed.
fn worst_case_is_its_row(a: &Advice, text: &str) {
    let c = a.chosen();
    let sig = &c.verdict.worst_signal;
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("worst case "))
        .unwrap_or_else(|| panic!("{text}"));
    let worst = number_after(line, "worst case").unwrap();
    assert!(line.contains(&format!("on {sig};")), "{line}");
    let predicted = text
        .lines()
        .find(|l| l.contains(&format!("predicted on {sig}:")))
        .unwrap_or_else(|| panic!("{text}"));
    let channels: Vec<f64> = predicted
        .split_once("relative RMS")
        .unwrap()
        .1
        .split('/')
        .take(3)
        .map(|v| number_after(v, "").unwrap())
        .collect();
    let largest = channels.iter().cloned().fold(0.0, f64::max);
    assert_eq!(
        format!("{worst:.3}"),
        format!("{largest:.3}"),
        "{line}\n{predicted}"
    );
    // The table: the chosen row's column of that signal ("NAME %" in
    // the header, after the six columns of the layout).
    let header: Vec<&str> = text
        .lines()
        .find(|l| l.trim_start().starts_with("model "))
        .unwrap_or_else(|| panic!("{text}"))
        .split_whitespace()
        .collect();
    let signals: Vec<&str> = header
        .windows(2)
        .filter(|w| w[1] == "%" && w[0] != "worst")
        .map(|w| w[0])
        .collect();
    let k = signals.iter().position(|s| s == sig).unwrap();
    let row = text
        .lines()
        .find(|l| l.trim_end().ends_with(" chosen"))
        .unwrap_or_else(|| panic!("{text}"));
    let cell: f64 = row.split_whitespace().nth(6 + k).unwrap().parse().unwrap();
    assert_eq!(format!("{cell:.3}"), format!("{worst:.3}"), "{row}");
}

/// Every arithmetic the text prints, evaluated: "P passes x T taps = S
/// samples per pixel", "1 pass of N samples = N samples per pixel", "R mm
/// = X px" at the scale, the extent rule "holding H% ... (1 - 0.7 N^-1.2
/// at N = n)"; and no square root printed without its evaluation.
fn formulas_evaluate(text: &str) {
    let mut checked = 0;
    for line in text.lines() {
        for part in line.split([';', '(', ')', ',']) {
            if let (Some(p), Some(t), Some(s)) = (
                number_after(part, ""),
                number_after(part, "passes x"),
                number_after(part, "taps ="),
            ) {
                assert_eq!(p * t, s, "{part}");
                checked += 1;
            }
            if part.contains("pass of") {
                let (n, s) = (
                    number_after(part, "pass of").unwrap(),
                    number_after(part, "samples =").unwrap(),
                );
                assert_eq!(n, s, "{part}");
                checked += 1;
            }
        }
        if let (Some(r), Some(px)) = (
            number_after(line, "holding 99%:"),
            number_after(line, "mm ="),
        ) {
            assert_eq!(format!("{:.1}", r / MM), format!("{px:.1}"), "{line}");
            checked += 1;
        }
        if let Some(n) = number_after(line, "N^-1.2 at N =") {
            let h = number_after(line, "holding").unwrap();
            assert_eq!(
                format!("{h:.2}"),
                format!("{:.2}", 100.0 * (1.0 - 0.7 * n.powf(-1.2))),
                "{line}"
            );
            checked += 1;
        }
        assert!(
            !line.contains("sqrt("),
            "a formula left unevaluated: {line}"
        );
    }
    assert!(checked >= 2, "no formula found: {text}");
}

/// A disk kernel chosen: its worst case is its row's; the disk line's
/// score ("errs X%") is that figure; the formulas evaluate.
#[test]
fn a_disk_answer_prints_one_figure_per_thing() {
    let a = advice(&["disk"], DEFAULT_TARGET);
    assert_eq!(a.chosen().model, "disk");
    let text = explain(&a);
    worst_case_is_its_row(&a, &text);
    formulas_evaluate(&text);
    let disk = text
        .lines()
        .find(|l| l.trim_start().starts_with("disk: on "))
        .unwrap_or_else(|| panic!("{text}"));
    let c = a.chosen();
    assert!(
        disk.contains(&format!("on {}, channel", c.verdict.worst_signal)),
        "{disk}"
    );
    let score = number_after(disk, "frames errs").unwrap();
    assert_eq!(
        format!("{score:.3}"),
        format!("{:.3}", 100.0 * c.verdict.rel_rms),
        "{disk}"
    );
}

/// Separable answers, one meeting a loose target and one missing a tight
/// one (the table's "why" column then compares costs): the same.
#[test]
fn separable_answers_print_one_figure_per_thing() {
    for target in [0.2, 0.001] {
        let a = advice(&["preintegrate", "svd"], target);
        let text = explain(&a);
        worst_case_is_its_row(&a, &text);
        formulas_evaluate(&text);
    }
}
