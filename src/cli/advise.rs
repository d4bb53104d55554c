//! `ssskit advise`: the cheapest kernel configuration that meets a target
//! image-space error at a pixel scale.

use super::args::{
    self, count, BudgetArgs, DirectionalArgs, FovYArg, FramesArg, ImageErrorArg, JsonArg,
    MmPerPixelArg, ModelsArg, OutFile, ProfileModel, ProfileSourceArgs, SceneCheckArgs,
    SignalSizeArg, UnitsPerMmArg,
};
use super::out::{out, outln};
use anyhow::bail;
use ssskit::report::eval::advise::{self, ViewScale, ADVISED_FAMILIES};
use ssskit::report::present::advice_text;
use ssskit::report::present::number::sig;
use std::path::Path;

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
    mut_arg("models", args::default(ADVISED_FAMILIES.join(","))),
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
    #[command(flatten)]
    frames: FramesArg,
    #[command(flatten)]
    models: ModelsArg,
    #[command(flatten)]
    json: JsonArg,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    scene: SceneCheckArgs,
    #[command(flatten)]
    directional: DirectionalArgs,
}

/// The light-space method's settings on the advice's scene, checked before
/// any work (None for `--directional-spp 0` or a scene the method refuses,
/// said on stderr with the reason; its warnings too).
fn directional_config(
    a: &Args,
    scene: &ssskit::scene::Scene,
    render: &ssskit::scene::Render,
) -> anyhow::Result<Option<ssskit::report::eval::scene::directional::DirectionalConfig>> {
    let samples = a.directional.samples()?;
    let Some(&most) = samples.iter().max() else {
        return Ok(None);
    };
    let side = render.info.config.gbuffer_side;
    let map = a.directional.light_map_side;
    match ssskit::filter::light_space::preflight(scene, map, side, most) {
        Ok(warnings) => {
            for w in warnings {
                super::errors::warn(&format!("light-space directional method: {w}"));
            }
        }
        Err(e) => {
            super::errors::warn(&format!("no light-space directional rows: {e}"));
            return Ok(None);
        }
    }
    Ok(Some(
        ssskit::report::eval::scene::directional::DirectionalConfig {
            samples,
            map_side: map,
            seed: ssskit::profile::mc::DEFAULT_SEED,
            frames: a.frames.frames,
        },
    ))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let units_per_mm = a.units_per_mm.units_per_mm;
    let scene = super::scene::scene_check(&a.scene)?;
    let scene_mm = scene
        .as_ref()
        .map(|(s, r, _)| ssskit::report::eval::scene::compare::median_mm_per_pixel(s, r));
    let view = view_of(&a, scene_mm)?;
    let mm = view.mm_per_pixel()?;
    if let Some(m) = scene_mm {
        super::scene::agrees_with_scene(mm, m)?;
    }
    ssskit::report::eval::disk::check_frames(a.frames.frames)?;
    let target = a.target.fraction()?;
    let (profile, source) = a
        .profile
        .load_for_scene(scene.as_ref().map(|(_, _, p)| p.as_slice()), &a.factors)?;
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
    cfg.frames = a.frames.frames;
    let directional = match &scene {
        Some((s, r, _)) => directional_config(&a, s, r)?,
        None => None,
    };
    let advice = advise::advise_on_scene(
        &profile,
        &cfg,
        scene.as_ref().map(|(s, r, _)| (s, r)),
        &super::progress::Bar::new(),
    )?;
    let out = a.out.out.as_ref();
    if let Some(out) = out {
        write_kernel(&advice, out)?;
    }
    let c = advice.chosen();
    let light_space = match (&scene, &advice.scene, &directional) {
        (Some((s, r, _)), Some(check), Some(d)) => Some(
            ssskit::report::eval::advise::directional::directional_on_advice(
                s, r, &profile, check, d,
            )?,
        ),
        _ => None,
    };
    let mut text = advice_text::explain(&advice);
    if let Some(l) = &light_space {
        text = format!("{}\n\n{text}", l.sentence);
    }
    if a.json.json {
        eprint!("{text}");
        let mut json = advice.to_json();
        if let (Some(l), Some(o)) = (&light_space, json.as_object_mut()) {
            o.insert("directional".into(), serde_json::to_value(l)?);
        }
        outln!("{}", serde_json::to_string_pretty(&json)?)?;
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

/// The view's scale: --mm-per-pixel (or the scene's median), else the
/// perspective of --fov-y, --view-depth and --image-height.
fn view_of(a: &Args, scene_mm: Option<f64>) -> anyhow::Result<ViewScale> {
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
            scene_units_per_mm: a.units_per_mm.units_per_mm,
        },
        _ => bail!("give --mm-per-pixel, or --fov-y with --view-depth and --image-height"),
    };
    Ok(view)
}

/// Writes the kernel the advice names to `out` and reads it back.
fn write_kernel(advice: &advise::Advice, out: &Path) -> anyhow::Result<()> {
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
    Ok(())
}
