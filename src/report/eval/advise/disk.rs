//! The disk kernels in the advice (`kernel::disk`): one pass of N
//! importance-sampled samples per pixel, beside the separable layouts at
//! the same cost (N samples against 2 x terms x taps).
//!
//! A disk kernel's image changes every frame (its per-pixel rotation), so
//! it is scored as a user sees it: the first accumulation of the K frames
//! a temporal filter averages under a static camera (`Config::frames`;
//! frames [`DISK_SEED`] .. K - 1, bit for bit the image `apply --frames K`
//! makes, [`crate::filter::disk_error::FirstAccumulation`]), its relative
//! RMS against the exact image in its worst channel, as the separable
//! score. What `apply` + `diff` of the shipped kernel measure is then the
//! figure the advice prints and predicts.
//!
//! An accumulation that starts on another frame errs a little otherwise:
//! the standard deviation of the error over the [`WINDOWS`] accumulations
//! of K consecutive frames measured is the score's frame noise, added in
//! quadrature to the bootstrap's standard deviation of the separable rows
//! ([`super::noise`]: each replicate profile's exact image against
//! the same accumulation), so the margin of the decision covers both.
//! Beside it the row keeps, in the same channel, the bias (the mean of
//! all W K rotations against the exact image, what a converged filter
//! shows, its own residual noise included) and the noise in one frame and
//! after K frames (batch means over the windows), which say where the
//! error comes from. A former score, sqrt(bias^2 + noise_K^2), counted the
//! mean's residual noise in the bias and the noise of K frames in full,
//! and its bias and noise were each the largest over the channels: on
//! skin1's 3-pixel checker at 0.1 mm per pixel (32 samples, 8 frames) it
//! printed 3.92% where one accumulation measures 3.47%.
//!
//! The disk is fitted to the profile cut where the exact reference is
//! ([`crate::filter::exact::reference_kernel`], the radius holding
//! [`DEFAULT_HOLD`] of every channel), radii from the widest channel (the
//! default of `fit --model disk`), rotations from seed [`DISK_SEED`]: both
//! families are scored against the one exact image.

use super::decide::Verdict;
use super::noise::Reference;
use super::search::Search;
use super::types::{Candidate, DiskScore, DiskScores};
use crate::error::{Error, Result};
use crate::filter::disk::{apply_disk, DiskSetup};
use crate::filter::disk_error::{disk_error_with_first, view};
use crate::filter::Image;
use crate::kernel::disk::{DiskKernelFile, RadiusPdf};
use crate::numerics::std_dev;
use crate::report::eval::disk::{
    disk_fingerprint, disk_kernel, with_frames, DISK, DISK_SAMPLES, DISK_SEED, WINDOWS,
};
use crate::report::eval::evaluate::{self, round_f32, ImageErrors};
use rayon::prelude::*;
use serde_json::json;
use std::collections::BTreeMap;

/// A score on one test image: (signal, score, standard deviation).
type Scored = (String, f64, f64);

/// The worst channel of `v` (the first of equals) and its value.
fn worst(v: [f64; 3]) -> (usize, f64) {
    (0..3).fold((0, v[0]), |b, c| if v[c] > b.1 { (c, v[c]) } else { b })
}

/// The score of `kernel` on `r`'s test image (module doc): (score, its
/// standard deviation, the row's measures on this signal).
fn score(kernel: &DiskKernelFile, r: &Reference, frames: u32) -> Result<(f64, f64, DiskScore)> {
    let case = &r.exact.case;
    let setup = DiskSetup::new(kernel, view(case.mm_per_pixel), DISK_SEED, 1);
    let t0 = std::time::Instant::now();
    let (e, first) =
        disk_error_with_first(&case.image, &setup, &r.exact_f32, WINDOWS * frames, frames)?;
    let secs = t0.elapsed().as_secs_f64() / (WINDOWS * frames) as f64;
    let f32_image = round_f32(&first.image);
    // The first accumulation is bit for bit the image `apply --frames K`
    // makes (`FirstAccumulation`): the chosen row's prediction takes it.
    r.keep_disk(disk_fingerprint(kernel), frames, first.image, secs);
    // The exact image's score first, then each replicate's (one pass).
    let all = r.rel_rms_all(&f32_image)?;
    let (c, s) = worst(all[0]);
    let reps: Vec<f64> = all[1..].iter().map(|&x| worst(x).1).collect();
    let sigma = std_dev(&reps).hypot(first.error_sd[c]);
    Ok((
        s,
        sigma,
        DiskScore {
            channel: ["r", "g", "b"][c].to_string(),
            error: s,
            error_sd: first.error_sd[c],
            bias: e.bias[c],
            noise: e.noise[c],
            noise_after: e.noise_after[c],
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

    /// The disk kernel of `c`, recording the frames of its prediction, and
    /// its errors on every signal, each on the first accumulation of K
    /// frames (the image scored), with FLIP.
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
        // The frames the prediction below is made on travel with the file.
        let kernel = with_frames(kernel, self.cfg.frames);
        let key = disk_fingerprint(&kernel);
        // Each signal on its own (FLIP runs on one thread): all at once.
        let predicted = self
            .refs
            .par_iter()
            .map(|r| {
                let e = &r.exact;
                // The accumulation scored last, where it is this kernel's.
                let (img, secs) = match r.kept_disk(&key, self.cfg.frames) {
                    Some(kept) => kept,
                    None => {
                        let t0 = std::time::Instant::now();
                        let (mm, k) = (e.case.mm_per_pixel, self.cfg.frames);
                        let img = accumulated(&kernel, &e.case.image, mm, k)?;
                        (img, t0.elapsed().as_secs_f64() / k as f64)
                    }
                };
                let mut errs = evaluate::errors(e, &img, &self.cfg.options)?;
                errs.ms_per_megapixel = 1e3 * secs / (img.len() as f64 / 1e6);
                errs.samples_per_pixel = c.cost;
                Ok((e.case.name.clone(), errs))
            })
            .collect::<Result<_>>()?;
        Ok((kernel, predicted))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The accumulation a score keeps for the prediction is bit for bit
    /// the one the prediction made again before (`apply --frames K`'s
    /// image), and is found only for its kernel and frames.
    #[test]
    fn the_kept_accumulation_is_the_one_apply_makes() {
        let profile = crate::kernel::reference::dipole_uniform("skin1", 0.02, 6.0);
        let signal = crate::filter::signals::Signal::Shapes;
        let case = crate::report::eval::evaluate::ImageCase::signal(signal, 24, 0.5).unwrap();
        let refs = Reference::all(&profile, &[case]).unwrap();
        let (k, r) = (disk_kernel(&profile, 8).unwrap(), &refs[0]);
        score(&k, r, 2).unwrap();
        let (kept, _) = r.kept_disk(&disk_fingerprint(&k), 2).unwrap();
        let made = accumulated(&k, &r.exact.case.image, 0.5, 2).unwrap();
        let bits = |i: &Image| {
            i.rgb
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&kept), bits(&made));
        assert!(r.kept_disk(&disk_fingerprint(&k), 3).is_none());
        let other = disk_kernel(&profile, 4).unwrap();
        assert!(r.kept_disk(&disk_fingerprint(&other), 2).is_none());
    }

    /// The worst channel is the largest, the first of equals.
    #[test]
    fn worst_is_the_largest_channel() {
        assert_eq!(worst([0.03, 0.05, 0.04]), (1, 0.05));
        assert_eq!(worst([0.02, 0.01, 0.02]), (0, 0.02));
    }
}
