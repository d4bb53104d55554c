//! The Blender Python script: a node material whose Principled BSDF holds
//! the printed values, for Blender 4.0 and later (checked in `bpy` 5.0.1).
//!
//! Socket names are those of blender/blender
//! source/blender/nodes/shader/nodes/node_shader_bsdf_principled.cc,
//! `node_declare` (read at v5.0.x: "Base Color", "Subsurface Weight",
//! "Subsurface Radius", "Subsurface Scale", "Subsurface IOR", "Subsurface
//! Anisotropy", ...); the subsurface method is the node's
//! `subsurface_method` enum (BURLEY, RANDOM_WALK, RANDOM_WALK_SKIN, as
//! `bpy` 5.0.1 lists them), whose UI names are the ones ssskit prints.

use super::super::printed::text;
use super::super::EngineFit;
use crate::error::{Error, Result};
use serde_json::Value;

/// The Principled BSDF's inputs in Blender 4.0 to 5.0 that a fit may set,
/// with whether the socket is a colour (RGBA: the script appends alpha 1).
/// node_shader_bsdf_principled.cc `node_declare`: `decl::Color` for Base
/// Color, `decl::Vector` for Subsurface Radius, `decl::Float` for the rest.
pub const SOCKETS: [(&str, bool); 13] = [
    ("Base Color", true),
    ("Metallic", false),
    ("Roughness", false),
    ("IOR", false),
    ("Subsurface Weight", false),
    ("Subsurface Radius", false),
    ("Subsurface Scale", false),
    ("Subsurface IOR", false),
    ("Subsurface Anisotropy", false),
    ("Specular IOR Level", false),
    ("Transmission Weight", false),
    ("Coat Weight", false),
    ("Sheen Weight", false),
];

/// The method's UI name (what ssskit prints) -> the RNA enum identifier
/// `subsurface_method` takes.
pub const METHODS: [(&str, &str); 3] = [
    ("Christensen-Burley", "BURLEY"),
    ("Random Walk", "RANDOM_WALK"),
    ("Random Walk (Skin)", "RANDOM_WALK_SKIN"),
];

/// Printed parameters that are not sockets: another form of a socket's
/// value, or the method (set as the node's enum).
fn not_a_socket(name: &str) -> bool {
    name.ends_with(" hex") || name == "Subsurface Method"
}

/// A Python literal for a JSON number or [r, g, b] (colour: with alpha
/// 1); a socket holds 32-bit floats, so a value beyond their range is
/// refused.
fn literal(name: &str, v: &Value, colour: bool) -> Result<String> {
    let bad = || {
        Error::Unsupported(format!(
            "parameter '{name}' is neither a finite number nor [r, g, b]"
        ))
    };
    let num = |v: &Value| {
        let x = v.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
        super::f32_value("Blender socket", name, x)?;
        Ok(format!("{x:?}"))
    };
    match v {
        Value::Array(a) if a.len() == 3 => {
            let mut parts = a.iter().map(num).collect::<Result<Vec<_>>>()?;
            if colour {
                parts.push("1.0".into());
            }
            Ok(format!("({})", parts.join(", ")))
        }
        _ => num(v),
    }
}

/// The script for `fit` (Blender's printed values), naming the material
/// `name`.
pub fn script(fit: &EngineFit, name: &str) -> Result<String> {
    let ui = text(&fit.params, "Subsurface Method")?;
    let method = METHODS
        .iter()
        .find(|m| m.0 == ui)
        .map(|m| m.1)
        .ok_or_else(|| {
            Error::invalid(
                "engine files",
                "Subsurface Method",
                ui,
                "expected Christensen-Burley, Random Walk or Random Walk (Skin)",
            )
        })?;
    let mut values = String::new();
    for (key, v) in &fit.params {
        if not_a_socket(key) {
            continue;
        }
        let Some(&(_, colour)) = SOCKETS.iter().find(|s| s.0 == key) else {
            return Err(Error::Unsupported(format!(
                "parameter '{key}' is not a Principled BSDF socket the script knows"
            )));
        };
        let key_lit = serde_json::to_string(key).map_err(|e| Error::Unsupported(e.to_string()))?;
        values.push_str(&format!("    {key_lit}: {},\n", literal(key, v, colour)?));
    }
    let q = |s: &str| serde_json::to_string(s).unwrap_or_else(|_| "\"\"".into());
    let warning = super::warning_of(fit);
    let banner = warning
        .as_ref()
        .map_or(String::new(), |w| super::comment_block("# ", w));
    Ok(format!(
        r#"{banner}"""ssskit: a Blender material whose Principled BSDF holds the values
`ssskit engine --engine blender` printed ({version}).

Run it in Blender 4.0 or later (Scripting > Text Editor > Run Script, or
`blender --python THIS_FILE`): it adds the material {name_lit}. Or import it
and call make_material(), which returns the material. Assign it to the
object; the scene conditions ssskit printed (scene units, view) still hold.
"""

import bpy

# ssskit's warning about these values (None: none), printed when the
# material is made.
WARNING = {warning_lit}
NAME = {name_lit}
# The Principled BSDF's subsurface_method (UI: {ui}).
METHOD = {method_lit}
# Socket name -> value, as printed (colours scene linear, alpha appended).
VALUES = {{
{values}}}


def principled_node(mat):
    """The material's Principled BSDF node."""
    for node in mat.node_tree.nodes:
        if node.bl_idname == "ShaderNodeBsdfPrincipled":
            return node
    raise RuntimeError("the new material has no Principled BSDF node")


def make_material(name=NAME, values=None, method=METHOD):
    """A new node material with a Principled BSDF set to `values`
    (default: VALUES) and `method` (default: METHOD); returns it."""
    values = VALUES if values is None else values
    if WARNING:
        print("ssskit warning: " + WARNING)
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    bsdf = principled_node(mat)
    bsdf.subsurface_method = method
    for key, value in values.items():
        sock = bsdf.inputs[key]
        if sock.type == "RGBA" and isinstance(value, (list, tuple)) and len(value) == 3:
            value = (*value, 1.0)  # an [r, g, b] for a colour socket
        sock.default_value = value
    return mat


if __name__ == "__main__":
    make_material()
"#,
        version = fit.version,
        name_lit = q(name),
        method_lit = q(method),
        warning_lit = warning.as_deref().map_or("None".to_string(), q),
    ))
}
