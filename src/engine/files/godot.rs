//! The Godot 4 files: a `.tres` StandardMaterial3D with subsurface
//! scattering on, and the `project.godot` lines of the project-wide
//! settings the fit assumes.
//!
//! Property names: godotengine/godot scene/resources/material.cpp,
//! `BaseMaterial3D::_bind_methods` (ADD_PROPERTY / ADD_PROPERTYI:
//! `albedo_color`, `subsurf_scatter_enabled`, `subsurf_scatter_strength`,
//! `subsurf_scatter_skin_mode`); project settings:
//! servers/rendering/rendering_server.cpp, the GLOBAL_DEF lines of
//! "rendering/environment/subsurface_scattering/subsurface_scattering_quality"
//! (enum "Disabled (Fastest),Low (Fast),Medium (Average),High (Slow)"),
//! "..._scale" and "..._depth_scale". The file layout is the text resource
//! format of scene/resources/resource_format_text.cpp
//! (`ResourceFormatSaverTextInstance::save`: a `[gd_resource type=...
//! format=3]` header, 3 being resource_format_text.h's
//! FORMAT_VERSION_COMPAT, what it writes without the newer variant types, then `[resource]` and one `name = value` line per
//! property, values as core/variant/variant_parser.cpp `VariantWriter`
//! writes them) and ProjectSettings' `project.godot` (`[section]`, then
//! `key=value`).
//!
//! `albedo_color` is an sRGB colour: BaseMaterial3D's shader declares
//! `uniform vec4 albedo : source_color` (`BaseMaterial3D::_update_shader`),
//! which Godot 4 converts from sRGB to linear before the shader reads it;
//! ssskit prints it as the inspector shows it, sRGB, and the file holds
//! the printed value.
//!
//! Strings are written as `VariantWriter` writes a String (double quotes,
//! `\\` and `\"` escaped, `String::c_escape_multiline`); numbers are 32-bit
//! floats in Godot (`BaseMaterial3D`'s `float` members, the setting's
//! `float`), so a value beyond that range is refused rather than written
//! as `inf`.

use super::super::godot::QUALITIES;
use super::super::printed::{number, text, triple};
use super::super::EngineFit;
use crate::error::{Error, Result};

/// The setting's prefix in project.godot's `[rendering]` section.
pub const SSS_SETTINGS: &str = "environment/subsurface_scattering/";

/// A float as Godot's `VariantWriter` writes a real (`rtos_fix`: the
/// shortest text that reads back, with ".0" on a whole number), refused
/// beyond the 32-bit range of the property `field`.
fn real(field: &str, x: f64) -> Result<String> {
    super::f32_value(".tres", field, x)?;
    let s = format!("{x:?}");
    Ok(if s.contains(['.', 'e']) {
        s
    } else {
        format!("{s}.0")
    })
}

/// A colour component as `VariantWriter` writes a `Color`'s (32-bit
/// floats: the shortest text that reads back as the same float).
fn colour(x: f64) -> Result<String> {
    Ok(format!("{}", super::f32_value(".tres", "albedo_color", x)?))
}

/// `s` as `VariantWriter` writes a String: double quotes, with `\` and
/// `"` escaped (`c_escape_multiline`), a line break refused (the name
/// check lets none through; one would end the line here).
fn string(field: &str, s: &str) -> Result<String> {
    if let Some(c) = s.chars().find(|c| c.is_control()) {
        return Err(Error::invalid(
            "engine files",
            field,
            s.escape_debug(),
            format!("holds the control character U+{:04X}", c as u32),
        ));
    }
    Ok(format!(
        "\"{}\"",
        s.replace('\\', "\\\\").replace('"', "\\\"")
    ))
}

/// The `.tres` for `fit` (Godot's printed values), `resource_name` =
/// `name`.
pub fn tres(fit: &EngineFit, name: &str) -> Result<String> {
    let albedo = triple(&fit.params, "albedo_color")?;
    let strength = number(&fit.params, "subsurf_scatter_strength")?;
    let name_lit = string("resource_name", name)?;
    let banner = super::warning_of(fit).map_or(String::new(), |w| super::comment_block("; ", &w));
    Ok(format!(
        "{banner}[gd_resource type=\"StandardMaterial3D\" format=3]

[resource]
resource_name = {name_lit}
albedo_color = Color({}, {}, {}, 1)
subsurf_scatter_enabled = true
subsurf_scatter_strength = {}
subsurf_scatter_skin_mode = false
",
        colour(albedo[0])?,
        colour(albedo[1])?,
        colour(albedo[2])?,
        real("subsurf_scatter_strength", strength)?,
    ))
}

/// The quality label ssskit prints -> the setting's enum value (the
/// GLOBAL_DEF's hint: Disabled 0, Low 1, Medium 2, High 3).
fn quality_value(label: &str) -> Result<usize> {
    QUALITIES
        .iter()
        .position(|q| q.0 == label)
        .map(|i| i + 1)
        .ok_or_else(|| {
            Error::invalid(
                "engine files",
                "subsurface_scattering_quality",
                label,
                "expected Low (Fast), Medium (Average) or High (Slow)",
            )
        })
}

/// The `project.godot` lines of the settings the fit assumes.
pub fn project_settings(fit: &EngineFit) -> Result<String> {
    let quality = quality_value(text(&fit.params, "subsurface_scattering_quality")?)?;
    let depth_scale = number(&fit.params, "subsurface_scattering_depth_scale")?;
    Ok(format!(
        "; ssskit: the project settings the material's values assume. Merge these lines
; into the [rendering] section of project.godot (or set them in Project
; Settings > Rendering > Environment > Subsurface Scattering).

[rendering]

{SSS_SETTINGS}subsurface_scattering_quality={quality}
{SSS_SETTINGS}subsurface_scattering_depth_scale={}
",
        real("subsurface_scattering_depth_scale", depth_scale)?
    ))
}
