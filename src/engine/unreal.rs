//! Unreal Engine 5's Subsurface Profile with Burley normalized diffusion,
//! the chain from the values typed into the profile asset to the profile
//! the screen-space Burley pass renders (Epic's UnrealEngine repository;
//! read in the 5.0.3, 5.4 and 5.8.0 sources):
//!
//! 1. `FSubsurfaceProfileStruct` (Engine/Classes/Engine/SubsurfaceProfile.h):
//!    SurfaceAlbedo (ClampMin 0.01, ClampMax 1), MeanFreePathColor (0.001
//!    to 1), MeanFreePathDistance in cm (ClampMin 0.1, ClampMax 50),
//!    WorldUnitScale (0.1 to 50), Tint.
//! 2. `FSubsurfaceProfileTexture::CreateTexture` (Engine/Private/Rendering/
//!    SubsurfaceProfile.cpp): SurfaceAlbedo and MeanFreePathColor clamped
//!    to [0.009, 1] (`GetClamped(Bias)`), then the diffuse mean free path
//!    in mm, DMFP = GetDiffuseMeanFreePathFromMeanFreePath(A, colour x
//!    distance) x 10 = MFP s_dmfp(A) / (s_perp(A) x 0.6) x 10
//!    (`Dmfp2MfpMagicNumber` 0.6; SubsurfaceScatteringMath.h in 5.8, the
//!    division written out in 5.0.3), clamped to [0, 500] mm by
//!    `SetupSurfaceAlbedoAndDiffuseMeanFreePath`.
//! 3. The Burley pass (Shaders/Private/SubsurfaceBurleyNormalized.ush,
//!    `BurleyNormalizedSS`; BurleyNormalizedSSSCommon.ush,
//!    `GetDiffuseReflectProfileWithDiffuseMeanFreePath`) weights samples
//!    by (e^{-r S/L} + e^{-r S/(3L)}) / (8 pi L / S) with L = DMFP and
//!    S = s_dmfp(A) (`GetScalingFactor3D`), i.e. Burley's d = DMFP /
//!    s_dmfp(A) = 10 MFP / (0.6 s_perp(A)) mm, and divides by the sum of
//!    the weights: the blur is normalised to 1.
//! 4. The profile's mm on the screen. `GetBurleyParameters`
//!    (SubsurfaceBurleyNormalized.ush) hands the pass
//!    `DecodeWorldUnitScale(...) * BURLEY_CM_2_MM`, i.e. 10 x WorldUnitScale;
//!    `CalculateBurleyScale` multiplies it by SubsurfaceParams.x / depth
//!    (SSSScaleX = cot(fov / 2) / 6, PostProcessSubsurface.cpp
//!    `GetSubsurfaceCommonParameters`) and, in 5.4, by
//!    SUBSURFACE_KERNEL_SIZE / BURLEY_CM_2_MM (= 0.3; absent in 5.0.3).
//!    The screen spans 2 depth / cot(fov / 2) world units, so one profile
//!    mm is WorldUnitScale world units (5.4) or 10 WorldUnitScale / 3
//!    (5.0): in Unreal's cm, the default WorldUnitScale 0.1
//!    (`FSubsurfaceProfileStruct`'s constructor) renders the profile at
//!    its true size in 5.4, as the pass's own bilateral comment says ("a
//!    1 cm world unit scale (i.e., 1cm is regarded as 1mm)").
//! 5. `SubsurfaceRecombinePS` (PostProcessSubsurface.usf): lerp(unblurred,
//!    blurred, Tint) x the material's Base Color (`StoredBaseColor`).
//!
//! So the rendered profile is Base Color x Burley(d), with SurfaceAlbedo
//! only shaping d; s_perp and s_dmfp are Christensen and Burley's
//! perpendicular-searchlight and diffuse-mean-free-path fits.

use super::burley::Burley;
use super::printed::{
    color, in_range, number, printed, require, srgb_hex, triple, typed, units_line, Printed,
};
use super::{Scene, Version};
use crate::error::Result;
use crate::profile::analytic::burley::{dmfp_scale, searchlight_scale};
use serde_json::{json, Map, Value};

pub const VERSIONS: [Version; 2] = [
    Version {
        key: "5.4",
        aliases: &["5", "5.5", "5.6", "5.7", "5.8"],
        label: "Unreal Engine 5.4 and later: Subsurface Profile, Burley \
                (read in the 5.4 and 5.8.0 sources)",
    },
    Version {
        key: "5.0",
        aliases: &[],
        label: "Unreal Engine 5.0: Subsurface Profile, Burley (read in the 5.0.3 source)",
    },
];

/// `Dmfp2MfpMagicNumber` (SubsurfaceProfile.cpp, SubsurfaceScatteringMath.h).
pub const DMFP2MFP: f64 = 0.6;
/// The `Bias` CreateTexture clamps SurfaceAlbedo and MeanFreePathColor to.
pub const TEXTURE_MIN: f64 = 0.009;
/// `DEC_UNIT_TO_DIFFUSEMEANFREEPATH_IN_MM`: the DMFP encoding's range, mm.
pub const DMFP_MAX_MM: f64 = 500.0;
/// MeanFreePathDistance's ClampMin and ClampMax, cm.
pub const DISTANCE_RANGE: (f64, f64) = (0.1, 50.0);
/// WorldUnitScale's ClampMin and ClampMax.
pub const WORLD_UNIT_SCALE_RANGE: (f64, f64) = (0.1, 50.0);
/// SurfaceAlbedo's ClampMin and ClampMax.
pub const SURFACE_ALBEDO_RANGE: (f64, f64) = (0.01, 1.0);
/// MeanFreePathColor's ClampMin and ClampMax.
pub const MFP_COLOR_RANGE: (f64, f64) = (0.001, 1.0);
const MM_PER_CM: f64 = 10.0;

pub const ERROR_FOR: &str = "the screen-space Burley pass (Implementation: Adaptive Filtered \
     Importance Sampling, the default, at r.SSS.Burley.Quality 1), its expected value; the \
     separable fallback (Implementation Separable, r.SSS.Burley.Quality 0, or r.SSS.HalfRes 1 \
     with r.SSS.HalfRes.ForceSeparable 1) blurs with a separable kernel Unreal fits to the \
     same profile and is not scored here";

/// `BURLEY_CM_2_MM`: `GetBurleyParameters` multiplies the decoded
/// WorldUnitScale by it before `CalculateBurleyScale` sees it.
pub const BURLEY_CM_2_MM: f64 = 10.0;
/// `SUBSURFACE_KERNEL_SIZE` (SubsurfaceProfile.h): SSSScaleX divides by it.
pub const SUBSURFACE_KERNEL_SIZE: f64 = 3.0;

/// World units per profile mm, divided by WorldUnitScale (step 4):
/// 10 WUS x cot / (2 x 3) / depth [x 3 / 10] UV per mm, against cot / (2
/// depth) UV per world unit.
pub fn world_units_per_profile_mm(v: Version) -> f64 {
    let per_mm = BURLEY_CM_2_MM / SUBSURFACE_KERNEL_SIZE;
    if v.key == "5.0" {
        per_mm
    } else {
        per_mm * SUBSURFACE_KERNEL_SIZE / BURLEY_CM_2_MM
    }
}

/// Scene mm per profile mm for `wus` at `units_per_mm` world units per mm.
fn scene_mm_per_profile_mm(v: Version, wus: f64, units_per_mm: f64) -> f64 {
    wus * world_units_per_profile_mm(v) / units_per_mm
}

/// The surface albedo and the diffuse mean free path in profile mm the
/// profile texture holds for one channel's asset values (step 2).
fn texture_values(albedo: f64, mfp_color: f64, distance_cm: f64) -> (f64, f64) {
    let a = albedo.clamp(TEXTURE_MIN, 1.0);
    let mfp_cm = mfp_color.clamp(TEXTURE_MIN, 1.0) * distance_cm;
    let dmfp_mm =
        (mfp_cm * dmfp_scale(a) / (searchlight_scale(a) * DMFP2MFP) * MM_PER_CM).min(DMFP_MAX_MM);
    (a, dmfp_mm)
}

/// Burley's d in profile mm from one channel's asset values (steps 2, 3).
fn profile_d_mm(albedo: f64, mfp_color: f64, distance_cm: f64) -> f64 {
    let (a, dmfp_mm) = texture_values(albedo, mfp_color, distance_cm);
    dmfp_mm / dmfp_scale(a)
}

/// What the Burley pass reads for the values `params` prints (steps 1 to
/// 3): the profile texture's surface albedo and diffuse mean free path in
/// profile mm, and the scene mm one profile mm covers (step 4).
pub fn sampled_profile(
    p: &Map<String, Value>,
    scene: Scene,
    v: Version,
) -> Result<(super::sampling::UnrealProfile, f64)> {
    // The checks of `from_params`, once.
    from_params(p, scene, v)?;
    let surface = triple(p, "SurfaceAlbedo")?;
    let mfp_color = triple(p, "MeanFreePathColor")?;
    let distance = number(p, "MeanFreePathDistance")?;
    let wus = number(p, "WorldUnitScale")?;
    let values: [(f64, f64); 3] =
        std::array::from_fn(|c| texture_values(surface[c], mfp_color[c], distance));
    Ok((
        super::sampling::UnrealProfile {
            surface_albedo: values.map(|v| v.0),
            dmfp_mm: values.map(|v| v.1),
        },
        scene_mm_per_profile_mm(v, wus, scene.units_per_mm),
    ))
}

/// The WorldUnitScale that maps the profile's mm to the scene's at `u`
/// units per mm, within the asset's range (a warning where it is not).
fn world_unit_scale(u: f64, v: Version, warnings: &mut Vec<String>) -> f64 {
    let (lo, hi) = WORLD_UNIT_SCALE_RANGE;
    let want = u / world_units_per_profile_mm(v);
    let wus = typed(want.clamp(lo, hi));
    if want != want.clamp(lo, hi) {
        warnings.push(format!(
            "WorldUnitScale: {want:.4} would map the profile's mm to the scene's at {u} units \
             per mm, outside [{lo}, {hi}]; {wus} is printed and the mean free paths scaled to \
             keep the profile's width in the scene"
        ));
    }
    wus
}

/// MeanFreePathColor and MeanFreePathDistance for the rendered d at `k`
/// scene mm per profile mm and the printed SurfaceAlbedo `surface`, within
/// the asset's ranges and the profile texture's (warnings where not).
fn mean_free_path(
    b: &Burley,
    k: f64,
    surface: [f64; 3],
    warnings: &mut Vec<String>,
) -> ([f64; 3], f64) {
    // Invert step 3 for the mean free path in cm.
    let mfp_cm: [f64; 3] = std::array::from_fn(|c| {
        b.d_mm[c] / k * DMFP2MFP * searchlight_scale(surface[c]) / MM_PER_CM
    });
    let longest = mfp_cm.iter().fold(0.0f64, |m, v| m.max(*v));
    let (dlo, dhi) = DISTANCE_RANGE;
    let distance = typed(longest.clamp(dlo, dhi));
    if longest < dlo {
        warnings.push(format!(
            "MeanFreePathDistance: the longest mean free path is {longest:.4} cm, below the \
             ClampMin {dlo}; {dlo} is printed and MeanFreePathColor scaled by {:.4} to keep \
             the mean free paths (as Unreal's own UpgradeDiffuseMeanFreePathToMeanFreePath \
             does)",
            longest / dlo
        ));
    } else if longest > dhi {
        warnings.push(format!(
            "MeanFreePathDistance: the longest mean free path is {longest:.4} cm, above the \
             ClampMax {dhi}; {dhi} is printed, so the profile renders narrower (the error \
             includes it)"
        ));
    }
    let mut mfp_color = mfp_cm.map(|m| m / distance);
    for (c, col) in mfp_color.iter_mut().enumerate() {
        if *col < TEXTURE_MIN {
            warnings.push(format!(
                "MeanFreePathColor channel {c}: {col:.5} is below {TEXTURE_MIN}, the least \
                 CreateTexture keeps (GetClamped(Bias)); {TEXTURE_MIN} is printed (the error \
                 includes it)"
            ));
            *col = TEXTURE_MIN;
        }
        *col = typed(col.min(MFP_COLOR_RANGE.1));
    }
    for c in 0..3 {
        let dmfp = mfp_color[c] * distance * dmfp_scale(surface[c])
            / (searchlight_scale(surface[c]) * DMFP2MFP)
            * MM_PER_CM;
        if dmfp > DMFP_MAX_MM {
            warnings.push(format!(
                "channel {c}: the diffuse mean free path {dmfp:.1} mm is above the {DMFP_MAX_MM} mm \
                 the profile texture encodes; Unreal clamps it (the error includes it)"
            ));
        }
    }
    (mfp_color, distance)
}

pub fn params(b: &Burley, scene: Scene, v: Version) -> Printed {
    let mut warnings = Vec::new();
    let wus = world_unit_scale(scene.units_per_mm, v, &mut warnings);
    let k = scene_mm_per_profile_mm(v, wus, scene.units_per_mm);
    let (alo, ahi) = SURFACE_ALBEDO_RANGE;
    let surface = b.albedo.map(|a| typed(a.clamp(alo, ahi)));
    let (mfp_color, distance) = mean_free_path(b, k, surface, &mut warnings);
    let base = b.albedo.map(|a| typed(a.clamp(0.0, 1.0)));
    let wus_unit = format!(
        "profile asset, in [0.1, 50]: one profile mm spans {} world units, cm \
         (GetBurleyParameters' x BURLEY_CM_2_MM, CalculateBurleyScale)",
        if v.key == "5.0" {
            "10/3 x WorldUnitScale"
        } else {
            "WorldUnitScale"
        }
    );
    let mut rows = vec![
        (
            "SurfaceAlbedo",
            color(surface),
            "profile asset, linear RGB in [0.01, 1]: shapes the profile (through s(A)), the \
             material's Base Color sets its brightness",
        ),
        (
            "MeanFreePathColor",
            color(mfp_color),
            "profile asset, linear RGB in [0.001, 1], times MeanFreePathDistance",
        ),
        (
            "MeanFreePathDistance",
            json!(distance),
            "profile asset, cm (world units), in [0.1, 50]",
        ),
        ("WorldUnitScale", json!(wus), &wus_unit),
        (
            "Tint",
            color([1.0; 3]),
            "profile asset: 1 blurs all of the diffuse light",
        ),
        (
            "Base Color",
            color(base),
            "the material's Base Color, linear RGB in [0, 1] (the colour picker's R, G, B \
             fields): the profile's total reflectance",
        ),
        (
            "Base Color hex",
            json!(srgb_hex(base)),
            "the same colour as the colour picker's Hex sRGB field (SColorPicker's \
             EColorPickerHexMode::SRGB)",
        ),
    ];
    if v.key != "5.0" {
        rows.insert(
            5,
            (
                "Implementation",
                json!("Adaptive Filtered Importance Sampling"),
                "profile asset: the Burley pass (Separable blurs with a fitted separable kernel)",
            ),
        );
    }
    printed(rows, warnings)
}

const UI: &str = "Unreal's UI";

/// The profile Unreal renders from the values `params` prints, through
/// steps 1 to 5 of the module comment.
pub fn from_params(p: &Map<String, Value>, scene: Scene, v: Version) -> Result<Burley> {
    let surface = triple(p, "SurfaceAlbedo")?;
    let mfp_color = triple(p, "MeanFreePathColor")?;
    for c in 0..3 {
        in_range(UI, "SurfaceAlbedo", surface[c], SURFACE_ALBEDO_RANGE)?;
        in_range(UI, "MeanFreePathColor", mfp_color[c], MFP_COLOR_RANGE)?;
    }
    let distance = in_range(
        UI,
        "MeanFreePathDistance",
        number(p, "MeanFreePathDistance")?,
        DISTANCE_RANGE,
    )?;
    let wus = in_range(
        UI,
        "WorldUnitScale",
        number(p, "WorldUnitScale")?,
        WORLD_UNIT_SCALE_RANGE,
    )?;
    require(
        p,
        "Tint",
        &json!([1.0, 1.0, 1.0]),
        "below 1 the recombine pass mixes in unblurred light, a spike the Burley model has not",
    )?;
    let base = triple(p, "Base Color")?;
    for b in base {
        in_range(UI, "Base Color", b, (0.0, 1.0))?;
    }
    let k = scene_mm_per_profile_mm(v, wus, scene.units_per_mm);
    Ok(Burley {
        albedo: base,
        d_mm: std::array::from_fn(|c| profile_d_mm(surface[c], mfp_color[c], distance) * k),
        truncate_d: None,
    })
}

/// What the error assumes of the scene.
pub fn scene_lines(scene: Scene) -> Vec<String> {
    vec![units_line(
        scene,
        "WorldUnitScale maps the profile's mm to them (CalculateBurleyScale); Unreal's own \
         unit is the cm",
    )]
}

pub fn requirements(v: Version) -> Vec<String> {
    let mut r = vec![
        "the material's Shading Model is Subsurface Profile with this profile, and its Base \
         Color is the Base Color printed here: the recombine pass multiplies the normalised \
         blur by it (SubsurfaceRecombinePS); SurfaceAlbedo only shapes the profile"
            .to_string(),
        "r.SSS.Scale 1 (it multiplies the radius) and r.SubsurfaceScattering 1".to_string(),
        "a profile with Burley and mean free path enabled (bEnableBurley, \
         bEnableMeanFreePath), as every profile Unreal 5 creates or loads is \
         (UpgradeSubsurfaceProfileParameters)"
            .to_string(),
    ];
    if v.key != "5.0" {
        r.push("Implementation: Adaptive Filtered Importance Sampling".into());
    }
    r
}
