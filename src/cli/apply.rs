//! `ssskit apply`: a kernel (or, as ground truth, the full 2D profile) applied
//! to an image on the CPU or with wgpu.

use super::args::{
    self, count, Backend, BackendArg, FovYArg, KernelFile as KernelFileArg, MmPerPixelArg, OutFile,
    UnitsPerMmArg,
};
use anyhow::Context;
use ssskit::filter::angular::around_pass;
use ssskit::filter::image::{png_depth_of, read_image, read_plane, write_image, PngDepth};
use ssskit::filter::kernel_setup::kernel_setup;
use ssskit::filter::{cpu, exact, gpu, separable, FollowSurface, Image, Plane, Scale, Setup};
use ssskit::kernel::KernelFile;
use ssskit::profile::Profile;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Working precision of the CPU fixed-kernel path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Precision {
    F32,
    F64,
}

impl From<Precision> for separable::Precision {
    fn from(p: Precision) -> separable::Precision {
        match p {
            Precision::F32 => separable::Precision::F32,
            Precision::F64 => separable::Precision::F64,
        }
    }
}

/// Where `--reference` takes the exact convolution in each pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Sampling {
    /// Averaged over the pixel (a box pixel filter).
    Average,
    /// At the pixel centre.
    Centre,
}

impl From<Sampling> for exact::PixelSampling {
    fn from(s: Sampling) -> exact::PixelSampling {
        match s {
            Sampling::Average => exact::PixelSampling::Average,
            Sampling::Centre => exact::PixelSampling::Centre,
        }
    }
}

/// Bits per sample of a PNG output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PngBits {
    #[value(name = "8")]
    Eight,
    #[value(name = "16")]
    Sixteen,
}

impl From<PngBits> for PngDepth {
    fn from(b: PngBits) -> PngDepth {
        match b {
            PngBits::Eight => PngDepth::Eight,
            PngBits::Sixteen => PngDepth::Sixteen,
        }
    }
}

#[derive(clap::Args)]
#[command(
    mut_arg("kernel", |a| a.required_unless_present("reference").conflicts_with("reference")),
    mut_arg("out", |a| args::required()(a).help("Output file: the image, .exr or .png by extension")),
    mut_arg("backend", args::default_enum(Backend::Auto)),
    mut_arg("mm_per_pixel", |a| a
        .conflicts_with_all(["fov_y", "units_per_mm"])
        .required_unless_present("fov_y")
        .help("Scale: surface millimetres per pixel (orthographic) [default: none: give it or --fov-y]")),
    mut_arg("units_per_mm", |a| a.alias("sss-width")),
)]
pub struct Args {
    #[command(flatten)]
    kernel: KernelFileArg,
    /// Ground truth instead of a kernel: the profile's exact 2D convolution.
    ///
    /// The exact 2D convolution with this profile's full 2D kernel at
    /// --mm-per-pixel (CPU only, f64).
    #[arg(long, value_name = "PROFILE.json")]
    reference: Option<PathBuf>,
    /// With --reference: the convolution averaged over each pixel or at its centre [default: average].
    ///
    /// average: a box pixel filter, what a camera or a path tracer
    /// records; centre: the discretisation the kernels' filters share,
    /// which `compare` and `advise` measure kernels against.
    #[arg(long, value_enum, value_name = "WHERE")]
    reference_sampling: Option<Sampling>,
    /// Irradiance image in linear light (.exr) or sRGB (.png).
    #[arg(long, value_name = "IMAGE")]
    input: PathBuf,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    backend: BackendArg,
    /// CPU working precision of the fixed-kernel path.
    ///
    /// The fixed-kernel path: uniform --mm-per-pixel scale without
    /// --strength or --follow-surface. f32 differs from f64 by a few f32
    /// round-offs (at most about taps x 1e-7 of the peak), the precision an
    /// EXR output stores anyway. The per-pixel path (--fov-y, --strength,
    /// --follow-surface) and --reference exist in f64 only and ignore it;
    /// the GPU is f32.
    #[arg(long, value_enum, value_name = "BITS", default_value_t = Precision::F32)]
    precision: Precision,
    /// Depth image (.exr channel Z, Y or R, or --depth-channel; .png grey)
    /// [default: the input EXR's depth channel].
    ///
    /// Depth is needed by --fov-y and --follow-surface; without this image,
    /// an EXR input's depth channel is used.
    #[arg(long, value_name = "IMAGE")]
    depth: Option<PathBuf>,
    /// Name of the depth channel in the input EXR or in --depth [default: Z].
    #[arg(long, value_name = "NAME")]
    depth_channel: Option<String>,
    /// Specular image added after the blur [default: none].
    #[arg(long, value_name = "IMAGE")]
    specular: Option<PathBuf>,
    /// Per-pixel SSS strength image in [0, inf): multiplies the kernel size [default: 1].
    #[arg(long, value_name = "IMAGE")]
    strength: Option<PathBuf>,
    #[command(flatten)]
    mm_per_pixel: MmPerPixelArg,
    #[command(flatten)]
    fov_y: FovYArg,
    #[command(flatten)]
    units_per_mm: UnitsPerMmArg,
    /// Depth-aware lerp toward the centre colour with constant C, in metres [default: off].
    ///
    /// Freude 2014, eq. 4.12. C is read in metres whatever the scene's unit
    /// (Jimenez's shader uses 300 for a scene in metres): the rate is
    /// C x 1e-6 / (--units-per-mm x tan(fov_y / 2)) per scene unit of depth,
    /// or C x 1e-3 per mm of depth under --mm-per-pixel (depth in mm).
    #[arg(long, value_name = "C", allow_hyphen_values = true, value_parser = args::real)]
    follow_surface: Option<f64>,
    /// The lerp of --follow-surface with C in the depth image's own units [default: off].
    ///
    /// Rate C x --units-per-mm / tan(fov_y / 2) (C per depth unit under
    /// --mm-per-pixel): the behaviour of --follow-surface before it was
    /// unit-safe, equal to it for a scene in metres.
    #[arg(
        value_parser = args::real,
        long,
        value_name = "C",
        allow_hyphen_values = true,
        conflicts_with = "follow_surface"
    )]
    follow_surface_scene_units: Option<f64>,
    /// Apply the fit's full-resolution factors instead of the tap table.
    ///
    /// By default `apply` runs the kernel file's real-time tap table
    /// (`taps.passes`): what an engine runs and what `compare` and
    /// `advise` score, so `apply` + `diff` agrees with them. The full
    /// factors are the fit before tap placement (resampled to whole pixels
    /// under a uniform scale).
    #[arg(long)]
    full_factors: bool,
    /// Deprecated: use --full-factors to leave the tap table (the default now).
    ///
    /// The tap table is what an engine runs; the flag is kept so that older
    /// scripts still run.
    #[arg(long, hide = true, conflicts_with = "full_factors")]
    taps_only: bool,
    /// Jitter each tap per pixel inside the interval it stands for.
    ///
    /// Interleaved gradient noise (Jimenez 2014): trades the banding
    /// stripes of few taps on a large kernel for fine noise; the same
    /// result on the CPU and the GPU.
    #[arg(long)]
    jitter: bool,
    /// Replace NaN/Inf samples instead of failing; the count is reported.
    ///
    /// Colour and specular by 0; depth by the largest finite depth;
    /// strength by 0.
    #[arg(long)]
    sanitize: bool,
    /// PNG output bit depth [default: the input PNG's, else 8].
    #[arg(long, value_enum, value_name = "BITS")]
    png_bits: Option<PngBits>,
    /// Frames: with a disk kernel, rotations accumulated (plain mean), 1 to 4096 [default: the kernel's, else 1].
    ///
    /// A static camera's temporal accumulation: frame k turns the samples
    /// by its own per-pixel angle (--frame-seed + k), and the output is the
    /// mean of the frames. By default the frames the kernel's predicted
    /// error assumes (its `accumulation`, recorded by advise and kernels),
    /// else 1; stderr says which ran. Separable kernels take 1 (the same
    /// every frame).
    #[arg(long, value_name = "N", value_parser = count::<u32>)]
    frames: Option<u32>,
    /// Disk kernels: how the frames are accumulated, mean or ema:W (W in (0, 1]).
    ///
    /// mean: the plain mean of the frames. ema:W: an exponential moving
    /// average, h = (1 - W) h + W frame from the first frame on (a TAA
    /// history blend of weight W); after K frames of independent noise s it
    /// leaves s sqrt(sum of the squared weights), at least s sqrt(W / (2 -
    /// W)) (docs/kernels.md). Runs on the CPU.
    #[arg(long, value_name = "HOW", default_value = "mean", value_parser = accumulate)]
    accumulate: ssskit::filter::accumulate::Accumulate,
    /// Disk kernels: index of the first frame, which picks its rotation [default: the kernel's, else 0].
    #[arg(long, value_name = "N", value_parser = count::<u32>)]
    frame_seed: Option<u32>,
    /// View-space unit normals in R, G, B: x right, y up, z toward the camera [default: the input EXR's N.X, N.Y, N.Z].
    ///
    /// With a kernel that carries the angular entry and exit factors: the
    /// exit factor is taken at N.V, V from the camera of --fov-y (or
    /// straight on under --mm-per-pixel), after the pass; 0 where nothing
    /// is seen.
    #[arg(long, value_name = "IMAGE")]
    normals: Option<PathBuf>,
    /// View-space direction toward the one light, for the entry factor at N.L [default: none].
    #[arg(long, value_name = "X,Y,Z", value_delimiter = ',', allow_negative_numbers = true,
          value_parser = args::real, conflicts_with_all = ["n_dot_l", "entry_weighted"])]
    light_toward: Vec<f64>,
    /// Per-pixel N.L of the one light, for the entry factor [default: the input EXR's NdotL].
    #[arg(long, value_name = "IMAGE", conflicts_with = "entry_weighted")]
    n_dot_l: Option<PathBuf>,
    /// The input is already weighted by the entry factor (an engine's lighting pass).
    ///
    /// Then only the exit factor is applied, after the pass.
    #[arg(long)]
    entry_weighted: bool,
    #[command(flatten)]
    factors: args::FactorsArg,
}

/// `--accumulate`: `mean` or `ema:W`.
fn accumulate(s: &str) -> Result<ssskit::filter::accumulate::Accumulate, String> {
    ssskit::filter::accumulate::Accumulate::parse(s).map_err(|e| e.to_string())
}

#[path = "apply_disk.rs"]
mod disk;

#[path = "apply_angular.rs"]
mod angular;

pub fn run(args: Args) -> anyhow::Result<()> {
    let out_path = args.out.path()?;
    if args.reference_sampling.is_some() && args.reference.is_none() {
        anyhow::bail!(
            "--reference-sampling applies to --reference (the exact 2D convolution) only"
        );
    }
    let need_depth = args.fov_y.fov_y.is_some() || follow(&args).is_some();
    let input_depth_channel = match (&args.depth, need_depth, is_exr(&args.input)) {
        (None, true, true) => Some(args.depth_channel.clone().unwrap_or_else(|| "Z".into())),
        _ => None,
    };
    ssskit::io::check_extension(out_path, &["exr", "png"], "image")?;
    let (mut image, extras) = read_image(&args.input, input_depth_channel.as_deref())?;
    let what = args.input.display().to_string();
    report_sanitized(&what, image.check_finite(&what, args.sanitize)?);

    let scale = scale_of(&args)?;

    let png_depth = match args.png_bits {
        Some(bits) => bits.into(),
        None if !is_exr(&args.input) => png_depth_of(&args.input)?,
        None => PngDepth::Eight,
    };

    let start = Instant::now();
    if let Some(reference) = &args.reference {
        let out = run_reference(&args, reference, &image, scale)?;
        return written(
            out_path,
            &out,
            png_depth,
            "exact 2D reference on the CPU:",
            start,
        );
    }

    let Some(kernel_path) = &args.kernel.kernel else {
        anyhow::bail!("give --kernel K.json or --reference PROFILE.json");
    };
    let depth = load_depth(&args, extras.depth)?;
    let factors = angular::kernel_factors(kernel_path)?;
    let around = angular::view(&args, factors.as_ref(), &image, &scale)?;
    if ssskit::kernel::disk::is_disk_file(kernel_path) {
        let kernel = disk::read(&args, kernel_path)?;
        let (frames, first) = kernel.frames_to_run(args.frames, args.frame_seed);
        eprintln!("{}", disk::frames_note(&kernel, args.frames, frames, first));
        let mut view = view_of(&args, scale, depth, &image)?;
        let specular = take_specular(&mut view, around.is_some());
        let out = around_pass(around.as_ref(), image, specular, |img| {
            disk::run(&args, kernel_path, &kernel, (frames, first), view, img)
        })?;
        let what = format!("disk pass, {frames} frame(s):");
        return written(out_path, &out, png_depth, &what, start);
    }
    if args.accumulate != ssskit::filter::accumulate::Accumulate::Mean {
        anyhow::bail!(
            "--accumulate weighs the frames of a disk kernel; {} is separable (the same every \
             frame)",
            kernel_path.display()
        );
    }
    if args.frames.is_some_and(|n| n != 1) {
        anyhow::bail!(
            "--frames accumulates the rotations of a disk kernel; {} is separable (the same \
             every frame)",
            kernel_path.display()
        );
    }
    let kernel = KernelFile::read(kernel_path)?;
    let mut setup = setup_of(&args, &kernel, kernel_path, scale, depth, &image)?;
    let specular = take_specular(&mut setup, around.is_some());
    let out = around_pass(around.as_ref(), image, specular, |img| {
        filter(&args, img, &setup)
    })?;
    let taps = setup.passes.iter().map(|t| t.offsets_mm.len()).max();
    let what = format!(
        "{} one-dimensional passes ({} separable term(s)) of up to {} taps,",
        2 * setup.passes.len(),
        setup.passes.len(),
        taps.unwrap_or(0),
    );
    written(out_path, &out, png_depth, &what, start)
}

/// The pixel scale from --mm-per-pixel or --fov-y and --units-per-mm.
fn scale_of(args: &Args) -> anyhow::Result<Scale> {
    let scale = match (args.mm_per_pixel.mm_per_pixel, args.fov_y.fov_y) {
        (Some(m), _) => Scale::MmPerPixel(m),
        (None, Some(f)) => Scale::Perspective {
            fov_y_deg: f,
            sss_width: args.units_per_mm.units_per_mm,
        },
        _ => anyhow::bail!("give --mm-per-pixel or --fov-y"),
    };
    scale.validate()?;
    Ok(scale)
}

/// Writes the result and says what made it, in how long, and where.
fn written(
    out_path: &Path,
    out: &Image,
    png_depth: PngDepth,
    what: &str,
    start: Instant,
) -> anyhow::Result<()> {
    write_image(out_path, out, png_depth)?;
    eprintln!(
        "{what} {:.3} s -> {}",
        start.elapsed().as_secs_f64(),
        out_path.display()
    );
    Ok(())
}

/// The specular image of `setup`, taken out of it when the factors go
/// around the pass: the exit factor weighs the subsurface light only, and
/// the specular is added after it.
fn take_specular(setup: &mut Setup, factors: bool) -> Option<Image> {
    if factors {
        setup.specular.take()
    } else {
        None
    }
}

/// The depth plane (--depth, else the input's own), its non-finite values
/// refused or, with --sanitize, set to the farthest finite depth.
fn load_depth(args: &Args, own: Option<Plane>) -> anyhow::Result<Option<Plane>> {
    let mut depth = match &args.depth {
        Some(p) => Some(read_plane(p, args.depth_channel.as_deref())?),
        None => own,
    };
    if let Some(d) = depth.as_mut() {
        report_sanitized("depth", d.check_finite_depth("depth", args.sanitize)?);
    }
    Ok(depth)
}

/// The pass's settings (`filter::kernel_setup::kernel_setup`: the
/// kernel's real-time tap table, or with --full-factors the full factors
/// resampled to pixels under a uniform scale), checked against the image;
/// prints the scale warnings.
fn setup_of(
    args: &Args,
    kernel: &KernelFile,
    kernel_path: &Path,
    scale: Scale,
    depth: Option<Plane>,
    image: &Image,
) -> anyhow::Result<Setup> {
    let view = view_of(args, scale, depth, image)?;
    eprintln!(
        "taps: the {}",
        if args.full_factors {
            "full-resolution factors (--full-factors)".to_string()
        } else {
            format!(
                "{}-tap table, what an engine runs (--full-factors for the fit's full resolution)",
                kernel.taps.count
            )
        }
    );
    let (setup, warnings) = kernel_setup(kernel, args.full_factors, view, image)
        .with_context(|| format!("applying {}", kernel_path.display()))?;
    for w in warnings {
        super::errors::warn(&w.to_string());
    }
    Ok(setup)
}

/// What any kernel's pass shares: the scale and the per-pixel planes, no
/// passes yet; checked against the image.
fn view_of(
    args: &Args,
    scale: Scale,
    depth: Option<Plane>,
    image: &Image,
) -> anyhow::Result<Setup> {
    let strength = load_plane(args.strength.as_deref(), args.sanitize, "strength")?;
    let specular = match &args.specular {
        Some(p) => {
            let (mut s, _) = read_image(p, None)?;
            let what = p.display().to_string();
            report_sanitized(&what, s.check_finite(&what, args.sanitize)?);
            Some(s)
        }
        None => None,
    };
    let view = Setup {
        passes: Vec::new(),
        scale,
        depth,
        strength,
        follow_surface: follow(args),
        specular,
        jitter: args.jitter,
    };
    view.validate_view(image)?;
    Ok(view)
}

/// Runs the pass on the backend --backend names (auto: a hardware GPU,
/// else the CPU), saying which on stderr. The CPU filters the image in
/// place (the peak stays near the image itself; docs/filter.md).
fn filter(args: &Args, mut image: Image, setup: &Setup) -> anyhow::Result<Image> {
    let precision = separable::Precision::from(args.precision);
    let cpu_path = if setup.is_uniform() {
        format!("fixed kernels, {precision:?}").to_lowercase()
    } else {
        "per-pixel, f64".into()
    };
    Ok(match args.backend.backend {
        Backend::Cpu => {
            eprintln!("backend: cpu ({cpu_path})");
            cpu::apply_in_place(&mut image, setup, precision)?;
            image
        }
        Backend::Gpu => {
            let g = gpu::Gpu::new()?;
            eprintln!("backend: gpu, adapter {}", g.describe());
            g.apply(&image, setup)?
        }
        Backend::Auto => match gpu::Gpu::new() {
            Ok(g) if !g.is_software() => {
                eprintln!("backend: gpu (auto), adapter {}", g.describe());
                g.apply(&image, setup)?
            }
            Ok(g) => {
                eprintln!(
                    "backend: cpu ({cpu_path}; auto: the only adapter, {}, is a software \
                     rasteriser, slower than the CPU path; --backend gpu forces it)",
                    g.describe()
                );
                cpu::apply_in_place(&mut image, setup, precision)?;
                image
            }
            Err(e) => {
                eprintln!("backend: cpu ({cpu_path}; auto: {e})");
                cpu::apply_in_place(&mut image, setup, precision)?;
                image
            }
        },
    })
}

/// The lerp the two follow-surface flags ask for.
fn follow(args: &Args) -> Option<FollowSurface> {
    args.follow_surface.map(FollowSurface::InMetres).or(args
        .follow_surface_scene_units
        .map(FollowSurface::InSceneUnits))
}

fn run_reference(
    args: &Args,
    reference: &Path,
    image: &Image,
    scale: Scale,
) -> anyhow::Result<Image> {
    let Scale::MmPerPixel(m) = scale else {
        anyhow::bail!("--reference needs --mm-per-pixel (the exact 2D kernel has one scale)");
    };
    let kernel_only = [
        ("--depth", args.depth.is_some()),
        ("--strength", args.strength.is_some()),
        ("--follow-surface", args.follow_surface.is_some()),
        (
            "--follow-surface-scene-units",
            args.follow_surface_scene_units.is_some(),
        ),
        ("--specular", args.specular.is_some()),
        ("--taps-only", args.taps_only),
        ("--full-factors", args.full_factors),
        ("--jitter", args.jitter),
    ];
    let given = kernel_only
        .iter()
        .find(|(_, g)| *g)
        .map(|(f, _)| *f)
        .or_else(|| angular::any_flag(args));
    if let Some(flag) = given {
        anyhow::bail!(
            "{flag} applies to a kernel; --reference is the plain exact 2D convolution of the \
             profile, which takes none of --depth, --strength, --follow-surface, --specular, \
             --full-factors, --jitter or the angular factors' flags"
        );
    }
    if args.backend.backend == Backend::Gpu {
        anyhow::bail!("--reference runs on the CPU only (use --backend cpu or auto)");
    }
    let profile = Profile::read(reference)?;
    let sampling = exact::PixelSampling::from(args.reference_sampling.unwrap_or(Sampling::Average));
    let k = exact::reference_kernel_sampled(&profile, m, sampling)?;
    exact::check_reference_fits(image.width, image.height, k.size)?;
    eprintln!(
        "exact 2D kernel: {0}x{0} pixels of {m} mm ({1}; {2})",
        k.size,
        if k.size > exact::FFT_ABOVE {
            "FFT"
        } else {
            "direct"
        },
        match sampling {
            exact::PixelSampling::Average =>
                "averaged over each pixel; compare, advise and kernels score against \
                 --reference-sampling centre, another discretisation, which diff then \
                 reproduces",
            exact::PixelSampling::Centre =>
                "at pixel centres, as compare, advise and kernels score",
        }
    );
    Ok(exact::convolve_2d(image, &k))
}

fn load_plane(path: Option<&Path>, sanitize: bool, what: &str) -> anyhow::Result<Option<Plane>> {
    let Some(p) = path else { return Ok(None) };
    let mut plane = read_plane(p, None)?;
    report_sanitized(what, plane.check_finite(what, sanitize, 0.0)?);
    Ok(Some(plane))
}

fn report_sanitized(what: &str, n: usize) {
    if n > 0 {
        eprintln!("{what}: replaced {n} NaN/Inf samples (--sanitize)");
    }
}

pub(super) fn is_exr(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}
