//! `ssskit engine`: the parameters of an engine's own diffusion model
//! fitted to a profile, with the fit's error and a plot.

use super::args::{
    self, EngineChoice, FactorsArg, MmPerPixelArg, OutDir, OutFile, ProfileModel, ProfileSourceArgs,
};
use super::out::outln;
use anyhow::Context;
use ssskit::engine::method::SubsurfaceMethod;
use ssskit::engine::priority::{Priority, COLOUR_TOL};
use ssskit::engine::request::{fit_with, Request};
use ssskit::engine::{self, burley, Engine, EngineFit, Scene};
use ssskit::numerics::Bounded;
use ssskit::profile::Profile;
use ssskit::report::present::plot;
use std::path::PathBuf;

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

/// What the fit keeps first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum PriorityArg {
    /// Each channel's total (the colour seen) within 1% of the profile's.
    Colour,
    /// The best shape of r R_d, the colour free (it moves by a few %).
    Shape,
}

impl From<PriorityArg> for Priority {
    fn from(p: PriorityArg) -> Priority {
        match p {
            PriorityArg::Colour => Priority::Colour,
            PriorityArg::Shape => Priority::Shape,
        }
    }
}

#[derive(clap::Args)]
#[command(
    mut_args(args::profile_source(ProfileModel::Mc)),
    mut_arg("engine", |a| a.required(true)),
    mut_arg("mm_per_pixel", |a| args::default(ssskit::report::eval::evaluate::DEFAULT_MM_PER_PIXEL)(a)
        .help("Scale: surface mm per pixel of the plane the engine's sampling is scored on")
        .long_help("Scale: surface millimetres per pixel of the flat plane the unreal and \
                    unity-hdrp parameters are scored on through the engine's own sampling")),
    mut_arg("out", args::help(
        "Output file: {\"engine\", \"params\", \"units\", \"error\"} as JSON [default: not written]"
    )),
    mut_arg("out_dir", |a| a.required(false).help(
        "Output folder (created): the JSON of --out and the file the engine imports \
         (unreal, blender, unity-hdrp, godot) [default: not written]"
    ).long_help(
        "Output folder (created, replaced as a whole): NAME-ENGINE.json (what --out writes) and \
         the file the engine imports, NAME after the profile's material: unreal NAME-unreal.py \
         (an editor script that makes the Subsurface Profile asset), blender NAME-blender.py \
         (a script that makes the material), unity-hdrp NAME.asset (a Diffusion Profile), godot \
         NAME.tres (a StandardMaterial3D) and NAME-project.godot (project settings) \
         [default: not written]"
    )),
)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileSourceArgs,
    #[command(flatten)]
    factors: FactorsArg,
    #[command(flatten)]
    engine: EngineChoice,
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
    /// What the fit keeps first: colour keeps each channel's total within 1% of the
    /// profile's and fits the shape for it; shape fits r R_d by least squares with the
    /// colour free. The other's error is printed beside, with what the choice costs.
    #[arg(long, value_enum, value_name = "WHAT", default_value = "colour")]
    priority: PriorityArg,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    out_dir: OutDir,
    /// Also plot to a PNG: the input profile and the engine model's r R_d(r) [default: not written].
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
    /// Scene units per millimetre (0.001: a scene in metres; Jimenez's sssWidth) [default: the
    /// engine's own unit: unreal 0.1 (the cm), the others 0.001 (the metre)].
    #[arg(long, value_name = "UNITS", allow_negative_numbers = true, value_parser = args::real)]
    units_per_mm: Option<f64>,
    #[command(flatten)]
    mm_per_pixel: MmPerPixelArg,
    /// Thickness table (`ssskit transmission --out`): the engine's transmission is fitted to it [default: none].
    ///
    /// unreal, unity-hdrp and godot: the settings of the engine's thin-object
    /// transmission (from its diffusion profile and the thickness it reads)
    /// fitted to the table's T per thickness, printed with the error at
    /// every thickness and written into --out and the --out-dir files.
    #[arg(long, value_name = "TABLE.json")]
    transmission: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if let Some(out) = &a.out.out {
        ssskit::io::check_extension(out, &["json"], "engine parameters")?;
    }
    let e = Engine::from(
        a.engine
            .engine
            .ok_or_else(|| anyhow::anyhow!("give --engine"))?,
    );
    // Before any work: an engine without a file, or a folder that may
    // not be replaced, fails here.
    let staged = match &a.out_dir.out_dir {
        Some(dir) => {
            engine::files::check_engine(e, a.engine_version.as_deref())?;
            Some(ssskit::io::StagedDir::new(dir)?)
        }
        None => None,
    };
    if !a.profile.given() {
        anyhow::bail!("give --material NAME (a preset or a TOML file) or --profile FILE.json");
    }
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
    // A profile read is used as it is (the factors' lines say whether it
    // has the angular tables); one made from a material gets them as in
    // the main job.
    let (profile, source) = if a.profile.profile.profile.is_some() {
        a.profile.load()?
    } else {
        a.profile.load_with_factors(&a.factors)?
    };
    let req = Request {
        version,
        method: Some(subsurface_method),
        priority: a.priority.into(),
        other: true,
        ..Request::default()
    };
    let fit = fit_with(e, &profile, scene, &req, &super::progress::Bar::new())?;
    print_fit(&fit, e, subsurface_method, &profile, &source, scene)?;
    if matches!(e, Engine::Unreal | Engine::UnityHdrp) {
        let v = e.version(a.engine_version.as_deref())?;
        sampled(&fit, e, scene, v, a.mm_per_pixel.or_default())?;
    }
    print_conditions(&fit)?;
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
        let profiles = [
            ("input".to_string(), profile.clone()),
            (format!("{} fit", fit.engine), fit.profile.clone()),
        ];
        let panels = plot::profile_panels(&ssskit::report::eval::radial::profile_figure(&profiles));
        plot::render(
            &panels,
            2,
            &format!("{} fitted to {}", fit.engine, profile.material.name),
            png,
        )?;
        eprintln!("wrote {}", png.display());
    }
    Ok(())
}

fn pct(v: [f64; 3]) -> String {
    v.map(|x| format!("{:.2}%", Bounded(100.0 * x))).join(", ")
}

/// The first lines: what was fitted, the values to type, the errors and
/// what the priority costs.
fn print_fit(
    fit: &EngineFit,
    e: Engine,
    method: SubsurfaceMethod,
    profile: &Profile,
    source: &str,
    scene: Scene,
) -> anyhow::Result<()> {
    let verdict = fit
        .cannot_match()
        .map_or(String::new(), |s| format!(": {s}"));
    let method = match e {
        Engine::Blender => format!(", {}", method.ui_name()),
        _ => String::new(),
    };
    outln!(
        "engine: {}{method} (profile of {}: {source}){verdict}",
        fit.engine,
        profile.material.name
    )?;
    outln!("version: {}", fit.version)?;
    outln!("scene: {} units per mm", scene.units_per_mm)?;
    outln!("values to type:")?;
    for (name, v) in &fit.params {
        let unit = fit.units.get(name).map_or("", String::as_str);
        outln!("  {name} = {v}    [{unit}]")?;
    }
    let noise = fit.walk.as_ref().map_or(String::new(), |w| {
        format!(" (Monte Carlo standard error {})", pct(w.shape_noise))
    });
    outln!(
        "error against the profile (r, g, b): total {}; shape (relative L2 of r R_d, \
         r < r99) {}{noise}",
        pct(fit.error.total),
        pct(fit.error.shape)
    )?;
    if let Some(o) = &fit.other {
        let how = o.note.as_ref().map_or(String::new(), |n| format!(" ({n})"));
        match fit.priority {
            Priority::Colour => outln!(
                "colour kept (each channel's total within {}% of the profile's); the shape first \
                 (--priority shape) would give shape {} and total {}{how}",
                100.0 * COLOUR_TOL,
                pct(o.error.shape),
                pct(o.error.total)
            )?,
            Priority::Shape => outln!(
                "shape first, the colour moved; keeping the colour (--priority colour) would give \
                 shape {} and total {}{how}",
                pct(o.error.shape),
                pct(o.error.total)
            )?,
        }
    }
    match burley::forward_error(profile) {
        Ok(f) => outln!(
            "forward Burley from the optical coefficients: total {}; shape {}",
            pct(f.total),
            pct(f.shape)
        )?,
        Err(err) => outln!("forward Burley from the optical coefficients: not available ({err})")?,
    }
    Ok(())
}

/// What the error is for and assumes: the scene (not values to type),
/// the engine's other settings, the warnings.
fn print_conditions(fit: &EngineFit) -> anyhow::Result<()> {
    if !fit.error_for.is_empty() {
        outln!("the error is for: {}", fit.error_for)?;
    }
    if !fit.scene.is_empty() {
        outln!("scene conditions the error assumes (not values to type):")?;
        for line in &fit.scene {
            outln!("  {line}")?;
        }
    }
    super::transmission::print_notes("", &fit.requirements, &fit.warnings)
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
    if let Some(w) = fit.cannot_match() {
        super::errors::warn(&format!(
            "{} {w}: the files are written, the best the engine can do, with this warning at \
             the top of each that takes a comment",
            fit.engine
        ));
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
