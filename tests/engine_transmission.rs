//! The engines' transmission as each engine computes it, re-implemented
//! here from the engines' own source (not from ssskit's code), fed the
//! values `ssskit engine --transmission` prints for skin1, and required to
//! give the light the JSON reports at every thickness of the table:
//!
//! - Unreal Engine 5.4 (Epic's UnrealEngine, read in the
//!   izzy2lost/UnrealEngineUWP mirror, Build.version 5.4.0; the shaders
//!   unchanged in the unicorn2022/UE5.8.0 mirror):
//!   Engine/Source/Runtime/Engine/Private/Rendering/BurleyNormalizedSSS.cpp
//!   `ComputeTransmissionProfileBurley` and `Burley_TransmissionProfile`
//!   (0.25 A (e^{-S r / L} + 3 e^{-S r / (3 L)})), SubsurfaceProfile.cpp
//!   `FSubsurfaceProfileTexture::CreateTexture` (the 0.009 clamps,
//!   `GetDiffuseMeanFreePathFromMeanFreePath` x 10 / 0.6,
//!   `SetupSurfaceAlbedoAndDiffuseMeanFreePath`), Engine/Shaders/Private/
//!   TransmissionThickness.ush `CalculateOpticalDepth`,
//!   ShadowProjectionPixelShader.usf `ApplyPCFOverBlurCorrection`,
//!   TransmissionCommon.ush `DecodeOpticalDepthFromShadowMask` and
//!   `GetTransmissionProfile`, ShadingModels.ush `ApproximateHG` and
//!   `SubsurfaceProfileBxDF`, the Base Color after the blur;
//! - Unity 6 HDRP 17 (Unity-Technologies/Graphics,
//!   com.unity.render-pipelines.high-definition): Runtime/Material/
//!   DiffusionProfile/DiffusionProfileSettings.cs `UpdateKernel` and
//!   `UpdateCache` (tint x 0.25, remap (min, max - min)),
//!   Runtime/Material/SubsurfaceScattering/SubsurfaceScattering.hlsl
//!   `FillMaterialTransmission`, Runtime/Material/DiffusionProfile/
//!   DiffusionProfile.hlsl `ComputeTransmittanceDisney`, Runtime/Material/
//!   Lit/Lit.hlsl `EvaluateBSDF` with the core package's
//!   CommonLighting.hlsl `ComputeWrappedDiffuseLighting`;
//! - Godot 4.6 (godotengine/godot, version.py 4.6.2-stable; the same
//!   Gaussian since 4.0): servers/rendering/renderer_rd/shaders/
//!   scene_forward_lights_inc.glsl `light_compute` (not SSS_MODE_SKIN:
//!   exp(-(8.25 |z| / depth)^2) x colour.rgb x colour.a x light x
//!   clamp(boost - N.L, 0, 1) / pi), then forward_clustered/
//!   scene_forward_clustered.glsl `diffuse_light *= albedo` after the
//!   light loop.
//!
//! Light from directly behind, seen along the normal.

#[path = "engine_support/mod.rs"]
mod support;

use serde_json::{Map, Value};
use std::f64::consts::PI;
use support::{num, ok_in, rgb, srgb_decode};

/// Relative difference allowed between the engine's chain written here and
/// the light the JSON reports: both in f64 from the same printed values.
const SAME: f64 = 1e-9;

fn perpendicular(a: f64) -> f64 {
    1.85 - a + 7.0 * (a - 0.8).abs().powi(3)
}

fn search_light(a: f64) -> f64 {
    3.5 + 100.0 * (a - 0.33).powi(4)
}

/// Unreal's pi L / E through `t_cm` world units (cm) of shadow-map
/// thickness.
fn unreal(refl: &Map<String, Value>, tr: &Map<String, Value>, t_cm: f64) -> [f64; 3] {
    let bias = 0.009;
    let a = rgb(refl, "SurfaceAlbedo").map(|v| v.clamp(bias, 1.0));
    let mfp = rgb(refl, "MeanFreePathColor").map(|v| v.clamp(bias, 1.0));
    let dist = num(refl, "MeanFreePathDistance");
    let wus = num(refl, "WorldUnitScale");
    let base = rgb(refl, "Base Color");
    let es = num(tr, "ExtinctionScale");
    let ns = num(tr, "NormalScale") * 0.5;
    let g = num(tr, "ScatteringDistribution");
    let tint = rgb(tr, "TransmissionTintColor").map(|v| v.clamp(bias, 1.0));
    // CalculateOpticalDepth, the pixel moved ns into the surface.
    let od = es * (t_cm - ns);
    let od = if od > 0.0 {
        (od + ns).abs()
    } else {
        (od + ns).max(0.0)
    };
    let od = od.clamp(0.15, 5.0) + 0.25;
    let enc = (1.0 - od / 5.0).powi(2);
    let od = (1.0 - enc) * 5.0;
    let x = od / 5.0 * 31.0;
    let i0 = (x.floor() as usize).min(30);
    let f = x - i0 as f64;
    let inv_unit = 1.0 / (wus / 0.1) * 0.1;
    let hg = 0.5 * (1.0 - g * g) / (1.0 - g).powi(2).max(1e-5);
    std::array::from_fn(|c| {
        let dmfp = (mfp[c] * dist * search_light(a[c]) / perpendicular(a[c]) * 10.0 / 0.6)
            .clamp(0.0, 500.0);
        let s = search_light(a[c]);
        let texel = |i: usize| {
            if i == 31 {
                return 0.0;
            }
            let r = (i as f64 / 32.0 * 50.0 + 0.6) * inv_unit;
            0.25 * a[c] * ((-s * r / dmfp).exp() + 3.0 * (-s * r / (3.0 * dmfp)).exp()) * tint[c]
        };
        PI * (texel(i0) * (1.0 - f) + texel(i0 + 1) * f) * hg * base[c]
    })
}

/// HDRP's pi L / E through a thickness map value t / map.
fn hdrp(refl: &Map<String, Value>, tr: &Map<String, Value>, t_mm: f64, map: f64) -> [f64; 3] {
    let sc = rgb(refl, "Scattering Color").map(srgb_decode);
    let mult = num(refl, "Multiplier");
    let base = rgb(refl, "Base Color").map(srgb_decode);
    let tint = rgb(tr, "Transmission Tint");
    let remap = rgb_pair(tr, "Thickness Remap");
    let thickness = remap.0 + (remap.1 - remap.0) * (t_mm / map).clamp(0.0, 1.0);
    let w = (PI / 2.0 - PI / 12.0).cos();
    let wrapped = ((1.0 + w) / ((1.0 + w) * (1.0 + w))).clamp(0.0, 1.0);
    std::array::from_fn(|c| {
        let s = (1.0 / (mult * sc[c])).min(16777216.0);
        let t = 0.25 * tint[c] * ((-s * thickness).exp() + 3.0 * (-s * thickness / 3.0).exp());
        wrapped / PI * t * base[c] * PI
    })
}

fn rgb_pair(p: &Map<String, Value>, k: &str) -> (f64, f64) {
    let a = p[k].as_array().unwrap();
    (a[0].as_f64().unwrap(), a[1].as_f64().unwrap())
}

/// Godot's pi L / E through `t_m` metres of shadow-map thickness.
fn godot(refl: &Map<String, Value>, tr: &Map<String, Value>, t_m: f64) -> [f64; 3] {
    // albedo_color as the inspector shows it (sRGB); the shader reads it as
    // a source_color, decoded to linear (BaseMaterial3D's shader).
    let albedo = rgb(refl, "albedo_color").map(srgb_decode);
    let c = tr["subsurf_scatter_transmittance_color"]
        .as_array()
        .unwrap();
    let colour: [f64; 3] = std::array::from_fn(|k| srgb_decode(c[k].as_f64().unwrap()));
    let alpha = c[3].as_f64().unwrap();
    let depth = num(tr, "subsurf_scatter_transmittance_depth");
    let boost = num(tr, "subsurf_scatter_transmittance_boost");
    let n_dot_l: f64 = -1.0;
    let d = 8.25 * t_m.abs() / depth;
    std::array::from_fn(|k| {
        (-d * d).exp() * colour[k] * alpha * (boost - n_dot_l).clamp(0.0, 1.0) / PI * albedo[k] * PI
    })
}

#[test]
fn printed_values_through_each_engines_chain_give_the_reported_light() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok_in(
        d,
        &[
            "transmission",
            "--material",
            "skin1",
            "--thickness",
            "0.3..12",
            "--steps",
            "6",
            "--photons",
            "2e4",
            "--engines",
            "none",
            "--out",
            "t.json",
        ],
    );
    let reference =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("profiles/reference/skin1.json");
    let mut lines = Vec::new();
    for engine in ["unreal", "unity-hdrp", "godot"] {
        let (v, text) = support::engine_json(
            reference.to_str().unwrap(),
            engine,
            &["--transmission", d.join("t.json").to_str().unwrap()],
        );
        assert!(text.contains(&format!("{engine} transmission")), "{text}");
        let refl = v["params"].as_object().unwrap();
        let t = &v["transmission"];
        let tr = t["params"].as_object().unwrap();
        let thickness: Vec<f64> = serde_json::from_value(t["thickness_mm"].clone()).unwrap();
        let map = thickness.iter().fold(0.0f64, |m, x| m.max(*x));
        if engine == "unity-hdrp" {
            // A tint an artist can set (the fit trades it against the remap).
            let tint = rgb(tr, "Transmission Tint");
            let max = ssskit::engine::transmission::hdrp::TINT_MAX;
            assert!(tint.iter().all(|t| *t <= max), "HDRP tint {tint:?}");
        }
        for (i, &mm) in thickness.iter().enumerate() {
            let ours = match engine {
                "unreal" => unreal(refl, tr, mm * 0.1),
                "unity-hdrp" => hdrp(refl, tr, mm, map),
                _ => godot(refl, tr, mm * 0.001),
            };
            let reported = support::triple(&t["engine_t"][i]);
            let table = support::triple(&t["table"][i]);
            for c in 0..3 {
                let (a, b) = (ours[c], reported[c]);
                assert!(
                    (a - b).abs() <= SAME * a.abs().max(b.abs()).max(1e-300),
                    "{engine}, {mm} mm, channel {c}: the engine's chain gives {a:e}, the JSON {b:e}"
                );
                if let Some(e) = t["rel_error"][i][c].as_f64() {
                    assert!(
                        (e - (b / table[c] - 1.0)).abs() < 1e-12,
                        "{engine}: rel_error"
                    );
                }
            }
            lines.push(format!("{engine} {mm:.3} mm: {ours:?}"));
        }
    }
    eprintln!("{}", lines.join("\n"));
}

/// Unreal's optical depth read back by the lighting pass, worked by hand
/// from the sources for ExtinctionScale 1 and NormalScale 0.08 through
/// 1 cm: OD = 1 x (1 - 0.04) + 0.04 + 0.25 = 1.25, encoded 1 - 1.25 / 5 =
/// 0.75, squared 0.5625, decoded (1 - 0.5625) x 5 = 2.1875; through no
/// thickness the clamp keeps 0.15 + 0.25 = 0.4, read back as 0.768.
#[test]
fn unreals_optical_depth_follows_its_shadow_pass() {
    use ssskit::engine::transmission::unreal::{decoded_optical_depth, Settings};
    let s = Settings {
        extinction_scale: 1.0,
        normal_scale: 0.08,
        scattering_distribution: 0.93,
        tint: [1.0; 3],
    };
    assert!((decoded_optical_depth(&s, 1.0) - 2.1875).abs() < 1e-12);
    assert!((decoded_optical_depth(&s, 0.0) - 0.768).abs() < 1e-12);
}
