//! Unity HDRP's Diffusion Profile (DiffusionProfileSettings.cs, UpdateKernel;
//! DiffusionProfile.hlsl): Burley normalized diffusion with shape parameter
//! S = 1 / (scatteringDistance x scatteringDistanceMultiplier) per channel,
//! the distance in millimetres when worldScale (metres per Unity unit)
//! matches the scene; the profile is normalised to 1 and the material's
//! diffuse colour multiplies it (Texturing Mode), so that colour plays the
//! surface albedo.

use super::burley::Burley;
use super::{color, number, table, triple, Scene, Units};
use crate::error::Result;
use serde_json::{json, Map, Value};

pub fn params(b: &Burley, scene: Scene) -> (Map<String, Value>, Units) {
    let max = b.d_mm.iter().fold(0.0f64, |m, v| m.max(*v));
    table(vec![
        (
            "scatteringDistance",
            color(b.d_mm.map(|d| d / max)),
            "per-channel colour, times scatteringDistanceMultiplier",
        ),
        (
            "scatteringDistanceMultiplier",
            json!(max),
            "mm (the shape distance d = 1 / S of the widest channel)",
        ),
        (
            "worldScale",
            json!(0.001 / scene.units_per_mm),
            "metres per scene unit",
        ),
        (
            "diffuseColor",
            color(b.albedo),
            "the material's base colour (linear RGB): the profile's total reflectance",
        ),
    ])
}

pub fn from_params(p: &Map<String, Value>) -> Result<Burley> {
    let sd = triple(p, "scatteringDistance")?;
    let m = number(p, "scatteringDistanceMultiplier")?;
    Ok(Burley {
        albedo: triple(p, "diffuseColor")?,
        d_mm: sd.map(|v| v * m),
    })
}
