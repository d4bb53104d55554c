//! The Unity HDRP Diffusion Profile `.asset`, as the editor saves a
//! `DiffusionProfileSettings` (Unity-Technologies/Graphics,
//! com.unity.render-pipelines.high-definition: the serialized fields of
//! Runtime/Material/DiffusionProfile/DiffusionProfileSettings.cs, class
//! `DiffusionProfile`, in declaration order, with the defaults of its
//! `ResetToDefault`; the document layout of the editor-saved
//! Samples~/MaterialSamples/Settings/Diffusion Profiles/Wool Thick.asset,
//! m_Version 2).
//!
//! `scatteringDistance` holds what the inspector's picker stores, the
//! linear colour (`Color.linear` of the sRGB colour shown:
//! DiffusionProfileSettingsEditor `DrawScattering`); `hash: 0` makes the
//! editor give the profile its hash on import
//! (DiffusionProfileHashTable `UpdateDiffusionProfileHashNow`: "If the hash
//! is 0, then we need to generate a new one").

use super::super::printed::{number, text, triple};
use super::super::EngineFit;
use crate::error::{Error, Result};
use crate::filter::image::srgb_to_linear;

/// The MonoScript GUID of DiffusionProfileSettings.cs (its `m_Script` in
/// every Diffusion Profile the editor saved).
pub const SCRIPT_GUID: &str = "b2686e09ec7aef44bad2843e4416f057";

/// A float as Unity's YAML writes one: the shortest text that reads back
/// as the same 32-bit float ("1", "0.7490196").
fn f32_text(x: f64) -> String {
    format!("{}", x as f32)
}

/// `TexturingMode` (DiffusionProfileSettings.cs): PreAndPostScatter = 0,
/// PostScatter = 1, from the name ssskit prints.
fn texturing_mode(printed: &str) -> Result<u32> {
    match printed {
        "Pre- and post-scatter" => Ok(0),
        "Post-scatter" => Ok(1),
        other => Err(Error::invalid(
            "engine files",
            "Texturing Mode",
            other,
            "expected Post-scatter or Pre- and post-scatter",
        )),
    }
}

/// The `.asset` for `fit` (HDRP's printed values), `m_Name` = `name`: a
/// file stem (`io::file_stem`: no space, colon, quote or line break that
/// YAML would read otherwise), as Unity names an asset after its file.
pub fn asset(fit: &EngineFit, name: &str) -> Result<String> {
    let shown = triple(&fit.params, "Scattering Color")?;
    let linear = shown.map(srgb_to_linear);
    let multiplier = number(&fit.params, "Multiplier")?;
    let world_scale = number(&fit.params, "World Scale")?;
    let mode = texturing_mode(text(&fit.params, "Texturing Mode")?)?;
    let [r, g, b] = linear.map(f32_text);
    Ok(format!(
        "%YAML 1.1
%TAG !u! tag:unity3d.com,2011:
--- !u!114 &11400000
MonoBehaviour:
  m_ObjectHideFlags: 0
  m_CorrespondingSourceObject: {{fileID: 0}}
  m_PrefabInstance: {{fileID: 0}}
  m_PrefabAsset: {{fileID: 0}}
  m_GameObject: {{fileID: 0}}
  m_Enabled: 1
  m_EditorHideFlags: 0
  m_Script: {{fileID: 11500000, guid: {SCRIPT_GUID}, type: 3}}
  m_Name: {name}
  m_EditorClassIdentifier: 
  profile:
    scatteringDistance: {{r: {r}, g: {g}, b: {b}, a: 1}}
    scatteringDistanceMultiplier: {multiplier}
    transmissionTint: {{r: 1, g: 1, b: 1, a: 1}}
    texturingMode: {mode}
    smoothnessMultipliers: {{x: 1, y: 1}}
    lobeMix: 0.5
    diffuseShadingPower: 1
    transmissionMode: 1
    thicknessRemap: {{x: 0, y: 5}}
    worldScale: {world_scale}
    ior: 1.4
    hash: 0
  m_Version: 2
",
        multiplier = f32_text(multiplier),
        world_scale = f32_text(world_scale),
    ))
}
