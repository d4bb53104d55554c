//! Shared by the Burley engine tests (engine_unreal.rs, engine_hdrp.rs,
//! engine_blender.rs): run `ssskit engine --out`, and score the profile an
//! engine renders, per channel a colour A times Burley's normalized
//! diffusion with shape distance d, against the reference profile.
//!
//! The bin averages come from the profile's closed-form radial CDF,
//! 1 - e^{-r/d} / 4 - 3 e^{-r/(3d)} / 4: the one the engines sample with
//! (Cycles kernel/closure/bssrdf.h `bssrdf_burley_root_find`; Unreal
//! SubsurfaceBurleyNormalized.ush `GetCDF`; HDRP DiffusionProfileSettings.cs
//! `DisneyProfileCdf`), not ssskit's quadrature. The metric is the one the
//! `error` block states: total (A - total) / total, and the relative L2
//! error of r R_d(r), bin-width weights, over the bins whose left edge is
//! below the radius holding 99% of the profile.
#![allow(dead_code)]

#[path = "../common/mod.rs"]
mod common;
pub use common::*;

use serde_json::{Map, Value};
use ssskit::profile::{radius_holding, Profile};
use std::f64::consts::PI;
use std::path::Path;

/// The materials the done-criterion names.
pub const MATERIALS: [&str; 3] = ["skin1", "marble", "ketchup"];

pub fn reference(m: &str) -> Profile {
    Profile::read(Path::new(&format!("profiles/reference/{m}.json"))).unwrap()
}

/// `ssskit engine --profile FILE --engine ENGINE [extra...] --out F`: the
/// JSON written and the printout.
pub fn engine_json(profile: &str, engine: &str, extra: &[&str]) -> (Value, String) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fit.json");
    let mut args = vec!["engine", "--profile", profile, "--engine", engine];
    args.extend_from_slice(extra);
    args.extend(["--out", p(&out)]);
    let text = ok(&args);
    (read_json(&out), text)
}

pub fn params(v: &Value) -> &Map<String, Value> {
    v["params"].as_object().expect("params is an object")
}

pub fn num(p: &Map<String, Value>, k: &str) -> f64 {
    p[k].as_f64()
        .unwrap_or_else(|| panic!("{k} is not a number: {}", p[k]))
}

pub fn rgb(p: &Map<String, Value>, k: &str) -> [f64; 3] {
    let a = p[k]
        .as_array()
        .unwrap_or_else(|| panic!("{k} is not [r, g, b]"));
    assert_eq!(a.len(), 3, "{k}");
    std::array::from_fn(|c| a[c].as_f64().unwrap())
}

pub fn triple(v: &Value) -> [f64; 3] {
    let a = v.as_array().unwrap();
    std::array::from_fn(|c| a[c].as_f64().unwrap())
}

/// sRGB decoding (IEC 61966-2-1), written out here: what Unity's
/// Color.linear and the hex fields of the colour pickers apply.
pub fn srgb_decode(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// "#RRGGBB" -> the linear colour it encodes.
pub fn hex_decode(h: &str) -> [f64; 3] {
    let h = h.strip_prefix('#').expect("hex starts with #");
    assert_eq!(h.len(), 6, "{h}");
    std::array::from_fn(|c| {
        srgb_decode(u8::from_str_radix(&h[2 * c..2 * c + 2], 16).unwrap() as f64 / 255.0)
    })
}

/// The radial CDF of normalized diffusion with shape distance d.
fn cdf(d: f64, r: f64) -> f64 {
    1.0 - 0.25 * (-r / d).exp() - 0.75 * (-r / (3.0 * d)).exp()
}

/// A rendered Burley profile per channel: colour and d in scene mm.
#[derive(Clone, Copy, Debug)]
pub struct Rendered {
    pub albedo: [f64; 3],
    pub d_mm: [f64; 3],
}

/// Total and shape error of `m` against `reference`.
pub fn score(m: &Rendered, reference: &Profile) -> ([f64; 3], [f64; 3]) {
    let mut total = [0.0; 3];
    let mut shape = [0.0; 3];
    for c in 0..3 {
        total[c] = (m.albedo[c] - reference.total_rd[c]) / reference.total_rd[c];
        let r99 = radius_holding(reference, c, 0.99);
        let (mut num, mut den) = (0.0, 0.0);
        for (i, e) in reference.r_edges.windows(2).enumerate() {
            if e[0] >= r99 {
                break;
            }
            let model = m.albedo[c] * (cdf(m.d_mm[c], e[1]) - cdf(m.d_mm[c], e[0]))
                / (PI * (e[1] * e[1] - e[0] * e[0]));
            let (w, r, v) = (e[1] - e[0], reference.r[i], reference.rd[c][i]);
            num += w * (r * (model - v)).powi(2);
            den += w * (r * v).powi(2);
        }
        shape[c] = (num / den).sqrt();
    }
    (total, shape)
}

/// The done-criterion of the issue for one engine run: (a) the engine's
/// chain, re-implemented by the caller from the engine's source, gives the
/// profile ssskit says the engine renders; (b) that profile's error agrees
/// with the reported error within 2 points and its shape error is under
/// 15%.
pub fn check_against_report(what: &str, fit: &Value, engine_chain: &Rendered, reference: &Profile) {
    let rendered = &fit["rendered"];
    let (albedo, d) = (triple(&rendered["albedo"]), triple(&rendered["d_mm"]));
    for c in 0..3 {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-12);
        assert!(
            close(engine_chain.albedo[c], albedo[c]) && close(engine_chain.d_mm[c], d[c]),
            "{what} channel {c}: the engine's chain gives A {} d {} mm, ssskit says A {} d {} mm",
            engine_chain.albedo[c],
            engine_chain.d_mm[c],
            albedo[c],
            d[c]
        );
    }
    let (total, shape) = score(engine_chain, reference);
    let (rt, rs) = (
        triple(&fit["error"]["total"]),
        triple(&fit["error"]["shape"]),
    );
    for c in 0..3 {
        eprintln!(
            "{what} channel {c}: shape {:.2}% (reported {:.2}%), total {:+.2}% (reported {:+.2}%)",
            100.0 * shape[c],
            100.0 * rs[c],
            100.0 * total[c],
            100.0 * rt[c]
        );
        assert!(
            (shape[c] - rs[c]).abs() <= 0.02 && (total[c] - rt[c]).abs() <= 0.02,
            "{what} channel {c}: rendered shape {} total {}, reported shape {} total {}",
            shape[c],
            total[c],
            rs[c],
            rt[c]
        );
        assert!(
            shape[c] < 0.15,
            "{what} channel {c}: shape error {}",
            shape[c]
        );
    }
}
