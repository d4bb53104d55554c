//! The main job's engine step (`kernels --engine NAME`): the engine's own
//! model fitted to the profile as `ssskit engine` fits it by default, and
//! its files (`engine::files`, what `engine --out-dir` writes) beside
//! recommended.json.

use crate::engine::priority::{Priority, COLOUR_TOL};
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

/// What report.md's engine section shows (`present::engine_section`),
/// read off the fit: plain data, so the section only writes it out.
pub struct EngineSection {
    pub engine: String,
    pub version: String,
    /// Which of the engine's rendering paths the error is for.
    pub error_for: String,
    /// (file name in the output folder, what it is), the JSON first.
    pub files: Vec<(String, &'static str)>,
    /// Why the engine cannot match the profile, where it cannot
    /// ([`EngineFit::cannot_match`]).
    pub cannot_match: Option<String>,
    /// (parameter, its value as the JSON prints it).
    pub params: Vec<(String, String)>,
    /// Relative error of each channel's total and shape (r, g, b).
    pub total: [f64; 3],
    pub shape: [f64; 3],
    /// The fit with the other priority.
    pub other: Option<OtherSection>,
    /// What the error assumes of the scene, then of the engine's settings.
    pub conditions: Vec<String>,
    pub warnings: Vec<String>,
}

/// The fit with the other priority, as the section shows it.
pub struct OtherSection {
    /// Where the main fit kept the colour: each channel's total kept to
    /// this percent of the profile's (and this row fitted the shape
    /// first); None where the main fit took the shape first.
    pub colour_kept_pct: Option<f64>,
    pub total: [f64; 3],
    pub shape: [f64; 3],
    /// How the error was found, where not through the engine's chain.
    pub note: Option<String>,
}

impl EngineStep {
    /// The section's data.
    pub fn section(&self) -> EngineSection {
        let fit = &self.fit;
        EngineSection {
            engine: fit.engine.clone(),
            version: fit.version.clone(),
            error_for: fit.error_for.clone(),
            files: self.files.clone(),
            cannot_match: fit.cannot_match(),
            params: fit
                .params
                .iter()
                .map(|(name, v)| (name.clone(), v.to_string()))
                .collect(),
            total: fit.error.total,
            shape: fit.error.shape,
            other: fit.other.as_ref().map(|o| OtherSection {
                colour_kept_pct: match fit.priority {
                    Priority::Colour => Some(100.0 * COLOUR_TOL),
                    Priority::Shape => None,
                },
                total: o.error.total,
                shape: o.error.shape,
                note: o.note.clone(),
            }),
            conditions: fit.scene.iter().chain(&fit.requirements).cloned().collect(),
            warnings: fit.warnings.clone(),
        }
    }
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
