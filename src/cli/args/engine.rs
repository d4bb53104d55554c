//! `--engine`, which `engine` and `kernels` both take: the engine whose
//! own model is fitted and whose files are written.

use ssskit::engine::Engine;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EngineArg {
    /// Unreal Engine's Subsurface Profile (Burley).
    Unreal,
    /// Unity HDRP's Diffusion Profile (Burley normalized diffusion).
    UnityHdrp,
    /// Blender's Principled BSDF subsurface (Random Walk for Cycles).
    Blender,
    /// Godot's screen-space subsurface scattering (one width).
    Godot,
    /// Jimenez's separable SSS (strength and falloff per channel).
    Iryoku,
}

impl From<EngineArg> for Engine {
    fn from(e: EngineArg) -> Engine {
        match e {
            EngineArg::Unreal => Engine::Unreal,
            EngineArg::UnityHdrp => Engine::UnityHdrp,
            EngineArg::Blender => Engine::Blender,
            EngineArg::Godot => Engine::Godot,
            EngineArg::Iryoku => Engine::Iryoku,
        }
    }
}

/// `--engine`.
#[derive(clap::Args)]
pub struct EngineChoice {
    /// Engine: whose own subsurface model is fitted to the profile.
    #[arg(long, value_enum, value_name = "ENGINE", ignore_case = true)]
    pub engine: Option<EngineArg>,
}
