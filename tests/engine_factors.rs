//! `ssskit engine` on the entry and exit factors (src/engine/factors_place.rs):
//! for every engine and Blender convention, the real binary prints where
//! each factor goes (or that it has no place), the tables to use where
//! there is one, and the error kept without them on the lit sphere; the
//! kept errors are recomputed here from the profile's own tables with a
//! different quadrature. A profile without angular tables gets one line.

mod common;

use common::{ok, p};
use ssskit::kernel::angular::AngularFactors;

/// The lines print percentages to 2 decimals: half a unit of the last
/// digit, plus the two quadratures' difference (far below 1e-4 points).
const PRINT_TOLERANCE_PCT: f64 = 0.006;
/// Trapezoid points in mu of this test's disk integral (the binary uses
/// midpoints in mu^2).
const POINTS: usize = 20_000;
/// Photons per channel and incidence of the test profile: the numbers
/// compared come from the same tables, so their noise does not matter.
const PHOTONS: &str = "20000";

/// (engine, version, has a place for E, has a place for X).
const ENGINES: [(&str, Option<&str>, bool, bool); 7] = [
    ("unreal", None, false, true),
    ("unity-hdrp", None, false, true),
    ("blender", Some("4"), false, true),
    ("blender", Some("eevee"), false, true),
    ("blender", Some("2.93"), false, true),
    ("godot", None, true, true),
    ("iryoku", None, true, true),
];

fn at(t: &[[f64; 3]], mu: f64, c: usize) -> f64 {
    let n = t.len() - 1;
    let x = mu * n as f64;
    let i = (x.floor() as usize).min(n - 1);
    t[i][c] + (x - i as f64) * (t[i + 1][c] - t[i][c])
}

/// RMS % of the peak and bias % of the image without the factors left
/// out, by the trapezoid rule in mu with the disk's weight 2 mu dmu.
fn kept(f: &AngularFactors, entry: bool, exit: bool) -> ([f64; 3], [f64; 3]) {
    let mut rms = [0.0; 3];
    let mut bias = [0.0; 3];
    for c in 0..3 {
        let (mut sq, mut d, mut w, mut peak) = (0.0, 0.0, 0.0, 0.0f64);
        for i in 0..=POINTS {
            let mu = i as f64 / POINTS as f64;
            let (e, x) = (at(&f.entry, mu, c), at(&f.exit, mu, c));
            let full = mu * e * x;
            let shipped = mu * if entry { e } else { 1.0 } * if exit { x } else { 1.0 };
            let weight = if i == 0 || i == POINTS { 0.5 } else { 1.0 } * 2.0 * mu / POINTS as f64;
            sq += weight * (shipped - full).powi(2);
            d += weight * (shipped - full);
            w += weight * full;
            peak = peak.max(full);
        }
        rms[c] = 100.0 * sq.sqrt() / peak;
        bias[c] = 100.0 * d / w;
    }
    (rms, bias)
}

/// The three numbers after `key` in `line` ("RMS 1.23 / 4.56 / 7.89%").
fn three(line: &str, key: &str) -> [f64; 3] {
    let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key} in {line}")) + key.len()..];
    let v: Vec<f64> = rest
        .split('%')
        .next()
        .unwrap()
        .split('/')
        .map(|s| s.trim().parse().unwrap_or_else(|_| panic!("{line}")))
        .collect();
    [v[0], v[1], v[2]]
}

fn close(got: [f64; 3], want: [f64; 3], what: &str) {
    for c in 0..3 {
        assert!(
            (got[c] - want[c]).abs() <= PRINT_TOLERANCE_PCT,
            "{what}, channel {c}: printed {got:?}, from the tables {want:?}"
        );
    }
}

/// skin1's profile, simulated with `extra` flags into `dir`.
fn skin1_profile(dir: &std::path::Path, extra: &[&str]) -> std::path::PathBuf {
    let prof = dir.join("p.json");
    let mut args = vec!["simulate", "--material", "skin1", "--photons", PHOTONS];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", p(&prof)]);
    ok(&args);
    prof
}

#[test]
fn each_engine_says_where_the_factors_go_and_what_is_kept_without_them() {
    let dir = tempfile::tempdir().unwrap();
    let prof = skin1_profile(
        dir.path(),
        &["--angle-bins", "90", "--incidence", "30,60,80"],
    );
    let profile = ssskit::profile::Profile::read(&prof).unwrap();
    let f = AngularFactors::from_profile(&profile).unwrap().unwrap();
    let (none_rms, none_bias) = kept(&f, false, false);
    // The measure has something to find: skin under a 1.3 boundary.
    assert!(
        none_rms.iter().all(|&r| r > 100.0 * PRINT_TOLERANCE_PCT),
        "{none_rms:?}"
    );
    for (engine, version, entry, exit) in ENGINES {
        let mut args = vec!["engine", "--profile", p(&prof), "--engine", engine];
        args.extend(version.iter().flat_map(|v| ["--engine-version", v]));
        let out = ok(&args);
        let what = format!("{engine} {version:?}");
        let line = |start: &str| {
            out.lines()
                .find(|l| l.starts_with(start))
                .unwrap_or_else(|| panic!("{what}: no line {start}\n{out}"))
        };
        let e_line = line("entry factor E(N.L): ");
        let x_line = line("exit factor X(N.V): ");
        assert_eq!(e_line.contains("no place"), !entry, "{what}: {e_line}");
        assert_eq!(x_line.contains("no place"), !exit, "{what}: {x_line}");
        // The tables where there is a place, as the profile holds them.
        for (has, table, tag) in [(entry, &f.entry, "  E at"), (exit, &f.exit, "  X at")] {
            let printed = out.lines().find(|l| l.starts_with(tag));
            assert_eq!(printed.is_some(), has, "{what}: {tag}\n{out}");
            if let Some(l) = printed {
                let r: Vec<String> = table.iter().map(|row| format!("{:.3}", row[0])).collect();
                assert!(l.contains(&format!("r [{}]", r.join(", "))), "{what}: {l}");
            }
        }
        let kept_line = line("error kept without the factors");
        close(three(kept_line, "RMS "), none_rms, &format!("{what}: RMS"));
        close(
            three(kept_line, "bias "),
            none_bias,
            &format!("{what}: bias"),
        );
        let part = out.lines().find(|l| l.starts_with("error kept with only"));
        assert_eq!(part.is_some(), entry != exit, "{what}\n{out}");
        if let Some(l) = part {
            let (rms, bias) = kept(&f, entry, exit);
            close(
                three(l, "RMS "),
                rms,
                &format!("{what}: RMS with one factor"),
            );
            close(
                three(l, "bias "),
                bias,
                &format!("{what}: bias with one factor"),
            );
        }
    }
}

#[test]
fn a_profile_without_angular_tables_gets_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let prof = skin1_profile(dir.path(), &[]);
    let out = ok(&["engine", "--profile", p(&prof), "--engine", "godot"]);
    let lines: Vec<&str> = out
        .lines()
        .filter(|l| l.contains("entry and exit factors") || l.contains("factor E(N.L)"))
        .collect();
    assert_eq!(lines.len(), 1, "{out}");
    assert!(lines[0].contains("no angular tables"), "{out}");
}
