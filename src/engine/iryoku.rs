//! Jimenez's separable SSS (iryoku/separable-sss, SeparableSSS.h and its
//! kernel code): the kernel evaluates the skin profile at offsets x in
//! [-RANGE, RANGE] as profile(x / (0.001 + falloff)), mixes it with the
//! centre by strength, and steps x sssWidth / (3 tan(fov_y / 2) depth) in
//! texture coordinates (0 to 1 over the screen, "divide by 3 as the
//! kernels range from -3 to 3"). A length L in scene units at that depth
//! spans L / (2 depth tan(fov_y / 2)) of the screen, so offset x lands at
//! L = 2 x sssWidth / 3: the profile's millimetre scale is the model width
//! w = 2 sssWidth / (3 u), u the scene units per mm, i.e. sssWidth = 1.5 w u.

use super::jimenez::Jimenez;
use super::{color, number, table, triple, Scene, Units};
use crate::error::Result;
use serde_json::{json, Map, Value};

pub fn params(j: &Jimenez, scene: Scene) -> (Map<String, Value>, Units) {
    // The widest channel gets falloff 1, as in iryoku's defaults.
    let w = j.scale_mm.iter().fold(0.0f64, |m, v| m.max(*v)) / 1.001;
    table(vec![
        (
            "sssWidth",
            json!(1.5 * w * scene.units_per_mm),
            "scene units (SeparableSSS.h's sssWidth)",
        ),
        ("strength", color(j.strength), "per channel, in [0, 1]"),
        (
            "falloff",
            color(j.scale_mm.map(|s| s / w - 0.001)),
            "per channel, >= 0",
        ),
        (
            "albedo",
            color(j.albedo),
            "diffuse colour multiplied after the blur (linear RGB)",
        ),
    ])
}

pub fn from_params(p: &Map<String, Value>, scene: Scene) -> Result<Jimenez> {
    let w = number(p, "sssWidth")? / (1.5 * scene.units_per_mm);
    let falloff = triple(p, "falloff")?;
    Ok(Jimenez {
        albedo: triple(p, "albedo")?,
        strength: triple(p, "strength")?,
        scale_mm: falloff.map(|f| w * (0.001 + f)),
    })
}
