//! The error of a disk kernel as a user sees it, against the exact 2D
//! convolution: the bias (the mean over many rotations, what a converged
//! temporal filter shows) and the noise (the spread of single frames about
//! that mean), also after K accumulated frames. Accumulation is a plain
//! mean, linear in the frames, so it leaves the bias as it is and only
//! lowers the noise. All relative to the reference's peak per channel, as
//! [`super::diff::DiffStats::rms_rel`].
//!
//! [`score_disk`] is the whole measure from a profile, for the advice and
//! the comparisons: cost (samples per pixel), bias, noise.

use super::accumulate::Accumulate;
use super::disk::{disk_frames, DiskSetup};
use super::exact::convolve_2d;
use super::{Image, Scale, Setup};
use crate::error::{Error, Result};
use crate::kernel::disk::{RadiusPdf, MAX_FRAMES};
use crate::kernel::disk_fit::fit_disk;
use crate::kernel::Kernel2D;
use crate::profile::radius::default_extent;
use crate::profile::Profile;
use serde::Serialize;

/// Bias and noise of a disk pass, per channel, relative to the
/// reference's peak.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiskError {
    /// Fetches per pixel and frame.
    pub samples_per_pixel: usize,
    /// Rotations the mean (the bias) is taken over.
    pub rotations: u32,
    /// Frames accumulated for `noise_after`.
    pub frames: u32,
    /// RMS over pixels of (mean over `rotations` frames - reference).
    pub bias: [f64; 3],
    /// The standard error of the mean over `rotations` frames, the part of
    /// `bias` its own noise may account for: by batch means,
    /// noise_after / sqrt(rotations / frames) (consecutive frames are not
    /// independent; blocks of `frames` nearly are).
    pub bias_noise_floor: [f64; 3],
    /// RMS over pixels and frames of (one frame - the mean), unbiased
    /// (divided by rotations - 1).
    pub noise: [f64; 3],
    /// The same for means of `frames` consecutive frames.
    pub noise_after: [f64; 3],
}

/// Measures `setup` (its `seed`; its `frames` is ignored) on `image`
/// against `reference` over `rotations` frames, in windows of `frames`.
pub fn disk_error(
    image: &Image,
    setup: &DiskSetup,
    reference: &Image,
    rotations: u32,
    frames: u32,
) -> Result<DiskError> {
    Ok(disk_error_with_first(image, setup, reference, rotations, frames)?.0)
}

/// [`disk_error`] and the first accumulation of `frames` frames
/// ([`FirstAccumulation`]), so that other references (the advice's
/// bootstrap replicates) can be compared with it.
pub fn disk_error_with_first(
    image: &Image,
    setup: &DiskSetup,
    reference: &Image,
    rotations: u32,
    frames: u32,
) -> Result<(DiskError, FirstAccumulation)> {
    frames_error(image, reference, setup.taps.len(), rotations, frames, |k| {
        let s = setup.with_frames(setup.seed.wrapping_add(k), 1);
        Ok(disk_frames(image, &s)?.swap_remove(0))
    })
}

/// The first accumulation of K frames (frames seed .. seed + K - 1, the
/// image `apply --frames K` makes) and its error as `ssskit diff` reports
/// it: what a user who accumulates K frames under a static camera sees,
/// the one figure the advice scores and predicts a disk kernel by.
#[derive(Clone, Debug)]
pub struct FirstAccumulation {
    /// The mean of the first K frames.
    pub image: Image,
    /// Per channel, RMS over pixels of (`image` - reference), relative to
    /// the reference's peak.
    pub error: [f64; 3],
    /// Per channel, the sample standard deviation of that error over the
    /// rotations / K windows of K consecutive frames: how far the error of
    /// an accumulation that starts on another frame may lie from `error`.
    pub error_sd: [f64; 3],
}

/// Rotations make whole windows of `frames`, at least two of them, within
/// [`MAX_FRAMES`] (the spread between windows needs two).
fn check_rotations(rotations: u32, frames: u32) -> Result<()> {
    if frames == 0
        || rotations > MAX_FRAMES
        || !rotations.is_multiple_of(frames)
        || rotations / frames < 2
    {
        return Err(Error::invalid(
            "disk error",
            "rotations",
            rotations,
            format!(
                "must be a multiple of frames ({frames}), at least twice it and at most \
                 {MAX_FRAMES}"
            ),
        ));
    }
    Ok(())
}

/// [`disk_error_with_first`] for any stochastic pass: `frame(k)` is the
/// pass's diffuse image of frame k (k < `rotations`), `samples_per_pixel`
/// its fetches per pixel and frame (an engine's own sampling, the disk
/// kernels).
pub fn frames_error(
    image: &Image,
    reference: &Image,
    samples_per_pixel: usize,
    rotations: u32,
    frames: u32,
    mut frame: impl FnMut(u32) -> Result<Image>,
) -> Result<(DiskError, FirstAccumulation)> {
    check_rotations(rotations, frames)?;
    super::image::check_same_size("the reference", reference.width, reference.height, image)?;
    let n = image.len();
    let mut sum = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut sumsq = sum.clone();
    let mut win = sum.clone();
    let (mut wsum, mut wsumsq) = (sum.clone(), sum.clone());
    // Per window and channel: the sum of squares of (window mean - reference).
    let mut werr: Vec<[f64; 3]> = Vec::new();
    let mut first = image.clone();
    // The plain mean's weight per frame, added frame by frame in order as
    // the disk pass accumulates (`Accumulate::weights`), so that the first
    // window is bit for bit the image `apply --frames K` makes.
    let wf = Accumulate::Mean.weights(frames)[0];
    // Frame by frame: memory of a few images whatever the rotations.
    for k in 0..rotations {
        let f = &frame(k)?;
        super::image::check_same_size("a frame", f.width, f.height, image)?;
        for c in 0..3 {
            for (i, &v) in f.rgb[c].iter().enumerate() {
                sum[c][i] += v;
                sumsq[c][i] += v * v;
                win[c][i] += wf * v;
            }
        }
        if (k + 1) % frames == 0 {
            let mut e = [0.0; 3];
            for (c, e) in e.iter_mut().enumerate() {
                for i in 0..n {
                    let m = win[c][i];
                    wsum[c][i] += m;
                    wsumsq[c][i] += m * m;
                    *e += (m - reference.rgb[c][i]).powi(2);
                    if k + 1 == frames {
                        first.rgb[c][i] = m;
                    }
                    win[c][i] = 0.0;
                }
            }
            werr.push(e);
        }
    }
    let peak = reference.peak();
    let windows = (rotations / frames) as f64;
    let m = rotations as f64;
    let rel =
        |c: usize, sq: f64| (sq / n as f64).sqrt() / if peak[c] > 0.0 { peak[c] } else { 1.0 };
    let spread = |s: &[f64], s2: &[f64], count: f64| -> f64 {
        s.iter()
            .zip(s2)
            .map(|(a, b)| ((b - a * a / count) / (count - 1.0)).max(0.0))
            .sum()
    };
    let bias: [f64; 3] = std::array::from_fn(|c| {
        rel(
            c,
            sum[c]
                .iter()
                .zip(&reference.rgb[c])
                .map(|(s, r)| (s / m - r).powi(2))
                .sum(),
        )
    });
    let noise: [f64; 3] = std::array::from_fn(|c| rel(c, spread(&sum[c], &sumsq[c], m)));
    let noise_after: [f64; 3] =
        std::array::from_fn(|c| rel(c, spread(&wsum[c], &wsumsq[c], windows)));
    let window_errors = |c: usize| -> Vec<f64> { werr.iter().map(|e| rel(c, e[c])).collect() };
    let first = FirstAccumulation {
        image: first,
        error: std::array::from_fn(|c| rel(c, werr[0][c])),
        error_sd: std::array::from_fn(|c| crate::numerics::std_dev(&window_errors(c))),
    };
    let e = DiskError {
        samples_per_pixel,
        rotations,
        frames,
        bias,
        bias_noise_floor: noise_after.map(|v| v / windows.sqrt()),
        noise,
        noise_after,
    };
    Ok((e, first))
}

/// The disk kernel of `profile` with `samples` per channel (radii from
/// `radii`) applied to `signal` at `mm_per_pixel`, measured against the
/// exact convolution averaged over each pixel (the expectation of the
/// pass's bilinear fetches) over `rotations` frames, noise also after
/// `frames`: what the advice weighs against a separable kernel of the same
/// cost (samples per pixel). Both see the profile cut at the radius that
/// holds [`DEFAULT_HOLD`](crate::profile::radius::DEFAULT_HOLD) of every channel (the extent of the exact
/// reference of `apply --reference`), so that the bias is the sampling's
/// alone.
pub fn score_disk(
    profile: &Profile,
    samples: usize,
    radii: RadiusPdf,
    signal: &Image,
    mm_per_pixel: f64,
    rotations: u32,
    frames: u32,
) -> Result<DiskError> {
    super::check_mm_per_pixel(mm_per_pixel)?;
    let radius = default_extent(profile, 0..profile.channels.len());
    let cut = truncated(profile, radius);
    let kernel = fit_disk(&cut, samples, radii)?;
    let reference = full_reference(&cut, signal, mm_per_pixel)?;
    let setup = DiskSetup::new(&kernel, view(mm_per_pixel), 0, 1);
    disk_error(signal, &setup, &reference, rotations, frames)
}

/// The finest scale (mm per pixel) at which [`full_reference`]'s grid over
/// `r_max` fits in [`crate::kernel::kernel2d::MAX_SIZE`] pixels (its size
/// is 2 (ceil(r_max / m) + 1) + 1).
/// Rounded up to three significant digits, so that the scale said fits.
fn coarsest_needed(r_max: f64) -> String {
    let half = ((crate::kernel::kernel2d::MAX_SIZE - 1) / 2 - 1) as f64;
    let m = r_max / half;
    let digits = 2 - m.log10().floor() as i32;
    let step = 10f64.powi(-digits);
    format!("{:.*}", digits.max(0) as usize, (m / step).ceil() * step)
}

/// `signal` convolved with the whole of `profile`'s kernel averaged over
/// each pixel: a grid that covers the profile's last edge, so nothing the
/// disk samples is outside it.
pub fn full_reference(profile: &Profile, signal: &Image, mm_per_pixel: f64) -> Result<Image> {
    let r_max = profile.r_edges.last().copied().unwrap_or(0.0);
    let half = (r_max / mm_per_pixel).ceil() + 1.0;
    let size = 2.0 * half + 1.0;
    if !(size <= crate::kernel::kernel2d::MAX_SIZE as f64) {
        return Err(Error::invalid(
            "disk error",
            "mm_per_pixel",
            mm_per_pixel,
            format!(
                "the exact image the disk kernel's error is measured against covers the \
                 profile's {r_max:.4} mm radius: {size} pixels wide at this scale, at most {}: \
                 use a scale of at least {} mm per pixel",
                crate::kernel::kernel2d::MAX_SIZE,
                coarsest_needed(r_max)
            ),
        ));
    }
    let k = Kernel2D::pixel_averaged(profile, size as usize, mm_per_pixel)?;
    super::exact::check_reference_fits(signal.width, signal.height, k.size)?;
    Ok(convolve_2d(signal, &k))
}

/// `profile` without the bins beyond `radius` (the bin holding it kept).
pub fn truncated(profile: &Profile, radius: f64) -> Profile {
    let n = profile.r_edges[1..]
        .iter()
        .position(|&e| e >= radius)
        .map_or(profile.r.len(), |i| i + 1);
    let mut p = profile.clone();
    p.r.truncate(n);
    p.r_edges.truncate(n + 1);
    p.rd.iter_mut().for_each(|v| v.truncate(n));
    if let Some(e) = p.rd_stderr.as_mut() {
        e.iter_mut().for_each(|v| v.truncate(n));
    }
    p
}

/// A plain orthographic view: no depth, strength, lerp or specular.
pub fn view(mm_per_pixel: f64) -> Setup {
    Setup {
        passes: Vec::new(),
        scale: Scale::MmPerPixel(mm_per_pixel),
        depth: None,
        strength: None,
        follow_surface: None,
        specular: None,
        jitter: false,
    }
}
