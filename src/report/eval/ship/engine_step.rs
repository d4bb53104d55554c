//! The main job's engine step (`kernels --engine NAME`): the engine's own
//! model fitted to the profile as `ssskit engine` fits it by default, and
//! its files (`engine::files`, what `engine --out-dir` writes) beside
//! recommended.json.

use crate::engine::request::{fit_with, Request};
use crate::engine::{files, Engine, EngineFit, Scene};
use crate::error::Result;
use crate::io::{file_stem, join_inside};
use crate::profile::Profile;
use crate::progress::Progress;
use std::path::Path;

/// What the step wrote: the fit, and each file's name with what it is.
pub struct EngineStep {
    pub fit: EngineFit,
    /// (file name in the output folder, what it is), the JSON first.
    pub files: Vec<(String, &'static str)>,
}

/// Refuses, before any work, an engine without a file to import.
pub fn check(engine: Engine) -> Result<()> {
    files::check_engine(engine, None)
}

/// Fits `engine` to `profile` (the engine's own scene unit, the default
/// version and method, the colour kept, the shape-first fit scored
/// beside) and writes its JSON and files into `dir`.
pub fn run(
    engine: Engine,
    profile: &Profile,
    dir: &Path,
    progress: &dyn Progress,
) -> Result<EngineStep> {
    let req = Request {
        other: true,
        ..Request::default()
    };
    let fit = fit_with(engine, profile, Scene::native(engine), &req, progress)?;
    let stem = file_stem(&profile.material.name);
    let json = format!("{stem}-{}.json", engine.name());
    crate::io::write_json_atomic(&join_inside(dir, &json)?, &fit)?;
    let mut written = vec![(json, "the fitted values, their errors and units (JSON)")];
    for f in files::files(engine, &fit, &stem)? {
        crate::io::write_atomic(&join_inside(dir, &f.name)?, f.text.as_bytes())?;
        written.push((f.name, f.what));
    }
    Ok(EngineStep {
        fit,
        files: written,
    })
}
