//! Engine parameters fitted to a reflectance profile: the values to type
//! into an engine's own diffusion model so that it matches a measured or
//! simulated R_d(r) as closely as that model can.
//!
//! Every engine here renders one of two radial models: Christensen and
//! Burley's normalized diffusion (Unreal, Unity HDRP, Blender) or a
//! separable tap table sampled from Jimenez's skin profile (iryoku, Godot;
//! `jimenez.rs` scores the table as the kernel it stands for). The fit works in the
//! model's own parameters (the colour A and shape distance d per channel
//! for Burley; width, strength and falloff for Jimenez) by least squares on
//! r R_d(r) over the radius holding 99% of the profile, the norm `profiles
//! compare` reports as the shape error (`profile::metrics`). Each engine
//! file then writes the values a user types into that engine's UI (its
//! names, units, colour encoding and clamps, for one pinned version of
//! its source) and reads them back through the engine's own conversion
//! chain: the error is that of the profile the engine renders from the
//! printed values.

pub mod blender;
pub mod blender_walk;
pub mod burley;
pub mod cycles_walk;
pub mod factors_place;
pub mod files;
pub mod godot;
pub mod hdrp;
pub mod iryoku;
pub mod jimenez;
pub mod printed;
pub mod sampled;
pub mod sampling;
pub mod transmission;
pub mod unreal;

use crate::error::{Error, Result};
use crate::numerics::Bounded;
use crate::profile::metrics::{self, channel_error, same_grid};
use crate::profile::{Profile, RadialGrid};
use printed::Units;
use serde::Serialize;
use serde_json::{Map, Value};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    Unreal,
    UnityHdrp,
    Blender,
    Godot,
    Iryoku,
}

impl Engine {
    pub const ALL: [Engine; 5] = [
        Engine::Unreal,
        Engine::UnityHdrp,
        Engine::Blender,
        Engine::Godot,
        Engine::Iryoku,
    ];

    /// The versions of the engine whose conversion chain ssskit follows,
    /// the default first.
    pub fn versions(self) -> &'static [Version] {
        match self {
            Engine::Unreal => &unreal::VERSIONS,
            Engine::UnityHdrp => &hdrp::VERSIONS,
            Engine::Blender => &blender::VERSIONS,
            Engine::Godot => &GODOT_VERSIONS,
            Engine::Iryoku => &IRYOKU_VERSIONS,
        }
    }

    /// The version named `requested` (a key or an alias), or the default.
    pub fn version(self, requested: Option<&str>) -> Result<Version> {
        let all = self.versions();
        let Some(name) = requested else {
            return Ok(all[0]);
        };
        all.iter()
            .find(|v| v.key == name || v.aliases.contains(&name))
            .copied()
            .ok_or_else(|| {
                let keys: Vec<&str> = all.iter().map(|v| v.key).collect();
                Error::invalid(
                    "engine",
                    "engine version",
                    name,
                    format!("{} knows {}", self.name(), keys.join(", ")),
                )
            })
    }

    pub fn name(self) -> &'static str {
        match self {
            Engine::Unreal => "unreal",
            Engine::UnityHdrp => "unity-hdrp",
            Engine::Blender => "blender",
            Engine::Godot => "godot",
            Engine::Iryoku => "iryoku",
        }
    }
}

impl std::str::FromStr for Engine {
    type Err = Error;
    fn from_str(s: &str) -> Result<Engine> {
        Engine::ALL
            .into_iter()
            .find(|e| e.name() == s.to_ascii_lowercase())
            .ok_or_else(|| {
                Error::invalid(
                    "engine",
                    "engine",
                    s,
                    "expected unreal, unity-hdrp, blender, godot or iryoku",
                )
            })
    }
}

/// One version of an engine's conversion chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Version {
    /// What `--engine-version` takes.
    pub key: &'static str,
    /// Other names `--engine-version` takes for it.
    pub aliases: &'static [&'static str],
    /// The versions covered and the source read, for the JSON and the
    /// printout.
    pub label: &'static str,
}

/// iryoku's reference code has no releases: the version is the repository.
pub const IRYOKU_VERSIONS: [Version; 1] = [Version {
    key: "reference",
    aliases: &[],
    label: iryoku::VERSION,
}];

pub const GODOT_VERSIONS: [Version; 1] = [Version {
    key: "4",
    aliases: &[],
    label: godot::VERSION,
}];

/// The fitted profile's error against the input, per channel, as
/// `profiles compare` computes it: total (model - input) / input, and the
/// relative L2 error of r R_d(r) over the radius holding 99% of the input.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitError {
    pub total: [f64; 3],
    pub shape: [f64; 3],
}

/// The answer for one engine: `{"engine", "params", "units", "error"}`.
#[derive(Clone, Debug, Serialize)]
pub struct EngineFit {
    pub engine: String,
    /// The engine version whose conversion chain the parameters follow
    /// (e.g. "Unreal Engine 5.4"), as read from that version's source.
    pub version: String,
    /// Parameter name (the engine's) -> a number or [r, g, b].
    pub params: Map<String, Value>,
    /// Parameter name -> unit and meaning.
    pub units: Units,
    pub error: FitError,
    /// Which of the engine's rendering paths `error` is for (e.g. the
    /// radial Burley path, or the separable tap table).
    pub error_for: String,
    /// What else must hold in the engine for `error` to apply (material
    /// settings, world scale), one sentence each.
    pub requirements: Vec<String>,
    /// Values moved to fit the engine's UI (clamps, rounding) and what
    /// that costs, one sentence each.
    pub warnings: Vec<String>,
    /// The Burley profile the engine renders from `params` (colour A and
    /// shape distance d in mm on the surface, per channel), read back
    /// through the engine's chain; absent for the Jimenez engines.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rendered: Option<burley::Burley>,
    /// Cycles' Random Walk profile of the printed values (`blender_walk`),
    /// on a grid of its own per channel, in two independent halves.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub walk: Option<blender_walk::WalkProfile>,
    /// The engine model's profile on the input's grid.
    #[serde(skip)]
    pub profile: Profile,
}

/// A shape error above which the engine cannot match the profile: its
/// best blur misses half of the profile's r R_d (relative L2). Godot's
/// fixed kernel shape misses skin, marble and ketchup by 68% to 80% in its
/// best channel fits; every Burley engine stays far below.
pub const CANNOT_MATCH_SHAPE: f64 = 0.5;

impl EngineFit {
    /// When the best values still miss the profile's shape by more than
    /// `CANNOT_MATCH_SHAPE` in some channel, a sentence saying so with the
    /// error of those values; the CLI puts it on its first line.
    pub fn cannot_match(&self) -> Option<String> {
        let worst = self.error.shape.iter().fold(0.0f64, |m, v| m.max(*v));
        (worst > CANNOT_MATCH_SHAPE).then(|| {
            let pct = self
                .error
                .shape
                .map(|x| format!("{:.1}%", crate::numerics::Bounded(100.0 * x)))
                .join(", ");
            format!(
                "cannot match this profile: the best it can do, the values below, misses its \
                 shape by {pct} (r, g, b)"
            )
        })
    }
}

/// Scene and engine settings the conversion needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Scene units per millimetre (0.001 for a scene in metres).
    pub units_per_mm: f64,
}

impl Default for Scene {
    fn default() -> Scene {
        Scene {
            units_per_mm: 0.001,
        }
    }
}

impl Scene {
    /// The engine's own world unit: Unreal's centimetre (0.1 units per
    /// mm), the metre elsewhere (Unity, Blender, Godot).
    pub fn native(engine: Engine) -> Scene {
        match engine {
            Engine::Unreal => Scene { units_per_mm: 0.1 },
            _ => Scene::default(),
        }
    }
}

/// Fits `engine`'s model to `profile`, for the engine's default version.
pub fn fit(engine: Engine, profile: &Profile, scene: Scene) -> Result<EngineFit> {
    fit_version(engine, profile, scene, None)
}

/// Fits `engine`'s model to `profile` for the version named `version`
/// (`Engine::versions`; None: the default).
pub fn fit_version(
    engine: Engine,
    profile: &Profile,
    scene: Scene,
    version: Option<&str>,
) -> Result<EngineFit> {
    check(profile)?;
    check_scene(scene)?;
    let v = engine.version(version)?;
    match engine {
        Engine::Unreal | Engine::UnityHdrp | Engine::Blender => {
            fit_burley(engine, v, profile, scene)
        }
        // The separable engines fill their whole answer (`jimenez.rs`).
        Engine::Iryoku => iryoku::fit(profile, scene),
        Engine::Godot => godot::fit(profile, scene),
    }
}

/// Blender's Subsurface Method a fit is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SubsurfaceMethod {
    /// The Burley profile, disk sampled (every engine's Burley fit).
    ChristensenBurley,
    /// Cycles' volume walk (`blender_walk`), Cycles 4.0 to 5.0.
    RandomWalk,
}

impl SubsurfaceMethod {
    /// The name in Blender's UI.
    pub fn ui_name(self) -> &'static str {
        match self {
            SubsurfaceMethod::ChristensenBurley => "Christensen-Burley",
            SubsurfaceMethod::RandomWalk => "Random Walk",
        }
    }

    /// The method fitted when none is named: Blender's own default, Random
    /// Walk, for Cycles 4.0 to 5.0 (its values render closer than
    /// Christensen-Burley's in each material's worst channel:
    /// docs/engines.md's `engine-cycles` record); Christensen-Burley
    /// elsewhere (EEVEE's Burley approximation; Cycles 2.93, whose walk
    /// ssskit does not model; the other engines' own Burley).
    pub fn default_for(engine: Engine, version: &Version) -> SubsurfaceMethod {
        match engine {
            Engine::Blender if version.key == "4" => SubsurfaceMethod::RandomWalk,
            _ => SubsurfaceMethod::ChristensenBurley,
        }
    }
}

impl std::str::FromStr for SubsurfaceMethod {
    type Err = Error;
    fn from_str(s: &str) -> Result<SubsurfaceMethod> {
        match s {
            "christensen-burley" => Ok(SubsurfaceMethod::ChristensenBurley),
            "random-walk" => Ok(SubsurfaceMethod::RandomWalk),
            _ => Err(Error::invalid(
                "engine",
                "subsurface method",
                s,
                "expected christensen-burley or random-walk",
            )),
        }
    }
}

impl SubsurfaceMethod {
    /// The method a fit for `engine` at `version` uses when `method` is
    /// asked (None: [`SubsurfaceMethod::default_for`]); Random Walk is
    /// Blender's, and ssskit models Cycles 4.0 to 5.0's walk only.
    pub fn resolve(
        engine: Engine,
        version: Option<&str>,
        method: Option<SubsurfaceMethod>,
    ) -> Result<SubsurfaceMethod> {
        let v = engine.version(version)?;
        let method = method.unwrap_or(SubsurfaceMethod::default_for(engine, &v));
        if method == SubsurfaceMethod::RandomWalk {
            if engine != Engine::Blender {
                return Err(Error::Unsupported(format!(
                    "random-walk is the blender engine's method, not {}'s",
                    engine.name()
                )));
            }
            if v.key != "4" {
                return Err(Error::Unsupported(format!(
                    "random-walk: ssskit models the walk of Cycles 4.0 to 5.0 (version 4), not {}",
                    v.key
                )));
            }
        }
        Ok(method)
    }
}

/// [`fit_version`] for a subsurface method, checked by
/// [`SubsurfaceMethod::resolve`].
pub fn fit_method(
    engine: Engine,
    profile: &Profile,
    scene: Scene,
    version: Option<&str>,
    method: SubsurfaceMethod,
) -> Result<EngineFit> {
    match SubsurfaceMethod::resolve(engine, version, Some(method))? {
        SubsurfaceMethod::RandomWalk => blender_walk::fit(profile, scene),
        SubsurfaceMethod::ChristensenBurley => fit_version(engine, profile, scene, version),
    }
}

/// The largest colour the Burley engines take (Unreal's Base Color and
/// Surface Albedo, HDRP's Base Map colour, Blender's Base Color are all
/// clamped to [0, 1] or picked in it).
const BURLEY_COLOUR_CAP: f64 = 1.0;

/// Fit with the colour capped, print the values, read them back through
/// the engine's chain, score that.
fn fit_burley(engine: Engine, v: Version, profile: &Profile, scene: Scene) -> Result<EngineFit> {
    let fitted = burley::fit_capped(profile, [BURLEY_COLOUR_CAP; 3])?;
    let printed = match engine {
        Engine::Unreal => unreal::params(&fitted, scene, v),
        Engine::UnityHdrp => hdrp::params(&fitted, scene, v),
        _ => blender::params(&fitted, scene, v),
    };
    let rendered = burley_from_params(engine, v, &printed.params, scene)?;
    let model_profile = Model::Burley(rendered.clone()).profile(profile, engine.name());
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
        Engine::Unreal => (unreal::requirements(v, scene), unreal::ERROR_FOR),
        Engine::UnityHdrp => (hdrp::requirements(v, scene), hdrp::ERROR_FOR),
        _ => (blender::requirements(v, scene), blender::error_for(v)),
    };
    Ok(EngineFit {
        engine: engine.name().into(),
        version: v.label.into(),
        params: printed.params,
        units: printed.units,
        error,
        error_for: error_for.into(),
        requirements,
        warnings,
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

fn check_scene(scene: Scene) -> Result<()> {
    if !(scene.units_per_mm > 0.0 && scene.units_per_mm.is_finite()) {
        return Err(Error::invalid(
            "engine",
            "scene units per mm",
            scene.units_per_mm,
            "must be finite and > 0",
        ));
    }
    Ok(())
}

/// The engine model given its own parameters (as `fit` writes them),
/// tabulated on `profile`'s grid: the round trip of a fit, for the
/// engine's default version.
pub fn model_from_params(
    engine: Engine,
    params: &Map<String, Value>,
    profile: &Profile,
    scene: Scene,
) -> Result<Profile> {
    model_from_params_version(engine, None, params, profile, scene)
}

/// `model_from_params` for the version named `version`.
pub fn model_from_params_version(
    engine: Engine,
    version: Option<&str>,
    params: &Map<String, Value>,
    profile: &Profile,
    scene: Scene,
) -> Result<Profile> {
    check(profile)?;
    check_scene(scene)?;
    let v = engine.version(version)?;
    let model = match engine {
        Engine::Unreal | Engine::UnityHdrp | Engine::Blender => {
            Model::Burley(burley_from_params(engine, v, params, scene)?)
        }
        Engine::Iryoku => {
            Model::Separable(iryoku::from_params(params, scene)?.on_grid(&profile.r_edges)?)
        }
        Engine::Godot => {
            Model::Separable(godot::from_params(params, scene)?.on_grid(&profile.r_edges)?)
        }
    };
    Ok(model.profile(profile, engine.name()))
}

/// Total and shape error of `model` against `reference` (same grid,
/// channels r, g, b in that order), as `profile::metrics` defines them.
pub fn error(model: &Profile, reference: &Profile) -> Result<FitError> {
    same_grid(model, reference)?;
    check(reference)?;
    if model.rd.len() != 3 || model.total_rd.len() != 3 {
        return Err(Error::Unsupported(format!(
            "the model profile has {} channels: engine parameters are RGB",
            model.rd.len()
        )));
    }
    let e: [_; 3] =
        std::array::from_fn(|c| channel_error(&model.rd[c], model.total_rd[c], reference, c));
    Ok(FitError {
        total: e.map(|e| e.total),
        shape: e.map(|e| e.shape),
    })
}

fn check(profile: &Profile) -> Result<()> {
    use crate::material::Channel;
    if profile.channels != [Channel::R, Channel::G, Channel::B] {
        return Err(Error::Unsupported(format!(
            "the profile's channels are {:?}: engine parameters need r, g, b in that order",
            profile.channels
        )));
    }
    if let Some(c) = (0..3).find(|&c| !(profile.total_rd[c] > 0.0)) {
        return Err(Error::Unsupported(format!(
            "channel {c} of the profile reflects nothing (total R_d {}): nothing to fit",
            profile.total_rd[c]
        )));
    }
    Ok(())
}

/// A fitted radial model, per channel, or a separable tap table on the
/// profile's grid.
#[derive(Clone, Debug)]
enum Model {
    Burley(burley::Burley),
    Separable(jimenez::Binned),
}

impl Model {
    fn profile(&self, like: &Profile, engine: &str) -> Profile {
        let grid = RadialGrid {
            edges: like.r_edges.clone(),
        };
        let (rd, total_rd, name) = match self {
            Model::Burley(b) => (
                (0..3).map(|c| b.bins(c, &grid)).collect(),
                b.albedo.to_vec(),
                "burley",
            ),
            Model::Separable(b) => (b.rd.to_vec(), b.total.to_vec(), "separable taps"),
        };
        let source = crate::profile::Source {
            kind: "analytic".into(),
            photons: None,
            seed: None,
            model: Some(format!("{engine} ({name})")),
            params: Value::Null,
        };
        like.modelled(source, rd, total_rd)
    }
}

/// Weights and targets of the least squares on r R_d(r): bins inside the
/// radius holding 99% of channel `c`, weight w = bin width r^2 (the
/// discrete norm of `profile::metrics::l2_errors`).
pub(crate) struct Target {
    pub bins: usize,
    pub weight: Vec<f64>,
    pub value: Vec<f64>,
}

impl Target {
    pub fn new(p: &Profile, c: usize) -> Target {
        let r99 = crate::profile::radius_holding(p, c, metrics::SHAPE_HOLD);
        let weight = metrics::shape_weights(p, r99);
        let bins = weight.len();
        Target {
            bins,
            weight,
            value: p.rd[c][..bins].to_vec(),
        }
    }

    /// The squared residual of `a` times `shape`.
    pub fn residual_at(&self, shape: &[f64], a: f64) -> f64 {
        (0..self.bins)
            .map(|i| self.weight[i] * (a * shape[i] - self.value[i]).powi(2))
            .sum()
    }

    /// Best non-negative amplitude for `shape` and its squared residual.
    pub fn scale_of(&self, shape: &[f64]) -> (f64, f64) {
        let (mut sg, mut gg, mut ss) = (0.0, 0.0, 0.0);
        for ((w, g), v) in self.weight.iter().zip(shape).zip(&self.value) {
            sg += w * g * v;
            gg += w * g * g;
            ss += w * v * v;
        }
        let a = if gg > 0.0 { (sg / gg).max(0.0) } else { 0.0 };
        (a, ss - 2.0 * a * sg + a * a * gg)
    }
}
