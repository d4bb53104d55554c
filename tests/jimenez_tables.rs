//! iryoku's kernel, exactly: `ssskit fit --model jimenez` with iryoku's
//! parameters (width 1, `--tap-extent` its RANGE, its default strength and
//! falloff, 11, 17 or 25 taps) reproduces the tables printed in iryoku's
//! SeparableSSS.h (github.com/iryoku/separable-sss at commit b2174689,
//! SSSS_QUALITY 0, 1, 2), and follows `SeparableSSS::calculateKernel` for
//! other parameters; the unscattered part of the strength is the centre
//! tap's weight, whatever the kernel grid.

mod separable_support;
use separable_support::*;

/// SeparableSSS.h, SSSS_QUALITY == 2 (SSSS_N_SAMPLES 25): float4(r, g, b,
/// offset), as printed (centre first).
const IRYOKU_25: [[f64; 4]; 25] = [
    [0.530605, 0.613514, 0.739601, 0.0],
    [0.000973794, 1.11862e-5, 9.43437e-7, -3.0],
    [0.00333804, 7.85443e-5, 1.2945e-5, -2.52083],
    [0.00500364, 0.00020094, 5.28848e-5, -2.08333],
    [0.00700976, 0.00049366, 0.000151938, -1.6875],
    [0.0094389, 0.00139119, 0.000416598, -1.33333],
    [0.0128496, 0.00356329, 0.00132016, -1.02083],
    [0.017924, 0.00711691, 0.00347194, -0.75],
    [0.0263642, 0.0119715, 0.00684598, -0.520833],
    [0.0410172, 0.0199899, 0.0118481, -0.333333],
    [0.0493588, 0.0367726, 0.0219485, -0.1875],
    [0.0402784, 0.0657244, 0.04631, -0.0833333],
    [0.0211412, 0.0459286, 0.0378196, -0.0208333],
    [0.0211412, 0.0459286, 0.0378196, 0.0208333],
    [0.0402784, 0.0657244, 0.04631, 0.0833333],
    [0.0493588, 0.0367726, 0.0219485, 0.1875],
    [0.0410172, 0.0199899, 0.0118481, 0.333333],
    [0.0263642, 0.0119715, 0.00684598, 0.520833],
    [0.017924, 0.00711691, 0.00347194, 0.75],
    [0.0128496, 0.00356329, 0.00132016, 1.02083],
    [0.0094389, 0.00139119, 0.000416598, 1.33333],
    [0.00700976, 0.00049366, 0.000151938, 1.6875],
    [0.00500364, 0.00020094, 5.28848e-5, 2.08333],
    [0.00333804, 7.85443e-5, 1.2945e-5, 2.52083],
    [0.000973794, 1.11862e-5, 9.43437e-7, 3.0],
];

/// SeparableSSS.h, SSSS_QUALITY == 1 (SSSS_N_SAMPLES 17).
const IRYOKU_17: [[f64; 4]; 17] = [
    [0.536343, 0.624624, 0.748867, 0.0],
    [0.00317394, 0.000134823, 3.77269e-5, -2.0],
    [0.0100386, 0.000914679, 0.000275702, -1.53125],
    [0.0144609, 0.00317269, 0.00106399, -1.125],
    [0.0216301, 0.00794618, 0.00376991, -0.78125],
    [0.0347317, 0.0151085, 0.00871983, -0.5],
    [0.0571056, 0.0287432, 0.0172844, -0.28125],
    [0.0582416, 0.0659959, 0.0411329, -0.125],
    [0.0324462, 0.0656718, 0.0532821, -0.03125],
    [0.0324462, 0.0656718, 0.0532821, 0.03125],
    [0.0582416, 0.0659959, 0.0411329, 0.125],
    [0.0571056, 0.0287432, 0.0172844, 0.28125],
    [0.0347317, 0.0151085, 0.00871983, 0.5],
    [0.0216301, 0.00794618, 0.00376991, 0.78125],
    [0.0144609, 0.00317269, 0.00106399, 1.125],
    [0.0100386, 0.000914679, 0.000275702, 1.53125],
    [0.00317394, 0.000134823, 3.77269e-5, 2.0],
];

/// SeparableSSS.h, SSSS_QUALITY == 0 (SSSS_N_SAMPLES 11).
const IRYOKU_11: [[f64; 4]; 11] = [
    [0.560479, 0.669086, 0.784728, 0.0],
    [0.00471691, 0.000184771, 5.07566e-5, -2.0],
    [0.0192831, 0.00282018, 0.00084214, -1.28],
    [0.03639, 0.0130999, 0.00643685, -0.72],
    [0.0821904, 0.0358608, 0.0209261, -0.32],
    [0.0771802, 0.113491, 0.0793803, -0.08],
    [0.0771802, 0.113491, 0.0793803, 0.08],
    [0.0821904, 0.0358608, 0.0209261, 0.32],
    [0.03639, 0.0130999, 0.00643685, 0.72],
    [0.0192831, 0.00282018, 0.00084214, 1.28],
    [0.00471691, 0.000184771, 5.07565e-5, 2.0],
];

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
    let printed: [(usize, &[[f64; 4]]); 3] = [(11, &IRYOKU_11), (17, &IRYOKU_17), (25, &IRYOKU_25)];
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
        assert_tables(&format!("{n} taps"), &got, &sorted(table), 1e-5, 1e-4);
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
    assert!((coarse[8].1[0] - IRYOKU_17[0][0]).abs() < SIX_DECIMALS);
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
        let got = fitted_table(&[
            "--jimenez-width",
            "2.5",
            "--tap-extent",
            &extent,
            "--taps",
            &taps,
            "--jimenez-strength",
            "0.2,0.9,1",
            "--jimenez-falloff",
            "0.5,0.1,0.8",
        ]);
        assert_tables(&format!("{n} taps"), &got, &want, 1e-12, 1e-12);
        // A wider span moves the taps out and samples the profile there.
        let wide = fitted_table(&[
            "--jimenez-width",
            "2.5",
            "--tap-extent",
            "9",
            "--taps",
            &taps,
            "--jimenez-strength",
            "0.2,0.9,1",
            "--jimenez-falloff",
            "0.5,0.1,0.8",
        ]);
        assert!((wide[n - 1].0 - 9.0).abs() < 1e-12);
        assert!(wide[n / 2].1[0] > got[n / 2].1[0]);
    }
}
