//! The transmission settings in the files an engine imports
//! (`engine::files`): HDRP's Diffusion Profile `.asset` fields
//! `transmissionTint`, `transmissionMode` and `thicknessRemap`
//! (DiffusionProfileSettings.cs, class `DiffusionProfile`) replace the
//! defaults there, and Godot's `.tres` gets the BaseMaterial3D properties
//! `subsurf_scatter_transmittance_enabled`, `_color`, `_depth` and
//! `_boost` (material.cpp `_bind_methods`). Unreal has no file (its
//! Subsurface Profile is a binary .uasset): its values are in the JSON.

use super::TransmissionFit;
use crate::engine::files::EngineFile;
use crate::engine::printed::{number, triple};
use crate::engine::Engine;
use crate::error::{Error, Result};

/// A float as Unity's YAML and Godot's text resources write one (the
/// shortest text that reads back as the same 32-bit float).
fn f32_text(x: f64) -> String {
    format!("{}", x as f32)
}

/// Replaces the line of `text` whose trimmed start is `key:` by `key: value`
/// at the same indentation; an error when the file has no such line.
fn replace_field(text: &mut String, key: &str, value: &str) -> Result<()> {
    let prefix = format!("{key}:");
    let mut found = false;
    let lines: Vec<String> = text
        .lines()
        .map(|l| {
            let trimmed = l.trim_start();
            if trimmed.starts_with(&prefix) && !found {
                found = true;
                format!("{}{prefix} {value}", &l[..l.len() - trimmed.len()])
            } else {
                l.to_string()
            }
        })
        .collect();
    if !found {
        return Err(Error::Unsupported(format!(
            "the Diffusion Profile .asset has no '{key}' field to set"
        )));
    }
    *text = lines.join("\n") + "\n";
    Ok(())
}

/// Adds `fit`'s settings to `engine`'s files.
pub fn add(engine: Engine, fit: &TransmissionFit, files: &mut [EngineFile]) -> Result<()> {
    match engine {
        Engine::UnityHdrp => {
            let tint = triple(&fit.params, "Transmission Tint")?;
            let remap = fit
                .params
                .get("Thickness Remap")
                .and_then(|v| v.as_array())
                .ok_or_else(|| {
                    Error::Unsupported("the HDRP transmission fit has no Thickness Remap".into())
                })?;
            let (lo, hi) = (
                remap.first().and_then(|v| v.as_f64()).unwrap_or(0.0),
                remap.get(1).and_then(|v| v.as_f64()).unwrap_or(0.0),
            );
            for f in files.iter_mut().filter(|f| f.name.ends_with(".asset")) {
                let [r, g, b] = tint.map(f32_text);
                replace_field(
                    &mut f.text,
                    "transmissionTint",
                    &format!("{{r: {r}, g: {g}, b: {b}, a: 1}}"),
                )?;
                replace_field(&mut f.text, "transmissionMode", "1")?;
                replace_field(
                    &mut f.text,
                    "thicknessRemap",
                    &format!("{{x: {}, y: {}}}", f32_text(lo), f32_text(hi)),
                )?;
            }
            Ok(())
        }
        Engine::Godot => {
            let c = fit
                .params
                .get("subsurf_scatter_transmittance_color")
                .and_then(|v| v.as_array())
                .filter(|a| a.len() == 4)
                .ok_or_else(|| {
                    Error::Unsupported("the Godot fit has no transmittance colour".into())
                })?;
            let comp = |i: usize| c[i].as_f64().map(f32_text).unwrap_or_else(|| "1".into());
            let depth = number(&fit.params, "subsurf_scatter_transmittance_depth")?;
            let boost = number(&fit.params, "subsurf_scatter_transmittance_boost")?;
            for f in files.iter_mut().filter(|f| f.name.ends_with(".tres")) {
                f.text.push_str(&format!(
                    "subsurf_scatter_transmittance_enabled = true\n\
                     subsurf_scatter_transmittance_color = Color({}, {}, {}, {})\n\
                     subsurf_scatter_transmittance_depth = {}\n\
                     subsurf_scatter_transmittance_boost = {}\n",
                    comp(0),
                    comp(1),
                    comp(2),
                    comp(3),
                    godot_real(depth),
                    godot_real(boost)
                ));
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A real as Godot's `VariantWriter` writes one: ".0" on a whole number.
fn godot_real(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'i', 'N']) {
        s
    } else {
        format!("{s}.0")
    }
}
