//! Godot 4's screen-space subsurface scattering (Forward+ renderer): one
//! kernel table for every channel, iryoku's red-channel skin kernel
//! (strength 0.48, falloff 1), whose only free parameter is its width on
//! screen; the colour comes from the material's albedo.
//!
//! The chain from Godot's settings to the kernel's width, as read from
//! Godot's source:
//!
//! - The material writes `SSS_STRENGTH` (BaseMaterial3D: the
//!   `subsurf_scatter_strength` property times the red channel of
//!   `subsurf_scatter_texture`, white by default) into the alpha of the
//!   RGBA16F diffuse buffer (scene_forward_clustered.glsl; negated in
//!   `SSS_MODE_SKIN`). BaseMaterial3D::set_subsurface_scattering_strength
//!   does not clamp it; only the inspector does (range 0 to 1, step 0.01).
//! - RendererRD's SSEffects::sub_surface_scattering fills the push
//!   constants: `scale` and `depth_scale` are the project settings
//!   rendering/environment/subsurface_scattering/subsurface_scattering_scale
//!   (default 0.05) and subsurface_scattering_depth_scale (default 0.01,
//!   both GLOBAL_DEF in rendering_server.cpp); `unit_size` is the x of
//!   Projection::xform4 applied to the point (1, 0, -1, 1) over its w,
//!   which for Projection::set_perspective is columns[0][0] = cot(fov_x / 2)
//!   and for set_orthogonal 2 / width: normalised device x per scene unit
//!   at depth 1.
//! - subsurface_scattering.glsl main(): the step in texture coordinates per
//!   kernel offset unit is mix(scale, unit_size / depth, depth_scale)
//!   x strength / 3 (unit_size alone for an orthogonal camera), depth the
//!   linear view depth, the same step for the horizontal and the vertical
//!   pass; do_filter samples uv + offset x step and stops at a neighbour
//!   whose abs(alpha) < 0.001.
//!
//! Texture coordinates span the screen (0 to 1) and normalised device
//! coordinates twice that, so one texture-coordinate unit across is
//! 2 depth / unit_size scene units: the horizontal step covers
//! (2 strength / 3) ((1 - depth_scale) scale depth / unit_size + depth_scale)
//! scene units per kernel unit. Only its depth_scale part is a fixed length
//! in the scene; the rest is a fixed fraction of the screen, so the width
//! in the scene grows with the camera's distance and field of view, which
//! ssskit does not know. At depth_scale 1 the step is 2 strength / 3 scene
//! units per kernel unit whatever the camera: iryoku's sssWidth
//! (Jimenez et al. 2015, SeparableSSS.h), with cot(fov_x / 2) where
//! iryoku has cot(fov_y / 2). The vertical pass steps the same texture
//! distance over the screen's height, 1 / aspect of that in the scene.

use super::jimenez::{Jimenez, SKIN_STRENGTH_RED};
use super::{color, number, table, triple, Scene, Units};
use crate::error::{Error, Result};
use serde_json::{json, Map, Value};

/// Default of subsurface_scattering_scale (rendering_server.cpp).
pub const DEFAULT_SCALE: f64 = 0.05;
/// Default of subsurface_scattering_depth_scale (rendering_server.cpp).
pub const DEFAULT_DEPTH_SCALE: f64 = 0.01;
/// do_filter stops at a neighbour whose abs(alpha) is below this, so a
/// smaller strength blurs nothing (subsurface_scattering.glsl).
pub const MIN_STRENGTH: f64 = 0.001;
/// The inspector's step for subsurf_scatter_strength (BaseMaterial3D,
/// PROPERTY_HINT_RANGE "0,1,0.01").
pub const INSPECTOR_STEP: f64 = 0.01;

/// The values subsurface_scattering.glsl reads: the material's strength
/// and the two project settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// abs(alpha) of the diffuse buffer: SSS_STRENGTH.
    pub strength: f64,
    /// subsurface_scattering_scale.
    pub scale: f64,
    /// subsurface_scattering_depth_scale.
    pub depth_scale: f64,
}

/// The camera terms of the step at one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Normalised device x per scene unit at depth 1: cot(fov_x / 2), or
    /// 2 / width for an orthogonal camera (SSEffects::sub_surface_scattering).
    pub unit_size: f64,
    /// Linear view depth of the pixel, scene units.
    pub depth: f64,
    pub orthogonal: bool,
}

impl Camera {
    /// A perspective camera with horizontal field of view `fov_x` (radians)
    /// looking at a surface `depth` scene units away.
    pub fn perspective(fov_x: f64, depth: f64) -> Camera {
        Camera {
            unit_size: 1.0 / (0.5 * fov_x).tan(),
            depth,
            orthogonal: false,
        }
    }

    /// An orthogonal camera `width` scene units across.
    pub fn orthogonal(width: f64) -> Camera {
        Camera {
            unit_size: 2.0 / width,
            depth: 1.0,
            orthogonal: true,
        }
    }

    /// Scene units across the screen at the pixel's depth: normalised
    /// device x spans 2.
    pub fn screen_width(&self) -> f64 {
        if self.orthogonal {
            2.0 / self.unit_size
        } else {
            2.0 * self.depth / self.unit_size
        }
    }
}

/// Texture coordinates per kernel offset unit (subsurface_scattering.glsl
/// main: mix(scale, depth term, depth_scale) x strength / 3).
pub fn step_uv(s: &Settings, cam: &Camera) -> f64 {
    let depth_term = if cam.orthogonal {
        cam.unit_size
    } else {
        cam.unit_size / cam.depth
    };
    let mixed = s.scale * (1.0 - s.depth_scale) + depth_term * s.depth_scale;
    mixed * s.strength / 3.0
}

/// Screen pixels per kernel offset unit on the horizontal pass of a
/// screen `width_px` pixels wide.
pub fn step_pixels(s: &Settings, cam: &Camera, width_px: f64) -> f64 {
    step_uv(s, cam) * width_px
}

/// Scene units per kernel offset unit on the horizontal pass.
pub fn step_scene_units(s: &Settings, cam: &Camera) -> f64 {
    step_uv(s, cam) * cam.screen_width()
}

/// The strength that makes the kernel `width` scene units per offset unit
/// at depth_scale 1, where `step_scene_units` is 2 strength / 3 for every
/// camera.
pub fn strength_for_width(width: f64) -> f64 {
    1.5 * width
}

/// What stands between `strength` and Godot, in words.
pub fn strength_note(strength: f64) -> String {
    if strength < MIN_STRENGTH {
        format!(
            "WARNING: below {MIN_STRENGTH}, where do_filter stops at every neighbour \
             (abs(alpha) < {MIN_STRENGTH}): Godot cannot blur this narrow in these scene \
             units; its narrowest kernel is {:.6} scene units per offset unit",
            MIN_STRENGTH / 1.5
        )
    } else if strength < INSPECTOR_STEP {
        format!(
            "WARNING: below the inspector's step {INSPECTOR_STEP}, which rounds it to {:.2}: \
             set it from a script (set_subsurface_scattering_strength keeps it) or as \
             SSS_STRENGTH in a shader",
            (strength / INSPECTOR_STEP).round() * INSPECTOR_STEP
        )
    } else if strength > 1.0 {
        "WARNING: above the inspector's range [0, 1]: set it from a script or as SSS_STRENGTH \
         in a shader (the renderer reads abs(alpha) of an RGBA16F buffer and does not clamp); \
         no project setting widens the kernel at subsurface_scattering_depth_scale 1"
            .into()
    } else {
        let rounded = (strength / INSPECTOR_STEP).round() * INSPECTOR_STEP;
        format!(
            "the inspector rounds it to {rounded:.2} ({:+.1}% width); a script keeps it exact",
            100.0 * (rounded / strength - 1.0)
        )
    }
}

pub fn params(j: &Jimenez, scene: Scene) -> (Map<String, Value>, Units) {
    let w = j.scale_mm[0] / 1.001;
    let strength = strength_for_width(w * scene.units_per_mm);
    let strength_unit = format!(
        "material subsurf_scatter_strength (SSS_STRENGTH) with \
         subsurface_scattering_depth_scale = 1: 1.5 x kernel_width_mm x scene units per mm \
         (the horizontal pass steps 2/3 of it in scene units per offset unit, the vertical \
         pass 1 / aspect of that); {}",
        strength_note(strength)
    );
    table(vec![
        (
            "kernel_width_mm",
            json!(w),
            "mm per unit of the kernel's offsets (iryoku's width w at falloff 1)",
        ),
        ("subsurf_scatter_strength", json!(strength), &strength_unit),
        (
            "subsurface_scattering_depth_scale",
            json!(1.0),
            "project setting (default 0.01): 1 makes the step unit_size / depth, a fixed \
             length in the scene, and subsurface_scattering_scale unused; at the defaults \
             the width is mostly a fixed fraction of the screen and grows with distance",
        ),
        (
            "albedo",
            color(j.albedo),
            "the material's albedo (linear RGB)",
        ),
        (
            "subsurface_scattering_quality",
            json!("High (25 samples)"),
            "project setting; fewer samples band on large kernels",
        ),
    ])
}

/// The model from the Godot values: the width from subsurf_scatter_strength
/// at depth_scale 1, checked against kernel_width_mm.
pub fn from_params(p: &Map<String, Value>, scene: Scene) -> Result<Jimenez> {
    let depth_scale = number(p, "subsurface_scattering_depth_scale")?;
    if depth_scale != 1.0 {
        return Err(Error::invalid(
            "engine",
            "subsurface_scattering_depth_scale",
            depth_scale,
            "only 1 gives a width in the scene; below 1 it depends on the camera's distance",
        ));
    }
    let w = number(p, "subsurf_scatter_strength")? / (1.5 * scene.units_per_mm);
    let stated = number(p, "kernel_width_mm")?;
    if (w - stated).abs() > 1e-9 * stated.abs() {
        return Err(Error::invalid(
            "engine",
            "kernel_width_mm",
            stated,
            format!(
                "disagrees with subsurf_scatter_strength, which gives {w} mm at these scene units"
            ),
        ));
    }
    Ok(Jimenez {
        albedo: triple(p, "albedo")?,
        strength: [SKIN_STRENGTH_RED; 3],
        scale_mm: [w * 1.001; 3],
    })
}
