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

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::ValueEnum;
use ssskit::material::Channel;
use ssskit::profile::mc;
use ssskit::report::{evaluate, pipeline};
use std::ffi::OsString;
use std::path::{Path, PathBuf};

// ---- Parsers -------------------------------------------------------------

// A parser's message is the reason only: the one format of a bad value
// (`errors::parse_error`) names the flag and the value.

/// A count: an integer, or a whole number in exponent notation (1e6).
pub fn count<T: TryFrom<u64>>(s: &str) -> Result<T, String> {
    let t = s.trim();
    let n = match t.parse::<u64>() {
        Ok(n) => n,
        Err(_) => {
            let v: f64 = t
                .parse()
                .map_err(|_| "expected a whole number, e.g. 1000000 or 1e6".to_string())?;
            if !(v >= 0.0 && v.fract() == 0.0) {
                return Err("expected a whole number >= 0, e.g. 1000000 or 1e6".into());
            }
            // 2^64 is exactly representable; every f64 below it converts exactly.
            if v >= 18_446_744_073_709_551_616.0 {
                return Err(format!("beyond the largest count, {}", u64::MAX));
            }
            v as u64
        }
    };
    T::try_from(n).map_err(|_| format!("too large (at most {})", max_of::<T>()))
}

/// The largest `T` a count converts to.
fn max_of<T: TryFrom<u64>>() -> u64 {
    // The largest n with T::try_from(n) ok: bisection over u64.
    let (mut lo, mut hi) = (0u64, u64::MAX);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if T::try_from(mid).is_ok() {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    lo
}

/// "WIDTHxHEIGHT", each a [`count`].
pub fn image_size(s: &str) -> Result<(usize, usize), String> {
    let bad = || "expected WIDTHxHEIGHT, e.g. 512x256".to_string();
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    Ok((count(w).map_err(|_| bad())?, count(h).map_err(|_| bad())?))
}

/// "R,G,B": three numbers, one per channel.
pub fn rgb(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("not three numbers R,G,B ({e})"))?;
    match v.as_slice() {
        [r, g, b] => Ok([*r, *g, *b]),
        _ => Err(format!("{} values, expected three (R,G,B)", v.len())),
    }
}

/// "R,G,B" of a default, as [`rgb`] reads it back.
pub fn rgb_text(v: [f64; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}

/// A tap count: odd, 1 to 255 (`ssskit::kernel::taps::check_count`).
pub fn taps(s: &str) -> Result<usize, String> {
    let n = count::<usize>(s)?;
    ssskit::kernel::taps::check_count(n).map_err(|e| reason(&e))?;
    Ok(n)
}

/// Side of a square test signal, in [`evaluate::SIGNAL_SIZE_RANGE`].
pub fn signal_size(s: &str) -> Result<usize, String> {
    let n = count::<usize>(s)?;
    let r = evaluate::SIGNAL_SIZE_RANGE;
    if !r.contains(&n) {
        return Err(format!("must be between {} and {}", r.start(), r.end()));
    }
    Ok(n)
}

/// One item of a rank list, "N" or "N-M", as the library reads it
/// (`kernel_compare::parse_ranks`); kept as text for that reader.
pub fn rank_item(s: &str) -> Result<String, String> {
    ssskit::report::kernel_compare::parse_ranks(s).map_err(|e| reason(&e))?;
    Ok(s.trim().to_string())
}

/// One item of a channel list: "r", "g", "b" or letters of them ("rgb"),
/// as the library reads them (`Channel::parse_list`).
pub fn channel_item(s: &str) -> Result<String, String> {
    Channel::parse_list(s).map_err(|e| reason(&e))?;
    Ok(s.trim().to_string())
}

/// A name in a list: not empty.
pub fn name_item(s: &str) -> Result<String, String> {
    match s.trim() {
        "" => Err("an empty name (two commas in a row?)".into()),
        t => Ok(t.to_string()),
    }
}

/// The reason of a library error, for a parser's message (clap names the
/// flag and the value).
fn reason(e: &ssskit::Error) -> String {
    match e {
        ssskit::Error::Invalid { reason, .. } => reason.clone(),
        e => e.to_string(),
    }
}

/// A list item of an enumerated flag: a value of `T` (Some) or the one
/// extra word `other` (None). The values' own help is dropped: it names
/// the flags of the subcommand that owns `T`.
pub fn value_or<T>(other: PossibleValue) -> impl TypedValueParser<Value = Option<T>>
where
    T: ValueEnum + Clone + Send + Sync + 'static,
{
    let values = T::value_variants()
        .iter()
        .filter_map(ValueEnum::to_possible_value)
        .map(|v| v.help(None::<&'static str>));
    PossibleValuesParser::new(std::iter::once(other).chain(values))
        .map(|s| T::from_str(&s, false).ok())
}

/// How a value of an enumerated flag is spelled on the command line.
pub fn flag_value<T: ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

// ---- Per-subcommand settings of a shared flag ----------------------------

/// `mut_arg(ID, default(v))`: this subcommand's default, shown in its help.
pub fn default<T: std::fmt::Display>(v: T) -> impl FnOnce(clap::Arg) -> clap::Arg {
    let s = v.to_string();
    move |a| a.default_value(s)
}

/// [`default`] of an enumerated flag.
pub fn default_enum<T: ValueEnum>(v: T) -> impl FnOnce(clap::Arg) -> clap::Arg {
    default(flag_value(&v))
}

/// `mut_arg(ID, help(...))`: this subcommand's one-line help; it keeps the
/// shared flag's concept (the words before the first ':').
pub fn help(text: &'static str) -> impl FnOnce(clap::Arg) -> clap::Arg {
    move |a| a.help(text)
}

/// `mut_arg(ID, required())`.
pub fn required() -> impl FnOnce(clap::Arg) -> clap::Arg {
    |a| a.required(true)
}

/// `mut_arg(ID, alias("--old"))`: a deprecated spelling, hidden, still
/// accepted, with a note when used.
pub fn alias(old: &'static str) -> impl FnOnce(clap::Arg) -> clap::Arg {
    move |a| a.alias(old.trim_start_matches("--"))
}

/// The long help (`--help`) of every argument of `cmd` and its
/// subcommands opens with its one-line help (`-h`): where a subcommand
/// refines the one-line help of a shared flag, the long help follows.
pub fn long_help_opens_with_help(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        let (Some(short), Some(long)) = (a.get_help(), a.get_long_help()) else {
            return a;
        };
        let (short, long) = (short.to_string(), long.to_string());
        let rest = long.split_once("\n\n").map_or("", |(_, rest)| rest);
        let first = long.split_once("\n\n").map_or(long.as_str(), |(f, _)| f);
        if first.trim_end_matches('.') == short {
            return a;
        }
        let text = if rest.is_empty() {
            short
        } else {
            format!("{short}\n\n{rest}")
        };
        a.long_help(text)
    })
    .mut_subcommands(long_help_opens_with_help)
}

/// A count as a person writes it: 1e6, 1.5e9, 20260101, 17.
pub fn count_text(n: u64) -> String {
    let zeros = (0..19)
        .take_while(|&k| n != 0 && n.is_multiple_of(10u64.pow(k + 1)))
        .count() as u32;
    if n < 10_000 || zeros < 3 {
        return n.to_string();
    }
    let m = (n / 10u64.pow(zeros)).to_string();
    let exp = zeros as usize + m.len() - 1;
    match m.split_at(1) {
        (d, "") => format!("{d}e{exp}"),
        (d, frac) => format!("{d}.{frac}e{exp}"),
    }
}

/// Counts as a person writes them, comma-separated.
pub fn counts_text(v: &[u64]) -> String {
    v.iter()
        .map(|&n| count_text(n))
        .collect::<Vec<_>>()
        .join(",")
}

// ---- Deprecated spellings --------------------------------------------------

/// A deprecated spelling the user typed: the flag as typed (`--size`), the
/// flag it stands for (`--signal-size`), and the note to print.
pub struct Deprecated {
    pub typed: String,
    pub canonical: String,
    pub note: String,
}

/// The subcommand `argv` runs (walking the subcommand names from the top;
/// the top-level command has no flag that takes a value, so no value can
/// be mistaken for a name).
pub fn running_command(top: &clap::Command, argv: &[OsString]) -> clap::Command {
    let mut c = top.clone();
    for a in argv.iter().skip(1) {
        let Some(a) = a.to_str() else { break };
        if a.starts_with('-') {
            continue;
        }
        match c.find_subcommand(a) {
            Some(sub) => c = sub.clone(),
            None => break,
        }
    }
    c
}

/// The deprecated spellings among the flags of `argv` for the subcommand
/// `cmd`: hidden aliases of a flag, and hidden flags (whose help says what
/// replaces them).
pub fn deprecated_spellings(cmd: &clap::Command, argv: &[OsString]) -> Vec<Deprecated> {
    let mut out: Vec<Deprecated> = Vec::new();
    for a in argv.iter().skip(1) {
        let Some(a) = a.to_str() else { continue };
        if a == "--" {
            break;
        }
        let Some(name) = a.strip_prefix("--") else {
            continue;
        };
        let name = name.split_once('=').map_or(name, |(n, _)| n);
        let typed = format!("--{name}");
        if out.iter().any(|d| d.typed == typed) {
            continue;
        }
        for arg in cmd.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            let hidden_alias = arg.get_all_aliases().unwrap_or_default().contains(&name)
                && !arg
                    .get_visible_aliases()
                    .unwrap_or_default()
                    .contains(&name);
            if hidden_alias {
                out.push(Deprecated {
                    note: format!("note: {typed} is deprecated: use --{long}"),
                    typed: typed.clone(),
                    canonical: format!("--{long}"),
                });
            } else if long == name && arg.is_hide_set() {
                let why = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
                out.push(Deprecated {
                    note: format!("note: {typed} is {}", lower_first(&why)),
                    typed: typed.clone(),
                    canonical: typed.clone(),
                });
            }
        }
    }
    out
}

fn lower_first(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_lowercase().chain(c).collect(),
        None => String::new(),
    }
}

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

/// How a profile is made from a material (`ssskit::report::pipeline::ProfileSource`).
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
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub dr: Option<f64>,
    /// Largest radius of the grid in mm [default: from the material].
    ///
    /// The default is the larger of 32 times the largest MFP (Freude 2014,
    /// table 6.1) and the radius where the exponential tail falls to 1e-5,
    /// ln(1e5) / min(sigma_tr, sigma_t), at most 2000 times the largest
    /// MFP.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
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
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
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
        "mc_error" => default(pipeline::MC_REL_ERROR)(a),
        "max_photons" => default(count_text(pipeline::MC_MAX_PHOTONS))(a).alias("mc-photons"),
        _ => a,
    }
}

// ---- Scale and test images ------------------------------------------------------

/// `--mm-per-pixel`.
#[derive(clap::Args)]
pub struct MmPerPixelArg {
    /// Scale: surface millimetres per pixel.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
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
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub fov_y: Option<f64>,
}

/// `--units-per-mm`.
#[derive(clap::Args)]
pub struct UnitsPerMmArg {
    /// Scene units per millimetre (0.001: a scene in metres; Jimenez's sssWidth).
    #[arg(
        long,
        value_name = "UNITS",
        allow_negative_numbers = true,
        default_value_t = ssskit::engine::Scene::default().units_per_mm
    )]
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
    #[arg(
        long,
        value_name = "E",
        allow_negative_numbers = true,
        default_value_t = ssskit::report::advise::DEFAULT_TARGET
    )]
    pub image_error: f64,
}

/// `--models`.
#[derive(clap::Args)]
pub struct ModelsArg {
    /// Kernel models, comma-separated, or all.
    #[arg(long, value_name = "MODEL,...", value_delimiter = ',', required = false, value_parser = value_or::<super::fit::ModelArg>(PossibleValue::new("all")))]
    models: Vec<Option<super::fit::ModelArg>>,
}

impl ModelsArg {
    /// The kernel model families, as the library spells them.
    pub fn families(&self) -> Vec<String> {
        match self.models.iter().copied().collect::<Option<Vec<_>>>() {
            Some(models) => models.iter().map(flag_value).collect(),
            None => ssskit::report::kernel_compare::FAMILIES
                .iter()
                .map(|s| s.to_string())
                .collect(),
        }
    }
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
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
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
        self.out
            .as_deref()
            .ok_or_else(|| anyhow::anyhow!("give --out FILE"))
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
        self.out_dir
            .as_deref()
            .ok_or_else(|| anyhow::anyhow!("give --out-dir DIR"))
    }
}

/// `--csv`.
#[derive(clap::Args)]
pub struct CsvArg {
    /// Also write the profile as CSV [default: not written].
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_take_exponent_notation() {
        assert_eq!(count::<u64>("1000000"), Ok(1_000_000));
        assert_eq!(count::<u64>("1e6"), Ok(1_000_000));
        assert_eq!(count::<u64>(" 2.5e3 "), Ok(2500));
        assert_eq!(count::<usize>("17"), Ok(17));
        assert_eq!(count::<u32>("1e9"), Ok(1_000_000_000));
        assert_eq!(
            count::<u32>("1e10").unwrap_err(),
            "too large (at most 4294967295)"
        );
        assert!(count::<u64>("1.5").unwrap_err().contains("whole number"));
        assert!(count::<u64>("-1").unwrap_err().contains(">= 0"));
        assert!(count::<u64>("abc").unwrap_err().contains("whole number"));
        assert!(count::<u64>("1e20").unwrap_err().contains("largest count"));
        assert_eq!(count::<u64>("18446744073709551615"), Ok(u64::MAX));
        assert_eq!(image_size("1e3x20"), Ok((1000, 20)));
        assert!(image_size("40by20").is_err());
    }

    #[test]
    fn counts_are_written_as_they_are_read() {
        for (n, text) in [
            (17, "17"),
            (1000, "1000"),
            (10_000, "1e4"),
            (300_000, "3e5"),
            (2_000_000, "2e6"),
            (1_500_000_000, "1.5e9"),
            (20_260_101, "20260101"),
            (20_260_000, "2.026e7"),
            (u64::MAX, "18446744073709551615"),
        ] {
            assert_eq!(count_text(n), text);
            assert_eq!(count::<u64>(text), Ok(n));
        }
    }

    #[test]
    fn list_items_are_read_by_the_library() {
        assert!(taps("17").is_ok() && taps("1e1").is_err() && taps("257").is_err());
        assert!(rank_item("1-3").is_ok() && rank_item("3-1").is_err());
        assert!(channel_item("rg").is_ok() && channel_item("x").is_err());
        assert!(name_item(" ").is_err());
        assert_eq!(rgb("1, 2,3"), Ok([1.0, 2.0, 3.0]));
        assert_eq!(rgb(&rgb_text([0.48, 0.41, 0.28])), Ok([0.48, 0.41, 0.28]));
        let r = evaluate::SIGNAL_SIZE_RANGE;
        assert!(signal_size(&r.start().to_string()).is_ok());
        assert!(signal_size(&(r.start() - 1).to_string()).is_err());
        assert!(signal_size(&r.end().to_string()).is_ok());
        assert!(signal_size(&(r.end() + 1).to_string()).is_err());
    }
}
