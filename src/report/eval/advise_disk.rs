//! The disk kernels in the advice (`kernel::disk`): one pass of N
//! importance-sampled samples per pixel, beside the separable layouts at
//! the same cost (N samples against 2 x terms x taps).
//!
//! A disk kernel's image changes every frame (its per-pixel rotation), so
//! its error on a test image has two parts ([`crate::filter::disk_error`]):
//! the bias b (the mean over many rotations against the exact image) and
//! the noise n_K of the mean of the K frames a temporal filter
//! accumulates (`Config::frames`). Both are per channel, relative to the
//! exact image's peak, as the separable score. The score on one signal is
//! the largest over the channels of the RMS the user sees after K frames,
//! sqrt(b^2 + n_K^2): the error of one accumulated image about the exact
//! one is its bias plus its zero-mean noise, whose mean squares add.
//!
//! The bias is measured as the RMS of the mean of R = [`WINDOWS`] x K
//! rotations less the exact image, so it holds that mean's own noise too
//! and errs high. Nothing is taken off for it: the batch-means floor
//! n_K / sqrt(WINDOWS) over-states that noise (the rotations step by a
//! low-discrepancy sequence, so the mean converges faster than independent
//! frames would; on skin1's shapes at 0.1 mm per pixel with 16 samples the
//! measured bias is 0.37% against a floor of 0.72%, docs/records/
//! disk-equal-cost.json), and a score that errs high never passes a disk
//! kernel that misses. The uncertainty carried into the decision is that
//! of the separable rows ([`super::advise_noise`]): the standard deviation
//! of the score over the bootstrap replicates of the profile, each
//! replicate's exact image against the same rotations' mean.
//!
//! The disk is fitted to the profile cut where the exact reference is
//! ([`crate::filter::exact::reference_kernel`], the radius holding
//! [`DEFAULT_HOLD`] of every channel), radii from the widest channel (the
//! default of `fit --model disk`), rotations from seed [`DISK_SEED`]: both
//! families are scored against the one exact image.

use super::advise_decide::{Verdict, NOISE_K};
use super::advise_noise::{std_dev, Reference};
use super::advise_search::Search;
use super::advise_types::{Candidate, DiskScore, DiskScores};
use super::evaluate::{self, ImageErrors};
use crate::error::{Error, Result};
use crate::filter::disk::{apply_disk, DiskSetup};
use crate::filter::disk_error::{disk_error_with_mean, truncated, view};
use crate::filter::Image;
use crate::kernel::disk::{fit_disk, DiskKernelFile, RadiusPdf};
use crate::profile::radius::DEFAULT_HOLD;
use crate::profile::Profile;
use serde_json::json;
use std::collections::BTreeMap;

/// Samples per pixel of the disk kernels advise tries: powers of two from
/// the fewest a disk kernel may have to 64, the most Unreal 5's Burley
/// pass takes per pixel (more costs more than the 2 x 33 of the widest
/// separable table).
pub const DISK_SAMPLES: [usize; 5] = [4, 8, 16, 32, 64];

/// Most frames advise accepts: a temporal filter's history is a few dozen
/// frames, and each signal costs [`WINDOWS`] x K disk passes to measure.
pub const MAX_FRAMES: u32 = 64;

/// Windows of K frames the noise after K frames is measured over (batch
/// means): the spread of 4 window means per pixel, averaged over the
/// 16384 pixels of a 128-pixel signal; the bias is the mean of the 4 K
/// frames.
pub const WINDOWS: u32 = 4;

/// The first frame's rotation seed.
pub const DISK_SEED: u32 = 0;

/// The label and model name of a disk row.
pub const DISK: &str = "disk";

/// A score on one test image: (signal, score, standard deviation).
type Scored = (String, f64, f64);

/// The disk kernel advise scores with `samples` per pixel.
pub fn disk_kernel(profile: &Profile, samples: usize) -> Result<DiskKernelFile> {
    let radius = (0..profile.channels.len())
        .map(|c| crate::profile::radius_holding(profile, c, DEFAULT_HOLD))
        .fold(0.0, f64::max);
    fit_disk(&truncated(profile, radius), samples, RadiusPdf::Widest)
}

/// A fingerprint of a disk kernel's samples (SHA-256 of their JSON, whose
/// numbers read back to the same bits): the advice carries the chosen
/// row's, so the written file can be checked to be the one scored.
pub fn disk_fingerprint(k: &DiskKernelFile) -> String {
    use sha2::{Digest, Sha256};
    let json = serde_json::to_vec(&k.samples).unwrap_or_default();
    Sha256::digest(json)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// sqrt(b^2 + n_K^2) per channel (module doc), the largest.
fn combined(bias: [f64; 3], after: [f64; 3]) -> f64 {
    (0..3).map(|c| bias[c].hypot(after[c])).fold(0.0, f64::max)
}

fn largest(v: [f64; 3]) -> f64 {
    v.into_iter().fold(0.0, f64::max)
}

/// Checks the frames to accumulate.
pub fn check_frames(frames: u32) -> Result<()> {
    if (1..=MAX_FRAMES).contains(&frames) {
        return Ok(());
    }
    Err(Error::invalid(
        "advise",
        "frames",
        frames,
        format!("must be in 1..={MAX_FRAMES}"),
    ))
}

/// The score of `kernel` on `r`'s test image: (score, its bootstrap
/// standard deviation, bias and noise).
fn score(kernel: &DiskKernelFile, r: &Reference, frames: u32) -> Result<(f64, f64, DiskScore)> {
    let case = &r.exact.case;
    let setup = DiskSetup::new(kernel, view(case.mm_per_pixel), DISK_SEED, 1);
    let (e, mean) =
        disk_error_with_mean(&case.image, &setup, &r.exact_f32, WINDOWS * frames, frames)?;
    let reps: Vec<f64> = r.rel_rms_all(&mean)?[1..]
        .iter()
        .map(|&rms| combined(rms, e.noise_after))
        .collect();
    Ok((
        combined(e.bias, e.noise_after),
        std_dev(&reps),
        DiskScore {
            bias: largest(e.bias),
            noise: largest(e.noise),
            noise_after: largest(e.noise_after),
        },
    ))
}

/// One K-frame accumulation (frames seed .. seed + K - 1), the image a
/// user sees once the temporal filter has run K frames.
fn accumulated(kernel: &DiskKernelFile, image: &Image, mm: f64, frames: u32) -> Result<Image> {
    apply_disk(image, &DiskSetup::new(kernel, view(mm), DISK_SEED, frames))
}

impl Search<'_> {
    /// Whether the disk family is searched.
    pub(super) fn with_disk(&self) -> bool {
        self.cfg.families.iter().any(|f| f == DISK)
    }

    /// The disk rows `fits` (passes, taps per pass, samples) allows, one
    /// pass of N samples each, filtered cheapest first and each stopping at
    /// its first missed signal; the first that misses none ends the search
    /// (the costlier cannot be chosen). Where none meets (and not
    /// `only_meeting`), every row is completed. Also how many were left out.
    pub(super) fn disk_candidates(
        &self,
        fits: &(dyn Fn(usize, usize, usize) -> bool + Sync),
        only_meeting: bool,
    ) -> Result<(Vec<Candidate>, usize)> {
        if !self.with_disk() {
            return Ok((Vec::new(), 0));
        }
        let kept: Vec<usize> = DISK_SAMPLES
            .into_iter()
            .filter(|&n| fits(1, n, n))
            .collect();
        let skipped = DISK_SAMPLES.len() - kept.len();
        let target = self.cfg.target;
        let mut rows: Vec<(usize, DiskKernelFile, Vec<Scored>, DiskScores)> = Vec::new();
        for n in kept {
            let kernel = disk_kernel(self.profile, n)?;
            let mut scores = DiskScores {
                frames: self.cfg.frames,
                rotations: WINDOWS * self.cfg.frames,
                signals: BTreeMap::new(),
            };
            let mut scored = Vec::new();
            self.extend_disk(&kernel, &mut scored, &mut scores, true)?;
            let meets = Verdict::new(&scored, target, scored.len() == self.refs.len()).meets;
            rows.push((n, kernel, scored, scores));
            if meets {
                break;
            }
        }
        if !only_meeting && !rows.iter().any(|r| r.2.len() == self.refs.len()) {
            for (_, kernel, scored, scores) in rows.iter_mut() {
                self.extend_disk(kernel, scored, scores, false)?;
            }
        }
        let out = rows
            .into_iter()
            .map(|(n, kernel, scored, scores)| self.disk_row(n, &kernel, &scored, scores))
            .collect();
        self.progress.advance(1);
        Ok((out, skipped))
    }

    /// Scores `kernel` on the references `scored` lacks, in order, until
    /// (with `stop`) a signal misses the target.
    fn extend_disk(
        &self,
        kernel: &DiskKernelFile,
        scored: &mut Vec<Scored>,
        scores: &mut DiskScores,
        stop: bool,
    ) -> Result<()> {
        while let Some(r) = self.refs.get(scored.len()) {
            let (s, sigma, d) = score(kernel, r, self.cfg.frames)?;
            let name = r.exact.case.name.clone();
            scored.push((name.clone(), s, sigma));
            scores.signals.insert(name, d);
            if stop && Verdict::new(scored, self.cfg.target, false).failed(self.cfg.target) {
                break;
            }
        }
        Ok(())
    }

    fn disk_row(
        &self,
        n: usize,
        kernel: &DiskKernelFile,
        scored: &[Scored],
        scores: DiskScores,
    ) -> Candidate {
        Candidate {
            label: DISK.into(),
            model: DISK.into(),
            params: json!({
                "samples": n,
                "radii": RadiusPdf::Widest.name(),
                "frames": self.cfg.frames,
                "seed": DISK_SEED,
            }),
            rank: 1,
            passes: 1,
            taps: Some(n),
            taps_per_pass: n,
            extent_rule: None,
            extent_mm: kernel
                .samples
                .iter()
                .map(|s| s.radius_mm)
                .fold(0.0, f64::max),
            cost: n,
            signed: false,
            verdict: Verdict::new(scored, self.cfg.target, scored.len() == self.refs.len()),
            disk: Some(scores),
            fingerprint: Some(disk_fingerprint(kernel)),
        }
    }

    /// The errors of the disk kernel of `c` on every signal, each on one
    /// accumulation of K frames, with FLIP.
    pub(super) fn predict_disk(
        &self,
        c: &Candidate,
    ) -> Result<(DiskKernelFile, BTreeMap<String, ImageErrors>)> {
        let kernel = disk_kernel(self.profile, c.cost)?;
        if c.fingerprint.as_deref() != Some(disk_fingerprint(&kernel).as_str()) {
            return Err(Error::Unsupported(format!(
                "advise: the disk kernel of {} differs from the one scored",
                c.describe()
            )));
        }
        let mut predicted = BTreeMap::new();
        for r in &self.refs {
            let e = &r.exact;
            let t0 = std::time::Instant::now();
            let img = accumulated(&kernel, &e.case.image, e.case.mm_per_pixel, self.cfg.frames)?;
            let secs = t0.elapsed().as_secs_f64() / self.cfg.frames as f64;
            let mut errs = evaluate::errors(e, &img, &self.cfg.options)?;
            errs.ms_per_megapixel = 1e3 * secs / (img.len() as f64 / 1e6);
            errs.samples_per_pixel = c.cost;
            predicted.insert(e.case.name.clone(), errs);
        }
        Ok((kernel, predicted))
    }
}

/// "bias 0.41%, noise 6.2% in one frame, 2.3% after 8 frames (checker2px)":
/// the disk row's parts on its worst signal.
pub fn disk_text(c: &Candidate) -> Option<String> {
    let d = c.disk.as_ref()?;
    let s = d.signals.get(&c.verdict.worst_signal)?;
    Some(format!(
        "bias {:.3}%, noise {:.3}% in one frame, {:.3}% after {} frames on {} (score \
         sqrt(bias^2 + noise_K^2); {} rotations, {NOISE_K} sd margin as the separable rows)",
        100.0 * s.bias,
        100.0 * s.noise,
        100.0 * s.noise_after,
        d.frames,
        c.verdict.worst_signal,
        d.rotations
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The score is the worst channel's sqrt(b^2 + n^2), not the sum or
    /// the larger of the two, nor one channel's bias with another's noise.
    #[test]
    fn combined_adds_bias_and_noise_in_quadrature() {
        let s = combined([0.03, 0.0, 0.0], [0.04, 0.0, 0.0]);
        assert!((s - 0.05).abs() < 1e-15, "{s}");
        let s = combined([0.0, 0.03, 0.0], [0.04, 0.0, 0.01]);
        assert!((s - 0.04).abs() < 1e-15, "{s}");
    }
}
