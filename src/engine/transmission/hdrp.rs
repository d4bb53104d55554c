//! Unity 6 HDRP's diffusion-profile transmission, read in
//! Unity-Technologies/Graphics (com.unity.render-pipelines.high-definition):
//!
//! 1. `DiffusionProfileSettings.UpdateCache`
//!    (Runtime/Material/DiffusionProfile/DiffusionProfileSettings.cs): the
//!    Transmission Tint (an HDR colour, `ColorUsage(false, true)`) is
//!    stored x 0.25, the Thickness Remap as (min, max - min) in
//!    millimetres; `Validate` keeps 0 <= min <= max. The shape parameter
//!    S = 1 / (Multiplier x Scattering Color) per channel is the
//!    reflection's (`UpdateKernel`).
//! 2. `FillMaterialTransmission`
//!    (Runtime/Material/SubsurfaceScattering/SubsurfaceScattering.hlsl):
//!    thickness = min + (max - min) x the material's thickness map;
//!    transmittance = `ComputeTransmittanceDisney`(S, tint / 4, thickness)
//!    (Runtime/Material/DiffusionProfile/DiffusionProfile.hlsl) =
//!    tint / 4 (e^{-S t} + 3 e^{-S t / 3}). For a directional light the
//!    thick-object mode keeps this baked value too (LightLoop's
//!    `EvaluateBSDF_Directional`: "Transmission through thick objects does
//!    not support shadowing from directional lights").
//! 3. `EvaluateBSDF` (Runtime/Material/Lit/Lit.hlsl): diffT = Lambert() x
//!    `ComputeWrappedDiffuseLighting`(-N.L, TRANSMISSION_WRAP_LIGHT), the
//!    wrap sin(15 deg) (SubsurfaceScattering.hlsl), `ComputeWrappedDiffuseLighting`
//!    = saturate((x + w) / (1 + w)^2) (CommonLighting.hlsl); the light is
//!    diffuse lighting, blurred with the reflection and multiplied by the
//!    Base Map colour (Post-scatter).
//!
//! So, lit from directly behind (-N.L = 1): pi L / E = tint / 4
//! (e^{-S t} + 3 e^{-S t / 3}) / (1 + w) x Base Color, t the remapped map
//! value in HDRP's millimetres (not scaled by World Scale).

use super::{Grid, Scored, Target};
use crate::engine::printed::{number, typed};
use crate::engine::{EngineFit, Scene};
use crate::error::{Error, Result};
use serde_json::json;

pub const SOURCE: &str = "Unity 6 HDRP 17: DiffusionProfileSettings.cs UpdateCache, \
     SubsurfaceScattering.hlsl FillMaterialTransmission, DiffusionProfile.hlsl \
     ComputeTransmittanceDisney, Lit.hlsl EvaluateBSDF (read in Unity-Technologies/Graphics)";

/// The largest Transmission Tint channel a fit may ask for: 2^10, ten
/// stops of the HDR colour picker's Intensity above white (a bound chosen
/// here so that an artist can set the colour; HDRP itself stores any float).
pub const TINT_MAX: f64 = 1024.0;

/// TRANSMISSION_WRAP_LIGHT = cos(pi / 2 - pi / 12).
const WRAP: f64 = 0.258_819_045_102_520_8;

/// The transmission settings of a diffusion profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub tint: [f64; 3],
    /// Thickness Remap min and max, HDRP millimetres.
    pub remap: (f64, f64),
}

/// HDRP's thickness (its millimetres) for a slab `t_mm` thick whose
/// thickness map holds t / `map_mm` (clamped to [0, 1]).
pub fn thickness(s: &Settings, t_mm: f64, map_mm: f64) -> f64 {
    s.remap.0 + (s.remap.1 - s.remap.0) * (t_mm / map_mm).clamp(0.0, 1.0)
}

/// pi L / E through a slab `t_mm` thick lit from directly behind: the
/// chain of the module comment, `shape` = S per channel (1 / HDRP mm),
/// `base` the linear Base Map colour ([`rendered_at`] with N.L = -1).
pub fn rendered(s: &Settings, shape: [f64; 3], base: [f64; 3], t_mm: f64, map_mm: f64) -> [f64; 3] {
    rendered_at(s, shape, base, t_mm, map_mm, -1.0)
}

/// pi L / E for the thickness map's `t_mm` and the light at `n_dot_l`.
pub fn rendered_at(
    s: &Settings,
    shape: [f64; 3],
    base: [f64; 3],
    t_mm: f64,
    map_mm: f64,
    n_dot_l: f64,
) -> [f64; 3] {
    let t = thickness(s, t_mm, map_mm);
    let wrapped = ((-n_dot_l + WRAP) / ((1.0 + WRAP) * (1.0 + WRAP))).clamp(0.0, 1.0);
    std::array::from_fn(|c| {
        let e = (-shape[c] * t / 3.0).exp();
        0.25 * s.tint[c] * (e * e * e + 3.0 * e) * wrapped * base[c]
    })
}

pub(crate) fn fit(
    reflect: &EngineFit,
    target: &Target,
    scene: Scene,
) -> Result<(Scored, Vec<[f64; 3]>, super::Model)> {
    let b = reflect
        .rendered
        .as_ref()
        .ok_or_else(|| Error::Unsupported("the HDRP fit has no rendered Burley profile".into()))?;
    // S in HDRP's mm from the rendered d (hdrp.rs `from_params`, Subsurface
    // Mask 1): d = 1 / (S x 1000 x World Scale x units per mm).
    let ws = number(&reflect.params, "World Scale")?;
    let shape = b.d_mm.map(|d| 1.0 / (d * 1000.0 * ws * scene.units_per_mm));
    let base = b.albedo;
    let map_mm = target.thickness.iter().fold(0.0f64, |m, t| m.max(*t));
    let model = |s: &Settings| target.rows(|t| rendered(s, shape, base, t, map_mm));
    let unit_tint = |lo: f64, span: f64| Settings {
        tint: [1.0; 3],
        remap: (lo, lo + span),
    };
    // Remap min from 0 (a scan of offsets, 0 first) and the span by
    // golden section in log space. Tint and remap min nearly trade off
    // (e^{-S min} x tint), so an offset counts only while its tint stays
    // under TINT_MAX; 0 always counts.
    let top = 2.0 * map_mm;
    let offsets: Vec<f64> = (0..=20)
        .map(|k| top * k as f64 / 20.0 * (k as f64 / 20.0))
        .collect();
    let best = target.search(
        Grid {
            grid: &offsets,
            range: (1e-3 * map_mm, 1e3 * map_mm),
            iters: 40,
            start: (0.0, map_mm),
        },
        |lo, span| model(&unit_tint(lo, span)),
        |k, tint| k == 0 || tint.iter().all(|t| *t <= TINT_MAX),
    );
    let (lo, hi) = (typed(best.0), typed(best.0 + best.1));
    let (k, _) = target.amplitude(&model(&unit_tint(lo, hi - lo)));
    let s = Settings {
        tint: k.map(typed),
        remap: (lo, hi),
    };
    let rows = vec![
        (
            "Transmission Mode",
            json!("Thin Object"),
            "diffusion profile; .asset: profile.transmissionMode = 1 (a directional light uses \
             the thickness map in both modes)",
        ),
        (
            "Transmission Tint",
            json!(s.tint),
            "diffusion profile, HDR colour (linear; values above 1 need the picker's HDR mode); \
             .asset: profile.transmissionTint",
        ),
        (
            "Thickness Remap",
            json!([lo, hi]),
            "diffusion profile, min and max in mm; .asset: profile.thicknessRemap",
        ),
        (
            "Thickness Map",
            json!(format!("t / {} mm", typed(map_mm))),
            "Lit material (_ThicknessMap, Transmission on): each texel the object's thickness \
             through the surface over the thickest slab of the table, clamped to [0, 1]",
        ),
    ];
    let requirements = vec![
        "the Lit material's Material Type Subsurface Scattering with Transmission on, this \
         Diffusion Profile, and the reflection settings printed above (S is the reflection's)"
            .to_string(),
        format!(
            "a thickness map of t / {} mm (t the object's thickness in mm) and Transmission Mask 1",
            typed(map_mm)
        ),
        "Directional Transmission Multiplier 1 in the Volume's shadow settings".to_string(),
    ];
    Ok((
        Scored::new(rows, requirements, Vec::new()),
        model(&s),
        super::Model::Hdrp(s, shape, base, map_mm),
    ))
}
