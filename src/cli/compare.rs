//! `ssskit compare`: kernel models across materials, in kernel space and in
//! image space; report.md, compare.csv, compare.json, the fitted kernels
//! and plots.

use super::errors::{between, invalid, positive};
use super::fit::ModelArg;
use super::out::out;
use super::profile_source::command_line;
use super::progress::Bar;
use super::signal::Kind as SignalArg;
use anyhow::{bail, Context};
use clap::ValueEnum;
use ssskit::filter::image::read_image;
use ssskit::material::{preset_names, Channel, Material};
use ssskit::profile::analytic::{self, Model as ProfileModel, Options as ProfileOptions};
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::profile::Profile;
use ssskit::report::evaluate::{ImageCase, Options, Which};
use ssskit::report::kernel_compare::{self, parse_ranks, Config, Factor, MaterialInput};
use ssskit::report::{kernel_report, pipeline};
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ProfileModelArg {
    /// Monte Carlo (--photons per channel, fixed seed).
    Mc,
    Pbd,
    Dipole,
    Burley,
    DirectionalDipole,
}

/// A list item of an enumerated flag: a value of `T` (Some) or the one
/// extra word `other` (None). The values' own help is dropped: it names
/// the flags of the subcommand that owns `T`.
fn value_or<T>(
    other: clap::builder::PossibleValue,
) -> impl clap::builder::TypedValueParser<Value = Option<T>>
where
    T: ValueEnum + Clone + Send + Sync + 'static,
{
    use clap::builder::{PossibleValuesParser, TypedValueParser};
    let values = T::value_variants()
        .iter()
        .filter_map(ValueEnum::to_possible_value)
        .map(|v| v.help(None::<&'static str>));
    PossibleValuesParser::new(std::iter::once(other).chain(values))
        .map(|s| T::from_str(&s, false).ok())
}

/// `--models`: a kernel model as `fit --model` spells it
/// (`kernel_compare::FAMILIES`), or "all" (None).
fn model_or_all() -> impl clap::builder::TypedValueParser<Value = Option<ModelArg>> {
    value_or(clap::builder::PossibleValue::new("all"))
}

/// `--signals`: a test signal as `signal` spells it, or "none" (also "")
/// for kernel space only (None).
fn signal_or_none() -> impl clap::builder::TypedValueParser<Value = Option<SignalArg>> {
    value_or(
        clap::builder::PossibleValue::new("none")
            .alias("")
            .help("kernel space only"),
    )
}

#[derive(clap::Args)]
pub struct Args {
    /// Comma-separated material names, or "all" (every profile in
    /// --profiles, or every half-space preset with --profile-model).
    #[arg(long, default_value = "all")]
    materials: String,
    /// Folder of profiles named <material>.json (e.g. profiles/reference).
    #[arg(long, value_name = "DIR", conflicts_with = "profile_model")]
    profiles: Option<PathBuf>,
    /// Make the profiles instead of reading them.
    #[arg(long, value_enum)]
    profile_model: Option<ProfileModelArg>,
    /// Photons per channel for --profile-model mc.
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    /// Seed for --profile-model mc.
    #[arg(long, default_value_t = 20260101)]
    seed: u64,
    /// Comma-separated kernel models, or all.
    #[arg(long, value_parser = model_or_all(), value_delimiter = ',', default_value = "all")]
    models: Vec<Option<ModelArg>>,
    /// Comma-separated test signals, or none for kernel space only.
    #[arg(long, value_parser = signal_or_none(), value_delimiter = ',', default_value = "edge,shapes")]
    signals: Vec<Option<SignalArg>>,
    /// Further images in linear light (.exr) or sRGB (.png), at --mm-per-pixel.
    #[arg(long, num_args = 1..)]
    images: Vec<PathBuf>,
    /// Surface millimetres per pixel of the images.
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    mm_per_pixel: f64,
    /// Side of the square test signals in pixels.
    #[arg(long, default_value_t = 256)]
    size: usize,
    /// Tap counts of the real-time tables (odd), e.g. 11,17,25; the first
    /// is the one stored in the kernels.
    #[arg(long, default_value = "17")]
    taps: String,
    /// SVD ranks and Gaussian counts, e.g. 1-6 or 1,3.
    #[arg(long, default_value = "1-3")]
    ranks: String,
    /// Half-width of the kernels in mm (default: the radius holding 99.9%
    /// of each profile's R_d).
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    extent: Option<f64>,
    /// FLIP viewing condition.
    #[arg(long, default_value_t = 67.0)]
    pixels_per_degree: f64,
    /// Skip the PNG plots and contact sheets.
    #[arg(long)]
    no_plots: bool,
    /// Output folder (created).
    #[arg(long)]
    out: PathBuf,
    /// A path-traced scene (TOML): every kernel model through the
    /// screen-space pass on its G-buffer, against the path-traced image
    /// (with --render; the profile is the render's).
    #[arg(long, value_name = "SCENE.toml", requires = "render")]
    scene: Option<PathBuf>,
    /// The scene's render (`ssskit scene SCENE.toml --out IMG.exr`).
    #[arg(long, value_name = "IMG.exr", requires = "scene")]
    render: Option<PathBuf>,
    /// Depth difference (mm) at which the screen-space pass's depth-aware
    /// lerp reaches the centre colour [default: the radius holding 99% of
    /// the profile's R_d].
    #[arg(
        long,
        value_name = "MM",
        requires = "scene",
        allow_negative_numbers = true
    )]
    follow_mm: Option<f64>,
}

fn list(s: &str) -> Vec<String> {
    s.split(',')
        .map(|x| x.trim().to_string())
        .filter(|x| !x.is_empty())
        .collect()
}

fn parse_taps(s: &str) -> anyhow::Result<Vec<usize>> {
    let mut v = Vec::new();
    for t in list(s) {
        let n: usize = t
            .parse()
            .map_err(|_| invalid("--taps", &t, "not a number (e.g. 11,17,25)"))?;
        if n == 0 || n.is_multiple_of(2) || n > 255 {
            return Err(invalid("--taps", n, "must be odd, between 1 and 255"));
        }
        if !v.contains(&n) {
            v.push(n);
        }
    }
    if v.is_empty() {
        bail!("--taps: give at least one tap count");
    }
    Ok(v)
}

fn load_profiles(a: &Args) -> anyhow::Result<Vec<MaterialInput>> {
    if let Some(dir) = &a.profiles {
        let names: Vec<String> = if a.materials.trim() == "all" {
            let mut v: Vec<String> = std::fs::read_dir(dir)
                .with_context(|| format!("--profiles {}", dir.display()))?
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|x| x == "json"))
                .filter_map(|p| p.file_stem()?.to_str().map(String::from))
                .collect();
            v.sort();
            v
        } else {
            list(&a.materials)
        };
        if names.is_empty() {
            bail!("--profiles {}: no <material>.json found", dir.display());
        }
        return names
            .into_iter()
            .map(|n| {
                let path = dir.join(format!("{n}.json"));
                let profile = Profile::read(&path)
                    .with_context(|| format!("material '{n}' (from --profiles)"))?;
                Ok(MaterialInput { name: n, profile })
            })
            .collect();
    }
    let Some(model) = a.profile_model else {
        bail!("give --profiles DIR (e.g. profiles/reference) or --profile-model mc|pbd|dipole|burley|directional-dipole");
    };
    let names: Vec<String> = if a.materials.trim() == "all" {
        preset_names()
            .iter()
            .filter(|n| Material::load(n).is_ok_and(|m| m.is_half_space()))
            .map(|s| s.to_string())
            .collect()
    } else {
        list(&a.materials)
    };
    if names.is_empty() {
        bail!("--materials: no material named");
    }
    let channels = Channel::ALL.to_vec();
    names
        .into_iter()
        .map(|n| {
            let m = Material::load(&n)?;
            let analytic_model = match model {
                ProfileModelArg::Mc => None,
                ProfileModelArg::Pbd => Some(ProfileModel::Pbd),
                ProfileModelArg::Dipole => Some(ProfileModel::Dipole),
                ProfileModelArg::Burley => Some(ProfileModel::Burley),
                ProfileModelArg::DirectionalDipole => Some(ProfileModel::DirectionalDipole),
            };
            let profile = match analytic_model {
                None => {
                    if a.photons == 0 {
                        return Err(invalid("--photons", 0, "must be > 0"));
                    }
                    let cfg = McConfig {
                        budget: PhotonBudget::Fixed(a.photons),
                        seed: a.seed,
                        threads: None,
                        channels: channels.clone(),
                        grid: None,
                    };
                    simulate(&m, &cfg, &Bar::new())?
                }
                Some(pm) => {
                    let grid = analytic::default_grid(&m, &channels)?;
                    let opts = ProfileOptions {
                        fresnel: ssskit::profile::fresnel::FresnelMode::Fit,
                        channels: channels.clone(),
                    };
                    analytic::profile(&m, pm, &grid, &opts)?
                }
            };
            Ok(MaterialInput {
                name: m.name.clone(),
                profile,
            })
        })
        .collect()
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let families: Vec<String> = match a.models.iter().copied().collect::<Option<Vec<_>>>() {
        Some(models) => models.iter().map(super::flag_value).collect(),
        None => kernel_compare::FAMILIES
            .iter()
            .map(|s| s.to_string())
            .collect(),
    };
    let ranks = parse_ranks(&a.ranks).context("--ranks")?;
    let taps = parse_taps(&a.taps)?;
    positive("--mm-per-pixel", a.mm_per_pixel)?;
    between("--size", a.size, 8, 4096)?;
    positive("--pixels-per-degree", a.pixels_per_degree)?;
    if let (Some(scene), Some(render)) = (&a.scene, &a.render) {
        return super::scene::compare(super::scene::CompareArgs {
            scene,
            render,
            families,
            ranks,
            taps,
            pixels_per_degree: a.pixels_per_degree,
            size: a.size,
            follow_mm: a.follow_mm,
            plots: !a.no_plots,
            out: &a.out,
        });
    }
    let mut cases = Vec::new();
    let mut signals = Vec::new();
    for &sig in a.signals.iter().flatten() {
        let case = ImageCase::signal(sig.into(), a.size, a.mm_per_pixel)?;
        if signals.contains(&case.name) {
            continue;
        }
        signals.push(case.name.clone());
        cases.push(case);
    }
    for p in &a.images {
        let (mut image, _) = read_image(p, None)?;
        let what = p.display().to_string();
        image.check_finite(&what, false)?;
        let name = p
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("image")
            .to_string();
        if signals.contains(&name) {
            bail!("--images {what}: its name '{name}' is already used by another image");
        }
        signals.push(name.clone());
        cases.push(ImageCase {
            name,
            image,
            mm_per_pixel: a.mm_per_pixel,
        });
    }
    if let Some(e) = a.extent {
        positive("--extent", e)?;
    }
    let inputs = load_profiles(&a)?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("--out {}", a.out.display()))?;
    let options = Options {
        round_to_f32: true,
        pixels_per_degree: a.pixels_per_degree,
    };
    let cfg = Config {
        families,
        ranks: ranks.clone(),
        cases,
        taps: taps.clone(),
        options,
        keep: (!a.no_plots).then_some(Which::Taps(taps[0])),
        extent_mm: a.extent,
    };
    let t0 = std::time::Instant::now();
    let cmp = kernel_compare::run(&inputs, &cfg, &Bar::new())?;
    let factors: Vec<Factor> = std::iter::once(Factor::Full)
        .chain(taps.iter().map(|&n| Factor::Taps(n)))
        .collect();
    let command = command_line(&a.out);
    let ctx = kernel_report::ReportContext {
        command: &command,
        signals: &signals,
        factors: &factors,
        ranks: &ranks,
        options: &options,
    };
    pipeline::write_comparison(
        &cmp,
        &ctx,
        &a.out,
        !a.no_plots,
        &format!("{}-tap tables", taps[0]),
    )?;
    pipeline::write_fitted_kernels(&cmp, &a.out.join("kernels"), false)?;
    let claims = kernel_report::claims(&cmp, &signals, &factors, &ranks);
    out!("{}", kernel_report::claims_table(&claims).markdown())?;
    eprintln!(
        "{} materials x {} kernels x {} images in {:.1} s -> {}/report.md, compare.csv, compare.json, kernels/{}",
        cmp.materials.len(),
        cmp.fitted.len(),
        signals.len(),
        t0.elapsed().as_secs_f64(),
        a.out.display(),
        if a.no_plots { "" } else { ", PNG plots" }
    );
    Ok(())
}
