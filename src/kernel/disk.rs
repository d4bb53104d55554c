//! The disk kernel file (`ssskit.disk/1`): its samples (radius, angle,
//! RGB weight), what its predicted error assumes ([`Accumulation`]), how
//! an engine runs it ([`DiskUsage`]), its checks, reading and writing. The
//! fit that draws the samples from a profile is `disk_fit`.

use super::format::{
    agrees, check_profile_total, kernel_file_struct, DISK_SCHEMA, STATED_SUM_TOLERANCE,
};
use super::ModelInfo;
use crate::error::{check_header, Error, Result};
use crate::material::Material;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;

/// Fewest samples per channel a disk kernel may have: below 4 the spiral
/// covers no angle twice and the estimate is a handful of spikes.
pub const MIN_SAMPLES: usize = 4;
/// Samples per channel of `ssskit fit --model disk` unless told: 32
/// fetches, the cost of a 17-tap separable pair (34 samples per pixel).
pub const DEFAULT_SAMPLES: usize = 32;
/// Most samples per channel: 1024 reaches the exact convolution within the
/// bias the oracles state; more costs fetches no renderer spends.
pub const MAX_SAMPLES: usize = 1024;

/// Most frames one filtering may accumulate (and a kernel may record): a
/// temporal filter's history is a few dozen frames; 4096 leaves room for
/// measuring the mean over rotations, and the work cap bounds the product
/// with the image anyway.
pub const MAX_FRAMES: u32 = 4096;

/// The camera an [`Accumulation`] assumes: static, the same surface point
/// under a pixel in every frame (no motion, nothing to reproject).
pub const STATIC_CAMERA: &str = "static";

/// How an [`Accumulation`] weighs its frames: the plain mean.
pub const MEAN: &str = "mean";

/// Largest sample radius a file may hold, in mm: far beyond any profile
/// (metres of scattering), small enough that radius x pixels-per-mm stays
/// finite in f32.
pub const MAX_RADIUS_MM: f64 = 1e6;

/// Which density the radii are drawn from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RadiusPdf {
    /// One set from the widest channel's kernel (largest mean radius), the
    /// engines' choice and the default; the other channels weighted
    /// K_c / K_widest.
    Widest,
    /// One set of N radii from the mean of the three normalised channel
    /// kernels; per-channel weights K_c / q (each below 3).
    Mean,
    /// N radii per channel from its own kernel, weight 1 / N in that channel
    /// and 0 in the others: 3 N samples in the file.
    PerChannel,
}

impl RadiusPdf {
    pub fn name(self) -> &'static str {
        match self {
            RadiusPdf::Mean => "mean",
            RadiusPdf::Widest => "widest",
            RadiusPdf::PerChannel => "per-channel",
        }
    }
}

/// One sample: polar position in mm on the surface, RGB weight.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskSample {
    pub radius_mm: f64,
    /// Radians in [0, 2 pi), before the per-pixel rotation.
    pub angle: f64,
    pub weight: [f64; 3],
}

/// What a disk kernel's predicted error assumes of the renderer
/// (`ssskit advise` and the `recommended.json` of `ssskit kernels` record
/// it; a kernel without it predicts nothing): the plain mean of `frames`
/// frames, frame k (from `first_frame`) turning the samples by its own
/// angle, under a static camera. One frame alone shows about sqrt(frames)
/// times the noise; a moving camera without reprojection, more too.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Accumulation {
    /// Frames averaged (K).
    pub frames: u32,
    /// The rotation seed of the first (`apply --frame-seed`).
    pub first_frame: u32,
    /// [`MEAN`].
    pub accumulate: String,
    /// [`STATIC_CAMERA`].
    pub camera: String,
}

impl Accumulation {
    /// The plain mean of `frames` frames from `first_frame`, static camera.
    pub fn static_mean(frames: u32, first_frame: u32) -> Accumulation {
        Accumulation {
            frames,
            first_frame,
            accumulate: MEAN.into(),
            camera: STATIC_CAMERA.into(),
        }
    }

    /// "the plain mean of 8 frames (frames 0 to 7) under a static camera".
    pub fn describe(&self) -> String {
        format!(
            "the plain mean of {} frames (frame seeds {} to {}) under a static camera",
            self.frames,
            self.first_frame,
            self.first_frame as u64 + self.frames as u64 - 1
        )
    }

    fn validate(&self) -> std::result::Result<(), String> {
        if !(1..=MAX_FRAMES).contains(&self.frames) {
            return Err(format!(
                "accumulation.frames is {}: must be in 1..={MAX_FRAMES}",
                self.frames
            ));
        }
        if self.accumulate != MEAN || self.camera != STATIC_CAMERA {
            return Err(format!(
                "accumulation is '{}' under a '{}' camera: the one recorded is '{MEAN}' under a \
                 '{STATIC_CAMERA}' camera",
                self.accumulate, self.camera
            ));
        }
        Ok(())
    }
}

/// How an engine runs a disk kernel, recomputed on every write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskUsage {
    pub pixels_per_mm: String,
    pub rotation: String,
    pub weights: String,
    pub depth: String,
    pub total_rd: String,
}

/// How to rotate, fetch and weigh (the header of the emitted tables too).
pub const ROTATION: &str = "rotate every sample by the pixel's angle phi = 2 pi fract(ign(x, y) + (seed + frame) x 0.41421356 (sqrt 2 - 1)), with interleaved gradient noise ign(x, y) = fract(52.9829189 fract(0.06711056 x + 0.00583715 y)) (Jimenez 2014; ssskit evaluates it in 32-bit fixed point and keeps 24 bits); the sample's pixel offset is pixels_per_mm x radius_mm x (cos(angle + phi), sin(angle + phi)), x right and y down; fetch the irradiance bilinearly, clamped to the image";

pub const WEIGHTS: &str = "result = sum over samples of weight x colour, per channel; the weights are R_d / pdf and already sum to 1 per channel (no division: a constant image stays constant), so only total_rd multiplies afterwards; accumulate frames with a changing `frame` (ssskit's apply --frames takes the plain mean, static camera)";

pub const DEPTH_DISK: &str = "as the separable pass: pixels_per_mm divides by the pixel's linear view depth, and with follow-surface each sample's colour is lerped toward the centre colour by t = clamp(C x sss_width x |d_centre - d_sample| / tan(fov_y / 2), 0, 1) (Freude 2014, eq. 4.12)";

kernel_file_struct! {
    /// A disk kernel file (`ssskit.disk/1`).
    #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
    pub struct DiskKernelFile {
        pub samples: Vec<DiskSample>,
        /// Per channel: the weights' sum before they were scaled to 1 (the
        /// stratified estimate of the kernel's integral, exactly 1 for
        /// per-channel radii); its distance from 1 is what the normalisation
        /// moved.
        pub raw_weight_sum: [f64; 3],
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub usage: Option<DiskUsage>,
        /// The profile's angular entry and exit factors, when it has them.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub angular: Option<super::angular::AngularFactors>,
        /// What its predicted error assumes (None: no prediction was made,
        /// `fit --model disk`, or a file written before it was recorded).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub accumulation: Option<Accumulation>,
    }
}

impl DiskKernelFile {
    /// Fetches per pixel and frame.
    pub fn samples_per_pixel(&self) -> usize {
        self.samples.len()
    }

    pub fn validate(&self, context: &str) -> Result<()> {
        check_header(context, &self.schema, DISK_SCHEMA, &self.units)?;
        let bad = |m: String| Err(Error::format(context, m));
        let n = self.samples.len();
        if !(MIN_SAMPLES..=3 * MAX_SAMPLES).contains(&n) {
            return bad(format!(
                "{n} samples: a disk kernel has {MIN_SAMPLES} to {} (3 x {MAX_SAMPLES} with \
                 per-channel radii)",
                3 * MAX_SAMPLES
            ));
        }
        if let Some(m) = &self.material {
            m.validate(context)?;
        }
        if let Some(x) = self.total_rd.iter().find(|x| !x.is_finite() || **x < 0.0) {
            return bad(format!("total_rd holds {x}: must be finite and >= 0"));
        }
        for (i, s) in self.samples.iter().enumerate() {
            if !(s.radius_mm >= 0.0 && s.radius_mm <= MAX_RADIUS_MM) {
                return bad(format!(
                    "samples[{i}].radius_mm is {}: must be in [0, {MAX_RADIUS_MM:e}] mm",
                    s.radius_mm
                ));
            }
            if !(s.angle >= 0.0 && s.angle < 2.0 * PI) {
                return bad(format!(
                    "samples[{i}].angle is {}: must be in [0, 2 pi)",
                    s.angle
                ));
            }
            if let Some(w) = s.weight.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
                return bad(format!(
                    "samples[{i}].weight holds {w}: must be finite and >= 0 (profile / pdf)"
                ));
            }
        }
        for (c, name) in ["r", "g", "b"].iter().enumerate() {
            let sum: f64 = self.samples.iter().map(|s| s.weight[c]).sum();
            if !agrees(1.0, sum) {
                return bad(format!(
                    "samples[*].weight: channel {name} sums to {sum:.9}; a disk kernel's weights \
                     sum to 1 per channel (they are normalised: a constant image stays constant; \
                     tolerance {STATED_SUM_TOLERANCE:.0e})"
                ));
            }
        }
        self.check_raw_sums().or_else(bad)?;
        if let Some(a) = &self.accumulation {
            a.validate().or_else(bad)?;
        }
        check_profile_total(&self.profile, &self.total_rd).or_else(bad)?;
        if let Some(a) = &self.angular {
            a.validate("angular").or_else(bad)?;
            a.check_energy("angular", &self.total_rd).or_else(bad)?;
        }
        Ok(())
    }

    /// `raw_weight_sum` against the radii the file names: the raw weights
    /// K_c / (N q) of the mixture q = sum mix_c K_c sum, over the channels
    /// mixed, to sum_c mix_c raw_c = 1 exactly (each sample adds 1 / N):
    /// every channel's sum is 1 with per-channel radii, the widest
    /// channel's with the widest, their mean with the mean.
    fn check_raw_sums(&self) -> std::result::Result<(), String> {
        let raw = self.raw_weight_sum;
        if let Some(x) = raw.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
            return Err(format!(
                "raw_weight_sum holds {x}: the weights' sums before normalising are finite and > 0"
            ));
        }
        let radii = self.model.params.get("radii").and_then(|v| v.as_str());
        let (ok, rule) = match radii {
            Some("per-channel") => (raw.iter().all(|&x| agrees(1.0, x)), "each channel's is 1"),
            Some("widest") => (
                raw.iter().any(|&x| agrees(1.0, x)),
                "the widest channel's is 1",
            ),
            Some("mean") => (
                agrees(1.0, raw.iter().sum::<f64>() / 3.0),
                "their mean is 1",
            ),
            _ => return Ok(()),
        };
        if !ok {
            return Err(format!(
                "raw_weight_sum is {raw:?}: with radii '{}' {rule} (each sample adds 1 / N to the \
                 density it was drawn from)",
                radii.unwrap_or_default()
            ));
        }
        Ok(())
    }

    pub fn usage(&self) -> DiskUsage {
        DiskUsage {
            pixels_per_mm: super::format::PIXELS_PER_MM.into(),
            rotation: ROTATION.into(),
            weights: WEIGHTS.into(),
            depth: DEPTH_DISK.into(),
            total_rd: super::format::TOTAL_RD.into(),
        }
    }

    /// The file as [`write`](Self::write) writes it: with its usage notes.
    pub fn as_written(&self) -> DiskKernelFile {
        DiskKernelFile {
            usage: Some(self.usage()),
            ..self.clone()
        }
    }

    /// The frames to accumulate and the first frame's seed: `frames` and
    /// `first` where given, else the recorded [`Accumulation`]'s (what the
    /// kernel's predicted error assumes), else one frame from seed 0.
    pub fn frames_to_run(&self, frames: Option<u32>, first: Option<u32>) -> (u32, u32) {
        let a = self.accumulation.as_ref();
        (
            frames.or(a.map(|a| a.frames)).unwrap_or(1),
            first.or(a.map(|a| a.first_frame)).unwrap_or(0),
        )
    }

    pub fn read(path: &Path) -> Result<DiskKernelFile> {
        let k: DiskKernelFile = super::format::read_kernel(path, DISK_SCHEMA)?;
        k.validate(&path.display().to_string())?;
        Ok(k)
    }

    /// Writes atomically, after the reader's checks (`format::write_kernel`).
    pub fn write(&self, path: &Path) -> Result<()> {
        super::format::write_kernel(path, |c| self.validate(c), || self.as_written())
    }
}

/// Whether the JSON file at `path` holds a disk kernel (its `schema`), for
/// readers that take either kind; false when it cannot be read as JSON
/// (the kernel reader then says why).
pub fn is_disk_file(path: &Path) -> bool {
    #[derive(Deserialize)]
    struct Schema {
        schema: String,
    }
    crate::io::read_json::<Schema>(path).is_ok_and(|s| s.schema == DISK_SCHEMA)
}
