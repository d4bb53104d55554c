//! Unreal Engine 5's Subsurface Profile transmission, read in Epic's
//! UnrealEngine source (5.4: the izzy2lost/UnrealEngineUWP mirror,
//! `Build.version` 5.4.0; the shaders in 5.8.0: the unicorn2022/UE5.8.0
//! mirror; `ApproximateHG` in the chenyong2github/UnrealEngine mirror):
//!
//! 1. `ComputeTransmissionProfileBurley`
//!    (`Engine/Private/Rendering/BurleyNormalizedSSS.cpp`, called by
//!    `FSubsurfaceProfileTexture::CreateTexture` in SubsurfaceProfile.cpp
//!    with the clamped SurfaceAlbedo and diffuse mean free path of the
//!    reflection): 32 texels, texel i at DistanceInMm = (i / 32 x 50 + 0.6)
//!    x InvUnitScale, InvUnitScale = 0.1 / WorldUnitScale x 0.1
//!    (`r.SSProfiles.Transmission.UseLegacy` 1, the default), holds
//!    `Burley_TransmissionProfile` = 0.25 A (e^{-r S / L} + 3 e^{-r S / (3 L)})
//!    = 0.25 A (e^{-r/d} + 3 e^{-r/(3d)}) (the Burley d of the reflection)
//!    times TransmissionTintColor (clamped to [0.009, 1]); the last texel
//!    is black.
//! 2. `CalculateEncodedOpticalDepth` and `CalculateOpticalDepth`
//!    (`Shaders/Private/TransmissionThickness.ush`), a directional light's
//!    shadow map: the pixel moved NormalScale / 2 world units into the
//!    surface, thickness = its shadow depth less the shadow map's (world
//!    units), optical depth = ExtinctionScale x thickness, then
//!    clamp(|OD + NormalScale / 2|, 0.15, 5) + 0.25 (for OD <= 0,
//!    max(0, OD N.L + NormalScale / 2) with N.L = 1), encoded 1 - OD / 5;
//!    `ShadowProjectionPixelShader.usf` squares the encoded value
//!    (`ApplyPCFOverBlurCorrection`) and `DecodeOpticalDepthFromShadowMask`
//!    (TransmissionCommon.ush) reads (1 - e^2) x 5.
//! 3. `GetTransmissionProfile` (TransmissionCommon.ush): texel coordinate
//!    OD / 5 x 31, bilinear between texels.
//! 4. `SubsurfaceProfileBxDF` (Shaders/Private/ShadingModels.ush):
//!    Transmission = light x Profile x ApproximateHG(dot(-L, refract(V, -N,
//!    1 / IOR)), ScatteringDistribution), with `ApproximateHG` = 0.5 (1 -
//!    g^2) / (1 - g cos)^2; seen along the normal with the light directly
//!    behind, cos = 1. The transmission is scatterable light
//!    (`LightAccumulator_AddSplit` in DeferredLightingCommon.ush), blurred
//!    with the reflection and multiplied by the Base Color in
//!    `SubsurfaceRecombinePS` (docs/engines.md, step 5).
//!
//! So pi L / E = pi x Tint x Profile(OD'(t)) x 0.5 (1 + g) / (1 - g) x
//! Base Color.

use super::{Grid, Scored, Target, TINY};
use crate::engine::printed::{number, triple, typed};
use crate::engine::{EngineFit, Scene};
use crate::error::{Error, Result};
use serde_json::json;

pub const SOURCE: &str = "Unreal Engine 5.4 and later: BurleyNormalizedSSS.cpp \
     ComputeTransmissionProfileBurley, TransmissionThickness.ush CalculateEncodedOpticalDepth, \
     TransmissionCommon.ush GetTransmissionProfile, ShadingModels.ush SubsurfaceProfileBxDF \
     (read in mirrors of Epic's UnrealEngine, 5.4.0 and 5.8.0)";

/// `FSubsurfaceProfileStruct` (SubsurfaceProfile.h): the Transmission
/// settings' ClampMin and ClampMax.
pub const EXTINCTION_SCALE_RANGE: (f64, f64) = (0.01, 100.0);
pub const NORMAL_SCALE_RANGE: (f64, f64) = (0.01, 1.0);
pub const SCATTERING_DISTRIBUTION_RANGE: (f64, f64) = (0.01, 0.99);
/// CreateTexture's `Bias`: every colour is clamped to at least this.
pub const COLOUR_BIAS: f64 = 0.009;
/// Texels of the transmission profile (BSSS_TRANSMISSION_PROFILE_SIZE).
const TEXELS: usize = 32;
/// SSSS_MAX_TRANSMISSION_PROFILE_DISTANCE.
const MAX_DISTANCE: f64 = 5.0;
/// `ProfileRadiusOffset` (BurleyNormalizedSSS.cpp).
const RADIUS_OFFSET: f64 = 0.06;

/// The transmission settings of a profile asset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub extinction_scale: f64,
    pub normal_scale: f64,
    pub scattering_distribution: f64,
    pub tint: [f64; 3],
}

/// What the reflection side fixes: SurfaceAlbedo (clamped as CreateTexture
/// does), Burley d in mm, the Base Color and WorldUnitScale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reflection {
    pub surface_albedo: [f64; 3],
    pub d_mm: [f64; 3],
    pub base_color: [f64; 3],
    pub world_unit_scale: f64,
}

/// The optical depth the lighting pass reads for a slab `t_units` thick
/// (world units) lit from behind along its normal: steps 2 and 3.
pub fn decoded_optical_depth(s: &Settings, t_units: f64) -> f64 {
    let ns = 0.5 * s.normal_scale;
    let od = s.extinction_scale * (t_units - ns);
    let od = if od > 0.0 {
        (od + ns).abs()
    } else {
        (od + ns).max(0.0)
    };
    let od = od.clamp(0.15, 5.0) + 0.25;
    let enc = 1.0 - od / MAX_DISTANCE;
    (1.0 - enc * enc) * MAX_DISTANCE
}

/// Texel `i` of channel `c` of the transmission profile (step 1).
fn texel(s: &Settings, r: &Reflection, c: usize, i: usize) -> f64 {
    if i + 1 >= TEXELS {
        return 0.0;
    }
    let inv_unit = 0.1 / r.world_unit_scale * 0.1;
    let mm = (i as f64 / TEXELS as f64 * MAX_DISTANCE * 10.0 + RADIUS_OFFSET * 10.0) * inv_unit;
    let (a, d) = (r.surface_albedo[c], r.d_mm[c]);
    let t = 0.25 * a * ((-mm / d).exp() + 3.0 * (-mm / (3.0 * d)).exp());
    t * s.tint[c].clamp(COLOUR_BIAS, 1.0)
}

/// `ApproximateHG` (ShadingModels.ush): 0.5 (1 - g^2) / (1 - g cos)^2.
pub fn approximate_hg(cos: f64, g: f64) -> f64 {
    0.5 * (1.0 - g * g) / ((1.0 - g * cos) * (1.0 - g * cos)).max(1e-5)
}

/// `ApproximateHG` at cos = 1.
pub fn phase_forward(g: f64) -> f64 {
    approximate_hg(1.0, g)
}

/// pi L / E through a slab `t_mm` thick seen along the light: the chain of
/// the module comment ([`rendered_at`] with cos = 1).
pub fn rendered(s: &Settings, r: &Reflection, scene: Scene, t_mm: f64) -> [f64; 3] {
    rendered_at(s, r, scene, t_mm, 1.0)
}

/// pi L / E through a thickness `t_mm` (the shadow map's) with `cos` =
/// dot(-L, V), the view through the surface with IOR 1 (`refract(V, -N,
/// 1)` = V).
pub fn rendered_at(s: &Settings, r: &Reflection, scene: Scene, t_mm: f64, cos: f64) -> [f64; 3] {
    let od = decoded_optical_depth(s, t_mm * scene.units_per_mm);
    let x = (od / MAX_DISTANCE * (TEXELS - 1) as f64).clamp(0.0, (TEXELS - 1) as f64);
    let i = (x.floor() as usize).min(TEXELS - 2);
    let f = x - i as f64;
    let phase = approximate_hg(cos, s.scattering_distribution);
    std::array::from_fn(|c| {
        let p = texel(s, r, c, i) * (1.0 - f) + texel(s, r, c, i + 1) * f;
        std::f64::consts::PI * p * phase * r.base_color[c]
    })
}

/// The reflection side of an Unreal fit: its printed SurfaceAlbedo, Base
/// Color and WorldUnitScale, and the Burley d it renders.
fn reflection(reflect: &EngineFit) -> Result<Reflection> {
    let b = reflect.rendered.as_ref().ok_or_else(|| {
        Error::Unsupported("the Unreal fit has no rendered Burley profile".into())
    })?;
    Ok(Reflection {
        surface_albedo: triple(&reflect.params, "SurfaceAlbedo")?
            .map(|a| a.clamp(COLOUR_BIAS, 1.0)),
        d_mm: b.d_mm,
        base_color: triple(&reflect.params, "Base Color")?,
        world_unit_scale: number(&reflect.params, "WorldUnitScale")?,
    })
}

/// The fit: ExtinctionScale and NormalScale by search, the amplitude per
/// channel in closed form, ScatteringDistribution the least that keeps the
/// tint at most 1.
pub(crate) fn fit(
    reflect: &EngineFit,
    target: &Target,
    scene: Scene,
) -> Result<(Scored, Vec<[f64; 3]>, super::Model)> {
    let r = reflection(reflect)?;
    let unit_tint = |es: f64, ns: f64| Settings {
        extinction_scale: es,
        normal_scale: ns,
        scattering_distribution: 0.0,
        tint: [1.0; 3],
    };
    let shape = |s: &Settings| target.rows(|t| rendered(s, &r, scene, t));
    let ns_grid: Vec<f64> = (0..=10).map(|k| 0.01 + 0.099 * k as f64).collect();
    let (ns, es) = target.search(
        Grid {
            grid: &ns_grid,
            range: EXTINCTION_SCALE_RANGE,
            iters: 40,
            start: (0.08, 1.0),
        },
        |ns, es| shape(&unit_tint(es, ns)),
        |_, _| true,
    );
    let (es, ns) = (typed(es), typed(ns));
    let (k, _) = target.amplitude(&shape(&unit_tint(es, ns)));
    // The shape was taken at tint 1 and g = 0, so k = tint x phase(g) /
    // phase(0), phase(g) / phase(0) = (1 + g) / (1 - g): the least g that
    // keeps every tint at most 1.
    let need = k.iter().fold(0.0f64, |m, v| m.max(*v));
    let (glo, ghi) = SCATTERING_DISTRIBUTION_RANGE;
    let g = typed(((need - 1.0) / (need + 1.0)).clamp(glo, ghi));
    let gain = phase_forward(g) / phase_forward(0.0);
    let tint = k.map(|k| typed((k / gain).clamp(COLOUR_BIAS, 1.0)));
    let warnings = super::capped(k.map(|k| k / gain), |c, k| {
        format!(
            "channel {c}: the table asks for {k:.3} times the light ScatteringDistribution \
             {ghi} lets through; TransmissionTintColor is capped at 1"
        )
    });
    let s = Settings {
        extinction_scale: es,
        normal_scale: ns,
        scattering_distribution: g,
        tint,
    };
    let model = shape(&s);
    if model.iter().all(|m| m.iter().all(|v| *v <= TINY)) {
        return Err(Error::Unsupported(
            "Unreal's profile lets no light through".into(),
        ));
    }
    let rows = vec![
        (
            "ExtinctionScale",
            json!(es),
            "Subsurface Profile, Transmission: multiplies the shadow-map thickness (world units) \
             into the profile's distance; 0.01 to 100",
        ),
        (
            "NormalScale",
            json!(ns),
            "Subsurface Profile, Transmission: half of it moves the pixel into the surface and is \
             added back to the optical depth; 0.01 to 1",
        ),
        (
            "ScatteringDistribution",
            json!(g),
            "Subsurface Profile, Transmission: ApproximateHG's g, the forward peak seen from behind; \
             0.01 to 0.99",
        ),
        (
            "TransmissionTintColor",
            json!(tint),
            "Subsurface Profile, Transmission: linear colour multiplied into the profile; 0.009 to 1",
        ),
        (
            "IOR",
            json!(1.0),
            "Subsurface Profile, Transmission: 1 keeps the view through the surface straight (the \
             error is for the view along the normal, where IOR changes nothing)",
        ),
    ];
    Ok((
        Scored::new(rows, requirements(scene), warnings),
        model,
        super::Model::Unreal(s, r, scene),
    ))
}

/// What must hold in Unreal for the fitted settings to give the light.
fn requirements(scene: Scene) -> Vec<String> {
    vec![
        "the reflection settings printed above (the transmission profile is built from the same \
         SurfaceAlbedo, mean free path and WorldUnitScale)"
            .to_string(),
        "a shadow-casting light behind the object (the thickness is the light's shadow-map depth \
         difference), r.SSProfiles.Transmission.UseLegacy 1 (the default)"
            .to_string(),
        format!(
            "scene units of {} mm (--units-per-mm {}): the thickness enters in world units",
            1.0 / scene.units_per_mm,
            scene.units_per_mm
        ),
    ]
}
