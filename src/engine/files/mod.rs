//! The files an engine imports, written from a fit's printed values: a
//! Blender Python script that makes the material, a Unity HDRP Diffusion
//! Profile `.asset`, a Godot 4 `.tres` material with the `project.godot`
//! lines it needs. Each file holds the values `ssskit engine` prints, under
//! the names the engine's own source gives them (cited in each writer).

mod blender;
mod godot;
mod unity;

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
                "no file to import is written for it ({why}); the files are for blender, \
                 unity-hdrp and godot"
            ),
        ))
    };
    match engine {
        Engine::Unreal => none("a Subsurface Profile is a binary .uasset"),
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
        Engine::UnityHdrp | Engine::Godot => Ok(()),
    }
}

/// The files for `fit` (engine `engine`), named after `stem` (a file stem,
/// `io::file_stem` of the material's name).
pub fn files(engine: Engine, fit: &EngineFit, stem: &str) -> Result<Vec<EngineFile>> {
    match engine {
        Engine::Blender => Ok(vec![EngineFile {
            name: format!("{stem}-blender.py"),
            text: blender::script(fit, stem)?,
            what: "Blender script (run it in Blender: it makes the material)",
        }]),
        Engine::UnityHdrp => Ok(vec![EngineFile {
            name: format!("{stem}.asset"),
            text: unity::asset(fit, stem)?,
            what: "Unity HDRP Diffusion Profile (copy it into Assets/)",
        }]),
        Engine::Godot => Ok(vec![
            EngineFile {
                name: format!("{stem}.tres"),
                text: godot::tres(fit, stem)?,
                what: "Godot 4 StandardMaterial3D (copy it into the project)",
            },
            EngineFile {
                name: format!("{stem}-project.godot"),
                text: godot::project_settings(fit)?,
                what: "Godot project settings: lines to merge into project.godot",
            },
        ]),
        Engine::Unreal | Engine::Iryoku => {
            check_engine(engine, None)?;
            Ok(Vec::new())
        }
    }
}
