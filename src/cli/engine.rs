//! `ssskit engine`: the parameters of an engine's own diffusion model
//! fitted to a profile, with the fit's error and a plot.

use super::args::{self, OutFile, ProfileFile, UnitsPerMmArg};
use super::out::outln;
use ssskit::engine::{self, burley, Engine, Scene};
use ssskit::profile::Profile;
use ssskit::report::plot;
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum EngineArg {
    /// Unreal Engine's Subsurface Profile (Burley).
    Unreal,
    /// Unity HDRP's Diffusion Profile (Burley normalized diffusion).
    UnityHdrp,
    /// Blender's Principled BSDF, Christensen-Burley subsurface.
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

#[derive(clap::Args)]
#[command(
    mut_arg("profile", |a| args::required()(a)
        .help("Reflectance profile file (ssskit.profile/1 JSON): with r, g, b channels")),
    mut_arg("out", args::help(
        "Output file: {\"engine\", \"params\", \"units\", \"error\"} as JSON [default: not written]"
    )),
)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileFile,
    /// The engine whose model is fitted.
    #[arg(long, value_enum, value_name = "ENGINE", ignore_case = true)]
    engine: EngineArg,
    #[command(flatten)]
    out: OutFile,
    /// Plot the input profile and the engine model's r R_d(r) [default: not written].
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
    #[command(flatten)]
    units_per_mm: UnitsPerMmArg,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let e = Engine::from(a.engine);
    let profile_path = a
        .profile
        .profile
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("give --profile"))?;
    let profile = Profile::read(profile_path)?;
    let scene = Scene {
        units_per_mm: a.units_per_mm.units_per_mm,
    };
    let fit = engine::fit(e, &profile, scene)?;
    outln!(
        "engine: {} (profile {})",
        fit.engine,
        profile_path.display()
    )?;
    for (name, v) in &fit.params {
        let unit = fit.units.get(name).map_or("", String::as_str);
        outln!("  {name} = {v}    [{unit}]")?;
    }
    let pct = |v: [f64; 3]| v.map(|x| format!("{:.2}%", 100.0 * x)).join(", ");
    outln!(
        "error against the profile (r, g, b): total {}; shape (relative L2 of r R_d, r < r99) {}",
        pct(fit.error.total),
        pct(fit.error.shape)
    )?;
    match burley::forward_error(&profile) {
        Ok(f) => outln!(
            "forward Burley from the optical coefficients: total {}; shape {}",
            pct(f.total),
            pct(f.shape)
        )?,
        Err(err) => outln!("forward Burley from the optical coefficients: not available ({err})")?,
    }
    if let Some(out) = &a.out.out {
        ssskit::io::write_json_atomic(out, &fit)?;
        eprintln!("wrote {}", out.display());
    }
    if let Some(png) = &a.plot {
        let panels = plot::profile_panels(&[
            ("input".to_string(), profile.clone()),
            (format!("{} fit", fit.engine), fit.profile.clone()),
        ]);
        plot::render(
            &panels,
            2,
            &format!("{} fitted to {}", fit.engine, profile_path.display()),
            png,
        )?;
        eprintln!("wrote {}", png.display());
    }
    Ok(())
}
