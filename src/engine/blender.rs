//! Blender's Principled BSDF, subsurface method Christensen-Burley (Cycles,
//! intern/cycles/kernel/closure/bssrdf.h: bssrdf_burley_setup): Subsurface
//! Radius (RGB) times Subsurface Scale, in scene units, is turned into a
//! mean free path l = radius / (4 pi) (bssrdf_burley_compatible_mfp) and a
//! shape distance d = l / s(A) with s(A) = 1.9 - A + 3.5 (A - 0.8)^2
//! (bssrdf_burley_fitting); A is the Base Color. Random Walk reads the
//! same radius as a mean free path per channel for its volume, so these
//! values are a starting point there, not a fit.

use super::burley::Burley;
use super::{color, number, table, triple, Scene, Units};
use crate::error::Result;
use serde_json::{json, Map, Value};
use std::f64::consts::PI;

/// bssrdf_burley_fitting.
pub fn burley_fitting(a: f64) -> f64 {
    1.9 - a + 3.5 * (a - 0.8) * (a - 0.8)
}

pub fn params(b: &Burley, scene: Scene) -> (Map<String, Value>, Units) {
    let radius_mm: [f64; 3] =
        std::array::from_fn(|c| b.d_mm[c] * burley_fitting(b.albedo[c]) * 4.0 * PI);
    let max = radius_mm.iter().fold(0.0f64, |m, v| m.max(*v));
    table(vec![
        ("Base Color", color(b.albedo), "linear RGB"),
        (
            "Subsurface Weight",
            json!(1.0),
            "fraction of diffuse that scatters",
        ),
        (
            "Subsurface Radius",
            color(radius_mm.map(|v| v / max)),
            "per channel, times Subsurface Scale",
        ),
        (
            "Subsurface Scale",
            json!(max * scene.units_per_mm),
            "scene units (metres by default)",
        ),
        (
            "Subsurface Method",
            json!("Christensen-Burley"),
            "the model fitted",
        ),
    ])
}

pub fn from_params(p: &Map<String, Value>, scene: Scene) -> Result<Burley> {
    let albedo = triple(p, "Base Color")?;
    let radius = triple(p, "Subsurface Radius")?;
    let scale = number(p, "Subsurface Scale")?;
    Ok(Burley {
        albedo,
        d_mm: std::array::from_fn(|c| {
            radius[c] * scale / scene.units_per_mm / (4.0 * PI) / burley_fitting(albedo[c])
        }),
    })
}
