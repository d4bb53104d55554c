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
pub mod method;
pub mod model;
pub mod printed;
pub mod priority;
pub mod request;
pub mod sampled;
pub mod sampling;
pub mod transmission;
pub mod unreal;
pub mod walk_profile;
pub mod walk_table;

use crate::error::{Error, Result};
use crate::profile::Profile;
use crate::progress::NoProgress;
use method::SubsurfaceMethod;
use printed::Units;
use priority::Priority;
use request::{fit_with, Request};
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
    /// What the fit kept first: the colour (each channel's total) or the
    /// shape.
    pub priority: Priority,
    /// Parameter name (the engine's) -> a number or [r, g, b].
    pub params: Map<String, Value>,
    /// Parameter name -> unit and meaning.
    pub units: Units,
    pub error: FitError,
    /// Which of the engine's rendering paths `error` is for (e.g. the
    /// radial Burley path, or the separable tap table).
    pub error_for: String,
    /// What `error` assumes of the scene (its units, the view, the
    /// light), one sentence each: conditions, not values to type.
    pub scene: Vec<String>,
    /// What else must hold in the engine for `error` to apply (material
    /// and project settings), one sentence each.
    pub requirements: Vec<String>,
    /// Values moved to fit the engine's UI (clamps, rounding) and what
    /// that costs, one sentence each.
    pub warnings: Vec<String>,
    /// The fit with the other priority, where asked
    /// (`request::Request::other`): what keeping the colour costs the
    /// shape, or the shape the colour.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub other: Option<OtherFit>,
    /// The Burley profile the engine renders from `params` (colour A and
    /// shape distance d in mm on the surface, per channel), read back
    /// through the engine's chain; absent for the Jimenez engines.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rendered: Option<burley::Burley>,
    /// Cycles' Random Walk profile of the printed values (`blender_walk`),
    /// on a grid of its own per channel, in two independent halves.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub walk: Option<walk_profile::WalkProfile>,
    /// The engine model's profile on the input's grid.
    #[serde(skip)]
    pub profile: Profile,
}

/// The other priority's fit, scored.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OtherFit {
    pub priority: Priority,
    pub error: FitError,
    /// How `error` was found where it is not the engine's chain from that
    /// fit's printed values.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
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

/// Fits `engine`'s model to `profile`: the default version, Blender's
/// method by [`SubsurfaceMethod::resolve`], the colour kept
/// (`Request::default`).
pub fn fit(engine: Engine, profile: &Profile, scene: Scene) -> Result<EngineFit> {
    fit_with(engine, profile, scene, &Request::default(), &NoProgress)
}

/// [`fit`] for the version named `version` (`Engine::versions`; None: the
/// default), Blender's method the version's default.
pub fn fit_version(
    engine: Engine,
    profile: &Profile,
    scene: Scene,
    version: Option<&str>,
) -> Result<EngineFit> {
    let req = Request {
        version,
        ..Request::default()
    };
    fit_with(engine, profile, scene, &req, &NoProgress)
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
    let req = Request {
        version,
        method: Some(method),
        ..Request::default()
    };
    fit_with(engine, profile, scene, &req, &NoProgress)
}
