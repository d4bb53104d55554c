//! `ssskit engine`: the parameters of an engine's own diffusion model
//! fitted to a profile, with the fit's error and a plot.

use super::args::{self, MmPerPixelArg, OutDir, OutFile, ProfileFile};
use super::out::outln;
use anyhow::Context;
use ssskit::engine::{self, burley, Engine, Scene, SubsurfaceMethod};
use ssskit::numerics::Bounded;
use ssskit::profile::Profile;
use ssskit::report::present::plot;
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

/// Blender's subsurface method the values are for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum MethodArg {
    /// Christensen-Burley: the Burley profile, disk sampled.
    ChristensenBurley,
    /// Random Walk: a volume walk (Cycles 4.0 to 5.0).
    RandomWalk,
}

impl From<MethodArg> for SubsurfaceMethod {
    fn from(m: MethodArg) -> SubsurfaceMethod {
        match m {
            MethodArg::ChristensenBurley => SubsurfaceMethod::ChristensenBurley,
            MethodArg::RandomWalk => SubsurfaceMethod::RandomWalk,
        }
    }
}

#[derive(clap::Args)]
#[command(
    mut_arg("profile", |a| args::required()(a)
        .help("Reflectance profile file (ssskit.profile/1 JSON): with r, g, b channels")),
    mut_arg("mm_per_pixel", |a| args::default(ssskit::report::eval::evaluate::DEFAULT_MM_PER_PIXEL)(a)
        .help("Scale: surface mm per pixel of the plane the engine's sampling is scored on")
        .long_help("Scale: surface millimetres per pixel of the flat plane the unreal and \
                    unity-hdrp parameters are scored on through the engine's own sampling")),
    mut_arg("out", args::help(
        "Output file: {\"engine\", \"params\", \"units\", \"error\"} as JSON [default: not written]"
    )),
    mut_arg("out_dir", |a| a.required(false).help(
        "Output folder (created): the JSON of --out and the file the engine imports \
         (blender, unity-hdrp, godot) [default: not written]"
    ).long_help(
        "Output folder (created, replaced as a whole): NAME-ENGINE.json (what --out writes) and \
         the file the engine imports, NAME after the profile's material: blender NAME-blender.py \
         (a script that makes the material), unity-hdrp NAME.asset (a Diffusion Profile), godot \
         NAME.tres (a StandardMaterial3D) and NAME-project.godot (project settings) \
         [default: not written]"
    )),
)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileFile,
    /// The engine whose model is fitted.
    #[arg(long, value_enum, value_name = "ENGINE", ignore_case = true)]
    engine: EngineArg,
    /// The engine version whose conversion chain to follow (unreal: 5.4,
    /// 5.0; unity-hdrp: 17; blender: 4, eevee, 2.93) [default: the newest].
    #[arg(long, value_name = "VERSION")]
    engine_version: Option<String>,
    /// Blender's Subsurface Method whose values to fit (blender only; random-walk for
    /// Cycles, --engine-version 4) [default: random-walk for Cycles, Blender's own default
    /// method, which renders its values closer in each material's worst channel; else
    /// christensen-burley].
    #[arg(long, value_enum, value_name = "METHOD")]
    subsurface_method: Option<MethodArg>,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    out_dir: OutDir,
    /// Plot the input profile and the engine model's r R_d(r) [default: not written].
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
    /// Scene units per millimetre (0.001: a scene in metres; Jimenez's sssWidth) [default: the
    /// engine's own unit: unreal 0.1 (the cm), the others 0.001 (the metre)].
    #[arg(long, value_name = "UNITS", allow_negative_numbers = true, value_parser = args::real)]
    units_per_mm: Option<f64>,
    #[command(flatten)]
    mm_per_pixel: MmPerPixelArg,
    /// Thickness table (`ssskit transmission --out`): also fit the engine's transmission to it.
    ///
    /// unreal, unity-hdrp and godot: the settings of the engine's thin-object
    /// transmission (from its diffusion profile and the thickness it reads)
    /// fitted to the table's T per thickness, printed with the error at
    /// every thickness and written into --out and the --out-dir files
    /// [default: none].
    #[arg(long, value_name = "TABLE.json")]
    transmission: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(out) = &a.out.out {
        ssskit::io::check_extension(out, &["json"], "engine parameters")?;
    }
    let e = Engine::from(a.engine);
    // Before any work: an engine without a file, or a folder that may
    // not be replaced, fails here.
    let staged = match &a.out_dir.out_dir {
        Some(dir) => {
            engine::files::check_engine(e, a.engine_version.as_deref())?;
            Some(ssskit::io::StagedDir::new(dir)?)
        }
        None => None,
    };
    let profile_path = a
        .profile
        .profile
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("give --profile"))?;
    let profile = Profile::read(profile_path)?;
    let table = match &a.transmission {
        Some(t) => Some(ssskit::profile::transmission::ThicknessTable::read(t)?),
        None => None,
    };
    let scene = a
        .units_per_mm
        .map_or(Scene::native(e), |units_per_mm| Scene { units_per_mm });
    let version = a.engine_version.as_deref();
    let subsurface_method =
        SubsurfaceMethod::resolve(e, version, a.subsurface_method.map(SubsurfaceMethod::from))
            .context("--subsurface-method")?;
    let fit = engine::fit_method(e, &profile, scene, version, subsurface_method)?;
    let verdict = fit
        .cannot_match()
        .map_or(String::new(), |s| format!(": {s}"));
    let method = match e {
        Engine::Blender => format!(", {}", subsurface_method.ui_name()),
        _ => String::new(),
    };
    outln!(
        "engine: {}{method} (profile {}){verdict}",
        fit.engine,
        profile_path.display()
    )?;
    outln!("version: {}", fit.version)?;
    outln!("scene: {} units per mm", scene.units_per_mm)?;
    for (name, v) in &fit.params {
        let unit = fit.units.get(name).map_or("", String::as_str);
        outln!("  {name} = {v}    [{unit}]")?;
    }
    let pct = |v: [f64; 3]| v.map(|x| format!("{:.2}%", Bounded(100.0 * x))).join(", ");
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
    if matches!(e, Engine::Unreal | Engine::UnityHdrp) {
        let v = e.version(a.engine_version.as_deref())?;
        sampled(&fit, e, scene, v, a.mm_per_pixel.or_default())?;
    }
    if !fit.error_for.is_empty() {
        outln!("the error is for: {}", fit.error_for)?;
    }
    for r in &fit.requirements {
        outln!("requires: {r}")?;
    }
    for w in &fit.warnings {
        outln!("warning: {w}")?;
    }
    let v = e.version(a.engine_version.as_deref())?;
    for line in engine::factors_place::lines(e, v, &profile)? {
        outln!("{line}")?;
    }
    let tfit = match &table {
        Some(t) => engine::transmission::fit(e, &fit, t, scene)?,
        None => None,
    };
    super::transmission::print_engine(e, table.is_some(), tfit.as_ref())?;
    let json = super::transmission::with_transmission(&fit, tfit.as_ref())?;
    if let Some(out) = &a.out.out {
        ssskit::io::write_json_atomic(out, &json)?;
        eprintln!("wrote {}", out.display());
    }
    if let Some(staged) = staged {
        write_files(staged, e, &fit, &profile, &json, tfit.as_ref())?;
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

/// The JSON and the engine's own files into the staged folder, then the
/// folder swapped in.
fn write_files(
    staged: ssskit::io::StagedDir,
    e: Engine,
    fit: &engine::EngineFit,
    profile: &Profile,
    value: &serde_json::Value,
    tfit: Option<&engine::transmission::TransmissionFit>,
) -> anyhow::Result<()> {
    let stem = ssskit::io::file_stem(&profile.material.name);
    let mut files = engine::files::files(e, fit, &stem)?;
    if let Some(t) = tfit {
        engine::transmission::files::add(e, t, &mut files)?;
    }
    let json = format!("{stem}-{}.json", e.name());
    ssskit::io::write_json_atomic(&ssskit::io::join_inside(staged.path(), &json)?, value)?;
    for f in &files {
        let path = ssskit::io::join_inside(staged.path(), &f.name)?;
        ssskit::io::write_atomic(&path, f.text.as_bytes())?;
    }
    let dir = staged.target().to_path_buf();
    staged.commit()?;
    eprintln!("wrote {}", dir.join(&json).display());
    for f in &files {
        eprintln!("wrote {}: {}", dir.join(&f.name).display(), f.what);
    }
    Ok(())
}

/// The fit's parameters through the engine's own sampling
/// (`engine::sampled`): bias and noise per sample setting and signal.
fn sampled(
    fit: &engine::EngineFit,
    e: Engine,
    scene: Scene,
    v: engine::Version,
    mm_per_pixel: f64,
) -> anyhow::Result<()> {
    use engine::sampled::{score, signals, FRAMES, ROTATIONS};
    let rows = score(fit, e, scene, v, &signals()?, mm_per_pixel)?;
    outln!(
        "sampled as the engine renders it (its own sample pattern; flat plane at {mm_per_pixel} mm \
         per pixel; worst channel, % of the exact image's peak; bias over {ROTATIONS} rotations):"
    )?;
    let worst = |v: [f64; 3]| 100.0 * v.into_iter().fold(0.0, f64::max);
    for r in rows {
        let after = if r.static_pattern {
            format!("the same after {FRAMES} (the pattern repeats on a static view)")
        } else {
            format!("{:.3}% after {FRAMES} frames", worst(r.error.noise_after))
        };
        outln!(
            "  {} ({} samples/px) on {}: bias {:.3}% (its own noise floor {:.3}%), noise {:.3}% \
             in one frame, {after}",
            r.setting,
            r.samples_per_pixel,
            r.signal,
            worst(r.error.bias),
            worst(r.error.bias_noise_floor),
            worst(r.error.noise)
        )?;
    }
    Ok(())
}
