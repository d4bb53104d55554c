//! Godot 4's BaseMaterial3D transmittance, read in godotengine/godot
//! (4.6.2-stable; the non-skin Gaussian is the same since 4.0):
//!
//! 1. `BaseMaterial3D::_update_shader` (scene/resources/material.cpp):
//!    `transmittance_color : source_color` (sRGB in the inspector, linear
//!    in the shader), `transmittance_depth : hint_range(0.001, 8.0)`,
//!    `transmittance_boost : hint_range(0.0, 1.0)`; SSS_TRANSMITTANCE_COLOR =
//!    colour x texture (white by default), DEPTH and BOOST as set.
//! 2. The directional light loop of
//!    servers/rendering/renderer_rd/shaders/forward_clustered/
//!    scene_forward_clustered.glsl: transmittance_z = the pixel's depth in
//!    the light's shadow map less the map's depth there (world units, the
//!    pixel moved by the light's transmittance bias along its normal).
//! 3. `light_compute` (scene_forward_lights_inc.glsl, not SSS_MODE_SKIN):
//!    diffuse_light += exp(-(8.25 |z| / depth)^2) x colour.rgb x colour.a x
//!    light x clamp(boost - N.L, 0, 1) / pi; the scene shader then
//!    multiplies diffuse_light by the albedo.
//!
//! So, lit from directly behind (N.L = -1, boost 0): pi L / E =
//! exp(-(8.25 t / depth)^2) x colour x albedo, t in metres.

use super::{Scored, Target};
use crate::engine::printed::{triple, typed};
use crate::engine::{EngineFit, Scene};
use crate::error::Result;
use crate::filter::image::{linear_to_srgb, srgb_to_linear};
use crate::numerics::minimise_log;
use serde_json::json;

pub const SOURCE: &str = "Godot 4.6: material.cpp BaseMaterial3D::_update_shader, \
     scene_forward_clustered.glsl (directional transmittance_z), scene_forward_lights_inc.glsl \
     light_compute (read in godotengine/godot, 4.6.2-stable; the Gaussian unchanged since 4.0)";

/// `transmittance_depth`'s hint_range, metres.
pub const DEPTH_RANGE: (f64, f64) = (0.001, 8.0);
/// The constant of light_compute's Gaussian in the thickness.
const SCALE: f64 = 8.25;
/// N.L of a light from directly behind, where the fit holds (the module
/// comment).
const BEHIND: f64 = -1.0;

/// pi L / E for a shadow-map thickness `t_mm` and the light at `n_dot_l`
/// (boost 0: clamp(-N.L, 0, 1)), `depth` in scene units, `colour` linear,
/// `albedo` the material's; the fit's slab is lit from directly behind
/// (`BEHIND`).
pub fn rendered_at(
    depth: f64,
    colour: [f64; 3],
    albedo: [f64; 3],
    scene: Scene,
    t_mm: f64,
    n_dot_l: f64,
) -> [f64; 3] {
    let d = SCALE * t_mm * scene.units_per_mm / depth;
    let facing = (-n_dot_l).clamp(0.0, 1.0);
    std::array::from_fn(|c| (-d * d).exp() * colour[c] * albedo[c] * facing)
}

pub(crate) fn fit(
    reflect: &EngineFit,
    target: &Target,
    scene: Scene,
) -> Result<(Scored, Vec<[f64; 3]>, super::Model)> {
    // The albedo Godot's reflection fit prints as the inspector shows it
    // (sRGB), decoded to the linear value the shader multiplies by, as
    // Godot decodes a source_color; at most 1.
    let albedo = triple(&reflect.params, "albedo_color")?
        .map(|a| crate::filter::image::srgb_to_linear(a.clamp(0.0, 1.0)));
    let model = |depth: f64, colour: [f64; 3]| {
        target.rows(|t| rendered_at(depth, colour, albedo, scene, t, BEHIND))
    };
    let (lo, hi) = DEPTH_RANGE;
    let depth = typed(minimise_log(
        |d| target.amplitude(&model(d, [1.0; 3])).1,
        lo,
        hi,
        60,
    ));
    let (k, _) = target.amplitude(&model(depth, [1.0; 3]));
    let mut warnings = super::capped(k, |c, k| {
        format!(
            "channel {c}: the table asks for a transmittance colour of {k:.3}, above the \
             inspector's 1; capped"
        )
    });
    // The inspector's (and the .tres's) colour is sRGB, as printed; the
    // shader gets its linear value, so the light is computed from that.
    let srgb = k.map(|k| typed(linear_to_srgb(k.min(1.0))));
    let colour = srgb.map(srgb_to_linear);
    let rows = vec![
        (
            "subsurf_scatter_transmittance_enabled",
            json!(true),
            "BaseMaterial3D, Subsurf Scatter > Transmittance",
        ),
        (
            "subsurf_scatter_transmittance_color",
            json!([srgb[0], srgb[1], srgb[2], 1.0]),
            "BaseMaterial3D: the colour as the inspector shows it (sRGB, alpha 1); the shader \
             gets its linear value",
        ),
        (
            "subsurf_scatter_transmittance_color linear",
            json!(colour.map(typed)),
            "the same colour as the shader sees it (Color.srgb_to_linear)",
        ),
        (
            "subsurf_scatter_transmittance_depth",
            json!(depth),
            "BaseMaterial3D: scene units (metres by default), 0.001 to 8",
        ),
        (
            "subsurf_scatter_transmittance_boost",
            json!(0.0),
            "BaseMaterial3D: 0 (light from directly behind is at full strength for any boost)",
        ),
    ];
    if !(lo..=hi).contains(&depth) {
        warnings.push(format!(
            "the fitted depth {depth} is outside the inspector's [{lo}, {hi}]"
        ));
    }
    let requirements = vec![
        "the reflection settings printed above (the albedo multiplies the transmitted light)"
            .to_string(),
        "a DirectionalLight3D behind the object with shadows on and Transmittance Bias 0 (the \
         thickness is its shadow map's depth difference)"
            .to_string(),
        format!(
            "scene units of {} mm (--units-per-mm {})",
            1.0 / scene.units_per_mm,
            scene.units_per_mm
        ),
    ];
    Ok((
        Scored::new(rows, requirements, warnings),
        model(depth, colour),
        super::Model::Godot(depth, colour, albedo, scene),
    ))
}
