//! `ssskit compare`: kernel models across materials, in kernel space and in
//! image space; report.md, compare.csv, compare.json, the fitted kernels
//! and plots.

use super::args::{
    self, count, value_or, DirectionalArgs, ExtentArg, MaterialsArg, MmPerPixelArg, ModelsArg,
    NoPlotsArg, OutDir, PhotonsArg, ProfileModel, ProfileModelArg, SeedArg, SignalSizeArg,
};
use super::errors::{invalid, positive};
use super::out::out;
use super::profile_source::command_line;
use super::progress::Bar;
use super::signal::Kind as SignalArg;
use anyhow::{bail, Context};
use clap::ValueEnum;
use ssskit::filter::image::read_image;
use ssskit::filter::Which;
use ssskit::material::Material;
use ssskit::profile::source::{self, ProfileSource};
use ssskit::profile::Profile;
use ssskit::report::eval::compare;
use ssskit::report::eval::compare::claims;
use ssskit::report::eval::compare::kernel::{parse_ranks, Config, MaterialInput};
use ssskit::report::eval::evaluate::{self, ImageCase, Options};
use ssskit::report::pipeline;
use ssskit::report::present::kernel_report;
use std::path::{Path, PathBuf};

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
#[command(
    mut_arg("profile_model", |a| a.conflicts_with("profiles").help(
        "Profile model: how the profiles are made from the materials [default: none: \
         give --profiles or this]"
    )),
    mut_arg("photons", args::help(
        "Photons per channel of the Monte Carlo run: a fixed count, with --profile-model mc \
         [default: none: the kernel-factor rule, as in kernels]"
    )),
    mut_arg("models", args::default("all")),
    mut_arg("mm_per_pixel", |a| args::default(evaluate::DEFAULT_MM_PER_PIXEL)(a)
        .help("Scale: surface millimetres per pixel of the signals and the images")),
    mut_arg("signal_size", args::alias("--size")),
    mut_arg("out_dir", |a| a.alias("out").help(
        "Output folder (created): report.md, compare.csv, compare.json, kernels/, plots"
    )),
    mut_arg("no_plots", args::help("No PNG plots: no plots and no contact sheets")),
)]
pub struct Args {
    #[command(flatten)]
    materials: MaterialsArg,
    /// Folder of profiles named <material>.json (e.g. profiles/reference).
    #[arg(long, value_name = "DIR")]
    profiles: Option<PathBuf>,
    #[command(flatten)]
    profile_model: ProfileModelArg,
    #[command(flatten)]
    photons: PhotonsArg,
    #[command(flatten)]
    seed: SeedArg,
    #[command(flatten)]
    models: ModelsArg,
    /// Frames: disk kernels (--models ...,disk) are scored on their noise after this many, 1 to 64.
    ///
    /// Each disk kernel gets a row beside the pre-integrated separable
    /// kernel at the same samples per pixel (2 passes of T taps for each
    /// --taps T against 2 T samples): its bias (the mean over 4 K
    /// rotations against the exact image), its noise in one frame and
    /// after K frames, and FLIP; in report.md, disk.json and on stdout.
    #[arg(long, value_name = "N", value_parser = count::<u32>,
          default_value_t = ssskit::report::eval::disk::DEFAULT_FRAMES)]
    frames: u32,
    /// Test signals, comma-separated, or none for kernel space only.
    #[arg(long, value_name = "SIGNAL,...", value_parser = signal_or_none(), value_delimiter = ',', default_value = "edge,shapes")]
    signals: Vec<Option<SignalArg>>,
    /// Further images in linear light (.exr) or sRGB (.png), at --mm-per-pixel [default: none].
    #[arg(long, value_name = "IMAGE,...", value_delimiter = ',')]
    images: Vec<PathBuf>,
    #[command(flatten)]
    mm_per_pixel: MmPerPixelArg,
    #[command(flatten)]
    signal_size: SignalSizeArg,
    /// Taps per pass of the real-time tap table: odd, comma-separated (11,17,25).
    ///
    /// The first count is the one stored in the kernels.
    #[arg(long, value_name = "N,...", value_delimiter = ',', default_value = ssskit::kernel::taps::DEFAULT_TAPS.to_string(), value_parser = args::taps)]
    taps: Vec<usize>,
    /// SVD ranks and Gaussian counts: N or N-M, comma-separated, e.g. 1-6 or 1,3.
    #[arg(long, value_name = "N-M,...", value_delimiter = ',', default_value = "1-3", value_parser = args::rank_item)]
    ranks: Vec<String>,
    #[command(flatten)]
    extent: ExtentArg,
    /// FLIP viewing condition: pixels per degree of visual angle.
    #[arg(long, value_name = "PPD", default_value_t = Options::default().pixels_per_degree, value_parser = args::real)]
    pixels_per_degree: f64,
    #[command(flatten)]
    no_plots: NoPlotsArg,
    #[command(flatten)]
    out_dir: OutDir,
    /// A path-traced scene (TOML) to score kernels on [default: none].
    ///
    /// Every kernel model through the screen-space pass on the scene's
    /// G-buffer, against the path-traced image (with --render; the profile
    /// is the render's).
    #[arg(long, value_name = "SCENE.toml", requires = "render")]
    scene: Option<PathBuf>,
    /// The scene's render, `ssskit scene SCENE.toml --out IMG.exr` [default: none].
    #[arg(long, value_name = "IMG.exr", requires = "scene")]
    render: Option<PathBuf>,
    /// Depth difference (mm) at which the depth-aware lerp reaches the centre colour [default: the radius holding 99% of R_d].
    ///
    /// The screen-space pass's follow-surface constant on the scene, in the
    /// scene's own length: the lerp reaches the centre colour at this depth
    /// difference.
    #[arg(long, value_name = "MM", requires = "scene", allow_negative_numbers = true, value_parser = args::real)]
    follow_mm: Option<f64>,
    /// Photons per channel and incidence of the scene's angular-factor run (0: none).
    ///
    /// One Monte Carlo run of the scene's material per entry node (N.L = 0,
    /// 1/8, ..., 1) with exit-angle bins: the entry and exit factors applied
    /// around the pass (rows `entry`, `exit`, `entry+exit` and
    /// `depth+follow+angular`). Seeded by --seed.
    #[arg(
        long,
        value_name = "N",
        requires = "scene",
        default_value = args::count_text(ssskit::kernel::angular::DEFAULT_PHOTONS),
        value_parser = args::count::<u64>
    )]
    angular_photons: u64,
    #[command(flatten)]
    directional: DirectionalArgs,
    /// Thickness table (`ssskit transmission --out`): the scene's object's [default: none].
    ///
    /// For a scene lit from behind: the screen-space input alone, the same
    /// plus each engine's transmission fitted to the table (the thickness
    /// from the shadow map or a thickness map, as the engine reads it), and
    /// the same plus the table itself, against the path-traced image; the
    /// first lines say what is lost without transmission.
    #[arg(long, value_name = "TABLE.json", requires = "scene")]
    transmission: Option<PathBuf>,
}

fn load_profiles(a: &Args) -> anyhow::Result<Vec<MaterialInput>> {
    let named = a.materials.named()?;
    if let Some(dir) = &a.profiles {
        let names: Vec<String> = match named {
            Some(v) => v.to_vec(),
            None => {
                let mut v: Vec<String> = std::fs::read_dir(dir)
                    .with_context(|| format!("--profiles {}", dir.display()))?
                    .filter_map(|e| e.ok())
                    .map(|e| e.path())
                    .filter(|p| p.extension().is_some_and(|x| x == "json"))
                    .filter_map(|p| p.file_stem()?.to_str().map(String::from))
                    .collect();
                v.sort();
                v
            }
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
    let Some(model) = a.profile_model.profile_model else {
        bail!(
            "give --profiles DIR (e.g. profiles/reference) or --profile-model {}",
            ProfileModel::value_variants()
                .iter()
                .map(args::flag_value)
                .collect::<Vec<_>>()
                .join("|")
        );
    };
    let names: Vec<String> = match named {
        Some(v) => v.to_vec(),
        None => MaterialsArg::half_space_presets(),
    };
    if model.analytic().is_none() && a.photons.photons == Some(0) {
        return Err(invalid("--photons", 0, "must be > 0"));
    }
    names
        .into_iter()
        .map(|n| -> anyhow::Result<MaterialInput> {
            let m = Material::load(&n).with_context(|| format!("material '{n}'"))?;
            // The pipeline's builder: all channels, the tracer's work cap,
            // the analytic models' Fresnel fits and default grid.
            let source = match (model.analytic(), a.photons.photons) {
                (Some(pm), _) => ProfileSource::analytic(pm),
                (None, Some(n)) => ProfileSource::photons(n, a.seed.seed),
                (None, None) => ProfileSource::monte_carlo(source::MC_MAX_PHOTONS, a.seed.seed),
            };
            let profile = source::make_profile(&m, &source, &Bar::new())?.0;
            Ok(MaterialInput {
                name: m.name.clone(),
                profile,
            })
        })
        .collect()
}

/// The light-space directional block of `compare --scene` (None for
/// `--directional-spp 0`).
fn directional_config(
    a: &Args,
) -> anyhow::Result<Option<ssskit::report::eval::scene::directional::DirectionalConfig>> {
    let samples = a.directional.samples()?;
    Ok((!samples.is_empty()).then_some(
        ssskit::report::eval::scene::directional::DirectionalConfig {
            samples,
            map_side: a.directional.light_map_side,
            seed: a.seed.seed,
            frames: a.frames,
        },
    ))
}

/// The tap counts in the order given, each once.
fn distinct(v: &[usize]) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::new();
    for &n in v {
        if !out.contains(&n) {
            out.push(n);
        }
    }
    out
}

pub fn run(a: Args) -> anyhow::Result<()> {
    // Disk kernels are not separable: they get their own rows, beside the
    // separable kernel at the same samples per pixel.
    let (disks, families): (Vec<String>, Vec<String>) = a
        .models
        .families()
        .into_iter()
        .partition(|f| f == ssskit::report::eval::disk::DISK);
    let with_disk = !disks.is_empty();
    let ranks = parse_ranks(&a.ranks.join(",")).context("--ranks")?;
    let taps = distinct(&a.taps);
    if taps.is_empty() {
        bail!("--taps: give at least one tap count");
    }
    let mm_per_pixel = positive("--mm-per-pixel", a.mm_per_pixel.or_default())?;
    positive("--pixels-per-degree", a.pixels_per_degree)?;
    let size = a.signal_size.signal_size;
    if let (Some(scene), Some(render)) = (&a.scene, &a.render) {
        return run_scene(&a, (scene, render), families, (ranks, taps));
    }
    let (cases, signals) = test_cases(&a, size, mm_per_pixel)?;
    if let Some(e) = a.extent.extent {
        positive("--extent", e)?;
    }
    let out_dir = a.out_dir.path()?;
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(out_dir)
        .with_context(|| format!("--out-dir {}", out_dir.display()))?;
    let no_plots = a.no_plots.no_plots;
    let inputs = load_profiles(&a)?;
    let options = Options {
        round_to_f32: true,
        pixels_per_degree: a.pixels_per_degree,
    };
    if families.is_empty() && !with_disk {
        bail!("--models: give at least one kernel model");
    }
    let cfg = Config {
        families,
        ranks: ranks.clone(),
        cases,
        taps: taps.clone(),
        options,
        keep: (!no_plots).then_some(Which::Taps(taps[0])),
        extent_mm: a.extent.extent,
    };
    let t0 = std::time::Instant::now();
    let cmp = compare::kernel::run(&inputs, &cfg, &Bar::new())?;
    let factors: Vec<Which> = std::iter::once(Which::Full)
        .chain(taps.iter().map(|&n| Which::Taps(n)))
        .collect();
    let command = command_line(out_dir);
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
        staged.path(),
        !no_plots,
        &format!("{}-tap tables", taps[0]),
    )?;
    ssskit::report::kernel_files::write_fitted_kernels(
        &cmp,
        &staged.path().join("kernels"),
        false,
    )?;
    let disk = if with_disk {
        Some(disk_rows(
            &inputs,
            &cfg.cases,
            &taps,
            a.frames,
            staged.path(),
        )?)
    } else {
        None
    };
    staged.commit()?;
    let claims = claims::claims(&cmp, &signals, &factors, &ranks);
    out!("{}", kernel_report::claims_table(&claims).markdown())?;
    if let Some(t) = disk {
        out!("\n{}", t.markdown())?;
    }
    eprintln!(
        "{} materials x {} kernels x {} images in {:.1} s -> {}/report.md, compare.csv, compare.json, kernels/{}",
        cmp.materials.len(),
        cmp.fitted.len(),
        signals.len(),
        t0.elapsed().as_secs_f64(),
        out_dir.display(),
        if no_plots { "" } else { ", PNG plots" }
    );
    Ok(())
}

/// `compare --scene --render`: the kernels scored on a path-traced scene.
fn run_scene(
    a: &Args,
    (scene, render): (&Path, &Path),
    families: Vec<String>,
    (ranks, taps): (Vec<usize>, Vec<usize>),
) -> anyhow::Result<()> {
    super::scene_compare::compare(super::scene_compare::CompareArgs {
        scene,
        render,
        families,
        ranks,
        taps,
        pixels_per_degree: a.pixels_per_degree,
        size: a.signal_size.signal_size,
        follow_mm: a.follow_mm,
        angular_photons: a.angular_photons,
        transmission: a.transmission.as_deref(),
        seed: a.seed.seed,
        plots: !a.no_plots.no_plots,
        out: a.out_dir.path()?,
        directional: directional_config(a)?,
    })
}

/// The test images: the named signals, then the given images (named by
/// their file stems), each at `mm_per_pixel`; and their names.
fn test_cases(
    a: &Args,
    size: usize,
    mm_per_pixel: f64,
) -> anyhow::Result<(Vec<ImageCase>, Vec<String>)> {
    let mut cases = Vec::new();
    let mut signals = Vec::new();
    for &sig in a.signals.iter().flatten() {
        let case = ImageCase::signal(sig.into(), size, mm_per_pixel)?;
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
            mm_per_pixel,
        });
    }
    Ok((cases, signals))
}

/// The disk rows of `compare --models ...,disk`: written to disk.json and
/// appended to report.md in `dir`; the table returned for stdout.
fn disk_rows(
    inputs: &[MaterialInput],
    cases: &[ImageCase],
    taps: &[usize],
    frames: u32,
    dir: &std::path::Path,
) -> anyhow::Result<ssskit::report::present::table::Table> {
    use ssskit::report::eval::compare::disk::compare_rows;
    let rows = compare_rows(inputs, cases, taps, frames)?;
    let t = ssskit::report::present::disk_table::disk_table(&rows, frames);
    ssskit::io::write_json_atomic(&dir.join("disk.json"), &serde_json::to_value(&rows)?)?;
    let report = dir.join("report.md");
    let mut md =
        std::fs::read_to_string(&report).with_context(|| format!("{}", report.display()))?;
    md.push_str(&format!(
        "\n## Disk kernels at equal samples per pixel\n\nThe pre-integrated separable kernel \
         (2 passes of T taps, 2 T samples per pixel) beside a disk kernel of as many samples, \
         importance-sampled from the profile: the disk's bias is the mean over {} rotations \
         against the exact image (+- its own noise floor), its noise the RMS of one frame and \
         of the mean of {frames} frames about that mean; % of the exact peak, largest \
         channel.\n\n{}",
        ssskit::report::eval::disk::WINDOWS * frames,
        t.markdown()
    ));
    ssskit::io::write_atomic(&report, md.as_bytes())?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Args as _, FromArgMatches};
    use ssskit::material::Channel;
    use ssskit::profile::analytic::{self, Model};

    fn parse(argv: &[&str]) -> Args {
        let m = Args::augment_args(clap::Command::new("compare"))
            .try_get_matches_from(argv)
            .unwrap();
        Args::from_arg_matches(&m).unwrap()
    }

    /// `--profile-model` with an analytic model: each material's profile is
    /// that model's closed form on the default grid, with the Fresnel fits,
    /// in every channel.
    #[test]
    fn analytic_profiles_are_the_closed_forms() {
        let m = Material::load("skin1").unwrap();
        let grid = analytic::default_grid(&m, &Channel::ALL).unwrap();
        let fits = analytic::Options {
            fresnel: ssskit::profile::fresnel::FresnelMode::Fit,
            channels: Channel::ALL.to_vec(),
        };
        for (flag, model) in [
            ("dipole", Model::Dipole),
            ("pbd", Model::Pbd),
            ("burley", Model::Burley),
            ("directional-dipole", Model::DirectionalDipole),
        ] {
            let a = parse(&[
                "compare",
                "--materials",
                "skin1",
                "--profile-model",
                flag,
                "--out-dir",
                "out",
            ]);
            let got = load_profiles(&a).unwrap();
            let want = analytic::profile(&m, model, &grid, &fits).unwrap();
            assert_eq!(got.len(), 1);
            assert_eq!(got[0].name, "skin1");
            assert_eq!(got[0].profile.r_edges, want.r_edges, "{flag}");
            assert_eq!(got[0].profile.rd, want.rd, "{flag}");
        }
    }

    /// `--profile-model mc`: the tracer's profile with the given photons
    /// and seed in every channel, as `simulate` makes it.
    #[test]
    fn monte_carlo_profiles_use_the_given_photons_and_seed() {
        use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
        let a = parse(&[
            "compare",
            "--materials",
            "skin1",
            "--profile-model",
            "mc",
            "--photons",
            "3000",
            "--seed",
            "11",
            "--out-dir",
            "out",
        ]);
        let got = load_profiles(&a).unwrap();
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(3000),
            seed: 11,
            threads: None,
            channels: Channel::ALL.to_vec(),
            grid: None,
        };
        let m = Material::load("skin1").unwrap();
        let want = simulate(&m, &cfg, &ssskit::progress::NoProgress).unwrap();
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].profile.source.photons, Some(vec![3000; 3]));
        assert_eq!(got[0].profile.rd, want.rd);
        assert_eq!(got[0].profile.total_rd, want.total_rd);
    }
}
