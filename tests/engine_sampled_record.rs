//! The Unreal and HDRP parameters `ssskit engine` prints, scored through
//! each engine's own sampling (`engine::sampled`) on the flat-plane edge
//! and shapes signals at 0.1 mm per pixel, for skin1, marble and ketchup:
//! recorded in docs/records/engine-sampling.json and shown in
//! docs/engines.md beside the profile-shape error. Deterministic (the
//! engines' own seeds, any thread count), checked exactly;
//! `SSSKIT_BLESS=1` rewrites it.

mod common;

use common::measured::{check, table};
use ssskit::engine::sampled::{score, signals, SampledError, FRAMES};
use ssskit::engine::{fit, Engine, Scene};
use ssskit::profile::Profile;
use std::collections::BTreeMap;
use std::path::Path;

/// The scale of the tables in docs/engines.md.
const MM_PER_PIXEL: f64 = 0.1;

fn worst(v: [f64; 3]) -> f64 {
    v.into_iter().fold(0.0, f64::max)
}

fn pct(v: f64) -> String {
    format!("{:.2}", 100.0 * v)
}

fn row(material: &str, engine: &str, e: &SampledError) -> Vec<String> {
    vec![
        material.into(),
        engine.into(),
        e.setting.clone(),
        e.samples_per_pixel.to_string(),
        e.signal.clone(),
        pct(worst(e.error.bias)),
        pct(worst(e.error.bias_noise_floor)),
        pct(worst(e.error.noise)),
        pct(worst(e.error.noise_after)),
    ]
}

/// Asserted: more samples never raise the noise (both engines divide by
/// their weights' sum over importance-sampled radii: variance ~ 1 / N);
/// Unreal's accumulated frames lower it; HDRP's static pattern does not.
#[test]
fn engines_scored_through_their_own_sampling() {
    let sigs = signals().unwrap();
    let mut rows = Vec::new();
    let mut data = serde_json::Map::new();
    for material in ["skin1", "marble", "ketchup"] {
        let p = Profile::read(Path::new(&format!("profiles/reference/{material}.json"))).unwrap();
        for engine in [Engine::Unreal, Engine::UnityHdrp] {
            let scene = Scene::native(engine);
            let f = fit(engine, &p, scene).unwrap();
            let v = engine.version(None).unwrap();
            let got = score(&f, engine, scene, v, &sigs, MM_PER_PIXEL).unwrap();
            for (name, _) in &sigs {
                let mut on: Vec<&SampledError> = got.iter().filter(|e| &e.signal == name).collect();
                on.sort_by_key(|e| e.samples_per_pixel);
                assert!(
                    on.windows(2)
                        .all(|w| worst(w[1].error.noise) < worst(w[0].error.noise)),
                    "{material} {name}: noise falls with the samples: {on:?}"
                );
            }
            for e in &got {
                if e.static_pattern {
                    assert_eq!(e.error.noise_after, e.error.noise);
                } else {
                    assert!(worst(e.error.noise_after) < worst(e.error.noise), "{e:?}");
                }
                rows.push(row(material, engine.name(), e));
            }
            data.insert(
                format!("{material}/{}", engine.name()),
                serde_json::json!({
                    "error": f.error,
                    "sampled": got,
                }),
            );
        }
    }
    let mut tables = BTreeMap::new();
    let after = format!("noise, {FRAMES} frames %");
    tables.insert(
        "sampled".to_string(),
        table(
            &[
                "material",
                "engine",
                "setting",
                "samples / px",
                "signal",
                "bias %",
                "its noise floor %",
                "noise, 1 frame %",
                &after,
            ],
            rows,
        ),
    );
    check(
        "engine-sampling",
        "engine_sampled_record",
        "the printed Unreal and HDRP parameters through each engine's own sampling: bias and \
         noise on a flat plane, beside the profile-shape error",
        tables,
        serde_json::Value::Object(data),
    );
}
