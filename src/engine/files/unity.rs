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
/// as the same 32-bit float ("1", "0.7490196"); a value beyond the 32-bit
/// range (which Unity would store as infinity) refused, naming `field`.
fn f32_text(field: &str, x: f64) -> Result<String> {
    Ok(format!("{}", super::f32_value(".asset", field, x)?))
}

/// `s` as a YAML single-quoted scalar (YAML 1.1, "Single Quoted"
/// flow scalars: a quote doubled, nothing else escaped), so that no name
/// reads back as anything but this string (a plain `true`, `null`, `1e3`,
/// `0x10`, `-` or `.inf` would resolve to a boolean, a null, a number or a
/// sequence). Refused: a character a single-quoted scalar cannot hold as
/// itself (a line break folds into a space; outside the YAML printable set
/// nothing is allowed).
pub(super) fn single_quoted(field: &str, s: &str) -> Result<String> {
    // YAML 1.1 c-printable, less the line breaks.
    let printable = |c: char| {
        matches!(c, '\u{9}' | '\u{20}'..='\u{7E}' | '\u{A0}'..='\u{D7FF}' | '\u{E000}'..='\u{FFFD}' | '\u{10000}'..='\u{10FFFF}')
            && !matches!(c, '\u{2028}' | '\u{2029}')
    };
    if let Some(c) = s.chars().find(|&c| !printable(c)) {
        return Err(Error::invalid(
            "engine files",
            field,
            s.escape_debug(),
            format!(
                "holds U+{:04X}, which a YAML single-quoted scalar cannot hold as itself",
                c as u32
            ),
        ));
    }
    Ok(format!("'{}'", s.replace('\'', "''")))
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

/// The `.asset` for `fit` (HDRP's printed values), `m_Name` = `name` (as
/// Unity names an asset after its file), single-quoted: every scalar
/// ssskit did not make itself is quoted, whatever the name.
pub fn asset(fit: &EngineFit, name: &str) -> Result<String> {
    let shown = triple(&fit.params, "Scattering Color")?;
    let linear = shown.map(srgb_to_linear);
    let multiplier = number(&fit.params, "Multiplier")?;
    let world_scale = number(&fit.params, "World Scale")?;
    let mode = texturing_mode(text(&fit.params, "Texturing Mode")?)?;
    let mut rgb = Vec::new();
    for x in linear {
        rgb.push(f32_text("Scattering Color", x)?);
    }
    let [r, g, b] = [&rgb[0], &rgb[1], &rgb[2]];
    let name = single_quoted("m_Name", name)?;
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
        multiplier = f32_text("Multiplier", multiplier)?,
        world_scale = f32_text("World Scale", world_scale)?,
    ))
}
