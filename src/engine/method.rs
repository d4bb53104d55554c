//! Blender's Subsurface Method a fit is for, and the one rule that picks
//! it: asked, or the version's default (Random Walk for Cycles 4.0 to
//! 5.0, Christensen-Burley elsewhere), checked against what ssskit models.

use super::{Engine, Version};
use crate::error::{Error, Result};

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
