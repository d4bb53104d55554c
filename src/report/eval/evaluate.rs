//! Image-space evaluation of a kernel: how far a separable kernel, applied
//! the way a renderer applies it, lands from the exact 2D convolution with
//! the profile it approximates (Freude 2014, section 6.2: the edge and shapes
//! signals, errors against the 2D reference).
//!
//! # API (plain data)
//!
//! - [`ImageCase`]: an input image in linear light and its scale in
//!   millimetres per pixel ([`ImageCase::signal`] builds a test signal).
//! - [`Exact::new`]`(profile, case)`: the exact 2D convolution of the case
//!   with the profile's ground-truth kernel at one pixel per cell
//!   ([`exact::reference_kernel`], [`exact::convolve_2d`]), sampled at the pixel
//!   centres: the discretisation the kernels' own pixel kernels share (box
//!   integrals of their factors), so that the error is the model's and not
//!   the difference between sampling and averaging over a pixel (`apply
//!   --reference` averages by default; `--reference-sampling centre` is
//!   this one). Build it once per profile and case; every kernel is
//!   evaluated against it.
//! - [`evaluate`]`(exact, kernel, taps, options) -> KernelImageErrors`: the
//!   case filtered with the kernel's full-resolution factors and with its tap
//!   table at each count in `taps` (all ranks, summed passes), and for each
//!   result the per-channel [`ImageErrors`].
//! - [`evaluate_keeping`]: the same, also returning one filtered image.
//! - [`evaluate_profile`]`(profile, kernel, case, taps, options)`: both steps
//!   at once, for a single kernel.
//! - Lower level, for callers that want the images (contact sheets):
//!   [`filter`], [`errors`], [`tap_passes`].
//!
//! # Definitions
//!
//! - Filtering: `ssskit apply` without depth, strength or specular at a
//!   uniform scale: the CPU fixed-kernel path in f64. Full factors are
//!   box-resampled to whole pixels ([`crate::filter::taps_for`]); tap tables
//!   are used as stored (linear interpolation between pixels). A tap count
//!   other than the one stored in the file is rebuilt from the file's full
//!   factors exactly as the kernel fit builds its table
//!   ([`crate::kernel::taps::tap_table`]).
//! - Storage: by default (`Options::round_to_f32`) the exact and filtered
//!   images are rounded to f32 before any error is taken, as `ssskit apply`
//!   stores them in EXR, so that `apply` + `diff` reproduce every number
//!   here. The rounding costs at most 2^-24 of a value (about 6e-8).
//! - Relative RMS, channel c: `sqrt(mean_pixels (F_c - E_c)^2) / max_pixels
//!   |E_c|`, with E the exact convolution and F the filtered image: the
//!   `rms_rel` of `ssskit diff EXACT FILTERED` ([`crate::filter::diff`]).
//! - FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for
//!   Alternating Images"; LDR-FLIP of NVIDIA's reference implementation via
//!   the `nv-flip` crate): the mean of the per-pixel FLIP error map, in
//!   [0, 1], at [`Options::pixels_per_degree`] (default 67, a 0.7 m wide 4K
//!   monitor seen from 0.7 m). LDR-FLIP compares sRGB images, so both images
//!   go through one stated tone mapping first:
//!   1. exposure: divide by P, the 99th percentile of the exact image over
//!      its lit pixels (value above 1e-6 of its peak), so that the exact
//!      image's 99th percentile maps to 1 (per channel for the channel
//!      scores; for the RGB score P is taken over each pixel's largest
//!      channel, one exposure for all three);
//!   2. clamp to [0, 1];
//!   3. sRGB encoding (IEC 61966-2-1) and rounding to 8 bits.
//!
//!   A channel score is FLIP of that channel shown as a grey image; the RGB
//!   score is FLIP of the colour image. Differences under half an 8-bit step
//!   after tone mapping are invisible to it by construction.
//! - The kernel's colour factor (total diffuse reflectance) is not applied:
//!   kernels and the ground truth have unit sum per channel, so the signals'
//!   brightness is kept.
//! - Filter time: wall time of the filter call divided by the image's
//!   megapixels (milliseconds per megapixel, CPU f64, this machine and load);
//!   `samples_per_pixel` (2 x passes x taps per pass) is the load-free cost.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use crate::error::{Error, Result};
use crate::filter::image::linear_to_srgb;
use crate::filter::signals::{generate, Signal};
use crate::filter::{cpu, diff, exact, separable, taps_for, Image, Scale, Setup, Taps, Which};
use crate::kernel::{Kernel2D, KernelFile};
use crate::profile::Profile;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Instant;

/// An image to filter and its scale.
#[derive(Clone, Debug)]
pub struct ImageCase {
    /// "edge", "shapes", "checker", "dirac" or the user image's name.
    pub name: String,
    /// Linear light.
    pub image: Image,
    /// Surface millimetres per pixel.
    pub mm_per_pixel: f64,
}

/// Width of a checker cell in the generated checker signal, mm.
pub const CHECKER_MM: f64 = 1.0;

/// Default scale of the test signals: surface millimetres per pixel.
pub const DEFAULT_MM_PER_PIXEL: f64 = 0.1;

/// Default side of the square test signals, pixels.
pub const DEFAULT_SIGNAL_SIZE: usize = 128;

/// Range of the side of the square test signals, pixels: below 8 the
/// shapes do not fit; above 4096 one exact convolution per model and
/// signal takes minutes.
pub const SIGNAL_SIZE_RANGE: std::ops::RangeInclusive<usize> = 8..=4096;

impl ImageCase {
    /// A test signal of `size` x `size` pixels at `mm_per_pixel` (the
    /// checker's cells are [`CHECKER_MM`] wide, as `ssskit signal` draws
    /// them by default).
    pub fn signal(signal: Signal, size: usize, mm_per_pixel: f64) -> Result<ImageCase> {
        check_scale(mm_per_pixel)?;
        let cell = (CHECKER_MM / mm_per_pixel).round().max(1.0) as usize;
        Ok(ImageCase {
            name: signal_name(signal).into(),
            image: generate(signal, size, size, cell)?,
            mm_per_pixel,
        })
    }
}

/// The name `ssskit signal` gives `s`.
pub fn signal_name(s: Signal) -> &'static str {
    match s {
        Signal::Edge => "edge",
        Signal::Shapes => "shapes",
        Signal::Checker => "checker",
        Signal::Dirac => "dirac",
    }
}

fn check_scale(mm_per_pixel: f64) -> Result<()> {
    Scale::MmPerPixel(mm_per_pixel).validate()
}

/// Evaluation settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Options {
    /// Round the exact and filtered images to f32 before taking errors (as
    /// an EXR stores them).
    pub round_to_f32: bool,
    /// FLIP's viewing condition.
    pub pixels_per_degree: f64,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            round_to_f32: true,
            pixels_per_degree: nv_flip::DEFAULT_PIXELS_PER_DEGREE as f64,
        }
    }
}

/// The exact 2D convolution of one case with one profile, and what the
/// errors against it need.
#[derive(Clone, Debug)]
pub struct Exact {
    pub case: ImageCase,
    /// The exact convolution (f64, not rounded).
    pub image: Image,
    /// Cells per side of the ground-truth kernel at one pixel per cell.
    pub kernel_size: usize,
    /// Exposure of the tone mapping per channel and for the RGB score.
    pub exposure: [f64; 3],
    pub exposure_rgb: f64,
    /// Time to build and apply the 2D kernel.
    pub seconds: f64,
    /// The exact image's [`Tones`], made on first use, without and with
    /// the rounding to f32: [`errors`] takes them for every filtered image.
    tones: [std::sync::OnceLock<Tones>; 2],
}

/// An image's FLIP inputs, tone-mapped with the exact image's exposures
/// ([`tone_map`]): each channel as a grey image, and the colour image.
type Tones = ([Vec<u8>; 3], Vec<u8>);

fn tones(img: &Image, exact: &Exact) -> Tones {
    let grey = std::array::from_fn(|c| tone_map_grey(&img.rgb[c], exact.exposure[c]));
    let rgb = |i| std::array::from_fn(|c| img.rgb[c][i] * exact.exposure_rgb);
    (grey, tone_map(img, rgb))
}

impl Exact {
    pub fn new(profile: &Profile, case: &ImageCase) -> Result<Exact> {
        Exact::checked(case)?;
        let t0 = Instant::now();
        let k: Kernel2D = exact::reference_kernel(profile, case.mm_per_pixel)?;
        let mut e = Exact::with_kernel(case, &k);
        e.seconds = t0.elapsed().as_secs_f64();
        Ok(e)
    }

    /// What [`Exact::new`] refuses of a case before its work: a bad scale,
    /// an empty image.
    pub fn checked(case: &ImageCase) -> Result<()> {
        check_scale(case.mm_per_pixel)?;
        if case.image.is_empty() {
            return Err(Error::Unsupported(format!(
                "image '{}' has no pixels",
                case.name
            )));
        }
        Ok(())
    }

    /// The exact image of every case: one reference kernel per scale
    /// serves the cases at that scale ([`Exact::with_kernel`]); an error
    /// is placed by `place` of the case it is about ([`Error::within`]).
    pub fn per_scale(
        profile: &Profile,
        cases: &[ImageCase],
        place: &dyn Fn(&ImageCase) -> String,
    ) -> Result<Vec<Exact>> {
        use rayon::prelude::*;
        let failed = |c: &ImageCase, e: Error| e.within(&place(c));
        // Per case, its kernel among those made (one per scale).
        let mut kernels: Vec<(f64, Kernel2D)> = Vec::new();
        let mut which = Vec::with_capacity(cases.len());
        for c in cases {
            Exact::checked(c).map_err(|e| failed(c, e))?;
            match kernels.iter().position(|(mm, _)| *mm == c.mm_per_pixel) {
                Some(i) => which.push(i),
                None => {
                    let k = exact::reference_kernel(profile, c.mm_per_pixel)
                        .map_err(|e| failed(c, e))?;
                    which.push(kernels.len());
                    kernels.push((c.mm_per_pixel, k));
                }
            }
        }
        Ok(cases
            .par_iter()
            .zip(which)
            .map(|(c, i)| Exact::with_kernel(c, &kernels[i].1))
            .collect())
    }

    /// [`Exact::new`] with the reference kernel made already (one kernel
    /// serves every case at its scale).
    pub fn with_kernel(case: &ImageCase, k: &Kernel2D) -> Exact {
        let t0 = Instant::now();
        let image = exact::convolve_2d(&case.image, k);
        let seconds = t0.elapsed().as_secs_f64();
        let exposure = std::array::from_fn(|c| exposure_of(&image.rgb[c]));
        let max_rgb: Vec<f64> = (0..image.len())
            .map(|i| (0..3).fold(0.0f64, |m, c| m.max(image.rgb[c][i])))
            .collect();
        Exact {
            case: case.clone(),
            exposure,
            exposure_rgb: exposure_of(&max_rgb),
            kernel_size: k.size,
            image,
            seconds,
            tones: Default::default(),
        }
    }
}

/// 1 / the 99th percentile of the lit pixels (above 1e-6 of the peak); 1
/// for a black image.
pub(crate) fn exposure_of(v: &[f64]) -> f64 {
    let peak = v.iter().fold(0.0f64, |m, &x| m.max(x));
    if !(peak > 0.0) {
        return 1.0;
    }
    let mut lit: Vec<f64> = v.iter().copied().filter(|&x| x > 1e-6 * peak).collect();
    lit.sort_by(f64::total_cmp);
    1.0 / crate::numerics::nearest_rank(&lit, 0.99)
}

/// Errors of one filtered image against the exact one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImageErrors {
    /// Per channel, as `ssskit diff`'s `rms_rel`.
    pub rel_rms: [f64; 3],
    /// Mean LDR-FLIP per channel (the channel as a grey image).
    pub flip: [f64; 3],
    /// Mean LDR-FLIP of the colour image.
    pub flip_rgb: f64,
    /// Filter wall time per megapixel, milliseconds.
    pub ms_per_megapixel: f64,
    /// 1D samples per pixel: 2 x passes x taps per pass.
    pub samples_per_pixel: usize,
}

/// One kernel on one case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KernelImageErrors {
    pub signal: String,
    pub mm_per_pixel: f64,
    /// With the full-resolution factors.
    pub full: ImageErrors,
    /// With the tap table at each count.
    pub taps: BTreeMap<usize, ImageErrors>,
}

/// The passes of `kernel` for `which` ([`taps_for`]: the full factors
/// resampled to `mm_per_pixel`, the stored table, or one rebuilt).
pub fn tap_passes(kernel: &KernelFile, which: Which, mm_per_pixel: f64) -> Result<Vec<Taps>> {
    taps_for(kernel, which, Some(mm_per_pixel))
}

/// `case` filtered with `passes` (f64 fixed-kernel path) and the wall time.
pub fn filter(case: &ImageCase, passes: Vec<Taps>) -> Result<(Image, f64)> {
    let setup = Setup {
        passes,
        scale: Scale::MmPerPixel(case.mm_per_pixel),
        depth: None,
        strength: None,
        follow_surface: None,
        specular: None,
        jitter: false,
    };
    let t0 = Instant::now();
    let out = cpu::apply_with(&case.image, &setup, separable::Precision::F64)?;
    Ok((out, t0.elapsed().as_secs_f64()))
}

/// Errors of `filtered` against `exact` (timing fields zero).
pub fn errors(exact: &Exact, filtered: &Image, options: &Options) -> Result<ImageErrors> {
    let (e, f) = if options.round_to_f32 {
        (round_f32(&exact.image), round_f32(filtered))
    } else {
        (exact.image.clone(), filtered.clone())
    };
    let stats = diff::compare(&e, &f)?;
    let ppd = options.pixels_per_degree as f32;
    if !(ppd > 0.0 && ppd.is_finite()) {
        return Err(Error::invalid(
            "evaluate",
            "pixels per degree",
            ppd,
            "must be finite and > 0",
        ));
    }
    // The exact side's tone maps are the same for every filtered image.
    let ours = exact.tones[usize::from(options.round_to_f32)].get_or_init(|| tones(&e, exact));
    let theirs = tones(&f, exact);
    // The four FLIP maps (each channel grey, then the colour image) are
    // independent: made at once, each a pure function of its two images.
    let means: Vec<f64> = (0..4)
        .into_par_iter()
        .map(|k| match k {
            3 => flip_mean(&ours.1, &theirs.1, e.width, e.height, ppd),
            c => flip_mean(&ours.0[c], &theirs.0[c], e.width, e.height, ppd),
        })
        .collect();
    Ok(ImageErrors {
        rel_rms: stats.rms_rel,
        flip: [means[0], means[1], means[2]],
        flip_rgb: means[3],
        ms_per_megapixel: 0.0,
        samples_per_pixel: 0,
    })
}

/// Every value rounded to f32, as the GPU pass stores it: both sides of a
/// comparison at the precision the shipped filter works in.
pub fn round_f32(img: &Image) -> Image {
    let mut out = img.clone();
    for plane in out.rgb.iter_mut() {
        plane.iter_mut().for_each(|v| *v = *v as f32 as f64);
    }
    out
}

/// Exposed linear RGB per pixel -> clamped, sRGB-encoded, 8-bit RGB.
pub(crate) fn tone_map(img: &Image, exposed: impl Fn(usize) -> [f64; 3]) -> Vec<u8> {
    let mut out = Vec::with_capacity(3 * img.len());
    for i in 0..img.len() {
        for v in exposed(i) {
            let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
            out.push((linear_to_srgb(v) * 255.0).round() as u8);
        }
    }
    out
}

/// [`tone_map`] of one plane shown as a grey image (`v` x `exposure` in
/// each of the three channels), each pixel encoded once.
fn tone_map_grey(plane: &[f64], exposure: f64) -> Vec<u8> {
    let mut out = Vec::with_capacity(3 * plane.len());
    for &x in plane {
        let v = x * exposure;
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        let b = (linear_to_srgb(v) * 255.0).round() as u8;
        out.extend([b, b, b]);
    }
    out
}

fn flip_mean(reference: &[u8], test: &[u8], w: usize, h: usize, ppd: f32) -> f64 {
    let v = flip_map(reference, test, w, h, ppd);
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64
}

/// The per-pixel LDR-FLIP error of two tone-mapped 8-bit RGB images.
pub(crate) fn flip_map(reference: &[u8], test: &[u8], w: usize, h: usize, ppd: f32) -> Vec<f32> {
    if reference == test {
        // FLIP of identical images is 0; skip the filters.
        return vec![0.0; w * h];
    }
    let map = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w as u32, h as u32, reference),
        nv_flip::FlipImageRgb8::with_data(w as u32, h as u32, test),
        ppd,
    );
    map.to_vec()
}

/// Samples per pixel of a rank-N separable application.
fn samples(passes: &[Taps]) -> usize {
    2 * passes.iter().map(|t| t.offsets_mm.len()).sum::<usize>()
}

/// `kernel` on `exact`'s case with its full factors and its tap table at
/// each count in `taps` (duplicates evaluated once).
pub fn evaluate(
    exact: &Exact,
    kernel: &KernelFile,
    taps: &[usize],
    options: &Options,
) -> Result<KernelImageErrors> {
    Ok(evaluate_keeping(exact, kernel, taps, options, None)?.0)
}

/// [`evaluate`], also returning the filtered image of `keep` (when it is
/// one of the evaluated factors) for contact sheets.
pub fn evaluate_keeping(
    exact: &Exact,
    kernel: &KernelFile,
    taps: &[usize],
    options: &Options,
    keep: Option<Which>,
) -> Result<(KernelImageErrors, Option<Image>)> {
    let mm = exact.case.mm_per_pixel;
    let mut kept = None;
    let mut run = |which: Which| -> Result<ImageErrors> {
        let passes = tap_passes(kernel, which, mm)?;
        let n = samples(&passes);
        let (img, secs) = filter(&exact.case, passes)?;
        let mut e = errors(exact, &img, options)?;
        e.ms_per_megapixel = 1e3 * secs / (img.len() as f64 / 1e6);
        e.samples_per_pixel = n;
        if keep == Some(which) {
            kept = Some(img);
        }
        Ok(e)
    };
    let full = run(Which::Full)?;
    let mut by_count = BTreeMap::new();
    for &n in taps {
        if let std::collections::btree_map::Entry::Vacant(slot) = by_count.entry(n) {
            slot.insert(run(Which::Taps(n))?);
        }
    }
    Ok((
        KernelImageErrors {
            signal: exact.case.name.clone(),
            mm_per_pixel: mm,
            full,
            taps: by_count,
        },
        kept,
    ))
}

/// [`Exact::new`] then [`evaluate`], for a single kernel.
pub fn evaluate_profile(
    profile: &Profile,
    kernel: &KernelFile,
    case: &ImageCase,
    taps: &[usize],
    options: &Options,
) -> Result<KernelImageErrors> {
    evaluate(&Exact::new(profile, case)?, kernel, taps, options)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{fit_kernel_file, Kernel2DSpec, Model};

    fn profile() -> Profile {
        let m = crate::material::preset("skin1").unwrap();
        let grid = crate::profile::RadialGrid::uniform(0.01, 8.0).unwrap();
        crate::kernel::reference::dipole_profile(&m, &grid).unwrap()
    }

    /// About 20 pixels of kernel radius: quick, and the FFT path.
    fn scale(p: &Profile) -> f64 {
        let r = (0..3)
            .map(|c| crate::profile::radius_holding(p, c, 0.999))
            .fold(0.0, f64::max);
        r / 20.0
    }

    fn kernel(p: &Profile, model: Model, mm: f64) -> KernelFile {
        // The 2D kernel on the pixel grid, so resampling to pixels is exact.
        let k = exact::reference_kernel(p, mm).unwrap();
        let spec = Kernel2DSpec {
            size: Some(k.size),
            extent_mm: Some(k.extent_mm()),
        };
        fit_kernel_file(p, &spec, &model, 17).unwrap()
    }

    /// Pre-integration is exact for additively separable irradiance (Freude 2014
    /// section 5.2): on the edge, full factors reproduce the 2D convolution
    /// to round-off (f64) or to f32 storage; the tap table does not.
    #[test]
    fn preintegration_is_exact_on_the_edge() {
        let p = profile();
        let mm = scale(&p);
        let k = kernel(
            &p,
            Model::Preintegrate {
                method: crate::kernel::preintegrate::PreMethod::Grid,
            },
            mm,
        );
        let case = ImageCase::signal(Signal::Edge, 64, mm).unwrap();
        let exact = Exact::new(&p, &case).unwrap();
        let f64_opts = Options {
            round_to_f32: false,
            ..Options::default()
        };
        let e = evaluate(&exact, &k, &[17, 9], &f64_opts).unwrap();
        for c in 0..3 {
            assert!(e.full.rel_rms[c] < 1e-9, "{:?}", e.full.rel_rms);
            assert_eq!(e.full.flip[c], 0.0, "{:?}", e.full.flip);
            assert!(e.taps[&17].rel_rms[c] > 1e-4, "{:?}", e.taps[&17]);
            // Fewer taps, larger error.
            assert!(e.taps[&9].rel_rms[c] > e.taps[&17].rel_rms[c]);
        }
        assert_eq!(e.full.flip_rgb, 0.0);
        assert!(e.taps[&9].flip_rgb > 0.0);
        assert_eq!(e.taps[&17].samples_per_pixel, 34);
        let stored = evaluate(&exact, &k, &[17], &Options::default()).unwrap();
        for c in 0..3 {
            // f32 storage: each value moves by at most 2^-24 of itself.
            assert!(stored.full.rel_rms[c] < 6e-8, "{:?}", stored.full.rel_rms);
        }
        // Not exact where irradiance is not additively separable.
        let shapes = ImageCase::signal(Signal::Shapes, 64, mm).unwrap();
        let s = evaluate_profile(&p, &k, &shapes, &[], &f64_opts).unwrap();
        assert!(s.full.rel_rms.iter().all(|&v| v > 1e-4), "{:?}", s.full);
    }

    #[test]
    fn flip_sees_a_blur_and_rms_matches_its_definition() {
        let p = profile();
        let mm = scale(&p);
        let case = ImageCase::signal(Signal::Shapes, 64, mm).unwrap();
        let exact = Exact::new(&p, &case).unwrap();
        let o = Options::default();
        // The unfiltered signal against the exact blur: large errors.
        let e = errors(&exact, &case.image, &o).unwrap();
        for c in 0..3 {
            assert!(e.flip[c] > 0.05, "{:?}", e.flip);
            let (ex, f) = (&exact.image.rgb[c], &case.image.rgb[c]);
            let peak = ex.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
            let rms = (ex
                .iter()
                .zip(f)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                / ex.len() as f64)
                .sqrt();
            // Definition in f64; the evaluation rounds to f32 first.
            assert!((e.rel_rms[c] - rms / peak).abs() < 1e-6 * rms / peak);
        }
        assert!(e.flip_rgb > 0.05);
        let same = errors(&exact, &exact.image, &o).unwrap();
        assert_eq!(same.flip, [0.0; 3]);
        assert_eq!(same.rel_rms, [0.0; 3]);
        // A difference the tone mapping clamps away (the brightest pixel,
        // above the exposure's 1) is invisible to FLIP, not to the RMS.
        let mut a = exact.image.clone();
        let i = (0..a.len())
            .max_by(|&i, &j| a.rgb[0][i].total_cmp(&a.rgb[0][j]))
            .unwrap();
        a.rgb[0][i] *= 1.5;
        let clipped = errors(&exact, &a, &o).unwrap();
        assert_eq!(clipped.flip[0], 0.0);
        assert!(clipped.rel_rms[0] > 0.0);
    }

    #[test]
    fn flip_of_identical_images_is_zero_in_the_library_too() {
        let img: Vec<u8> = (0..48 * 32 * 3).map(|i| (i * 37 % 251) as u8).collect();
        let map = nv_flip::flip(
            nv_flip::FlipImageRgb8::with_data(48, 32, &img),
            nv_flip::FlipImageRgb8::with_data(48, 32, &img),
            67.0,
        );
        assert!(map.to_vec().iter().all(|&v| v == 0.0));
        let mut other = img.clone();
        other[3 * (16 * 48 + 24)] ^= 0x80;
        assert!(flip_mean(&img, &other, 48, 32, 67.0) > 0.0);
    }

    /// The grey tone map gives the bytes of the colour one of (v, v, v),
    /// NaN, negatives and values past 1 included; the exact side's tone
    /// maps, kept per rounding, score as made afresh.
    #[test]
    fn grey_and_kept_tone_maps_are_the_per_call_ones() {
        let plane: Vec<f64> = (0..4000).map(|i| (i as f64 * 0.37).sin() * 1.3).collect();
        let plane = [&plane[..], &[f64::NAN, -0.0, 1e-9, 0.0031308, 1.0, 2.5]].concat();
        let mut img = Image::new(plane.len(), 1);
        img.rgb = [plane.clone(), plane.clone(), plane.clone()];
        for x in [1.0, 0.731, 3.2] {
            let old = tone_map(&img, |i| [img.rgb[0][i] * x; 3]);
            assert_eq!(tone_map_grey(&plane, x), old);
        }
        let p = profile();
        let case = ImageCase::signal(Signal::Shapes, 32, scale(&p)).unwrap();
        let (kept, blur) = (Exact::new(&p, &case).unwrap(), &case.image);
        for round_to_f32 in [true, false, true] {
            let o = Options {
                round_to_f32,
                ..Options::default()
            };
            let fresh = errors(&Exact::new(&p, &case).unwrap(), blur, &o).unwrap();
            assert_eq!(errors(&kept, blur, &o).unwrap(), fresh, "{round_to_f32}");
            let e = if round_to_f32 {
                round_f32(&kept.image)
            } else {
                kept.image.clone()
            };
            let made = kept.tones[usize::from(round_to_f32)].get();
            assert_eq!(made, Some(&tones(&e, &kept)), "{round_to_f32}");
        }
    }

    #[test]
    fn exposure_maps_the_99th_percentile_to_one() {
        let v: Vec<f64> = (1..=1000).map(|i| i as f64).chain([0.0; 50]).collect();
        assert_eq!(exposure_of(&v), 1.0 / 990.0);
        assert_eq!(exposure_of(&[0.0; 4]), 1.0);
    }
}
