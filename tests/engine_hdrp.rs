//! `ssskit engine --engine unity-hdrp` against HDRP's own chain,
//! re-implemented here from Unity-Technologies/Graphics
//! (com.unity.render-pipelines.high-definition), not from ssskit's code:
//!
//! - Editor/Material/DiffusionProfile/DiffusionProfileSettingsEditor.cs,
//!   DrawScattering: the Scattering Color picker shows `.gamma` and stores
//!   `color.linear` (Unity's Color.linear: the inverse sRGB curve);
//! - Runtime/Material/DiffusionProfile/DiffusionProfileSettings.cs,
//!   DiffusionProfile.UpdateKernel: shapeParam = min(16777216, 1 /
//!   (scatteringDistanceMultiplier x scatteringDistance)); Validate:
//!   worldScale = max(worldScale, 0.001);
//! - Runtime/Material/SubsurfaceScattering/SubsurfaceScattering.compute,
//!   EvaluateSss: mmPerUnit = 1000 x metersPerUnit / subsurfaceMask, the
//!   Burley weights in those mm normalised by their sum, times the albedo
//!   (ApplySubsurfaceScatteringTexturingMode);
//! - the Lit material's Base Map colour: a Color property, sRGB in the
//!   inspector, linear in the shader (Unity Manual, "Add material
//!   properties": in linear colour space material colours are supplied as
//!   sRGB and converted to linear).

mod engine_support;
use engine_support::*;
use serde_json::{Map, Value};

fn hdrp_chain(p: &Map<String, Value>, units_per_mm: f64) -> Rendered {
    let stored = rgb(p, "Scattering Color").map(srgb_decode);
    let multiplier = num(p, "Multiplier");
    let meters_per_unit = num(p, "World Scale").max(0.001);
    let mask = num(p, "Subsurface Mask");
    let mm_per_unit = 1000.0 * meters_per_unit / mask;
    let base = rgb(p, "Base Color").map(srgb_decode);
    Rendered {
        albedo: base,
        // d = 1 / S in the engine's mm, to scene units, to scene mm.
        d_mm: stored.map(|s| {
            let shape = (1.0 / (multiplier * s)).min(16777216.0);
            (1.0 / shape) / mm_per_unit / units_per_mm
        }),
    }
}

#[test]
fn printed_values_through_hdrps_chain_reproduce_the_reported_error() {
    for m in MATERIALS {
        let file = format!("profiles/reference/{m}.json");
        let (fit, text) = engine_json(&file, "unity-hdrp", &[]);
        assert!(fit["version"]
            .as_str()
            .unwrap()
            .starts_with("Unity 6 HDRP 17"));
        assert!(text.contains("requires: the Lit material"), "{text}");
        let p = params(&fit);
        for c in 0..3 {
            for k in ["Scattering Color", "Base Color"] {
                assert!(
                    (0.0..=1.0).contains(&rgb(p, k)[c]),
                    "{m}: {k} {:?}",
                    rgb(p, k)
                );
            }
        }
        assert_eq!(num(p, "Subsurface Mask"), 1.0);
        assert_eq!(num(p, "World Scale"), 1.0, "a scene in metres");
        // The hex fields are the same colours in 8 bits.
        for (k, hex) in [
            ("Scattering Color", "Scattering Color hex"),
            ("Base Color", "Base Color hex"),
        ] {
            let from_hex = hex_decode(p[hex].as_str().unwrap());
            let typed = rgb(p, k).map(srgb_decode);
            for c in 0..3 {
                let step = srgb_decode((rgb(p, k)[c] + 0.5 / 255.0).min(1.0)) - typed[c];
                assert!(
                    (from_hex[c] - typed[c]).abs() <= step.abs() + 1e-12,
                    "{m} {hex}: {from_hex:?} against {typed:?}"
                );
            }
        }
        check_against_report(
            &format!("hdrp {m}"),
            &fit,
            &hdrp_chain(p, 0.001),
            &reference(m),
        );
    }
}

/// A scene in centimetres: World Scale 0.01 m per unit, the same profile.
#[test]
fn world_scale_follows_the_scene_unit() {
    let skin1 = "profiles/reference/skin1.json";
    let (fit, _) = engine_json(skin1, "unity-hdrp", &["--units-per-mm", "0.1"]);
    let p = params(&fit);
    assert!(
        (num(p, "World Scale") - 0.01).abs() < 1e-15,
        "{}",
        p["World Scale"]
    );
    check_against_report(
        "hdrp skin1 cm",
        &fit,
        &hdrp_chain(p, 0.1),
        &reference("skin1"),
    );
}

/// The inspector's names and what the files hold, printed together: the
/// Diffusion Profile .asset serializes `DiffusionProfileSettings.profile`, a
/// `DiffusionProfile` whose fields scatteringDistance,
/// scatteringDistanceMultiplier, worldScale and texturingMode the
/// inspector's Scattering Color, Multiplier, World Scale and Texturing
/// Mode write (Unity-Technologies/Graphics, DiffusionProfileSettings.cs;
/// DiffusionProfileSettingsEditor `DrawScattering` stores the picker's
/// colour `.linear`); the Lit material's Base Map colour and Subsurface
/// Mask are the shader properties _BaseColor and _SubsurfaceMask (Lit.shader).
#[test]
fn inspector_and_serialized_names_are_printed_together() {
    let (fit, text) = engine_json("profiles/reference/skin1.json", "unity-hdrp", &[]);
    let line = |name: &str| {
        text.lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} = ")))
            .unwrap_or_else(|| panic!("no {name} line: {text}"))
            .to_string()
    };
    for (inspector, serialized) in [
        ("Scattering Color", "profile.scatteringDistance = "),
        ("Multiplier", "profile.scatteringDistanceMultiplier"),
        ("World Scale", "profile.worldScale"),
        ("Texturing Mode", "profile.texturingMode = 1"),
        ("Base Color", "_BaseColor"),
        ("Subsurface Mask", "_SubsurfaceMask"),
    ] {
        let l = line(inspector);
        assert!(l.contains(serialized), "{l}");
    }
    // The .asset's scatteringDistance is the linear form of the picker's
    // sRGB value, to the 4 digits ssskit prints.
    let l = line("Scattering Color");
    let stored: Vec<f64> = l
        .split("scatteringDistance = [")
        .nth(1)
        .and_then(|r| r.split(']').next())
        .unwrap()
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let picker = rgb(params(&fit), "Scattering Color");
    for c in 0..3 {
        let linear = srgb_decode(picker[c]);
        assert!(
            (stored[c] - linear).abs() <= 5e-4 * linear,
            "channel {c}: .asset {} against linear {linear}",
            stored[c]
        );
        assert!(
            (stored[c] - picker[c]).abs() > 0.01 || picker[c] > 0.99,
            "channel {c}: the .asset value is the picker's, not its .linear"
        );
    }
    // A Burley engine that matches the profile says nothing of the kind.
    assert!(
        !text.lines().next().unwrap().contains("cannot match"),
        "{text}"
    );
}
