//! `ssskit advise`: the cheapest kernel configuration that meets a target
//! image-space error at a pixel scale.

use super::args::{
    self, count, BudgetArgs, FovYArg, ImageErrorArg, JsonArg, MmPerPixelArg, ModelsArg, OutFile,
    ProfileModel, ProfileSourceArgs, SignalSizeArg, UnitsPerMmArg,
};
use super::out::{out, outln};
use anyhow::bail;
use ssskit::report::advise::{self, ViewScale, FAMILIES};
use ssskit::report::kernel_report::sig;
use std::path::PathBuf;

/// The perspective scale's own flags (with --fov-y and --units-per-mm).
#[derive(clap::Args)]
struct ViewArgs {
    /// Linear view depth of the surface, scene units (with --fov-y).
    #[arg(long, value_name = "UNITS", allow_negative_numbers = true, value_parser = args::real)]
    view_depth: Option<f64>,
    /// Image height in pixels (with --fov-y).
    #[arg(long, value_name = "PX", value_parser = count::<usize>)]
    image_height: Option<usize>,
}

#[derive(clap::Args)]
#[command(mut_args(args::profile_source(ProfileModel::Mc)))]
#[command(
    mut_arg("mm_per_pixel", |a| a
        .conflicts_with_all(["fov_y", "view_depth", "image_height"])
        .required_unless_present_any(["fov_y", "scene"])
        .help("Scale: surface millimetres per pixel (orthographic) [default: none: give it or --fov-y]")),
    mut_arg("fov_y", |a| a.requires_all(["view_depth", "image_height"]).alias("fov")),
    mut_arg("view_depth", args::alias("--depth")),
    mut_arg("image_height", args::alias("--height")),
    mut_arg("units_per_mm", args::alias("--scene-units-per-mm")),
    mut_arg("image_error", args::alias("--target-error")),
    mut_arg("signal_size", args::alias("--size")),
    mut_arg("models", args::default(FAMILIES.join(","))),
    mut_arg("out", args::help("Output file: the chosen kernel (ssskit.kernel/1 JSON, ssskit.disk/1 for a disk kernel) [default: not written]")),
)]
pub struct Args {
    #[command(flatten)]
    profile: ProfileSourceArgs,
    #[command(flatten)]
    mm_per_pixel: MmPerPixelArg,
    #[command(flatten)]
    fov_y: FovYArg,
    #[command(flatten)]
    view: ViewArgs,
    #[command(flatten)]
    units_per_mm: UnitsPerMmArg,
    #[command(flatten)]
    target: ImageErrorArg,
    #[command(flatten)]
    budget: BudgetArgs,
    #[command(flatten)]
    factors: args::FactorsArg,
    #[command(flatten)]
    signal_size: SignalSizeArg,
    /// Frames: disk kernels are scored on their noise after this many, 1 to 64.
    ///
    /// A temporal filter accumulates them under a static camera; a disk
    /// kernel's image changes every frame (its per-pixel rotation).
    /// Its score on a signal is, in its worst channel, sqrt(bias^2 +
    /// noise_K^2): the bias (the mean over 4 K rotations against the exact
    /// image, which errs high by that mean's own noise) and the RMS noise
    /// of the mean of K frames, relative to the exact image's peak.
    /// Separable kernels are the same every frame.
    #[arg(long, value_name = "N", value_parser = count::<u32>,
          default_value_t = ssskit::report::eval::advise_types::DEFAULT_FRAMES)]
    frames: u32,
    #[command(flatten)]
    models: ModelsArg,
    #[command(flatten)]
    json: JsonArg,
    #[command(flatten)]
    out: OutFile,
    /// A path-traced scene (TOML) to score kernels on [default: none].
    ///
    /// Each model's answer within the budget and the chosen one run
    /// through the screen-space pass on the scene's G-buffer (scaled by
    /// depth, depth-aware) against its path-traced image (--render): the
    /// chosen kernel's scene error beside the best's, with the uncertainty
    /// the render's noise gives the difference. The seen object must be of
    /// the advised material (the same preset, eta included). Without
    /// --material or --profile the profile is the render's own (its first
    /// object's); the scale is the scene's unless --mm-per-pixel is given.
    #[arg(long, value_name = "SCENE.toml", requires = "render")]
    scene: Option<PathBuf>,
    /// The scene's render, `ssskit scene SCENE.toml --out IMG.exr` [default: none].
    #[arg(long, value_name = "IMG.exr", requires = "scene")]
    render: Option<PathBuf>,
}

/// Relative difference between a given scale and the scene's beyond which
/// the two are refused as different views (1%: well above the rounding of
/// a scale typed from the scene file).
const SCALE_AGREEMENT: f64 = 0.01;

pub fn run(a: Args) -> anyhow::Result<()> {
    let units_per_mm = a.units_per_mm.units_per_mm;
    let scene = match (&a.scene, &a.render) {
        (Some(s), Some(r)) => Some(super::scene::scene_and_render(s, r)?),
        _ => None,
    };
    let scene_mm = scene
        .as_ref()
        .map(|(s, r, _)| ssskit::report::scene_compare::median_mm_per_pixel(s, r));
    let view = match (
        a.mm_per_pixel.mm_per_pixel.or(scene_mm),
        a.fov_y.fov_y,
        a.view.view_depth,
        a.view.image_height,
    ) {
        (Some(m), _, _, _) => ViewScale::MmPerPixel(m),
        (None, Some(f), Some(d), Some(h)) => ViewScale::Perspective {
            fov_y_deg: f,
            depth: d,
            height: h,
            scene_units_per_mm: units_per_mm,
        },
        _ => bail!("give --mm-per-pixel, or --fov-y with --view-depth and --image-height"),
    };
    let mm = view.mm_per_pixel()?;
    if let Some(m) = scene_mm {
        if (mm - m).abs() > SCALE_AGREEMENT * m {
            bail!(
                "--scene: the scene is seen at {} mm per pixel (its median depth), the advice \
                 asked for {}: drop the scale flags to take the scene's",
                sig(m),
                sig(mm)
            );
        }
    }
    ssskit::report::advise_disk::check_frames(a.frames)?;
    let target = a.target.fraction()?;
    let (profile, source) = match &scene {
        // The render's own profile of the scene's first object: the
        // material it was rendered with, to its Monte Carlo error.
        Some((_, _, profiles)) if !a.profile.given() => match profiles.first() {
            Some(p) => (p.clone(), "the render's (its first object's)".to_string()),
            None => bail!("--render: its record holds no profile: give --material"),
        },
        _ => a.profile.load_with_factors(&a.factors)?,
    };
    eprintln!(
        "{}: profile {source}; scale {} mm per pixel{}",
        profile.material.name,
        sig(mm),
        match view {
            ViewScale::Perspective {
                fov_y_deg,
                depth,
                height,
                ..
            } => format!(
                " (fov {fov_y_deg} deg, depth {depth}, height {height} px, \
                 {units_per_mm} scene units per mm)"
            ),
            ViewScale::MmPerPixel(_) => String::new(),
        }
    );
    let mut cfg = advise::Config::new(mm, target);
    cfg.size = a.signal_size.signal_size;
    cfg.budget = a.budget.budget();
    cfg.families = a.models.families();
    cfg.frames = a.frames;
    let advice = advise::advise_on_scene(
        &profile,
        &cfg,
        scene.as_ref().map(|(s, r, _)| (s, r)),
        &super::progress::Bar::new(),
    )?;
    let out = a.out.out.as_ref();
    if let Some(out) = out {
        match &advice.disk_kernel {
            Some(k) => {
                k.write(out)?;
                ssskit::kernel::disk::DiskKernelFile::read(out)?;
            }
            None => {
                advice.kernel.write(out)?;
                ssskit::kernel::KernelFile::read(out)?;
            }
        }
    }
    let c = advice.chosen();
    let text = advise::explain(&advice);
    if a.json.json {
        eprint!("{text}");
        outln!("{}", serde_json::to_string_pretty(&advice.to_json())?)?;
    } else {
        out!("{text}")?;
    }
    for w in &advice.warnings {
        super::errors::warn(&w.to_string());
    }
    if let Some(out) = out {
        eprintln!("kernel ({}) -> {}", c.describe(), out.display());
    }
    Ok(())
}
