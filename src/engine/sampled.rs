//! The parameters `ssskit engine` prints for Unreal and HDRP, scored
//! through each engine's own sampling (`super::sampling`) on a flat plane
//! seen straight on, as the disk kernels are scored
//! ([`crate::filter::disk_error`]): the bias (the mean over many
//! rotations against the exact convolution with the engine's own Burley
//! profile) and the noise, in one frame and after the engine's
//! accumulation. The profile-shape error (`super::FitError`) is the
//! distance from that Burley profile to the measured one; these are what
//! the sampling adds on top.
//!
//! What the flat plane leaves out, where a scene would differ: depth and
//! normal weights (equal on a plane seen straight on), other profiles'
//! pixels, Unreal's irradiance mips (the pass reads level 0 here) and its
//! adaptive count (scored at its two ends, [`UNREAL_MIN_SAMPLES`] and
//! [`UNREAL_MAX_SAMPLES`]); texels beyond the image are clamped to its
//! border as the exact reference's are (HDRP drops them, which only
//! matters within a kernel radius of the screen's edge).
//!
//! Accumulation: Unreal's pass changes its pattern every frame
//! (`View.FrameNumber` seeds it), so K frames are K rotations; HDRP's
//! rotation hashes the pixel and its depth, not the frame, so on a static
//! view every frame repeats the same pattern and K frames leave the noise
//! of one ([`SampledError::static_pattern`]); its bias is measured over
//! rotations from distinct depth values.

use super::sampling::{
    EngineSample, HdrpProfile, UnrealProfile, HDRP_BUDGETS, UNREAL_MAX_SAMPLES, UNREAL_MIN_SAMPLES,
};
use super::{EngineFit, Scene, Version};
use crate::error::{Error, Result};
use crate::filter::disk_error::{frames_error, full_reference, truncated, DiskError};
use crate::filter::rows::par_planes;
use crate::filter::Image;
use serde::Serialize;

/// Rotations the bias is the mean over: 4 windows of [`FRAMES`] (batch
/// means for the noise after K, as `advise` measures disk kernels).
pub const ROTATIONS: u32 = 32;
/// Frames accumulated for the noise after K: the 8 of the disk tables.
pub const FRAMES: u32 = 8;

/// One engine pass on a flat plane.
#[derive(Clone, Copy, Debug)]
pub enum Sampler {
    /// Unreal's Burley pass with `samples` per pixel; `mm_scale` scene mm
    /// per profile mm.
    Unreal {
        profile: UnrealProfile,
        mm_scale: f64,
        samples: usize,
    },
    /// HDRP's pass under a sample budget.
    Hdrp { profile: HdrpProfile, budget: usize },
}

impl Sampler {
    /// Samples per pixel at `mm_per_pixel` (scene mm).
    pub fn samples_per_pixel(&self, mm_per_pixel: f64) -> usize {
        match *self {
            Sampler::Unreal { samples, .. } => samples,
            Sampler::Hdrp { profile, budget } => profile.sample_count(mm_per_pixel, budget),
        }
    }

    /// The pass's image of `image` in frame `frame` (Unreal: the frame
    /// number; HDRP: the depth value's 24-bit integer that seeds the
    /// rotation).
    pub fn frame(&self, image: &Image, mm_per_pixel: f64, frame: u32) -> Image {
        let (w, h) = (image.width, image.height);
        let rgb = par_planes(w, h, |x, y| self.pixel(image, mm_per_pixel, frame, x, y));
        Image {
            width: w,
            height: h,
            rgb,
            alpha: image.alpha.clone(),
        }
    }

    fn pixel(&self, image: &Image, mm_per_pixel: f64, frame: u32, x: usize, y: usize) -> [f64; 3] {
        let centre = image_at(image, x as i64, y as i64);
        match *self {
            Sampler::Unreal {
                profile,
                mm_scale,
                samples,
            } => {
                // The shader works in profile mm: one pixel is
                // mm_per_pixel / mm_scale of them.
                let pixel_mm = mm_per_pixel / mm_scale;
                let s = profile.samples(x as u32, y as u32, frame, samples, pixel_mm);
                // Point sampling at the texel under uv + offset:
                // floor(x + 1/2 + dx).
                let (acc, wsum) = gather(image, &s, |v| (v / pixel_mm + 0.5).floor(), x, y);
                profile.resolve(acc, wsum, centre, profile.centre_weight(pixel_mm))
            }
            Sampler::Hdrp { profile, budget } => {
                let n = profile.sample_count(mm_per_pixel, budget);
                if n == 0 {
                    return centre;
                }
                let phase = HdrpProfile::phase(x as u32, y as u32, frame);
                let s = profile.samples(phase, n);
                // position = pixelCoord + round(pixelsPerMm x offset).
                let (acc, wsum) = gather(image, &s, |v| (v / mm_per_pixel).round(), x, y);
                std::array::from_fn(|c| acc[c] / wsum[c].max(f64::MIN_POSITIVE))
            }
        }
    }
}

/// The texel of (x, y) clamped to the image.
fn image_at(image: &Image, x: i64, y: i64) -> [f64; 3] {
    let xi = x.clamp(0, image.width as i64 - 1) as usize;
    let yi = y.clamp(0, image.height as i64 - 1) as usize;
    let i = yi * image.width + xi;
    [image.rgb[0][i], image.rgb[1][i], image.rgb[2][i]]
}

/// Sum of weight x colour and of the weights over `samples`, each fetched
/// at the texel `texel(offset)` pixels from (x, y).
fn gather(
    image: &Image,
    samples: &[EngineSample],
    texel: impl Fn(f64) -> f64,
    x: usize,
    y: usize,
) -> ([f64; 3], [f64; 3]) {
    let (mut acc, mut wsum) = ([0.0; 3], [0.0; 3]);
    for s in samples {
        let px = x as i64 + texel(s.x_mm) as i64;
        let py = y as i64 + texel(s.y_mm) as i64;
        let v = image_at(image, px, py);
        for c in 0..3 {
            acc[c] += s.weight[c] * v[c];
            wsum[c] += s.weight[c];
        }
    }
    (acc, wsum)
}

/// The error of one engine pass on one signal.
#[derive(Clone, Debug, Serialize)]
pub struct SampledError {
    /// What sets the sample count ("BURLEY_NUM_SAMPLES", "Medium budget").
    pub setting: String,
    pub samples_per_pixel: usize,
    pub signal: String,
    /// True where frames repeat one pattern on a static view (HDRP): the
    /// noise after K frames is the noise of one.
    pub static_pattern: bool,
    pub error: DiskError,
}

/// The passes an engine runs at its default sample counts for the fit's
/// printed values: Unreal at the ends of its adaptive count, HDRP at its
/// Low, Medium and High budgets.
pub fn samplers(
    fit: &EngineFit,
    engine: super::Engine,
    scene: Scene,
    v: Version,
) -> Result<Vec<(String, Sampler)>> {
    match engine {
        super::Engine::Unreal => {
            let (profile, mm_scale) = super::unreal::sampled_profile(&fit.params, scene, v)?;
            Ok([
                (UNREAL_MAX_SAMPLES, "BURLEY_NUM_SAMPLES"),
                (UNREAL_MIN_SAMPLES, "BETA_LIMIT"),
            ]
            .into_iter()
            .map(|(samples, name)| {
                let s = Sampler::Unreal {
                    profile,
                    mm_scale,
                    samples,
                };
                (name.to_string(), s)
            })
            .collect())
        }
        super::Engine::UnityHdrp => {
            let rendered = fit.rendered.as_ref().ok_or_else(|| {
                Error::Unsupported("the HDRP fit holds no rendered profile".into())
            })?;
            let profile = HdrpProfile {
                d_mm: rendered.d_mm,
            };
            Ok(HDRP_BUDGETS
                .into_iter()
                .zip(["Low", "Medium", "High"])
                .map(|(budget, level)| {
                    let s = Sampler::Hdrp { profile, budget };
                    (format!("{level} budget ({budget})"), s)
                })
                .collect())
        }
        _ => Err(Error::Unsupported(format!(
            "{}: no sampled pass is re-implemented (Unreal and HDRP are)",
            engine.name()
        ))),
    }
}

/// Scores every pass of [`samplers`] on each of `signals` (name, image) at
/// `mm_per_pixel`, against the exact convolution with the fit's Burley
/// profile cut where it holds [`DEFAULT_HOLD`](crate::profile::radius::DEFAULT_HOLD) of
/// every channel (`default_extent`).
pub fn score(
    fit: &EngineFit,
    engine: super::Engine,
    scene: Scene,
    v: Version,
    signals: &[(String, Image)],
    mm_per_pixel: f64,
) -> Result<Vec<SampledError>> {
    crate::filter::check_mm_per_pixel(mm_per_pixel)?;
    let passes = samplers(fit, engine, scene, v)?;
    let p = &fit.profile;
    let radius = crate::profile::radius::default_extent(p, 0..p.channels.len());
    let cut = truncated(p, radius);
    let mut out = Vec::new();
    for (name, image) in signals {
        let reference = full_reference(&cut, image, mm_per_pixel)?;
        for (setting, pass) in &passes {
            let n = pass.samples_per_pixel(mm_per_pixel);
            let (mut error, _) = frames_error(image, &reference, n, ROTATIONS, FRAMES, |k| {
                Ok(pass.frame(image, mm_per_pixel, k))
            })?;
            let static_pattern = matches!(pass, Sampler::Hdrp { .. });
            if static_pattern {
                error.noise_after = error.noise;
            }
            out.push(SampledError {
                setting: setting.clone(),
                samples_per_pixel: n,
                signal: name.clone(),
                static_pattern,
                error,
            });
        }
    }
    Ok(out)
}

/// Side of the square test images the sampled passes are scored on: the
/// disk tables' 64 pixels (6.4 mm at 0.1 mm per pixel, several shape
/// distances of the reference materials).
pub const SIGNAL_SIZE: usize = 64;

/// The flat-plane signals of the scores: the edge and the shapes.
pub fn signals() -> Result<Vec<(String, Image)>> {
    use crate::filter::signals::{generate, Signal};
    Ok(vec![
        (
            "edge".into(),
            generate(Signal::Edge, SIGNAL_SIZE, SIGNAL_SIZE, 8)?,
        ),
        (
            "shapes".into(),
            generate(Signal::Shapes, SIGNAL_SIZE, SIGNAL_SIZE, 8)?,
        ),
    ])
}
