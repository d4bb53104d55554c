//! Unreal Engine's Subsurface Profile with Burley normalized diffusion
//! (Engine/Classes/Engine/SubsurfaceProfile.h, FSubsurfaceProfileStruct;
//! Engine/Shaders/Private/BurleyNormalizedSSSCommon.ush): SurfaceAlbedo A,
//! MeanFreePathColor times MeanFreePathDistance = the mean free path l per
//! channel in world units (cm), and the shape distance d = l / s(A) with
//! the perpendicular-incidence scaling s(A) = 1.85 - A + 7 |A - 0.8|^3
//! (GetPerpendicularScalingFactor; Christensen and Burley 2015, eq. 6).

use super::burley::Burley;
use super::{color, number, table, triple, Units};
use crate::error::Result;
use serde_json::{json, Map, Value};

/// Unreal's world unit in mm.
pub const MM_PER_CM: f64 = 10.0;
/// WorldUnitScale's default in the engine, reported as is.
pub const WORLD_UNIT_SCALE: f64 = 0.1;

/// GetPerpendicularScalingFactor.
pub fn perpendicular_scaling(a: f64) -> f64 {
    1.85 - a + 7.0 * (a - 0.8).abs().powi(3)
}

pub fn params(b: &Burley) -> (Map<String, Value>, Units) {
    let mfp_cm: [f64; 3] =
        std::array::from_fn(|c| b.d_mm[c] * perpendicular_scaling(b.albedo[c]) / MM_PER_CM);
    let dist = mfp_cm.iter().fold(0.0f64, |m, v| m.max(*v));
    table(vec![
        ("SurfaceAlbedo", color(b.albedo), "linear RGB in [0, 1]"),
        (
            "MeanFreePathColor",
            color(mfp_cm.map(|v| v / dist)),
            "per-channel fraction of MeanFreePathDistance",
        ),
        (
            "MeanFreePathDistance",
            json!(dist),
            "cm (Unreal world units)",
        ),
        (
            "WorldUnitScale",
            json!(WORLD_UNIT_SCALE),
            "the engine default, left as is",
        ),
        ("bEnableBurley", json!(true), "Burley normalized"),
        (
            "bEnableMeanFreePath",
            json!(true),
            "mean free path, not diffuse mean free path",
        ),
    ])
}

pub fn from_params(p: &Map<String, Value>) -> Result<Burley> {
    let albedo = triple(p, "SurfaceAlbedo")?;
    let color = triple(p, "MeanFreePathColor")?;
    let dist = number(p, "MeanFreePathDistance")?;
    Ok(Burley {
        albedo,
        d_mm: std::array::from_fn(|c| {
            color[c] * dist * MM_PER_CM / perpendicular_scaling(albedo[c])
        }),
    })
}
