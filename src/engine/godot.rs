//! Godot's screen-space subsurface scattering (servers/rendering/
//! renderer_rd, effects/subsurface_scattering.glsl; project settings
//! rendering/environment/subsurface_scattering/subsurface_scattering_quality
//! with 11, 17 or 25 samples, subsurface_scattering_scale,
//! subsurface_scattering_depth_scale; material subsurf_scatter_strength):
//! one kernel table for every channel, iryoku's red-channel skin kernel
//! (strength 0.48, falloff 1), scaled on screen. The only shape parameter
//! is its width; the colour comes from the material's albedo. The width is
//! reported in millimetres of the kernel's profile: the chain from Godot's
//! scale settings to screen pixels is not converted here.

use super::jimenez::{Jimenez, SKIN_STRENGTH_RED};
use super::{color, number, table, triple, Units};
use crate::error::Result;
use serde_json::{json, Map, Value};

pub fn params(j: &Jimenez) -> (Map<String, Value>, Units) {
    table(vec![
        (
            "kernel_width_mm",
            json!(j.scale_mm[0] / 1.001),
            "mm per unit of the kernel's offsets (iryoku's width w at falloff 1)",
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

pub fn from_params(p: &Map<String, Value>) -> Result<Jimenez> {
    let s = number(p, "kernel_width_mm")? * 1.001;
    Ok(Jimenez {
        albedo: triple(p, "albedo")?,
        strength: [SKIN_STRENGTH_RED; 3],
        scale_mm: [s; 3],
    })
}
