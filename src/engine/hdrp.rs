//! Unity 6 HDRP's Diffusion Profile, the chain from the values typed into
//! the profile and the Lit material to the profile the subsurface pass
//! renders (Unity-Technologies/Graphics, com.unity.render-pipelines.
//! high-definition):
//!
//! 1. Editor/Material/DiffusionProfile/DiffusionProfileSettingsEditor.cs,
//!    `DrawScattering`: the Scattering Color field shows the stored colour
//!    `.gamma` and stores what is typed `.linear` (Unity's Color.linear:
//!    the inverse sRGB curve); Multiplier and World Scale are plain floats.
//! 2. Runtime/Material/DiffusionProfile/DiffusionProfileSettings.cs,
//!    `DiffusionProfile.UpdateKernel`: shape parameter S = 1 /
//!    (Multiplier x linear colour) per channel (at most 2^24), i.e.
//!    Burley's d = 1 / S; `Validate` keeps World Scale >= 0.001.
//! 3. Runtime/Material/SubsurfaceScattering/SubsurfaceScattering.compute,
//!    `EvaluateSss`: mmPerUnit = 1000 x World Scale / Subsurface Mask
//!    (the material's mask "rescales the filter"); the samples are
//!    weighted by the Burley profile in those mm (`EvalBurleyDiffusionProfile`)
//!    and divided by the sum of the weights; the result is multiplied by
//!    the albedo (`ApplySubsurfaceScatteringTexturingMode`: all of it after
//!    the blur in Post-scatter, its square root before and after in Pre-
//!    and post-scatter, the same total for a uniform colour).
//! 4. The Lit material's Base Map colour is a Color property: in linear
//!    colour space (HDRP's) the inspector takes sRGB and the shader gets
//!    linear values (Unity Manual, "Add material properties").
//!
//! So the rendered profile is linear(Base Map colour) x Burley(d), d =
//! Multiplier x linear(Scattering Color) x Subsurface Mask / (1000 World
//! Scale u) mm for u scene units per mm.

use super::burley::Burley;
use super::printed::{
    check, color, from_srgb_hex, in_range, number, printed, srgb_hex, text, triple, typed,
    units_line, Printed,
};
use super::{Scene, Version};
use crate::error::Result;
use crate::filter::image::{linear_to_srgb, srgb_to_linear};
use crate::numerics::Bounded;
use serde_json::{json, Map, Value};

pub const VERSIONS: [Version; 1] = [Version {
    key: "17",
    aliases: &["6", "6000"],
    label: "Unity 6 HDRP 17: Diffusion Profile and Lit material \
            (read in Unity-Technologies/Graphics)",
}];

/// `DiffusionProfile.UpdateKernel`'s bound on S.
pub const MAX_SHAPE_PARAM: f64 = 16777216.0;
/// The field of `DiffusionProfileSettings` (DiffusionProfileSettings.cs) that
/// holds the `DiffusionProfile` the .asset serializes: its fields
/// `scatteringDistance`, `scatteringDistanceMultiplier`, `worldScale`,
/// `texturingMode` are what the inspector's Scattering Color, Multiplier,
/// World Scale and Texturing Mode write.
pub const SERIALIZED: &str = "profile";
/// `DiffusionProfile.Validate`'s least World Scale.
pub const MIN_WORLD_SCALE: f64 = 0.001;
const MM_PER_M: f64 = 1000.0;

pub const ERROR_FOR: &str = "HDRP's screen-space subsurface scattering pass \
     (SubsurfaceScattering.compute), its expected value; the pass samples within Max Radius \
     (the 99.7% radius of the widest channel) and blurs nothing where that radius is under a \
     pixel";

pub fn params(b: &Burley, scene: Scene, _v: Version) -> Printed {
    let u = scene.units_per_mm;
    let mut warnings = Vec::new();
    let want = 1.0 / (MM_PER_M * u);
    let world_scale = typed(want.max(MIN_WORLD_SCALE));
    if want < MIN_WORLD_SCALE {
        warnings.push(format!(
            "World Scale: {want} m per unit is below the {MIN_WORLD_SCALE} Validate keeps; \
             {world_scale} is printed and the Multiplier scaled to keep the profile's width"
        ));
    }
    // d in the engine's mm (step 3 with Subsurface Mask 1).
    let d_engine = b.d_mm.map(|d| d * MM_PER_M * world_scale * u);
    let multiplier = typed(d_engine.iter().fold(0.0f64, |m, v| m.max(*v)));
    let linear = d_engine.map(|d| (d / multiplier).min(1.0));
    let scattering = linear.map(|l| typed(linear_to_srgb(l)));
    let hex = srgb_hex(linear);
    if let Some(from_hex) = from_srgb_hex(&hex) {
        let worst = (0..3)
            .map(|c| (from_hex[c] / srgb_to_linear(scattering[c]) - 1.0).abs())
            .fold(0.0f64, f64::max);
        if worst > 0.01 {
            warnings.push(format!(
                "Scattering Color: typed as the hex {hex} (8 bits) instead of the numbers, d \
                 moves by up to {:.1}%",
                Bounded(100.0 * worst)
            ));
        }
    }
    let base = b.albedo.map(|a| typed(linear_to_srgb(a.clamp(0.0, 1.0))));
    // The .asset holds what the picker stores, Color.linear of the typed
    // colour (DiffusionProfileSettingsEditor `DrawScattering`).
    let stored = scattering.map(|s| typed(srgb_to_linear(s)));
    let scattering_unit = format!(
        "diffusion profile, as the colour picker shows it (sRGB, 0 to 1); .asset: \
         {SERIALIZED}.scatteringDistance = {} (its .linear): the shape distance per channel, \
         times Multiplier",
        color(stored)
    );
    printed(
        vec![
            ("Scattering Color", color(scattering), &scattering_unit),
            (
                "Scattering Color hex",
                json!(hex),
                "the same colour as the picker's 8-bit hex field",
            ),
            (
                "Multiplier",
                json!(multiplier),
                "diffusion profile; .asset: profile.scatteringDistanceMultiplier: mm at World \
                 Scale x scene units per mm = 0.001",
            ),
            (
                "World Scale",
                json!(world_scale),
                "diffusion profile; .asset: profile.worldScale: metres per scene unit",
            ),
            (
                "Base Color",
                color(base),
                "the Lit material's Base Map colour (shader property _BaseColor), as the \
                 picker shows it (sRGB): the profile's total reflectance",
            ),
            (
                "Base Color hex",
                json!(srgb_hex(b.albedo)),
                "the same colour as the picker's 8-bit hex field",
            ),
            (
                "Subsurface Mask",
                json!(1.0),
                "Lit material (shader property _SubsurfaceMask): the filter is scaled by it, 1 \
                 keeps the profile's width",
            ),
            (
                "Texturing Mode",
                json!("Post-scatter"),
                "diffusion profile; .asset: profile.texturingMode = 1 (PostScatter; Pre- and \
                 post-scatter, 0, gives the same for a uniform colour)",
            ),
        ],
        warnings,
    )
}

fn unit_interval(name: &str, x: f64) -> Result<f64> {
    in_range("HDRP's colour picker", name, x, (0.0, 1.0))
}

/// The profile HDRP renders from the values `params` prints, through
/// steps 1 to 4 of the module comment.
pub fn from_params(p: &Map<String, Value>, scene: Scene, _v: Version) -> Result<Burley> {
    let scattering = triple(p, "Scattering Color")?;
    let multiplier = number(p, "Multiplier")?;
    check(
        multiplier > 0.0,
        "Multiplier",
        multiplier,
        "must be > 0 (0 blurs nothing)",
    )?;
    let world_scale = number(p, "World Scale")?.max(MIN_WORLD_SCALE);
    let mask = unit_interval("Subsurface Mask", number(p, "Subsurface Mask")?)?;
    check(
        mask != 0.0,
        "Subsurface Mask",
        mask,
        "0 turns the scattering off",
    )?;
    let mode = text(p, "Texturing Mode")?;
    check(
        mode == "Post-scatter" || mode == "Pre- and post-scatter",
        "Texturing Mode",
        mode,
        "expected Post-scatter or Pre- and post-scatter",
    )?;
    let base = triple(p, "Base Color")?;
    let mut d_mm = [0.0; 3];
    let mut albedo = [0.0; 3];
    for c in 0..3 {
        let linear = srgb_to_linear(unit_interval("Scattering Color", scattering[c])?);
        let shape = (1.0 / (multiplier * linear)).min(MAX_SHAPE_PARAM);
        d_mm[c] = mask / shape / (MM_PER_M * world_scale * scene.units_per_mm);
        albedo[c] = srgb_to_linear(unit_interval("Base Color", base[c])?);
    }
    Ok(Burley {
        albedo,
        d_mm,
        truncate_d: None,
    })
}

/// What the error assumes of the scene.
pub fn scene_lines(scene: Scene) -> Vec<String> {
    vec![units_line(scene, "World Scale tells HDRP the unit's size")]
}

pub fn requirements(_v: Version) -> Vec<String> {
    vec![
        "the Lit material's Material Type is Subsurface Scattering with this Diffusion \
         Profile, Subsurface Mask 1, and Base Map colour the Base Color printed here (no \
         texture, or one whose texels are that colour)"
            .to_string(),
        "the diffusion profile is in the Diffusion Profile List of the active Volume (or of the \
         HDRP asset)"
            .to_string(),
    ]
}
