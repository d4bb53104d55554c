//! `ssskit engine --engine godot` checked against Godot 4's own source
//! (godotengine/godot; servers/rendering/renderer_rd/shaders/effects/
//! subsurface_scattering.glsl at commit 19843743, renderer_rd/effects/
//! ss_effects.cpp at 006f0390, servers/rendering_server.cpp): the values it
//! prints, fed to Godot's tables and step as re-implemented here, render
//! the error it reports; and ssskit's Godot step functions against cases
//! worked by hand from the shader's formulas.

mod separable_support;
use separable_support::common::srgb;
use separable_support::*;
use ssskit::engine::godot::{self, step_pixels, step_scene_units, step_uv, Camera, Settings};
use ssskit::engine::Scene;

/// subsurface_scattering.glsl, USE_25_SAMPLES: `kernel[]`, vec2(weight,
/// offset), the centre and one side.
const GODOT_25: [[f64; 2]; 13] = [
    [0.530605, 0.0],
    [0.0211412, 0.0208333],
    [0.0402784, 0.0833333],
    [0.0493588, 0.1875],
    [0.0410172, 0.333333],
    [0.0263642, 0.520833],
    [0.017924, 0.75],
    [0.0128496, 1.02083],
    [0.0094389, 1.33333],
    [0.00700976, 1.6875],
    [0.00500364, 2.08333],
    [0.00333804, 2.52083],
    [0.000973794, 3.0],
];

/// USE_17_SAMPLES.
const GODOT_17: [[f64; 2]; 9] = [
    [0.536343, 0.0],
    [0.0324462, 0.03125],
    [0.0582416, 0.125],
    [0.0571056, 0.28125],
    [0.0347317, 0.5],
    [0.0216301, 0.78125],
    [0.0144609, 1.125],
    [0.0100386, 1.53125],
    [0.00317394, 2.0],
];

/// USE_11_SAMPLES.
const GODOT_11: [[f64; 2]; 6] = [
    [0.560479, 0.0],
    [0.0771802, 0.08],
    [0.0821904, 0.32],
    [0.03639, 0.72],
    [0.0192831, 1.28],
    [0.00471691, 2.0],
];

/// The table the project setting subsurface_scattering_quality selects:
/// SSEffects compiles USE_11, USE_17, USE_25_SAMPLES as shader versions 0,
/// 1, 2 and binds version quality - 1 (ss_effects.cpp); the setting's
/// labels are "Disabled (Fastest),Low (Fast),Medium (Average),High (Slow)"
/// (rendering_server.cpp).
fn table_for(quality: &str) -> &'static [[f64; 2]] {
    match quality {
        "Low (Fast)" => &GODOT_11,
        "Medium (Average)" => &GODOT_17,
        "High (Slow)" => &GODOT_25,
        other => panic!("no table for quality {other}"),
    }
}

/// What main() and do_filter do with a table, as one 1D kernel: the centre
/// weighted by kernel[0].x, do_filter adding kernel[i].x at +-kernel[i].y
/// steps for i >= 1 on both sides, the result divided by the sum of the
/// weights used; `units` scene mm per offset unit.
fn godot_table(t: &[[f64; 2]], mm: f64) -> Vec<(f64, [f64; 3])> {
    let divisor: f64 = t[0][0] + 2.0 * t[1..].iter().map(|k| k[0]).sum::<f64>();
    let mut taps: Vec<(f64, [f64; 3])> = t
        .iter()
        .skip(1)
        .flat_map(|k| [(k[1] * mm, k[0]), (-k[1] * mm, k[0])])
        .chain(std::iter::once((0.0, t[0][0])))
        .map(|(o, w)| (o, [w / divisor; 3]))
        .collect();
    taps.sort_by(|a, b| a.0.total_cmp(&b.0));
    taps
}

/// The horizontal pass's scene units per offset unit, from main():
/// scale = mix(params.scale, unit_size / depth, params.depth_scale), step =
/// scale * dir * strength / 3 in texture coordinates, and texture x spans
/// the screen's width, 2 depth / unit_size scene units at that depth;
/// unit_size = x / w of Projection::xform4(Plane(1, 0, -1, 1))
/// (SSEffects::sub_surface_scattering), cot(fov_x / 2) for a perspective
/// projection of vertical field of view fov_y and aspect a: cot(fov_y / 2) / a.
fn horizontal_scene_units(
    strength: f64,
    scale: f64,
    depth_scale: f64,
    fovy_deg: f64,
    aspect: f64,
    depth: f64,
) -> f64 {
    let unit_size = 1.0 / (0.5 * fovy_deg.to_radians()).tan() / aspect;
    let mixed = scale + (unit_size / depth - scale) * depth_scale;
    mixed * strength / 3.0 * 2.0 * depth / unit_size
}

#[test]
fn printed_values_render_the_reported_error() {
    let units_per_mm = 0.001;
    for m in MATERIALS {
        let json = engine_json(m, "godot");
        let params = json["params"].as_object().unwrap();
        assert!(json["version"].as_str().unwrap().contains("Godot 4"));
        assert!(json["error_for"]
            .as_str()
            .unwrap()
            .contains("horizontal pass"));
        assert_eq!(params["subsurface_scattering_depth_scale"], 1.0);
        let quality = params["subsurface_scattering_quality"].as_str().unwrap();
        let t = table_for(quality);
        assert_eq!(
            params["nSamples"].as_u64().unwrap() as usize,
            2 * t.len() - 1,
            "{m}"
        );
        let strength = params["subsurf_scatter_strength"].as_f64().unwrap();
        // At depth_scale 1 the width does not depend on the camera, nor on
        // subsurface_scattering_scale.
        let mm = horizontal_scene_units(strength, 0.05, 1.0, 45.0, 16.0 / 9.0, 0.5) / units_per_mm;
        let other = horizontal_scene_units(strength, 0.3, 1.0, 90.0, 4.0 / 3.0, 3.0) / units_per_mm;
        assert!((mm - other).abs() < 1e-12 * mm, "{mm} {other}");
        // Printed to 4 digits: the width the strength gives agrees with the
        // stated one within that rounding, the albedo with the profile's.
        let stated = params["kernel_width_mm"].as_f64().unwrap();
        assert!(
            (mm - stated).abs() <= TYPED_REL * mm,
            "{m}: {mm} vs {stated}"
        );
        // albedo_color is shown and typed sRGB (BaseMaterial3D's shader
        // reads it as source_color): decoded, the profile's total.
        let albedo = rgb(&params["albedo_color"]).map(srgb::decode);
        let reference = reference(m);
        for (a, t) in albedo.iter().zip(&reference.total_rd) {
            assert!((a - t).abs() <= srgb::TYPED_REL * t, "{m}: {a} vs {t}");
        }
        check_reported(m, &json, &godot_table(t, mm), albedo, &reference);
    }
}

/// ssskit's Godot kernel is Godot's table (the shader's constants) at its
/// width, for every quality.
#[test]
fn the_kernel_is_the_shader_table() {
    for (samples, t) in [
        (11, &GODOT_11[..]),
        (17, &GODOT_17[..]),
        (25, &GODOT_25[..]),
    ] {
        let k = godot::Godot {
            samples,
            mm_per_unit: 1.7,
            albedo: [1.0; 3],
        }
        .separable()
        .unwrap();
        let want = godot_table(t, 1.7);
        assert_eq!(k.taps.offsets_mm.len(), want.len());
        for (i, (o, w)) in want.iter().enumerate() {
            assert!(
                (k.taps.offsets_mm[i] - o).abs() < 1e-5,
                "{samples}: tap {i}"
            );
            for (got, want) in k.taps.weights[i].iter().zip(w) {
                // Printed to 6 significant digits.
                assert!(
                    (got - want).abs() < 1e-5 * want,
                    "{samples} tap {i}: {got} vs {want}"
                );
            }
        }
    }
}

/// Godot's width from its shader's formulas, worked by hand
/// (subsurface_scattering.glsl main: step = mix(scale, unit_size / depth,
/// depth_scale) x strength / 3 in texture coordinates; the screen is
/// 2 depth / unit_size scene units across, unit_size = cot(fov_x / 2) from
/// SSEffects::sub_surface_scattering).
#[test]
fn godot_width_follows_the_shader_chain() {
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
    // The vertical pass: the same texture step over a 16:9 screen's height.
    assert!(close(
        godot::vertical_step_scene_units(&exact, &cam, 16.0 / 9.0),
        0.002 * 9.0 / 16.0
    ));
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

/// Godot values written for a width (mm per offset unit) in a scene.
fn written(mm: f64, units_per_mm: f64) -> serde_json::Map<String, serde_json::Value> {
    let k = godot::Godot {
        samples: 17,
        mm_per_unit: mm,
        albedo: [0.5; 3],
    };
    godot::params(&k, Scene { units_per_mm }).0
}

/// Strengths Godot cannot take as typed are warned about.
#[test]
fn godot_strength_outside_the_inspector_is_flagged() {
    // A scene in mm: w = 2 mm gives 1.5 x 2 x 1 = 3, above the range.
    let s = written(2.0, 1.0)["subsurf_scatter_strength"]
        .as_f64()
        .unwrap();
    assert!((s - 3.0).abs() < 1e-12);
    let w = godot::strength_warning(s).unwrap();
    assert!(w.contains("above the inspector's range [0, 1]"), "{w}");
    // Metres, w = 0.5 mm: 0.00075 < 0.001, do_filter blurs nothing.
    let s = written(0.5, 0.001)["subsurf_scatter_strength"]
        .as_f64()
        .unwrap();
    assert!((s - 0.00075).abs() < 1e-15);
    assert!(godot::strength_warning(s).unwrap().contains("below 0.001"));
    // Metres, w = 2 mm: 0.003, rounded to 0.00 by the inspector.
    let w = godot::strength_warning(0.003).unwrap();
    assert!(
        w.contains("below the inspector's step 0.01, which rounds it to 0.00"),
        "{w}"
    );
    // Metres, w = 401 mm: 0.6015, which the inspector takes as 0.60.
    assert!(godot::strength_warning(0.6015).is_none());
    assert!((godot::inspector_strength(0.6015).unwrap() - 0.6).abs() < 1e-12);
    // Through the binary: the reference skin in metres needs a strength
    // below the inspector's step; in centimetres, the inspector rounds it
    // and the warning says what that costs.
    let json = engine_json("skin1", "godot");
    let s = json["params"]["subsurf_scatter_strength"].as_f64().unwrap();
    let warnings = json["warnings"].as_array().unwrap();
    assert_eq!(
        s < 0.01,
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("inspector's step"))
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cm.json");
    ok(&[
        "engine",
        "--profile",
        "profiles/reference/skin1.json",
        "--engine",
        "godot",
        "--units-per-mm",
        "0.1",
        "--out",
        p(&out),
    ]);
    let cm = read_json(&out);
    let s = cm["params"]["subsurf_scatter_strength"].as_f64().unwrap();
    if (0.01..=1.0).contains(&s) && ((s / 0.01).round() * 0.01 - s).abs() > 1e-12 {
        assert!(cm["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("inspector rounds")));
    }
}

/// Godot values that disagree, or a depth_scale that ties the width to
/// the camera, are refused.
#[test]
fn godot_params_that_do_not_fix_a_width_are_refused() {
    let scene = Scene::default();
    let p = written(2.0, 0.001);
    assert!(godot::from_params(&p, scene).is_ok());
    let refused = |key: &str, v: serde_json::Value, needle: &str| {
        let mut bad = p.clone();
        bad.insert(key.into(), v);
        let e = godot::from_params(&bad, scene).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains(needle), "{e}");
    };
    refused(
        "kernel_width_mm",
        serde_json::json!(3.0),
        "subsurf_scatter_strength",
    );
    refused(
        "subsurface_scattering_depth_scale",
        serde_json::json!(0.01),
        "camera",
    );
    refused("nSamples", serde_json::json!(25), "17-tap");
    refused(
        "subsurface_scattering_quality",
        serde_json::json!("Ultra"),
        "High (Slow)",
    );
}

/// Godot's fixed kernel cannot match these profiles: its first line says
/// so with the shape error of the best values it prints, and those values
/// are printed as typed (at most 4 significant digits, the error being
/// scored on them: `printed_values_render_the_reported_error` renders the
/// printed values through Godot's table and finds the reported error).
#[test]
fn godot_says_in_its_first_line_that_it_cannot_match() {
    for m in MATERIALS {
        let text = engine_text(m, "godot");
        let json = engine_json(m, "godot");
        let first = text.lines().next().unwrap();
        assert!(first.starts_with("engine: godot"), "{first}");
        assert!(first.contains("cannot match this profile"), "{m}: {first}");
        let shape = rgb(&json["error"]["shape"]);
        for s in shape {
            assert!(
                first.contains(&format!("{:.1}%", 100.0 * s)),
                "{m}: {first}"
            );
        }
        assert!(
            shape
                .iter()
                .any(|s| *s > ssskit::engine::CANNOT_MATCH_SHAPE),
            "{m}: {shape:?}"
        );
        for (k, v) in printed_numbers(json["params"].as_object().unwrap()) {
            assert!(significant_digits(v) <= 4, "{m}: {k} = {v}");
        }
    }
}
