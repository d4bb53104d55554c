//! The files an engine imports, written from a fit's printed values: a
//! Blender Python script that makes the material, an Unreal editor Python
//! script that makes the Subsurface Profile asset, a Unity HDRP Diffusion
//! Profile `.asset`, a Godot 4 `.tres` material with the `project.godot`
//! lines it needs. Each file holds the values `ssskit engine` prints, under
//! the names the engine's own source gives them (cited in each writer).
//! A fit that cannot match its profile (`EngineFit::cannot_match`) is
//! still written, the best the engine can do, with that sentence at the
//! top of every file that takes a comment: the user asked for this
//! engine, and its best values are what they can ship; the warning keeps
//! them from taking it for a match.

mod blender;
mod godot;
mod unity;
mod unreal;

use super::{Engine, EngineFit};
use crate::error::{Error, Result};

/// One file to write: its name inside the output folder and its text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EngineFile {
    pub name: String,
    pub text: String,
    /// What the file is, for the printout.
    pub what: &'static str,
}

/// The engines with a file to import, and why the others have none.
pub fn check_engine(engine: Engine, version: Option<&str>) -> Result<()> {
    let none = |why: &str| {
        Err(Error::invalid(
            "engine files",
            "engine",
            engine.name(),
            format!(
                "no file to import is written for it ({why}); the files are for unreal, \
                 blender, unity-hdrp and godot"
            ),
        ))
    };
    match engine {
        Engine::Iryoku => none("its values go into the shader's code"),
        Engine::Blender => {
            let v = engine.version(version)?;
            if v.key == "2.93" {
                return Err(Error::invalid(
                    "engine files",
                    "engine version",
                    v.key,
                    "the Blender script sets the Principled BSDF's sockets of Blender 4.0 and \
                     later (2.93 names them differently)",
                ));
            }
            Ok(())
        }
        Engine::Unreal | Engine::UnityHdrp | Engine::Godot => Ok(()),
    }
}

/// The files for `fit` (engine `engine`), named after `stem` (a file stem,
/// `io::file_stem` of the material's name).
pub fn files(engine: Engine, fit: &EngineFit, stem: &str) -> Result<Vec<EngineFile>> {
    match engine {
        Engine::Unreal => Ok(vec![EngineFile {
            name: format!("{stem}-unreal.py"),
            text: unreal::script(fit, stem)?,
            what: "Unreal editor Python script: Tools > Execute Python Script (Python Editor \
                   Script Plugin) makes the Subsurface Profile asset in /Game/ssskit",
        }]),
        Engine::Blender => Ok(vec![EngineFile {
            name: format!("{stem}-blender.py"),
            text: blender::script(fit, stem)?,
            what: "Blender script: Scripting > Run Script (or blender --python FILE) makes the \
                   material",
        }]),
        Engine::UnityHdrp => Ok(vec![EngineFile {
            name: format!("{stem}.asset"),
            text: unity::asset(fit, stem)?,
            what: "Unity HDRP Diffusion Profile: copy it into Assets/ and add it to the \
                   Diffusion Profile List",
        }]),
        Engine::Godot => Ok(vec![
            EngineFile {
                name: format!("{stem}.tres"),
                text: godot::tres(fit, stem)?,
                what: "Godot 4 StandardMaterial3D: copy it into the project",
            },
            EngineFile {
                name: format!("{stem}-project.godot"),
                text: godot::project_settings(fit)?,
                what: "Godot project settings: merge these lines into project.godot",
            },
        ]),
        Engine::Iryoku => {
            check_engine(engine, None)?;
            Ok(Vec::new())
        }
    }
}

/// `x` as the 32-bit float the engine stores for `field` of a `file`;
/// beyond that range (where it would store infinity) refused, naming the
/// field.
pub(crate) fn f32_value(file: &str, field: &str, x: f64) -> Result<f32> {
    let y = x as f32;
    if !y.is_finite() {
        return Err(Error::invalid(
            "engine files",
            field,
            x,
            format!(
                "is beyond the largest 32-bit float ({:e}) the {file} stores; the scene's units \
                 per mm make it so",
                f32::MAX
            ),
        ));
    }
    Ok(y)
}

/// The warning a file carries at its top: the fit cannot match its
/// profile.
pub(crate) fn warning_of(fit: &EngineFit) -> Option<String> {
    fit.cannot_match()
        .map(|s| format!("WARNING from ssskit: {} {s}", fit.engine))
}

/// `text` as comment lines starting with `prefix`, wrapped at 76 columns,
/// then a blank line.
pub(crate) fn comment_block(prefix: &str, text: &str) -> String {
    let mut out = String::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && prefix.len() + line.len() + 1 + word.len() > 76 {
            out += &format!("{prefix}{line}\n");
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        out += &format!("{prefix}{line}\n");
    }
    out + "\n"
}
