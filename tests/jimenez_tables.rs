//! iryoku's kernel, exactly: `ssskit fit --model jimenez` with iryoku's
//! parameters (width 1, `--tap-extent` its RANGE, its default strength and
//! falloff, 11, 17 or 25 taps) reproduces the tables printed in iryoku's
//! SeparableSSS.h (github.com/iryoku/separable-sss at commit b2174689,
//! SSSS_QUALITY 0, 1, 2), and follows `SeparableSSS::calculateKernel` for
//! other parameters; the unscattered part of the strength is the centre
//! tap's weight, whatever the kernel grid.

mod separable_support;
use separable_support::*;

/// SeparableSSS.h's table of `n` samples (SSSS_QUALITY 0, 1, 2 for 11,
/// 17, 25): float4(r, g, b, offset), as printed (centre first), from
/// tests/golden/iryoku-separable-sss.txt.
fn iryoku(n: usize) -> Vec<[f64; 4]> {
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/golden/iryoku-separable-sss.txt"
    );
    let text = std::fs::read_to_string(file).unwrap();
    let rows: Vec<[f64; 4]> = text
        .lines()
        .skip_while(|l| !l.starts_with(&format!("samples {n} ")))
        .skip(1)
        .take_while(|l| !l.starts_with("samples"))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            v.try_into().unwrap()
        })
        .collect();
    assert_eq!(rows.len(), n, "SSSS_N_SAMPLES {n}");
    rows
}

/// SeparableSSS.h prints its weights to 6 decimals: half a unit of the
/// last one (5e-7) plus its f32 arithmetic (3e-8 of a weight near 0.5)
/// stay within one unit.
const SIX_DECIMALS: f64 = 1e-6;

/// `fit --model jimenez` with `extra` flags: the tap table (offset,
/// weights), increasing offsets.
fn fitted_table(extra: &[&str]) -> Vec<(f64, [f64; 3])> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("k.json");
    let mut args = vec![
        "fit",
        "--profile",
        "profiles/reference/skin1.json",
        "--model",
        "jimenez",
        "--quiet",
        "--out",
        p(&out),
    ];
    args.extend_from_slice(extra);
    ok(&args);
    let k = read_json(&out);
    let pass = &k["taps"]["passes"][0];
    let offsets = pass["offsets_mm"].as_array().unwrap();
    let weights = pass["weights"].as_array().unwrap();
    offsets
        .iter()
        .zip(weights)
        .map(|(o, w)| (o.as_f64().unwrap(), rgb(w)))
        .collect()
}

/// Same taps (offsets to `offset_tol` mm), weights to `rel` of each weight.
fn assert_tables(
    what: &str,
    got: &[(f64, [f64; 3])],
    want: &[(f64, [f64; 3])],
    offset_tol: f64,
    rel: f64,
) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g.0 - w.0).abs() <= offset_tol,
            "{what} tap {i}: offset {} vs {}",
            g.0,
            w.0
        );
        for c in 0..3 {
            assert!(
                (g.1[c] - w.1[c]).abs() <= rel * w.1[c].abs(),
                "{what} tap {i} channel {c}: {} vs {}",
                g.1[c],
                w.1[c]
            );
        }
    }
}

#[test]
fn fit_reproduces_the_tables_printed_in_separable_sss_h() {
    let printed = [11, 17, 25].map(|n| (n, iryoku(n)));
    for (n, table) in printed {
        let range = if n > 20 { "3" } else { "2" };
        let taps = n.to_string();
        let got = fitted_table(&[
            "--jimenez-width",
            "1",
            "--tap-extent",
            range,
            "--taps",
            &taps,
            "--jimenez-strength",
            "0.48,0.41,0.28",
            "--jimenez-falloff",
            "1,0.37,0.3",
        ]);
        // Printed to 6 significant digits, computed in f32 there.
        assert_tables(&format!("{n} taps"), &got, &sorted(&table), 1e-5, 1e-4);
        // iryoku's defaults are the model's defaults, and its span the
        // table's default extent.
        let default = fitted_table(&["--taps", &taps]);
        assert_tables(&format!("{n} taps, defaults"), &default, &got, 0.0, 0.0);
    }
}

/// The centre weight is the table's, not the kernel grid's: the same table
/// from grids of different cell sizes.
#[test]
fn the_table_does_not_move_with_the_kernel_grid() {
    let coarse = fitted_table(&["--taps", "17", "--grid-size", "41", "--extent", "6"]);
    let fine = fitted_table(&["--taps", "17", "--grid-size", "401", "--extent", "12"]);
    assert_tables("grid", &coarse, &fine, 0.0, 1e-15);
    assert!((coarse[8].1[0] - iryoku(17)[0][0]).abs() < SIX_DECIMALS);
}

/// Parameters other than the defaults follow calculateKernel too; the width
/// scales the offsets (mm per offset unit).
#[test]
fn other_parameters_follow_calculate_kernel() {
    let (strength, falloff, width) = ([0.2, 0.9, 1.0], [0.5, 0.1, 0.8], 2.5);
    for n in [9, 17, 23] {
        let range = if n > 20 { 3.0 } else { 2.0 };
        let want: Vec<(f64, [f64; 3])> = sorted(&calculate_kernel(n, strength, falloff))
            .into_iter()
            .map(|(o, w)| (o * width, w))
            .collect();
        let (taps, extent) = (n.to_string(), (range * width).to_string());
        // Width 2.5 and other strength and falloff, over `span` mm.
        let other = |span: &str| {
            fitted_table(
                &[
                    &[
                        "--jimenez-width",
                        "2.5",
                        "--tap-extent",
                        span,
                        "--taps",
                        &taps,
                    ][..],
                    &[
                        "--jimenez-strength",
                        "0.2,0.9,1",
                        "--jimenez-falloff",
                        "0.5,0.1,0.8",
                    ],
                ]
                .concat(),
            )
        };
        let got = other(&extent);
        assert_tables(&format!("{n} taps"), &got, &want, 1e-12, 1e-12);
        // A wider span moves the taps out and samples the profile there.
        let wide = other("9");
        assert!((wide[n - 1].0 - 9.0).abs() < 1e-12);
        assert!(wide[n / 2].1[0] > got[n / 2].1[0]);
    }
}
