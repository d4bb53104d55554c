//! What a fit is asked for (version, Blender's method, colour or shape
//! first as [`super::priority`] says, the Random Walk's walks) and the one dispatch from an engine to
//! its fit; the Burley engines' shared fit; the model read back from
//! printed values.

use super::method::SubsurfaceMethod;
use super::model::{check, check_scene, error};
use super::priority::{Priority, COLOUR_TOL};
use super::{
    blender, blender_walk, burley, godot, hdrp, iryoku, unreal, Engine, EngineFit, Scene, Version,
};
use crate::error::Result;
use crate::numerics::Bounded;
use crate::profile::Profile;
use crate::progress::Progress;
use serde_json::{Map, Value};

/// A fit asked for: `Request::default()` is what `ssskit engine` fits
/// when no option is given.
#[derive(Clone, Copy, Debug)]
pub struct Request<'a> {
    /// `Engine::versions` key or alias; None: the default.
    pub version: Option<&'a str>,
    /// Blender's method; None: [`SubsurfaceMethod::default_for`].
    pub method: Option<SubsurfaceMethod>,
    pub priority: Priority,
    /// Random Walk: the walks of the printed values' profile
    /// ([`blender_walk::WALKS`]; fewer walks give a noisier error, stated
    /// in the answer's `walk`).
    pub walks: usize,
    /// Also fit with the other priority and give its error
    /// ([`EngineFit::other`]): what keeping one costs the other.
    pub other: bool,
}

impl Default for Request<'_> {
    fn default() -> Self {
        Request {
            version: None,
            method: None,
            priority: Priority::Colour,
            walks: blender_walk::WALKS,
            other: false,
        }
    }
}

/// The fit of `engine`'s model to `profile` that `req` asks for.
pub fn fit_with(
    engine: Engine,
    profile: &Profile,
    scene: Scene,
    req: &Request,
    progress: &dyn Progress,
) -> Result<EngineFit> {
    check(profile)?;
    check_scene(scene)?;
    let v = engine.version(req.version)?;
    let method = SubsurfaceMethod::resolve(engine, req.version, req.method)?;
    let mut fit = match (engine, method) {
        (_, SubsurfaceMethod::RandomWalk) => {
            let walk = blender_walk::Options {
                priority: req.priority,
                walks: req.walks,
                other: req.other,
            };
            blender_walk::fit(profile, scene, &walk, progress)?
        }
        (Engine::Unreal | Engine::UnityHdrp | Engine::Blender, _) => {
            fit_burley(engine, v, profile, scene, req.priority)?
        }
        (Engine::Iryoku, _) => iryoku::fit(profile, scene, req.priority)?,
        // Godot's albedo is the profile's total whatever is asked: its
        // one table leaves nothing to trade.
        (Engine::Godot, _) => godot::fit(profile, scene)?,
    };
    if req.other && fit.other.is_none() && engine != Engine::Godot {
        let alt = Request {
            priority: req.priority.other(),
            other: false,
            ..*req
        };
        let f = fit_with(engine, profile, scene, &alt, progress)?;
        fit.other = Some(super::OtherFit {
            priority: alt.priority,
            error: f.error,
            note: None,
        });
    }
    if req.priority == Priority::Colour {
        colour_warnings(&mut fit);
    }
    Ok(fit)
}

/// A warning for each channel whose total is further from the profile's
/// than [`COLOUR_TOL`] although the colour was kept.
fn colour_warnings(fit: &mut EngineFit) {
    for c in 0..3 {
        let t = fit.error.total[c];
        if t.abs() > COLOUR_TOL {
            fit.warnings.push(format!(
                "channel {}: the total renders {:+.1}% from the profile's, beyond the {}% the \
                 colour is kept to: a clamp or a colour the engine cannot take moved it (see \
                 the other warnings)",
                ["r", "g", "b"][c],
                Bounded(100.0 * t),
                100.0 * COLOUR_TOL
            ));
        }
    }
}

/// The largest colour the Burley engines take (Unreal's Base Color and
/// Surface Albedo, HDRP's Base Map colour, Blender's Base Color are all
/// clamped to [0, 1] or picked in it).
const BURLEY_COLOUR_CAP: f64 = 1.0;

/// Fit with the colour capped, print the values, read them back through
/// the engine's chain, score that.
fn fit_burley(
    engine: Engine,
    v: Version,
    profile: &Profile,
    scene: Scene,
    priority: Priority,
) -> Result<EngineFit> {
    let fitted = burley::fit_for(profile, [BURLEY_COLOUR_CAP; 3], priority)?;
    let printed = match engine {
        Engine::Unreal => unreal::params(&fitted, scene, v),
        Engine::UnityHdrp => hdrp::params(&fitted, scene, v),
        _ => blender::params(&fitted, scene, v),
    };
    let rendered = burley_from_params(engine, v, &printed.params, scene)?;
    let model_profile = rendered.profile(profile, engine.name());
    let error = error(&model_profile, profile)?;
    let mut warnings = Vec::new();
    for c in 0..3 {
        if fitted.albedo[c] >= BURLEY_COLOUR_CAP {
            warnings.push(format!(
                "channel {}: the fit asks for a colour above 1, the most the engine takes \
                 (the profile reflects {:.4} in total); the colour is capped at 1 and d \
                 fitted for it (total error {:+.1}%)",
                ["r", "g", "b"][c],
                profile.total_rd[c],
                Bounded(100.0 * error.total[c])
            ));
        }
    }
    warnings.extend(printed.warnings);
    let (requirements, error_for) = match engine {
        Engine::Unreal => (unreal::requirements(v), unreal::ERROR_FOR),
        Engine::UnityHdrp => (hdrp::requirements(v), hdrp::ERROR_FOR),
        _ => (blender::requirements(v), blender::error_for(v)),
    };
    let scene_lines = match engine {
        Engine::Unreal => unreal::scene_lines(scene),
        Engine::UnityHdrp => hdrp::scene_lines(scene),
        _ => blender::scene_lines(scene, false),
    };
    Ok(EngineFit {
        engine: engine.name().into(),
        version: v.label.into(),
        priority,
        params: printed.params,
        units: printed.units,
        error,
        error_for: error_for.into(),
        scene: scene_lines,
        requirements,
        warnings,
        other: None,
        rendered: Some(rendered),
        walk: None,
        profile: model_profile,
    })
}

/// The Burley profile a Burley engine renders from its printed values.
fn burley_from_params(
    engine: Engine,
    v: Version,
    params: &Map<String, Value>,
    scene: Scene,
) -> Result<burley::Burley> {
    match engine {
        Engine::Unreal => unreal::from_params(params, scene, v),
        Engine::UnityHdrp => hdrp::from_params(params, scene, v),
        _ => blender::from_params(params, scene, v),
    }
}

/// The engine model given its own parameters (as a fit writes them) for
/// the version named `version` (None: the default), tabulated on
/// `profile`'s grid: the round trip of a fit.
pub fn model_from_params(
    engine: Engine,
    version: Option<&str>,
    params: &Map<String, Value>,
    profile: &Profile,
    scene: Scene,
) -> Result<Profile> {
    check(profile)?;
    check_scene(scene)?;
    let v = engine.version(version)?;
    let name = engine.name();
    Ok(match engine {
        Engine::Unreal | Engine::UnityHdrp | Engine::Blender => {
            burley_from_params(engine, v, params, scene)?.profile(profile, name)
        }
        Engine::Iryoku => iryoku::from_params(params, scene)?
            .on_grid(&profile.r_edges)?
            .profile(profile, name),
        Engine::Godot => godot::from_params(params, scene)?
            .on_grid(&profile.r_edges)?
            .profile(profile, name),
    })
}
