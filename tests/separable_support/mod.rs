//! Shared by the tests of the separable engines (iryoku, Godot) and of
//! iryoku's tables: iryoku's `calculateKernel` re-implemented from its
//! source, a tap table scored as the kernel it stands for, and the shape
//! error, all written here without ssskit's engine or kernel code.
//!
//! The scoring follows its definition (each tap's weight spread evenly over
//! its footprint, from the midpoints to its neighbours and half a gap
//! beyond the end taps; the separable product binned on the profile's
//! annuli) by a different method from ssskit's `kernel::tap_kernel`, which
//! has the area of a rectangle inside a disc in closed form: here the area
//! is integrated across x by the midpoint rule, exactly along y.
#![allow(dead_code)]

#[path = "../common/mod.rs"]
pub mod common;
pub use common::{ok, p, read_json};

use ssskit::profile::Profile;
use std::path::Path;

pub const MATERIALS: [&str; 3] = ["skin1", "marble", "ketchup"];

pub fn reference(m: &str) -> Profile {
    Profile::read(Path::new(&format!("profiles/reference/{m}.json"))).unwrap()
}

/// The most ssskit's 4-significant-digit rounding moves a printed value,
/// relative: half a unit in the 4th digit of a mantissa of at least 1.000.
pub const TYPED_REL: f64 = 5e-4;

/// Significant digits of `x` as printed (its shortest round-trip form).
pub fn significant_digits(x: f64) -> usize {
    let e = format!("{:e}", x.abs());
    let mantissa = e.split('e').next().unwrap();
    mantissa.chars().filter(char::is_ascii_digit).count()
}

/// Every number of a printed parameter table, scalars and [r, g, b].
pub fn printed_numbers(params: &serde_json::Map<String, serde_json::Value>) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for (k, v) in params {
        match v {
            serde_json::Value::Number(n) => out.push((k.clone(), n.as_f64().unwrap())),
            serde_json::Value::Array(a) => {
                out.extend(a.iter().filter_map(|x| x.as_f64()).map(|x| (k.clone(), x)))
            }
            _ => {}
        }
    }
    out
}

/// `ssskit engine --engine <engine>` on a reference profile: its stdout.
pub fn engine_text(m: &str, engine: &str) -> String {
    let profile = format!("profiles/reference/{m}.json");
    ok(&["engine", "--profile", &profile, "--engine", engine])
}

/// `ssskit engine --engine <engine> --out` on a reference profile: the JSON.
pub fn engine_json(m: &str, engine: &str) -> serde_json::Value {
    engine_json_with(m, engine, &[])
}

/// [`engine_json`] with `extra` arguments.
pub fn engine_json_with(m: &str, engine: &str, extra: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("e.json");
    let profile = format!("profiles/reference/{m}.json");
    let mut args = vec![
        "engine",
        "--profile",
        &profile,
        "--engine",
        engine,
        "--out",
        p(&out),
    ];
    args.extend_from_slice(extra);
    ok(&args);
    read_json(&out)
}

/// iryoku's SeparableSSS::calculateKernel (github.com/iryoku/separable-sss,
/// Demo/Code/SeparableSSS.cpp at commit b2174689, with
/// SeparableSSS::gaussian and SeparableSSS::profile), in f64: the kernel as
/// the shader receives it, centre tap first, (r, g, b, offset in offset
/// units).
// The loops and the 3.14 are the C++ code's.
#[allow(clippy::needless_range_loop, clippy::approx_constant)]
pub fn calculate_kernel(n: usize, strength: [f64; 3], falloff: [f64; 3]) -> Vec<[f64; 4]> {
    let gaussian = |variance: f64, r: f64, c: usize| {
        let rr = r / (0.001 + falloff[c]);
        (-(rr * rr) / (2.0 * variance)).exp() / (2.0 * 3.14 * variance)
    };
    let profile = |r: f64, c: usize| {
        0.100 * gaussian(0.0484, r, c)
            + 0.118 * gaussian(0.187, r, c)
            + 0.113 * gaussian(0.567, r, c)
            + 0.358 * gaussian(1.99, r, c)
            + 0.078 * gaussian(7.41, r, c)
    };
    let range = if n > 20 { 3.0 } else { 2.0 };
    let exponent = 2.0;
    let mut kernel = vec![[0.0f64; 4]; n];
    let step = 2.0 * range / (n as f64 - 1.0);
    for (i, k) in kernel.iter_mut().enumerate() {
        let o: f64 = -range + i as f64 * step;
        let sign = if o < 0.0 { -1.0 } else { 1.0 };
        k[3] = range * sign * o.powf(exponent).abs() / range.powf(exponent);
    }
    for i in 0..n {
        let w0 = if i > 0 {
            (kernel[i][3] - kernel[i - 1][3]).abs()
        } else {
            0.0
        };
        let w1 = if i < n - 1 {
            (kernel[i][3] - kernel[i + 1][3]).abs()
        } else {
            0.0
        };
        let area = (w0 + w1) / 2.0;
        for c in 0..3 {
            kernel[i][c] = area * profile(kernel[i][3], c);
        }
    }
    let t = kernel[n / 2];
    for i in (1..=n / 2).rev() {
        kernel[i] = kernel[i - 1];
    }
    kernel[0] = t;
    let mut sum = [0.0; 3];
    for k in &kernel {
        for c in 0..3 {
            sum[c] += k[c];
        }
    }
    for k in kernel.iter_mut() {
        for c in 0..3 {
            k[c] /= sum[c];
        }
    }
    for c in 0..3 {
        kernel[0][c] = (1.0 - strength[c]) * 1.0 + strength[c] * kernel[0][c];
    }
    for k in kernel.iter_mut().skip(1) {
        for c in 0..3 {
            k[c] *= strength[c];
        }
    }
    kernel
}

/// A table as (offset, weights), sorted by offset.
pub fn sorted(kernel: &[[f64; 4]]) -> Vec<(f64, [f64; 3])> {
    let mut t: Vec<(f64, [f64; 3])> = kernel.iter().map(|k| (k[3], [k[0], k[1], k[2]])).collect();
    t.sort_by(|a, b| a.0.total_cmp(&b.0));
    t
}

/// Footprint bounds: midpoints between neighbours, half a gap beyond the
/// end taps.
pub fn footprints(x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut b = vec![x[0] - 0.5 * (x[1] - x[0])];
    b.extend((1..n).map(|i| 0.5 * (x[i - 1] + x[i])));
    b.push(x[n - 1] + 0.5 * (x[n - 1] - x[n - 2]));
    b
}

/// Area of [x0, x1] x [y0, y1] inside the disc of radius r about the
/// origin: the midpoint rule over x (`steps` strips), the chord's overlap
/// with [y0, y1] exact in each strip.
fn area_in_disc(x0: f64, x1: f64, y0: f64, y1: f64, r: f64, steps: usize) -> f64 {
    let dx = (x1 - x0) / steps as f64;
    (0..steps)
        .map(|k| {
            let x = x0 + (k as f64 + 0.5) * dx;
            let h = (r * r - x * x).max(0.0).sqrt();
            (y1.min(h) - y0.max(-h)).max(0.0) * dx
        })
        .sum()
}

/// The annulus averages on `edges` of the separable product K(x) K(y) of a
/// table (offsets in mm, increasing; weights per channel), each tap's
/// weight spread evenly over its footprint.
pub fn rendered_bins(table: &[(f64, [f64; 3])], edges: &[f64]) -> [Vec<f64>; 3] {
    let x: Vec<f64> = table.iter().map(|t| t.0).collect();
    let b = footprints(&x);
    let n = x.len();
    let bins = edges.len() - 1;
    let mut mass = [vec![0.0; bins], vec![0.0; bins], vec![0.0; bins]];
    let dist = |lo: f64, hi: f64| {
        let near = if lo <= 0.0 && hi >= 0.0 {
            0.0
        } else {
            lo.abs().min(hi.abs())
        };
        (near, lo.abs().max(hi.abs()))
    };
    for i in 0..n {
        for j in 0..n {
            let (x0, x1, y0, y1) = (b[i], b[i + 1], b[j], b[j + 1]);
            let rect = (x1 - x0) * (y1 - y0);
            let ((xn, xf), (yn, yf)) = (dist(x0, x1), dist(y0, y1));
            let (near, far) = (xn.hypot(yn), xf.hypot(yf));
            let mut below = 0.0;
            for k in 0..bins {
                if edges[k + 1] <= near {
                    continue;
                }
                let above = if edges[k + 1] >= far {
                    rect
                } else {
                    area_in_disc(x0, x1, y0, y1, edges[k + 1], 400)
                };
                for (c, m) in mass.iter_mut().enumerate() {
                    m[k] += table[i].1[c] * table[j].1[c] * (above - below) / rect;
                }
                below = above;
                if edges[k + 1] >= far {
                    break;
                }
            }
        }
    }
    for m in mass.iter_mut() {
        for (k, v) in m.iter_mut().enumerate() {
            *v /= std::f64::consts::PI * (edges[k + 1].powi(2) - edges[k].powi(2));
        }
    }
    mass
}

/// The shape error `profiles compare` reports: the relative L2 error of
/// r R_d(r), bins weighted by their width, over the bins starting inside
/// the radius holding 99% of the reference.
pub fn shape_error(model: &[f64], reference: &Profile, c: usize) -> f64 {
    let r99 = ssskit::profile::radius_holding(reference, c, 0.99);
    let (mut num, mut den) = (0.0, 0.0);
    for (i, e) in reference.r_edges.windows(2).enumerate() {
        if e[0] >= r99 {
            break;
        }
        let (w, r, y) = (e[1] - e[0], reference.r[i], reference.rd[c][i]);
        num += w * (r * (model[i] - y)).powi(2);
        den += w * (r * y).powi(2);
    }
    (num / den).sqrt()
}

/// Reads [r, g, b] from a JSON value.
pub fn rgb(v: &serde_json::Value) -> [f64; 3] {
    let a = v.as_array().expect("[r, g, b]");
    std::array::from_fn(|c| a[c].as_f64().unwrap())
}

/// The rendered profile's shape and total errors against the reference,
/// checked against what the engine's JSON reports: within 2 points each.
/// Returns the rendered shape errors.
pub fn check_reported(
    what: &str,
    json: &serde_json::Value,
    table: &[(f64, [f64; 3])],
    albedo: [f64; 3],
    reference: &Profile,
) -> [f64; 3] {
    let bins = rendered_bins(table, &reference.r_edges);
    let reported = rgb(&json["error"]["shape"]);
    let reported_total = rgb(&json["error"]["total"]);
    std::array::from_fn(|c| {
        let model: Vec<f64> = bins[c].iter().map(|v| albedo[c] * v).collect();
        let shape = shape_error(&model, reference, c);
        let sum: f64 = table.iter().map(|t| t.1[c]).sum();
        let total = albedo[c] * sum * sum / reference.total_rd[c] - 1.0;
        eprintln!(
            "{what} channel {c}: rendered shape {:.2}%, reported {:.2}%; total {:+.2}%, \
             reported {:+.2}%",
            100.0 * shape,
            100.0 * reported[c],
            100.0 * total,
            100.0 * reported_total[c]
        );
        assert!(
            (shape - reported[c]).abs() <= 0.02,
            "{what} channel {c}: renders a shape error of {shape}, reports {}",
            reported[c]
        );
        assert!(
            (total - reported_total[c]).abs() <= 0.02,
            "{what} channel {c}: renders a total error of {total}, reports {}",
            reported_total[c]
        );
        shape
    })
}
