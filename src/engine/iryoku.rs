//! iryoku's separable SSS (Jimenez et al. 2015; github.com/iryoku/separable-sss
//! at commit b2174689, 2012-06-23; SeparableSSS.h, Demo/Code/SeparableSSS.cpp
//! and Demo/Shaders/SeparableSSS.fx are unchanged since the first commit
//! 5235b256). The chain from its parameters to the kernel it renders, as
//! read from that source:
//!
//! - `SeparableSSS::calculateKernel` (SeparableSSS.cpp): nSamples taps at
//!   o_i = RANGE sign(u_i) u_i^2 / RANGE^2 offset units, u_i evenly spaced
//!   over [-RANGE, RANGE], RANGE = nSamples > 20 ? 3 : 2; weight = tap area
//!   (half the distance between its neighbours) times `profile(o_i)`, d'Eon's
//!   red skin Gaussians without the narrowest at o_i / (0.001 + falloff),
//!   normalised per channel; then lerp(1, w, strength) at the centre tap and
//!   strength w elsewhere (`kernel::jimenez::tap_table`).
//! - `SSSSBlurPS` (SeparableSSS.h): finalStep = sssWidth (1 / tan(SSSS_FOVY / 2))
//!   / depth x dir x strength source / 3 in texture coordinates, the sample
//!   of tap i at texcoord + o_i finalStep, dir (1, 0) on the pass SSSSBlurX and
//!   (0, 1) on SSSSBlurY (SeparableSSS.fx). SSSS_FOVY is the vertical field
//!   of view (the demo passes the CAMERA_FOV of its camera's
//!   setProjection(fov_y, aspect, ...), Demo.cpp); the strength source is
//!   the colour buffer's alpha by default.
//! - Texture coordinates span the screen, whose height at that depth is
//!   2 depth tan(fov_y / 2) scene units: an offset unit of the vertical pass
//!   covers 2 sssWidth / 3 scene units whatever the camera; the horizontal
//!   pass uses the same fov_y over the screen's width, aspect times longer.
//!   The kernel iryoku renders is aspect times wider across than down.
//!
//! ssskit converts for the vertical pass: one offset unit is
//! L = 2 sssWidth / (3 u) mm (u scene units per mm), sssWidth = 1.5 L u, and
//! scores the table at that step on both axes. The shader's "kernels range
//! from -3 to 3" holds for 25 taps; below 21 the table spans +-2 units.

use super::jimenez::{self as sep, ChannelFit, FitData, Separable};
use super::printed::units_line;
use super::printed::{check, color, number, table, triple, typed, Units};
use super::priority::Priority;
use super::{EngineFit, Scene};
use crate::error::Result;
use crate::kernel::jimenez::{tap_table, JimenezParams, IRYOKU_FALLOFF, IRYOKU_STRENGTH};
use crate::kernel::taps;
use crate::profile::Profile;
use serde_json::{json, Map, Value};

pub const VERSION: &str =
    "iryoku/separable-sss b2174689 (2012-06-23): SeparableSSS.h, SeparableSSS.cpp calculateKernel";

/// Texture coordinates per kernel offset unit on either pass at a pixel of
/// linear depth `depth` (SSSSBlurPS: sssWidth cot(fov_y / 2) / depth / 3,
/// strength source 1).
pub fn step_texcoord(sss_width: f64, fov_y: f64, depth: f64) -> f64 {
    sss_width / (0.5 * fov_y).tan() / depth / 3.0
}

/// Scene units per offset unit on the vertical pass: texture y spans the
/// screen's height, 2 depth tan(fov_y / 2).
pub fn vertical_step(sss_width: f64, fov_y: f64, depth: f64) -> f64 {
    step_texcoord(sss_width, fov_y, depth) * 2.0 * depth * (0.5 * fov_y).tan()
}

/// Scene units per offset unit on the horizontal pass: texture x spans the
/// screen's width, `aspect` (width / height) times its height.
pub fn horizontal_step(sss_width: f64, fov_y: f64, depth: f64, aspect: f64) -> f64 {
    aspect * vertical_step(sss_width, fov_y, depth)
}

/// Scene units per offset unit per unit of sssWidth on the vertical pass:
/// 2/3 for every camera (`vertical_step`, evaluated at one).
fn step_per_width() -> f64 {
    vertical_step(1.0, 1.0, 1.0)
}

/// sssWidth that makes the vertical pass step `mm_per_unit` mm per offset
/// unit: 1.5 mm_per_unit u.
pub fn sss_width_for(mm_per_unit: f64, scene: Scene) -> f64 {
    mm_per_unit * scene.units_per_mm / step_per_width()
}

/// The vertical pass's mm per offset unit for `sss_width`.
pub fn mm_per_unit(sss_width: f64, scene: Scene) -> f64 {
    sss_width * step_per_width() / scene.units_per_mm
}

/// iryoku's values: what SeparableSSS takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iryoku {
    /// nSamples (SSSS_N_SAMPLES).
    pub samples: usize,
    /// mm per kernel offset unit on the vertical pass.
    pub mm_per_unit: f64,
    pub strength: [f64; 3],
    pub falloff: [f64; 3],
    /// The material's diffuse colour: the normalised blur keeps it.
    pub albedo: [f64; 3],
}

impl Iryoku {
    /// The kernel it renders.
    pub fn separable(&self) -> Result<Separable> {
        let p = JimenezParams {
            width: self.mm_per_unit,
            strength: self.strength,
            falloff: self.falloff,
        };
        let n = self.samples;
        Ok(Separable {
            albedo: self.albedo,
            taps: tap_table(&p, n, taps::range(n) * self.mm_per_unit)?,
        })
    }
}

/// The best iryoku kernel with `samples` taps and its summed squared
/// shape error; with `Priority::Colour` the albedo is the profile's total
/// (the table sums to 1 per channel, so that is the total it renders).
pub fn fit_samples(p: &Profile, samples: usize, priority: Priority) -> Result<(Iryoku, f64)> {
    let d = FitData::new(p)?;
    let fixed = (priority == Priority::Colour).then(|| std::array::from_fn(|c| p.total_rd[c]));
    let l = sep::best_unit(&d, |l| Ok(sep::fit_channels(&d, samples, l, fixed)?.1))?;
    let (fits, cost) = sep::fit_channels(&d, samples, l, fixed)?;
    let pick = |f: fn(&ChannelFit) -> f64| -> [f64; 3] { std::array::from_fn(|c| f(&fits[c])) };
    Ok((
        Iryoku {
            samples,
            mm_per_unit: l,
            strength: pick(|f| f.strength),
            falloff: pick(|f| f.falloff),
            albedo: pick(|f| f.albedo),
        },
        cost,
    ))
}

/// The values to type, each to 4 significant digits (`typed`, as for
/// every engine): SeparableSSS::setWidth, setStrength and setFalloff take
/// floats set in code, where 16 digits are noise; the error is scored on
/// these rounded values (`fit`).
pub fn params(k: &Iryoku, scene: Scene) -> (Map<String, Value>, Units) {
    table(vec![
        (
            "sssWidth",
            json!(typed(sss_width_for(k.mm_per_unit, scene))),
            "scene units (SSSSBlurPS sssWidth, SeparableSSS::setWidth): the vertical pass \
             steps 2/3 of it per kernel offset unit",
        ),
        (
            "nSamples",
            json!(k.samples),
            "taps per pass (SSSS_N_SAMPLES; the SeparableSSS constructor's nSamples)",
        ),
        (
            "strength",
            color(k.strength.map(typed)),
            "per channel, in [0, 1] (SeparableSSS::setStrength)",
        ),
        (
            "falloff",
            color(k.falloff.map(typed)),
            "per channel, in [0, 1] (SeparableSSS::setFalloff; the demo's slider range)",
        ),
        (
            "albedo",
            color(k.albedo.map(typed)),
            "the material's diffuse colour (linear RGB): the blur is normalised and keeps it",
        ),
    ])
}

/// The kernel from iryoku's values as written.
pub fn from_params(p: &Map<String, Value>, scene: Scene) -> Result<Separable> {
    let samples = number(p, "nSamples")?;
    check(
        samples.fract() == 0.0 && (3.0..=255.0).contains(&samples) && samples % 2.0 == 1.0,
        "nSamples",
        samples,
        "must be an odd whole number from 3 to 255",
    )?;
    let width = number(p, "sssWidth")?;
    check(width > 0.0, "sssWidth", width, "must be > 0 (scene units)")?;
    Iryoku {
        samples: samples as usize,
        mm_per_unit: mm_per_unit(width, scene),
        strength: triple(p, "strength")?,
        falloff: triple(p, "falloff")?,
        albedo: triple(p, "albedo")?,
    }
    .separable()
}

fn list(v: [f64; 3]) -> String {
    v.map(|x| x.to_string()).join(", ")
}

/// What else must hold for the error to apply.
fn requirements() -> Vec<String> {
    vec![
        "SSSS_FOVY is the camera's vertical field of view (degrees): both passes step \
         sssWidth cot(fov_y / 2) / (3 depth) of the screen, so the vertical pass covers \
         2 sssWidth / 3 scene units per offset unit and the horizontal pass aspect times \
         that (the error is for the vertical pass's step on both axes)"
            .into(),
        "the depth buffer the blur reads holds linear view depth in the scene units of sssWidth"
            .into(),
        "the strength source (SSSS_STREGTH_SOURCE, the colour buffer's alpha by default) is 1 \
         on the material: it multiplies the step"
            .into(),
        format!(
            "the kernel comes from SeparableSSS::calculateKernel with these strength, falloff \
             and nSamples (setStrength, setFalloff), not from the preset tables of \
             SeparableSSS.h (those are the defaults strength {} and falloff {})",
            list(IRYOKU_STRENGTH),
            list(IRYOKU_FALLOFF)
        ),
    ]
}

fn warnings(k: &Iryoku) -> Vec<String> {
    (0..3)
        .filter(|&c| k.falloff[c] >= 0.999)
        .map(|c| {
            format!(
                "`falloff` channel {c} is at 1, the top of the demo's slider: the profile is \
                 wider than a table spanning {} offset units renders",
                taps::range(k.samples)
            )
        })
        .collect()
}

/// Fits iryoku's kernel with each of its tap counts and keeps the best.
pub fn fit(profile: &Profile, scene: Scene, priority: Priority) -> Result<EngineFit> {
    let k = sep::best_count(|n| fit_samples(profile, n, priority))?;
    let (params, units) = params(&k, scene);
    // The error of what the engine renders from the values as written.
    let (model_profile, error) = sep::rendered(&from_params(&params, scene)?, profile, "iryoku")?;
    Ok(EngineFit {
        engine: "iryoku".into(),
        version: VERSION.into(),
        priority,
        params,
        units,
        error,
        error_for: format!(
            "the separable product K(x) K(y) of the {}-tap table of calculateKernel, each \
             tap's weight spread over its footprint, at the vertical pass's step",
            k.samples
        ),
        scene: vec![units_line(scene, "sssWidth is a length in them")],
        requirements: requirements(),
        warnings: warnings(&k),
        other: None,
        rendered: None,
        walk: None,
        profile: model_profile,
    })
}
