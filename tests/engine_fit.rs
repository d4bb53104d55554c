//! Engine parameters fitted to the reference profiles: the fitted Burley
//! model beats the forward Burley-from-coefficients model on shape error,
//! the written parameters reproduce the reported error (every engine,
//! every version). Each engine's conversion chain is checked against its
//! own source in tests/engine_{unreal,hdrp,blender,iryoku,godot}.rs.

mod filter_support;
use filter_support::*;
use ssskit::engine::burley::forward_error;
use ssskit::engine::{self, Engine, Scene};
use ssskit::profile::Profile;
use std::path::Path;

const PRESETS: [&str; 5] = ["apple", "ketchup", "marble", "skin1", "wholemilk"];

fn reference(m: &str) -> Profile {
    Profile::read(Path::new(&format!("profiles/reference/{m}.json"))).unwrap()
}

/// The shape error (relative L2 of r R_d over r99, as `profiles compare`)
/// of the least-squares Burley fit against the forward model's, per
/// preset and channel; printed as the table docs/engines.md quotes.
#[test]
fn fitted_burley_beats_the_forward_model_on_every_preset() {
    for m in PRESETS {
        let p = reference(m);
        let fit = engine::fit(Engine::Unreal, &p, Scene::native(Engine::Unreal)).unwrap();
        let fwd = forward_error(&p).unwrap();
        for c in 0..3 {
            eprintln!(
                "{m} ch {c}: fitted shape {:.1}%, forward {:.1}% ({:.1}x smaller)",
                100.0 * fit.error.shape[c],
                100.0 * fwd.shape[c],
                fwd.shape[c] / fit.error.shape[c]
            );
            assert!(
                fit.error.shape[c] < fwd.shape[c],
                "{m} channel {c}: fitted {} >= forward {}",
                fit.error.shape[c],
                fwd.shape[c]
            );
        }
    }
}

/// The parameters as written (JSON) give back the engine model and its
/// reported error, for every engine on two presets.
#[test]
fn fitted_parameters_round_trip_with_the_reported_error() {
    for m in ["skin1", "marble"] {
        let p = reference(m);
        for (e, v) in Engine::ALL
            .into_iter()
            .flat_map(|e| e.versions().iter().map(move |v| (e, v.key)))
        {
            let scene = Scene::native(e);
            let fit = engine::fit_version(e, &p, scene, Some(v)).unwrap();
            let json = serde_json::to_value(&fit).unwrap();
            for key in ["engine", "version", "params", "units", "error"] {
                assert!(json.get(key).is_some(), "{key} missing");
            }
            let params = json["params"].as_object().unwrap();
            let model = engine::model_from_params_version(e, Some(v), params, &p, scene).unwrap();
            let err = engine::error(&model, &p).unwrap();
            for c in 0..3 {
                for (a, b, what) in [
                    (err.shape[c], fit.error.shape[c], "shape"),
                    (err.total[c], fit.error.total[c], "total"),
                ] {
                    assert!(
                        (a - b).abs() <= 1e-9 * b.abs().max(1e-3),
                        "{m} {} {what} channel {c}: {a} from params, {b} reported",
                        e.name()
                    );
                }
            }
        }
    }
}

#[test]
fn cli_writes_the_fit_and_a_plot_and_refuses_unknown_engines() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("unreal.json");
    let png = dir.path().join("unreal.png");
    let o = run(&[
        "engine",
        "--profile",
        "profiles/reference/skin1.json",
        "--engine",
        "unreal",
        "--out",
        p(&out),
        "--plot",
        p(&png),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(text.contains("MeanFreePathDistance") && text.contains("forward Burley"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(v["engine"], "unreal");
    assert_eq!(v["error"]["shape"].as_array().unwrap().len(), 3);
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    let bad = run(&[
        "engine",
        "--profile",
        "profiles/reference/skin1.json",
        "--engine",
        "cryengine",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("cryengine"));
    assert!(stderr(&bad).contains("unreal, unity-hdrp, blender, godot, iryoku"));
}
