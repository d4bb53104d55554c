//! Every flag that more than one subcommand takes, defined once: its name,
//! value name, one-line help (`-h`), long help (`--help`), parser and,
//! where the subcommands agree, its default, taken from the library's
//! constants. A subcommand whose default differs, or that ties a flag to
//! another (requires, conflicts), says so on its own argument struct with
//! `#[command(mut_arg("id", ...))]`, so that its `--help` shows it.
//!
//! The vocabulary (`src/cli/walk.rs` checks it on every subcommand): one
//! name per concept and one concept per name; a flag's value name says the
//! kind of value (`N` a count, `MM`, `PX`, `DEG`, `E` a relative error,
//! `FILE`, `DIR`...), the same in every subcommand; a list takes commas
//! (`N,...`) and is named in the plural where one value would be singular;
//! counts accept exponent notation (`1e6`) everywhere ([`count`]).
//!
//! Old spellings stay as hidden aliases ([`alias`]): they still work and
//! print a one-line deprecation note ([`deprecated_spellings`]); messages
//! name the flag as the user typed it (`errors::set_typed`).

mod budget;
mod deprecated;
mod directional;
pub mod engine;
mod model;
mod settings;
mod values;

pub use budget::BudgetArgs;
pub use deprecated::{deprecated_spellings, running_command};
pub use directional::DirectionalArgs;
pub use engine::EngineChoice;
pub use model::ModelArg;
pub use settings::{
    alias, default, default_enum, help, long_help_opens_with_help, negative_numbers_are_values,
    required,
};
pub use values::{
    channel_item, count, count_text, counts_text, flag_value, image_size, name_item, rank_item,
    real, rgb, rgb_text, signal_size, taps, value_or,
};

use clap::builder::PossibleValue;
use clap::ValueEnum;
use ssskit::material::Channel;
use ssskit::profile::mc;
use ssskit::report::eval::evaluate;
use std::path::{Path, PathBuf};

// ---- Shared enumerations ---------------------------------------------------

/// Where the work runs (`simulate`, `apply`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The CPU.
    Cpu,
    /// wgpu; an error when no adapter is found.
    Gpu,
    /// wgpu on a hardware adapter, else the CPU; says which it used.
    Auto,
}

/// How a profile is made from a material (`ssskit::profile::ProfileSource`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ProfileModel {
    /// Monte Carlo photon tracing (the simulate tracer).
    Mc,
    /// Standard dipole (Jensen et al. 2001), closed form.
    Dipole,
    /// Photon beam diffusion (Habel et al. 2013), closed form.
    Pbd,
    /// Normalized diffusion (Christensen and Burley 2015).
    Burley,
    /// Directional dipole (Frisvad et al. 2014) at normal incidence.
    DirectionalDipole,
}

impl ProfileModel {
    /// The analytic model, None for Monte Carlo.
    pub fn analytic(self) -> Option<ssskit::profile::analytic::Model> {
        use ssskit::profile::analytic::Model;
        match self {
            ProfileModel::Mc => None,
            ProfileModel::Pbd => Some(Model::Pbd),
            ProfileModel::Dipole => Some(Model::Dipole),
            ProfileModel::Burley => Some(Model::Burley),
            ProfileModel::DirectionalDipole => Some(Model::DirectionalDipole),
        }
    }
}

/// Fresnel moments of the analytic models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Fresnel {
    /// Polynomial fits of the Fresnel moments (d'Eon and Irving 2011).
    Fit,
    /// Numerical integration of the exact Fresnel reflectance.
    Exact,
}

impl From<Fresnel> for ssskit::profile::fresnel::FresnelMode {
    fn from(f: Fresnel) -> Self {
        match f {
            Fresnel::Fit => Self::Fit,
            Fresnel::Exact => Self::Exact,
        }
    }
}

/// `--backend`: each subcommand sets its default.
#[derive(clap::Args)]
pub struct BackendArg {
    /// Where it runs: cpu, gpu (wgpu) or auto (a hardware GPU when found).
    ///
    /// The GPU computes in f32 (simulate: the GPU tracer has classic
    /// boundaries only, docs/mc_gpu.md; apply: see --precision for the
    /// CPU). The same seed gives the same output per backend and adapter,
    /// not across them. auto prefers a hardware adapter and says which
    /// backend ran; a software rasteriser (lavapipe) is slower than the
    /// CPU, so auto leaves it out (--backend gpu forces it).
    #[arg(long, value_enum, value_name = "WHERE", required = false)]
    pub backend: Backend,
}

// The arguments of a subcommand that only groups others (`ssskit plot
// profile`); `W` lists them. A plain comment: a doc comment here would
// become the help of every such group.
#[derive(clap::Args)]
pub struct Group<W: clap::Subcommand> {
    #[command(subcommand)]
    pub what: W,
}

// ---- Inputs ------------------------------------------------------------------

/// `--material`.
#[derive(clap::Args)]
pub struct MaterialArg {
    /// Material: a preset name (see `ssskit materials`) or a TOML file.
    #[arg(long, value_name = "NAME")]
    pub material: Option<String>,
}

/// `--materials` (None: all).
#[derive(clap::Args)]
pub struct MaterialsArg {
    /// Materials: presets or TOML files, comma-separated, or all
    /// [default: all].
    ///
    /// `all`: with --profiles DIR every <material>.json there, otherwise
    /// every preset that is one semi-infinite layer (the analytic models
    /// need a half-space).
    #[arg(long, value_name = "NAME,...", value_delimiter = ',', value_parser = name_item)]
    materials: Vec<String>,
}

impl MaterialsArg {
    /// The names given, or None for all (also when `all` is given).
    pub fn named(&self) -> anyhow::Result<Option<&[String]>> {
        match self.materials.as_slice() {
            [] => Ok(None),
            [one] if one == "all" => Ok(None),
            v if v.iter().any(|m| m == "all") => Err(super::errors::invalid(
                "--materials",
                v.join(","),
                "'all' stands alone",
            )),
            v => Ok(Some(v)),
        }
    }

    /// Every half-space preset (what `all` means without a profile folder).
    pub fn half_space_presets() -> Vec<String> {
        ssskit::material::preset_names()
            .iter()
            .filter(|n| ssskit::material::Material::load(n).is_ok_and(|m| m.is_half_space()))
            .map(|s| s.to_string())
            .collect()
    }
}

/// `--profile`.
#[derive(clap::Args)]
pub struct ProfileFile {
    /// Reflectance profile file (ssskit.profile/1 JSON).
    #[arg(long, value_name = "PROFILE.json")]
    pub profile: Option<PathBuf>,
}

/// `--kernel`.
#[derive(clap::Args)]
pub struct KernelFile {
    /// Kernel file (ssskit.kernel/1 JSON).
    #[arg(long, value_name = "KERNEL.json")]
    pub kernel: Option<PathBuf>,
}

/// `--profile-model`: no default here; each subcommand sets its own.
#[derive(clap::Args)]
pub struct ProfileModelArg {
    /// Profile model: how the profile is made from the material.
    #[arg(long, value_enum, value_name = "MODEL")]
    pub profile_model: Option<ProfileModel>,
}

/// `--fresnel`.
#[derive(clap::Args)]
pub struct FresnelArg {
    /// Fresnel moments of the analytic models: polynomial fits or exact.
    #[arg(long, value_enum, value_name = "MODE", default_value_t = Fresnel::Fit)]
    pub fresnel: Fresnel,
}

/// `--channels`.
#[derive(clap::Args)]
pub struct ChannelsArg {
    /// Channels: r, g, b, a list (r,g) or letters (rgb).
    #[arg(long, value_name = "RGB", value_delimiter = ',', default_value = "rgb", value_parser = channel_item)]
    channels: Vec<String>,
}

impl ChannelsArg {
    pub fn channels(&self) -> anyhow::Result<Vec<Channel>> {
        Ok(Channel::parse_list(&self.channels.concat())?)
    }

    /// Whether the default (all three) was left.
    pub fn is_default(&self) -> bool {
        self.channels == ["rgb"]
    }
}

/// `--dr`, `--rmax`: the radial grid (`ssskit::profile::GridSpec`).
#[derive(clap::Args)]
pub struct GridArgs {
    /// Radial bin width in mm [default: min MFP / 20, Freude 2014, table 6.1].
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = real)]
    pub dr: Option<f64>,
    /// Largest radius of the grid in mm [default: from the material].
    ///
    /// The default is the larger of 32 times the largest MFP (Freude 2014,
    /// table 6.1) and the radius where the exponential tail falls to 1e-5,
    /// ln(1e5) / min(sigma_tr, sigma_t), at most 2000 times the largest
    /// MFP.
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = real)]
    pub rmax: Option<f64>,
}

// ---- Monte Carlo ---------------------------------------------------------------

/// `--photons`.
#[derive(clap::Args)]
pub struct PhotonsArg {
    /// Photons per channel of the Monte Carlo run: a fixed count (e.g. 1e6).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = count::<u64>)]
    pub photons: Option<u64>,
}

/// `--mc-error`: no default here; each subcommand sets its own.
#[derive(clap::Args)]
pub struct McErrorArg {
    /// Monte Carlo target: relative standard error of total R_d and profile.
    ///
    /// Photons are traced until the relative standard error of total R_d
    /// and of the profile (the R_d-weighted mean relative error of the
    /// bins inside the radius holding 99% of R_d) are below E in every
    /// channel, or until --max-photons.
    #[arg(long, value_name = "E", allow_hyphen_values = true, value_parser = real)]
    pub mc_error: Option<f64>,
}

/// `--max-photons`: each subcommand sets its default.
#[derive(clap::Args)]
pub struct MaxPhotonsArg {
    /// Monte Carlo photon cap per channel of the error targets.
    #[arg(long, value_name = "N", required = false, allow_hyphen_values = true, value_parser = count::<u64>)]
    pub max_photons: u64,
}

/// `--seed`: one default for every Monte Carlo run.
#[derive(clap::Args)]
pub struct SeedArg {
    /// Monte Carlo seed: the same seed gives the same result, any thread count.
    #[arg(long, value_name = "N", default_value_t = mc::DEFAULT_SEED, value_parser = count::<u64>)]
    pub seed: u64,
}

/// `--threads`: the worker threads of a Monte Carlo run.
#[derive(clap::Args)]
pub struct ThreadsArg {
    /// Worker threads (results are identical for any count) [default: one per core].
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = count::<usize>)]
    pub threads: Option<usize>,
}

/// `--seed`, `--threads` and `--channels`: a Monte Carlo run of `simulate`
/// or `transmission`, its seed, its workers and the channels it traces.
#[derive(clap::Args)]
pub struct McRunArgs {
    #[command(flatten)]
    pub seed: SeedArg,
    #[command(flatten)]
    pub threads: ThreadsArg,
    #[command(flatten)]
    pub channels: ChannelsArg,
}

/// Where `kernels`, `advise` and `study` get their profile: a file, or
/// made from a material by Monte Carlo or an analytic model.
#[derive(clap::Args)]
pub struct ProfileSourceArgs {
    #[command(flatten)]
    pub material: MaterialArg,
    #[command(flatten)]
    pub profile: ProfileFile,
    #[command(flatten)]
    pub model: ProfileModelArg,
    #[command(flatten)]
    pub mc_error: McErrorArg,
    #[command(flatten)]
    pub max_photons: MaxPhotonsArg,
    #[command(flatten)]
    pub seed: SeedArg,
}

/// `#[command(mut_args(profile_source(MODEL)))]`: the settings of
/// [`ProfileSourceArgs`] in every subcommand that takes it: the pipeline's
/// Monte Carlo defaults, `--profile` read instead of made, this
/// subcommand's default profile model, the old spelling.
pub fn profile_source(model: ProfileModel) -> impl FnMut(clap::Arg) -> clap::Arg {
    move |a| match a.get_id().as_str() {
        "profile" => a
            .conflicts_with_all(["material", "profile_model"])
            .help("Reflectance profile file (ssskit.profile/1 JSON): read, not made"),
        "profile_model" => default_enum(model)(a),
        "mc_error" => a.help(format!(
            "Monte Carlo target: relative standard error of total R_d and profile \
             [default: none: the kernel-factor rule, E = {}, as in simulate]",
            mc::DEFAULT_KERNEL_ERROR
        )),
        "max_photons" => {
            default(count_text(ssskit::profile::source::MC_MAX_PHOTONS))(a).alias("mc-photons")
        }
        _ => a,
    }
}

// ---- Scale and test images ------------------------------------------------------

/// `--mm-per-pixel`.
#[derive(clap::Args)]
pub struct MmPerPixelArg {
    /// Scale: surface millimetres per pixel.
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = real)]
    pub mm_per_pixel: Option<f64>,
}

impl MmPerPixelArg {
    /// The value, the test signals' default where the subcommand sets none.
    pub fn or_default(&self) -> f64 {
        self.mm_per_pixel.unwrap_or(evaluate::DEFAULT_MM_PER_PIXEL)
    }
}

/// `--fov-y`.
#[derive(clap::Args)]
pub struct FovYArg {
    /// Vertical field of view in degrees (perspective scale, Freude 2014, eq. 4.11).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true, value_parser = real)]
    pub fov_y: Option<f64>,
}

/// `--units-per-mm`.
#[derive(clap::Args)]
pub struct UnitsPerMmArg {
    /// Scene units per millimetre (0.001: a scene in metres; Jimenez's sssWidth).
    #[arg(long, value_name = "UNITS", allow_negative_numbers = true, default_value_t = ssskit::engine::Scene::default().units_per_mm, value_parser = real)]
    pub units_per_mm: f64,
}

/// `--signal-size`.
#[derive(clap::Args)]
pub struct SignalSizeArg {
    /// Side of the square test signals, pixels.
    #[arg(long, value_name = "PX", default_value_t = evaluate::DEFAULT_SIGNAL_SIZE, value_parser = signal_size)]
    pub signal_size: usize,
}

/// `--image-size`.
#[derive(clap::Args)]
pub struct ImageSizeArg {
    /// Image size in pixels, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", required = false, value_parser = image_size)]
    pub image_size: (usize, usize),
}

/// `--image-error`.
#[derive(clap::Args)]
pub struct ImageErrorArg {
    /// Image-space target: the largest relative RMS accepted (0.05 = 5%).
    ///
    /// Relative RMS as `ssskit diff` reports it (per channel, divided by
    /// the exact image's peak), the largest over channels and test signals.
    #[arg(long, value_name = "E", allow_negative_numbers = true, default_value_t = ssskit::report::eval::advise::DEFAULT_TARGET, value_parser = real)]
    pub image_error: f64,
}

impl ImageErrorArg {
    /// The target as a fraction; 1 or more is refused (a percent typed
    /// where a fraction is meant: `--image-error 5` means 5%, not 500%).
    pub fn fraction(&self) -> anyhow::Result<f64> {
        let e = self.image_error;
        if e >= 1.0 && e.is_finite() {
            return Err(super::errors::invalid(
                "--image-error",
                e,
                &format!(
                    "the target is a relative RMS, a fraction of the exact image's peak between \
                     0 and 1 (0.05 is 5%); {e} would be {}%: for {e}% give {}",
                    e * 100.0,
                    e / 100.0
                ),
            ));
        }
        if !(e > 0.0 && e.is_finite()) {
            return Err(super::errors::invalid(
                "--image-error",
                e,
                "must be > 0 (a fraction: 0.05 is 5%)",
            ));
        }
        Ok(e)
    }
}

/// `--scene` with `--render`: the advice checked on a path-traced scene.
#[derive(clap::Args)]
pub struct SceneCheckArgs {
    /// A path-traced scene (TOML) to score kernels on [default: none].
    ///
    /// Each model's answer within the budget and the chosen one run
    /// through the screen-space pass on the scene's G-buffer (scaled by
    /// depth, depth-aware) against its path-traced image (--render),
    /// without and with the entry and exit factors around the pass: the
    /// chosen kernel's scene error beside the best's, with the uncertainty
    /// the render's noise gives the difference. The seen object must be of
    /// the advised material (the same preset, eta included). Without
    /// --material or --profile the profile is the render's own (its first
    /// object's); the scale is the scene's unless --mm-per-pixel is given
    /// (and then must agree).
    #[arg(long, value_name = "SCENE.toml", requires = "render")]
    pub scene: Option<PathBuf>,
    /// The scene's render, `ssskit scene SCENE.toml --out IMG.exr` [default: none].
    #[arg(long, value_name = "IMG.exr", requires = "scene")]
    pub render: Option<PathBuf>,
}

/// `--models`.
#[derive(clap::Args)]
pub struct ModelsArg {
    /// Kernel models, comma-separated, or all.
    #[arg(long, value_name = "MODEL,...", value_delimiter = ',', required = false, value_parser = value_or::<ModelArg>(PossibleValue::new("all")))]
    models: Vec<Option<ModelArg>>,
}

impl ModelsArg {
    /// The kernel model families, as the library spells them.
    pub fn families(&self) -> Vec<String> {
        match self.models.iter().copied().collect::<Option<Vec<_>>>() {
            Some(models) => models.iter().map(flag_value).collect(),
            None => ssskit::report::eval::compare::kernel::FAMILIES
                .iter()
                .map(|s| s.to_string())
                .collect(),
        }
    }
}

/// `--frames` of the commands that choose a kernel to ship (`advise`,
/// `kernels`): the frames a temporal filter accumulates.
#[derive(clap::Args)]
pub struct FramesArg {
    /// Frames: disk kernels are scored on the mean of this many, 1 to 64.
    ///
    /// A temporal filter accumulates them under a static camera; a disk kernel's image changes
    /// every frame (its per-pixel rotation). Its score on a signal is the relative RMS, in its
    /// worst channel, of the first accumulation of N frames against the exact image: what `apply`
    /// makes of the kernel written, which records N and runs it by default. Its uncertainty adds
    /// the spread over 4 such accumulations to the bootstrap's. Separable kernels are the same
    /// every frame.
    #[arg(long, value_name = "N", value_parser = count::<u32>, default_value_t = ssskit::report::eval::disk::DEFAULT_FRAMES)]
    pub frames: u32,
}

/// `--taps` (one count; `compare` takes a list).
#[derive(clap::Args)]
pub struct TapsArg {
    /// Taps per pass of the real-time tap table: odd, 1 to 255.
    #[arg(long, value_name = "N", default_value_t = ssskit::kernel::taps::DEFAULT_TAPS, value_parser = taps)]
    pub taps: usize,
}

/// `--extent`.
#[derive(clap::Args)]
pub struct ExtentArg {
    /// Half-width of the kernel in mm [default: the radius holding 99.9% of R_d].
    #[arg(long, value_name = "MM", allow_negative_numbers = true, value_parser = real)]
    pub extent: Option<f64>,
}

// ---- Outputs ---------------------------------------------------------------------

/// `--out`: an output file; each subcommand says which in its help.
#[derive(clap::Args)]
pub struct OutFile {
    /// Output file: its extension picks the format.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

impl OutFile {
    /// The path where the subcommand requires one (clap has checked).
    pub fn path(&self) -> anyhow::Result<&Path> {
        given(&self.out, "--out FILE")
    }
}

/// `--out-dir`: required but where a subcommand says otherwise.
#[derive(clap::Args)]
pub struct OutDir {
    /// Output folder (created).
    #[arg(long, value_name = "DIR", required = true)]
    pub out_dir: Option<PathBuf>,
}

impl OutDir {
    /// The folder where the subcommand requires one (clap has checked).
    pub fn path(&self) -> anyhow::Result<&Path> {
        given(&self.out_dir, "--out-dir DIR")
    }
}

/// The path of an output flag a subcommand requires (clap has checked; the
/// error names `flag` with its value name, should it ever be reached).
fn given<'a>(path: &'a Option<PathBuf>, flag: &str) -> anyhow::Result<&'a Path> {
    path.as_deref()
        .ok_or_else(|| anyhow::anyhow!("give {flag}"))
}

/// `--csv`.
#[derive(clap::Args)]
pub struct CsvArg {
    /// Also write a CSV: the profile [default: not written].
    #[arg(long, value_name = "FILE.csv")]
    pub csv: Option<PathBuf>,
}

/// `--json`.
#[derive(clap::Args)]
pub struct JsonArg {
    /// JSON on standard output instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `--no-plots`.
#[derive(clap::Args)]
pub struct NoPlotsArg {
    /// No PNG plots.
    #[arg(long)]
    pub no_plots: bool,
}

/// `--no-factors`.
#[derive(clap::Args)]
pub struct FactorsArg {
    /// Leave out the entry and exit factors (and their Monte Carlo run).
    ///
    /// By default a profile made from --material by Monte Carlo gets the
    /// angle-resolved entry and exit factors (one more run, a few seconds),
    /// which every kernel and shader array then carries.
    #[arg(long)]
    pub no_factors: bool,
}

/// What `kernels` and `study` measure on and where their report goes.
#[derive(clap::Args)]
pub struct ReportArgs {
    #[command(flatten)]
    pub mm_per_pixel: MmPerPixelArg,
    #[command(flatten)]
    pub signal_size: SignalSizeArg,
    #[command(flatten)]
    pub no_plots: NoPlotsArg,
    #[command(flatten)]
    pub out_dir: OutDir,
}

/// `#[command(mut_args(report()))]`: the settings of [`ReportArgs`] in every
/// subcommand that takes it, with the old spellings.
pub fn report() -> impl FnMut(clap::Arg) -> clap::Arg {
    |a| match a.get_id().as_str() {
        "mm_per_pixel" => default(evaluate::DEFAULT_MM_PER_PIXEL)(a),
        "signal_size" => a.alias("size"),
        "out_dir" => a.alias("out"),
        _ => a,
    }
}
