//! `ssskit scene`: path-traces a scene file to an EXR holding the radiance,
//! its standard error and the G-buffer a screen-space pass gets; writes the
//! render's record (settings, noise, the materials' profiles) beside it,
//! and reads a render back for the commands that score kernels on it
//! (`compare --scene`: `scene_compare.rs`; `advise --scene`).

use super::args::{self, count, OutFile, SeedArg, ThreadsArg};
use super::out::outln;
use super::progress::Bar;
use anyhow::{bail, Context};
use ssskit::filter::image::{read_exr_channels, write_exr_channels, write_image, PngDepth};
use ssskit::filter::Image;
use ssskit::numerics::Bounded;
use ssskit::profile::mc::PhotonBudget;
use ssskit::profile::source::{default_budget, MC_MAX_PHOTONS};
use ssskit::profile::Profile;
use ssskit::scene::{
    material_profiles, render, Render, RenderConfig, RenderInfo, SampleBudget, Scene,
    DEFAULT_GBUFFER_SIDE, DEFAULT_MAX_SPP, DEFAULT_MAX_WORK, DEFAULT_SCENE_ERROR,
};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Boxed so that the subcommand enum stays small.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    flags: Box<Flags>,
}

#[derive(clap::Args)]
#[command(mut_arg("out", |a| args::required()(a).help(
    "Output file: the image, .exr (radiance R, G, B; stderr.R/G/B; the G-buffer \
     irradiance.R/G/B = diffuse irradiance / pi x R_d, Z, N.X/Y/Z, coverage); the render's \
     record goes to the same name with .json"
)))]
struct Flags {
    /// The scene (TOML; see docs/scene.md).
    #[arg(value_name = "SCENE.toml")]
    scene: PathBuf,
    #[command(flatten)]
    out: OutFile,
    /// Samples per pixel and channel [default: as many as --render-error asks].
    #[arg(long, value_name = "N", conflicts_with = "render_error", value_parser = count::<u64>)]
    spp: Option<u64>,
    /// Render target: the image's relative noise [default: 0.01].
    ///
    /// Trace until the noise (RMS standard error over the pixels that see
    /// an object, over their 99th-percentile radiance) is below E in every
    /// channel, or until --max-spp.
    #[arg(long, value_name = "E", allow_hyphen_values = true, value_parser = args::real)]
    render_error: Option<f64>,
    /// Cap on samples per pixel of --render-error.
    #[arg(long, value_name = "N", default_value = args::count_text(DEFAULT_MAX_SPP), value_parser = count::<u64>)]
    max_spp: u64,
    /// Work cap per channel, in events (interactions + boundary hits).
    ///
    /// Scattering events and boundary crossings of the render; the
    /// materials' profiles have their own (`simulate`'s).
    #[arg(long, value_name = "N", default_value = args::count_text(DEFAULT_MAX_WORK), value_parser = count::<u64>)]
    max_work: u64,
    #[command(flatten)]
    seed: SeedArg,
    #[command(flatten)]
    threads: ThreadsArg,
    /// G-buffer positions per pixel side (box filter).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_GBUFFER_SIDE, value_parser = count::<usize>)]
    gbuffer_side: usize,
    /// Photons per channel of each material's profile [default: the kernel-factor rule of `simulate`, 0.5%].
    ///
    /// Monte Carlo, the R_d of the irradiance channels.
    #[arg(long, value_name = "N", value_parser = count::<u64>)]
    profile_photons: Option<u64>,
    /// Also write the G-buffer as `ssskit apply` reads it [default: not written].
    ///
    /// R, G, B = irradiance / pi x R_d, Z = depth (apply --fov-y F
    /// --units-per-mm U), N.X, N.Y, N.Z = view-space normals and, under one
    /// directional light alone, NdotL: what apply needs for the angular
    /// entry and exit factors of a kernel that carries them.
    #[arg(long, value_name = "FILE.exr")]
    irradiance_out: Option<PathBuf>,
    /// Also write a tone-mapped PNG of the radiance [default: not written].
    ///
    /// The 99th percentile of the lit pixels maps to white.
    #[arg(long, value_name = "FILE.png")]
    preview: Option<PathBuf>,
}

/// The record written beside an image.
#[derive(serde::Serialize, serde::Deserialize)]
struct Sidecar {
    info: RenderInfo,
    /// The scene file's text: a comparison checks it renders this scene.
    scene: String,
    /// The profile behind each object's R_d.
    profiles: Vec<Profile>,
}

fn sidecar_path(out: &Path) -> PathBuf {
    out.with_extension("json")
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let a = *args.flags;
    let out = a.out.path()?;
    ssskit::io::check_extension(out, &["exr"], "image")?;
    if let Some(p) = &a.irradiance_out {
        ssskit::io::check_extension(p, &["exr"], "image")?;
    }
    if let Some(p) = &a.preview {
        ssskit::io::check_extension(p, &["png"], "image")?;
    }
    check_record_replaceable(out)?;
    let scene = Scene::load(&a.scene)?;
    let text = ssskit::io::read_text(&a.scene)?;
    let budget = match (a.spp, a.render_error) {
        (Some(n), _) => SampleBudget::Fixed(n),
        (None, e) => SampleBudget::TargetError {
            rel: e.unwrap_or(DEFAULT_SCENE_ERROR),
            max_spp: a.max_spp,
        },
    };
    let cfg = RenderConfig {
        budget,
        seed: a.seed.seed,
        threads: a.threads.threads,
        gbuffer_side: a.gbuffer_side,
        max_work: a.max_work,
    };
    cfg.validate(&scene)?;
    let photons = match a.profile_photons {
        Some(n) => PhotonBudget::Fixed(n),
        None => default_budget(MC_MAX_PHOTONS),
    };
    let profiles = material_profiles(&scene, photons, a.seed.seed, a.threads.threads, &Bar::new())?;
    let rd: Vec<[f64; 3]> = profiles
        .iter()
        .map(|p| [p.total_rd[0], p.total_rd[1], p.total_rd[2]])
        .collect();
    let r = render(&scene, &rd, &cfg, &Bar::new())?;
    write_render(out, &r, &text, &profiles)?;
    if let Some(p) = &a.irradiance_out {
        write_gbuffer(p, &scene, &r)?;
    }
    if let Some(p) = &a.preview {
        write_image(p, &preview(&r), PngDepth::Eight)?;
    }
    let i = &r.info;
    outln!(
        "{}: {}x{} pixels, {} / {} / {} samples per pixel (r/g/b), noise {:.3}% / {:.3}% / {:.3}% \
         of the 99th-percentile radiance, {:.1} s",
        a.scene.display(),
        r.width,
        r.height,
        i.spp[0],
        i.spp[1],
        i.spp[2],
        Bounded(100.0 * i.noise[0]),
        Bounded(100.0 * i.noise[1]),
        Bounded(100.0 * i.noise[2]),
        i.seconds
    )?;
    for (o, rd) in scene.objects.iter().zip(&i.rd) {
        outln!(
            "  {} ({}): R_d = {:.4} / {:.4} / {:.4}",
            o.name,
            o.material.name,
            rd[0],
            rd[1],
            rd[2]
        )?;
    }
    print_profile_warnings(&scene, &profiles)?;
    if !i.converged {
        super::errors::warn(&format!(
            "the render stopped before its target ({}): raise `max_spp` or `max_work`",
            if i.work_capped {
                "work cap"
            } else {
                "samples per pixel cap"
            }
        ));
    }
    let lost: u64 = i.lost.iter().sum();
    if lost > 0 {
        super::errors::warn(&format!(
            "{lost} paths ended by round-off at a grazing boundary crossing"
        ));
    }
    eprintln!("-> {}, {}", out.display(), sidecar_path(out).display());
    Ok(())
}

/// The warnings of each material's profile (too few photons, ...) on
/// standard output, once per material; the record holds them too, in each
/// profile's `extra.warnings`.
fn print_profile_warnings(scene: &Scene, profiles: &[Profile]) -> anyhow::Result<()> {
    let mut seen: Vec<&str> = Vec::new();
    for (o, p) in scene.objects.iter().zip(profiles) {
        if seen.contains(&o.material.name.as_str()) {
            continue;
        }
        seen.push(&o.material.name);
        for w in p.warnings()? {
            outln!("warning: profile of {}: {w}", o.material.name)?;
        }
    }
    Ok(())
}

/// Radiance tone-mapped for a look: the 99th percentile of the seen
/// pixels' largest channel maps to 1.
fn preview(r: &Render) -> Image {
    let mut m: Vec<f64> = (0..r.width * r.height)
        .filter(|&i| r.gbuffer.coverage[i] > 0.0)
        .map(|i| (0..3).fold(0.0f64, |a, c| a.max(r.radiance[c][i])))
        .collect();
    m.sort_by(f64::total_cmp);
    let p = m
        .get(((0.99 * m.len() as f64) as usize).min(m.len().saturating_sub(1)))
        .copied()
        .filter(|v| *v > 0.0)
        .unwrap_or(1.0);
    Image {
        width: r.width,
        height: r.height,
        rgb: std::array::from_fn(|c| r.radiance[c].iter().map(|v| v / p).collect()),
        alpha: None,
    }
}

/// The G-buffer as `apply` reads it: R, G, B the irradiance / pi x R_d, Z
/// the depth, N.X, N.Y, N.Z the normals in view space (x right, y up, z
/// toward the camera; 0 where nothing is seen) and, for a scene lit by one
/// directional light and nothing else, NdotL (the cosines the angular
/// factors of `compare --scene` take).
fn write_gbuffer(path: &Path, scene: &Scene, r: &Render) -> anyhow::Result<()> {
    let g = &r.gbuffer;
    let cam = &scene.camera;
    let axes = [cam.right, cam.up, -cam.forward];
    let view: Vec<Vec<f64>> = axes
        .iter()
        .map(|a| {
            (0..r.width * r.height)
                .map(|i| g.normal[0][i] * a.x + g.normal[1][i] * a.y + g.normal[2][i] * a.z)
                .collect()
        })
        .collect();
    let mut planes: Vec<(&str, &[f64])> = vec![
        ("R", &g.irradiance[0]),
        ("G", &g.irradiance[1]),
        ("B", &g.irradiance[2]),
        ("Z", &g.depth),
        ("N.X", &view[0]),
        ("N.Y", &view[1]),
        ("N.Z", &view[2]),
    ];
    let cos = ssskit::report::eval::scene::score::cosines(scene, r);
    if ssskit::report::eval::scene::compare::angular_obstacle(scene).is_none() {
        if let Some(nl) = &cos.n_dot_l {
            planes.push(("NdotL", nl));
        }
    }
    let mut group = ssskit::io::AtomicGroup::new();
    write_exr_channels(&mut group, path, r.width, r.height, &planes)?;
    group.commit()?;
    Ok(())
}

/// The image and its record, committed as one: two runs writing the same
/// `--out` at once leave the pair of one of them.
fn write_render(out: &Path, r: &Render, scene: &str, profiles: &[Profile]) -> anyhow::Result<()> {
    let mut group = ssskit::io::AtomicGroup::new();
    write_exr_channels(&mut group, out, r.width, r.height, &r.planes())?;
    let side = Sidecar {
        info: r.info.clone(),
        scene: scene.to_string(),
        profiles: profiles.to_vec(),
    };
    let text = serde_json::to_string_pretty(&side)? + "\n";
    group.add_with(&sidecar_path(out), |w| w.write_all(text.as_bytes()))?;
    // Read back before the commit, from the staged files: the pair must
    // load as is.
    let (Some(exr), Some(record)) = (group.staged_path(0), group.staged_path(1)) else {
        bail!("{}: not staged as files", out.display());
    };
    // Messages name the outputs, not their temporary names.
    let back = read_render_from(exr, record).map_err(|e| {
        let text = format!("{e:#}")
            .replace(&exr.display().to_string(), &out.display().to_string())
            .replace(
                &record.display().to_string(),
                &sidecar_path(out).display().to_string(),
            );
        anyhow::anyhow!("{}: reading back what was written: {text}", out.display())
    })?;
    if back.0.info != r.info || back.0.width != r.width {
        bail!("{}: read back differs from what was written", out.display());
    }
    check_record_replaceable(out)?;
    group.commit()?;
    Ok(())
}

/// Refuses a render's `--out` whose record (`<out>.json`) could not be
/// written beside it or would replace a file that is not such a record (a
/// scene file, a profile, anything else): checked before the work and again
/// before the commit. A device or a pipe takes neither: the render is read
/// back, with its record, after it is written.
fn check_record_replaceable(out: &Path) -> anyhow::Result<()> {
    let side = sidecar_path(out);
    for p in [out, side.as_path()] {
        if ssskit::io::writes_in_place(p) {
            bail!(
                "{}: a device or a named pipe; a render is written with its record beside it \
                 and read back: give a file name",
                p.display()
            );
        }
    }
    if std::fs::symlink_metadata(&side).is_err() {
        return Ok(());
    }
    let schema = ssskit::io::read_json::<serde_json::Value>(&side)
        .ok()
        .and_then(|v| v.pointer("/info/schema")?.as_str().map(str::to_string));
    if schema.as_deref() != Some(ssskit::scene::RENDER_SCHEMA) {
        bail!(
            "{}: the render's record would replace it, and it is not a render's record (no \
             info.schema '{}'): give another --out, or move the file",
            side.display(),
            ssskit::scene::RENDER_SCHEMA
        );
    }
    Ok(())
}

/// Relative difference between a given scale and the scene's beyond which
/// the two are refused as different views (1%: well above the rounding of
/// a scale typed from the scene file).
const SCALE_AGREEMENT: f64 = 0.01;

/// The scene and render of `--scene` / `--render`, when given.
pub(super) fn scene_check(
    a: &super::args::SceneCheckArgs,
) -> anyhow::Result<Option<(Scene, Render, Vec<Profile>)>> {
    match (&a.scene, &a.render) {
        (Some(s), Some(r)) => Ok(Some(scene_and_render(s, r)?)),
        _ => Ok(None),
    }
}

/// A scale `mm` asked for beside a scene seen at `scene_mm` (its median
/// depth): refused where they are different views.
pub(super) fn agrees_with_scene(mm: f64, scene_mm: f64) -> anyhow::Result<()> {
    if (mm - scene_mm).abs() > SCALE_AGREEMENT * scene_mm {
        bail!(
            "--scene: the scene is seen at {} mm per pixel (its median depth), the advice \
             asked for {}: drop the scale flags to take the scene's",
            ssskit::report::present::number::sig(scene_mm),
            ssskit::report::present::number::sig(mm)
        );
    }
    Ok(())
}

/// A scene and its render (`ssskit scene SCENE --out IMG`), refused when
/// the render's record holds another scene's text; with the render's
/// profiles.
pub(super) fn scene_and_render(
    scene: &Path,
    render: &Path,
) -> anyhow::Result<(Scene, Render, Vec<Profile>)> {
    let loaded = Scene::load(scene)?;
    let text = ssskit::io::read_text(scene)?;
    let (r, scene_text, profiles) = read_render(render)?;
    if scene_text != text {
        bail!(
            "--render {}: it was rendered from another scene than {} (its record holds that \
             scene's text): render this one with `ssskit scene {} --out IMG.exr`",
            render.display(),
            scene.display(),
            scene.display()
        );
    }
    Ok((loaded, r, profiles))
}

/// A render written by `ssskit scene`, with its scene text and profiles.
fn read_render(path: &Path) -> anyhow::Result<(Render, String, Vec<Profile>)> {
    read_render_from(path, &sidecar_path(path))
}

/// A render from its image at `path` and its record at `side_path`.
fn read_render_from(
    path: &Path,
    side_path: &Path,
) -> anyhow::Result<(Render, String, Vec<Profile>)> {
    let text = ssskit::io::read_text(side_path)
        .with_context(|| format!("the record of {}", path.display()))?;
    let side: Sidecar = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: not the record of a scene render (ssskit scene writes it)",
            side_path.display()
        )
    })?;
    if side.info.schema != ssskit::scene::RENDER_SCHEMA {
        bail!(
            "{}: schema '{}', expected '{}'",
            side_path.display(),
            side.info.schema,
            ssskit::scene::RENDER_SCHEMA
        );
    }
    let ((w, h), planes) = read_exr_channels(path)?;
    let r = Render::from_planes(w, h, planes, side.info, &path.display().to_string())?;
    Ok((r, side.scene, side.profiles))
}
