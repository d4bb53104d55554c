//! Engine parameters fitted to the reference profiles: the fitted Burley
//! model beats the forward Burley-from-coefficients model on shape error,
//! the written parameters reproduce the reported error (every engine,
//! every version), and the Jimenez engines' unit conversions match cases
//! computed by hand.

mod filter_support;
use filter_support::*;
use ssskit::engine::burley::forward_error;
use ssskit::engine::jimenez::Jimenez;
use ssskit::engine::{self, godot, iryoku, Engine, Scene};
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

/// The Jimenez engines' unit conversions on cases computed by hand. (The
/// Burley engines are checked against their engines' own chains in
/// engine_unreal.rs, engine_hdrp.rs and engine_blender.rs.)
#[test]
fn unit_conversions_match_hand_computed_cases() {
    let scene = Scene::default();
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b.abs().max(1.0);
    // iryoku: widest scale 2.002 mm = w (0.001 + 1) with w = 2; sssWidth =
    // 1.5 w u = 0.003 in metres.
    let j = Jimenez {
        albedo: [0.5; 3],
        strength: [0.48, 0.41, 0.28],
        scale_mm: [2.002, 2.0 * 0.371, 2.0 * 0.301],
    };
    let (p, _) = iryoku::params(&j, scene);
    assert!(close(p["sssWidth"].as_f64().unwrap(), 0.003));
    let f = p["falloff"].as_array().unwrap();
    assert!(close(f[1].as_f64().unwrap(), 0.37) && close(f[2].as_f64().unwrap(), 0.3));
    // Godot: one width, w (0.001 + 1) = scale; strength = 1.5 w u = 0.003
    // in metres.
    let (p, _) = godot::params(
        &Jimenez {
            scale_mm: [2.002; 3],
            ..j
        },
        scene,
    );
    assert!(close(p["kernel_width_mm"].as_f64().unwrap(), 2.0));
    assert!(close(
        p["subsurf_scatter_strength"].as_f64().unwrap(),
        0.003
    ));
    assert_eq!(p["subsurface_scattering_depth_scale"], 1.0);
}

/// Godot's width from its shader's formulas, worked by hand
/// (subsurface_scattering.glsl main: step = mix(scale, unit_size / depth,
/// depth_scale) x strength / 3 in texture coordinates; the screen is
/// 2 depth / unit_size scene units across, unit_size = cot(fov_x / 2) from
/// SSEffects::sub_surface_scattering).
#[test]
fn godot_width_follows_the_shader_chain() {
    use godot::{step_pixels, step_scene_units, step_uv, Camera, Settings};
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b.abs().max(1e-6);
    // fov_x 90 degrees: unit_size = cot(45) = 1; depth 0.5 m; strength
    // 0.003 (w = 2 mm in metres), depth_scale 1: mix = 1 / 0.5 = 2, step =
    // 2 x 0.003 / 3 = 0.002 of the screen, which is 2 x 0.5 / 1 = 1 m wide:
    // 0.002 m = 2 mm per offset unit = w; 0.002 x 1920 = 3.84 pixels.
    let cam = Camera::perspective(std::f64::consts::FRAC_PI_2, 0.5);
    assert!(close(cam.unit_size, 1.0));
    let exact = Settings {
        strength: 0.003,
        scale: godot::DEFAULT_SCALE,
        depth_scale: 1.0,
    };
    assert!(close(step_uv(&exact, &cam), 0.002));
    assert!(close(step_scene_units(&exact, &cam), 0.002));
    assert!(close(step_pixels(&exact, &cam, 1920.0), 3.84));
    // The defaults (scale 0.05, depth_scale 0.01): mix = 0.05 x 0.99 +
    // 2 x 0.01 = 0.0695, step = 0.0695 x 0.001 = 6.95e-5 of the screen =
    // 6.95e-5 m; at depth 1 m mix = 0.0495 + 0.01 = 0.0595, the screen 2 m:
    // 1.19e-4 m, the width grows with the distance.
    let defaults = Settings {
        depth_scale: godot::DEFAULT_DEPTH_SCALE,
        ..exact
    };
    assert!(close(step_scene_units(&defaults, &cam), 6.95e-5));
    let far = Camera { depth: 1.0, ..cam };
    assert!(close(step_scene_units(&defaults, &far), 1.19e-4));
    // Orthogonal, 2 m across: unit_size = 1, step = 1 x 0.003 / 3 = 0.001
    // of 2 m = 0.002 m.
    assert!(close(
        step_scene_units(&exact, &Camera::orthogonal(2.0)),
        0.002
    ));
    // At depth_scale 1 the width is 2 strength / 3 whatever the camera, so
    // the strength ssskit writes realises w for every camera.
    for fov_deg in [30.0f64, 75.0, 120.0] {
        for depth in [0.1, 1.0, 10.0] {
            let cam = Camera::perspective(fov_deg.to_radians(), depth);
            assert!(close(step_scene_units(&exact, &cam), 2.0 * 0.003 / 3.0));
        }
    }
    assert!(close(godot::strength_for_width(0.002), 0.003));
}

/// Strengths Godot cannot take as typed are flagged in the unit text.
#[test]
fn godot_strength_outside_the_inspector_is_flagged() {
    let j = |w: f64| Jimenez {
        albedo: [0.5; 3],
        strength: [0.48; 3],
        scale_mm: [w * 1.001; 3],
    };
    let note = |w: f64, units_per_mm: f64| {
        let (p, u) = godot::params(&j(w), Scene { units_per_mm });
        (
            p["subsurf_scatter_strength"].as_f64().unwrap(),
            u["subsurf_scatter_strength"].clone(),
        )
    };
    // A scene in mm: w = 2 mm gives 1.5 x 2 x 1 = 3, above the range.
    let (s, u) = note(2.0, 1.0);
    assert!((s - 3.0).abs() < 1e-12);
    assert!(
        u.contains("WARNING: above the inspector's range [0, 1]"),
        "{u}"
    );
    // Metres, w = 0.5 mm: 0.00075 < 0.001, do_filter blurs nothing.
    let (s, u) = note(0.5, 0.001);
    assert!((s - 0.00075).abs() < 1e-15);
    assert!(u.contains("WARNING: below 0.001"), "{u}");
    // Metres, w = 2 mm: 0.003, rounded to 0.00 by the inspector.
    let (_, u) = note(2.0, 0.001);
    assert!(u.contains("WARNING: below the inspector's step 0.01, which rounds it to 0.00"));
    // Metres, w = 401 mm: 0.6015, rounded to 0.60 (-0.2%).
    let (_, u) = note(401.0, 0.001);
    assert!(
        !u.contains("WARNING") && u.contains("rounds it to 0.60 (-0.2% width)"),
        "{u}"
    );
}

/// Godot values that disagree, or a depth_scale that ties the width to
/// the camera, are refused.
#[test]
fn godot_params_that_do_not_fix_a_width_are_refused() {
    let scene = Scene::default();
    let j = Jimenez {
        albedo: [0.5; 3],
        strength: [0.48; 3],
        scale_mm: [2.002; 3],
    };
    let (p, _) = godot::params(&j, scene);
    assert!(godot::from_params(&p, scene).is_ok());
    let mut bad = p.clone();
    bad.insert("kernel_width_mm".into(), serde_json::json!(3.0));
    let e = godot::from_params(&bad, scene).unwrap_err().to_string();
    assert!(
        e.contains("kernel_width_mm") && e.contains("subsurf_scatter_strength"),
        "{e}"
    );
    let mut bad = p;
    bad.insert(
        "subsurface_scattering_depth_scale".into(),
        serde_json::json!(0.01),
    );
    let e = godot::from_params(&bad, scene).unwrap_err().to_string();
    assert!(e.contains("subsurface_scattering_depth_scale"), "{e}");
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
