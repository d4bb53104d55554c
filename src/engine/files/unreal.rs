//! The Unreal editor Python script: a Subsurface Profile asset whose
//! settings hold the printed values, made with the editor's own Python
//! API (the `unreal` module of the Python Editor Script Plugin).
//!
//! Names: the asset's `Settings` is an `FSubsurfaceProfileStruct`
//! (Engine/Source/Runtime/Engine/Classes/Engine/SubsurfaceProfile.h, read
//! in the 5.4 and 5.8.0 sources), whose UPROPERTYs Python sees under
//! `PyGenUtil::PythonizePropertyName` (the "b" of a bool dropped, the
//! CamelCase made snake_case): `surface_albedo`, `mean_free_path_color`,
//! `mean_free_path_distance`, `world_unit_scale`, `tint`, `enable_burley`,
//! `enable_mean_free_path`, `implementation`, as Unreal's Python API
//! reference lists them (`unreal.SubsurfaceProfileStruct`). The asset is
//! made by `unreal.AssetToolsHelpers.get_asset_tools().create_asset(
//! asset_name, package_path, asset_class, factory)` with
//! `unreal.SubsurfaceProfileFactory` (UnrealEd's factory for the class),
//! read and written with `get_editor_property` / `set_editor_property`,
//! saved with `unreal.EditorAssetLibrary.save_loaded_asset`.
//!
//! `enable_burley` and `enable_mean_free_path` are set true: a profile
//! with either false is "upgraded" by `UpgradeSubsurfaceProfileParameters`
//! (SubsurfaceProfile.cpp, called on load and by `CreateTexture`), which
//! overwrites SurfaceAlbedo, MeanFreePathColor and MeanFreePathDistance
//! from the deprecated separable fields.

use super::super::printed::{number, text, triple};
use super::super::EngineFit;
use crate::error::{Error, Result};

/// The printed name -> the settings property's Python name, and whether
/// it is a colour (`unreal.LinearColor`, alpha 1).
pub const SETTINGS: [(&str, &str, bool); 5] = [
    ("SurfaceAlbedo", "surface_albedo", true),
    ("MeanFreePathColor", "mean_free_path_color", true),
    ("MeanFreePathDistance", "mean_free_path_distance", false),
    ("WorldUnitScale", "world_unit_scale", false),
    ("Tint", "tint", true),
];

/// The printed Implementation -> `ESubsurfaceImplementationTechniqueHint`'s
/// entry (`unreal.SubsurfaceImplementationTechniqueHint.SIH_AFIS`).
const IMPLEMENTATIONS: [(&str, &str); 2] = [
    ("Adaptive Filtered Importance Sampling", "SIH_AFIS"),
    ("Separable", "SIH_SEPARABLE"),
];

/// Where the script puts the asset by default.
pub const PACKAGE_PATH: &str = "/Game/ssskit";

/// The characters an object's name may not hold
/// (`INVALID_OBJECTNAME_CHARACTERS`, Core/Public/UObject/NameTypes.h).
pub const INVALID_OBJECTNAME_CHARACTERS: &str = "\"' ,/.:|&!~\n\r\t@#(){}[]=;^%$`";

/// `name` as an asset name: each character an object name may not hold
/// made '_' (a file stem may hold '.').
pub fn asset_name(name: &str) -> String {
    name.chars()
        .map(|c| {
            if INVALID_OBJECTNAME_CHARACTERS.contains(c) {
                '_'
            } else {
                c
            }
        })
        .collect()
}

/// A Python literal of the printed `x` (the property is a 32-bit float:
/// a value beyond that range refused).
fn py_float(field: &str, x: f64) -> Result<String> {
    super::f32_value("Unreal asset", field, x)?;
    Ok(format!("{x:?}"))
}

fn py_rgb(field: &str, v: [f64; 3]) -> Result<String> {
    Ok(format!(
        "({}, {}, {})",
        py_float(field, v[0])?,
        py_float(field, v[1])?,
        py_float(field, v[2])?
    ))
}

/// A Python string literal.
fn q(s: &str) -> Result<String> {
    serde_json::to_string(s).map_err(|e| Error::Unsupported(e.to_string()))
}

/// The SETTINGS dict's entries, one a line: the printed values under the
/// properties' Python names.
fn settings(fit: &EngineFit) -> Result<String> {
    let mut settings = String::new();
    for (printed, py, colour) in SETTINGS {
        let value = if colour {
            py_rgb(printed, triple(&fit.params, printed)?)?
        } else {
            py_float(printed, number(&fit.params, printed)?)?
        };
        settings += &format!("    {}: {value},\n", q(py)?);
    }
    Ok(settings)
}

/// The IMPLEMENTATION entry's Python literal (None where the version has
/// no such setting).
fn implementation(fit: &EngineFit) -> Result<String> {
    if fit.params.get("Implementation").is_none() {
        return Ok("None".to_string());
    }
    let ui = text(&fit.params, "Implementation")?;
    let entry = IMPLEMENTATIONS.iter().find(|i| i.0 == ui).ok_or_else(|| {
        Error::invalid(
            "engine files",
            "Implementation",
            ui,
            "expected Adaptive Filtered Importance Sampling or Separable",
        )
    })?;
    q(entry.1)
}

/// The script for `fit` (Unreal's printed values), naming the asset
/// `name`.
pub fn script(fit: &EngineFit, name: &str) -> Result<String> {
    let settings = settings(fit)?;
    let implementation = implementation(fit)?;
    let base = py_rgb("Base Color", triple(&fit.params, "Base Color")?)?;
    let warning = super::warning_of(fit);
    let banner = warning
        .as_ref()
        .map_or(String::new(), |w| super::comment_block("# ", w));
    let warning_lit = match &warning {
        Some(w) => q(w)?,
        None => "None".into(),
    };
    Ok(format!(
        r#"{banner}"""ssskit: an Unreal Engine Subsurface Profile asset holding the values
`ssskit engine --engine unreal` printed, for {version}.

Run it in the Unreal Editor with the Python Editor Script Plugin enabled
(Tools > Execute Python Script, or `py "THIS_FILE"` in the Output Log): it
makes the Subsurface Profile {name_lit} in {path_lit} (or sets the values of
the one there) and saves it. Or import it and call make_profile(). Then set
the material's Shading Model to Subsurface Profile, its Subsurface Profile to
this asset and its Base Color to BASE_COLOR (linear), which the profile does
not hold; the scene conditions ssskit printed (world units) still hold.
"""

import unreal

# ssskit's warning about these values (None: none), logged when the asset
# is made.
WARNING = {warning_lit}
NAME = {name_lit}
PACKAGE_PATH = {path_lit}
# The asset's settings (FSubsurfaceProfileStruct) under their Python names,
# as printed; colours linear (FLinearColor), alpha 1 appended.
SETTINGS = {{
{settings}}}
# Burley with mean free paths: with either false, Unreal replaces the values
# above from its deprecated separable fields (UpgradeSubsurfaceProfileParameters).
ENABLE = {{"enable_burley": True, "enable_mean_free_path": True}}
# ESubsurfaceImplementationTechniqueHint's entry (None: the version has none).
IMPLEMENTATION = {implementation}
# The material's Base Color (linear RGB): the recombine pass multiplies the
# blur by it.
BASE_COLOR = {base}


def linear_color(rgb):
    """An unreal.LinearColor of a linear (r, g, b), alpha 1."""
    return unreal.LinearColor(r=rgb[0], g=rgb[1], b=rgb[2], a=1.0)


def make_profile(name=NAME, package_path=PACKAGE_PATH, settings=None):
    """The Subsurface Profile `package_path`/`name`, made if missing, with
    `settings` (default: SETTINGS) and ENABLE and IMPLEMENTATION set and the
    asset saved; returns it."""
    settings = SETTINGS if settings is None else settings
    if WARNING:
        unreal.log_warning("ssskit warning: " + WARNING)
    path = package_path + "/" + name
    if unreal.EditorAssetLibrary.does_asset_exist(path):
        profile = unreal.EditorAssetLibrary.load_asset(path)
    else:
        tools = unreal.AssetToolsHelpers.get_asset_tools()
        profile = tools.create_asset(
            name, package_path, unreal.SubsurfaceProfile, unreal.SubsurfaceProfileFactory()
        )
    if profile is None:
        raise RuntimeError("could not make the Subsurface Profile " + path)
    values = profile.get_editor_property("settings")
    for key, value in settings.items():
        if isinstance(value, tuple):
            value = linear_color(value)
        values.set_editor_property(key, value)
    for key, value in ENABLE.items():
        values.set_editor_property(key, value)
    if IMPLEMENTATION is not None:
        hint = getattr(unreal.SubsurfaceImplementationTechniqueHint, IMPLEMENTATION)
        values.set_editor_property("implementation", hint)
    profile.set_editor_property("settings", values)
    unreal.EditorAssetLibrary.save_loaded_asset(profile)
    return profile


if __name__ == "__main__":
    make_profile()
"#,
        version = fit.version,
        name_lit = q(&asset_name(name))?,
        path_lit = q(PACKAGE_PATH)?,
    ))
}
