//! `ssskit engine --engine blender --subsurface-method random-walk` against Cycles'
//! chain from the node's values to its walk, re-implemented here from the
//! source (blender/cycles at v5.0.0): src/kernel/svm/closure.h, the
//! principled BSDF: radius = max(subsurface_radius x subsurface_scale, 0),
//! albedo = clamped base colour; src/kernel/closure/bssrdf.h,
//! bssrdf_setup_radius: radius *= 0.25 x M_1_PI_F for
//! CLOSURE_BSSRDF_RANDOM_WALK_ID; src/kernel/integrator/
//! subsurface_random_walk.h, subsurface_random_walk_remap: sigma_t = 1 /
//! (max(d, 1e-16) (1 - g)); subsurface_random_walk_coefficients: alpha
//! below 0.2 is raised to 0.2 and the throughput scaled by alpha / 0.2.

mod common;
use common::*;
use std::f64::consts::PI;

const SKIN1: &str = "profiles/reference/skin1.json";

/// `ssskit engine --profile SKIN1 --engine engine`, then `extra`.
fn engine_args<'a>(engine: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [
        &["engine", "--profile", SKIN1, "--engine", engine][..],
        extra,
    ]
    .concat()
}

/// Random Walk is the default for Cycles (no --subsurface-method here), and
/// its values are the walk they claim.
#[test]
fn random_walk_values_are_the_walk_they_claim() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rw.json");
    let text = ok(&engine_args("blender", &["--out", p(&out)]));
    let first = text.lines().next().unwrap();
    assert!(first.starts_with("engine: blender, Random Walk"), "{first}");
    let j = read_json(&out);
    let params = &j["params"];
    assert_eq!(params["Subsurface Method"], "Random Walk");
    let scale = params["Subsurface Scale"].as_f64().unwrap();
    let g = params["Subsurface Anisotropy"].as_f64().unwrap();
    let walk = &j["walk"];
    for c in 0..3 {
        let radius_mm = params["Subsurface Radius"][c].as_f64().unwrap() * scale / 0.001;
        let d = radius_mm * 0.25 / PI;
        let sigma_t = 1.0 / (d.max(1e-16) * (1.0 - g));
        let got = walk["sigma_t_per_mm"][c].as_f64().unwrap();
        assert!(
            (got - sigma_t).abs() < 1e-9 * sigma_t,
            "channel {c}: {got} vs {sigma_t}"
        );
        let alpha = walk["alpha"][c].as_f64().unwrap();
        let k = walk["throughput"][c].as_f64().unwrap();
        assert!(
            alpha >= 0.2 && k <= 1.0 && (k < 1.0) == (alpha == 0.2),
            "{alpha} {k}"
        );
        for half in 0..2 {
            let bins = walk["rd_halves"][half][c].as_array().unwrap().len();
            assert_eq!(bins + 1, walk["r_edges_mm"][c].as_array().unwrap().len());
        }
    }
}

/// Where ssskit has no walk (EEVEE, Cycles 2.93) the default stays
/// Christensen-Burley, named in the first line.
#[test]
fn the_default_method_elsewhere_is_christensen_burley() {
    for version in ["eevee", "2.93"] {
        let text = ok(&engine_args("blender", &["--engine-version", version]));
        let first = text.lines().next().unwrap();
        assert!(
            first.starts_with("engine: blender, Christensen-Burley"),
            "{version}: {first}"
        );
    }
}

#[test]
fn random_walk_is_blender_cycles_only() {
    let walk = ["--subsurface-method", "random-walk"];
    fails_with(
        &engine_args("unreal", &walk),
        &["--subsurface-method", "blender"],
    );
    fails_with(
        &engine_args(
            "blender",
            &[&["--engine-version", "eevee"][..], &walk].concat(),
        ),
        &["--subsurface-method", "eevee"],
    );
}
