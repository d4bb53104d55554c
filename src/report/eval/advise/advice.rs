//! The advice's answer ([`Advice`]): the row chosen at a pixel scale,
//! every row scored, what would make one pass, the kernel files that ship
//! and their predicted errors; plain data that `present::advice_text`
//! only reads. [`super::run`] searches for it.

use super::decide::{choose, Budget, Cost, NOISE_K};
use super::noise::BOOTSTRAP_SEED;
use super::scene::SceneCheck;
use super::types::{Candidate, Remedy};
use crate::filter::warnings::ScaleWarning;
use crate::kernel::disk::DiskKernelFile;
use crate::kernel::KernelFile;
use crate::report::eval::evaluate::ImageErrors;
use serde_json::json;
use std::collections::BTreeMap;

/// The answer.
#[derive(Clone, Debug)]
pub struct Advice {
    pub mm_per_pixel: f64,
    /// Tap counts searched.
    pub taps: Vec<usize>,
    pub target: f64,
    pub budget: Budget,
    /// Layouts left out for the budget.
    pub out_of_budget: usize,
    /// Replicate profiles of the score uncertainty (0: analytic profile).
    pub replicates: usize,
    /// Every configuration evaluated within the budget.
    pub candidates: Vec<Candidate>,
    /// Index into `candidates`.
    pub chosen: usize,
    pub meets_target: bool,
    /// Where none meets the target: what would.
    pub remedy: Option<Remedy>,
    /// The chosen separable kernel (where a disk kernel is chosen, the
    /// best separable row's), its tap table as chosen (the stored 17-tap
    /// table when full factors were chosen).
    pub kernel: KernelFile,
    /// The chosen disk kernel, where a disk row is chosen.
    pub disk_kernel: Option<DiskKernelFile>,
    /// Frames a disk kernel's noise is scored after.
    pub frames: u32,
    /// The chosen configuration's errors on each signal with FLIP.
    pub predicted: BTreeMap<String, ImageErrors>,
    pub warnings: Vec<ScaleWarning>,
    /// Kernel radius holding 99% of the ground truth's 1D projection, mm.
    pub kernel_radius_mm: f64,
    /// Where the chosen row's tap table has the automatic extent: the
    /// fraction of the factor's mass that extent holds at its tap count
    /// ([`crate::kernel::taps::hold_for_taps`]).
    pub auto_extent_hold: Option<f64>,
    /// With a path-traced scene: each model's answer run on it, the chosen
    /// one beside the best ([`advise_on_scene`]).
    pub scene: Option<SceneCheck>,
}

impl Advice {
    pub fn chosen(&self) -> &Candidate {
        &self.candidates[self.chosen]
    }

    /// Per model variant its winner by the rule of the whole search (the
    /// cheapest meeting the target, else the most accurate, ties to the
    /// cheaper), cheapest first; each filtered on every signal.
    pub fn best_per_model(&self) -> Vec<&Candidate> {
        best_per_model(&self.candidates)
            .into_iter()
            .map(|i| &self.candidates[i])
            .collect()
    }

    /// The JSON answer: model, params, taps, rank, passes, extent, scale,
    /// budget, predicted errors (largest over channels and signals), the
    /// worst case with its uncertainty and deciding signal, and why.
    pub fn to_json(&self) -> serde_json::Value {
        let c = self.chosen();
        let flip = self
            .predicted
            .values()
            .map(|e| e.flip_rgb)
            .fold(0.0, f64::max);
        let rel = self
            .predicted
            .values()
            .map(|e| e.rel_rms.iter().cloned().fold(0.0, f64::max))
            .fold(0.0, f64::max);
        json!({
            "model": c.model,
            "label": c.label,
            "params": c.params,
            "fingerprint": c.fingerprint,
            "taps": c.taps,
            "rank": c.rank,
            "passes": c.passes,
            "taps_per_pass": c.taps_per_pass,
            "frames": self.frames,
            "disk": c.disk,
            "target_format": c.target_format(),
            "extent_mm": c.extent_mm,
            "extent_rule": c.extent_rule,
            "mm_per_pixel": self.mm_per_pixel,
            "cost_samples_per_pixel": c.cost,
            "target_rel_rms": self.target,
            "meets_target": self.meets_target,
            "budget": self.budget,
            "worst_case": {
                "rel_rms": c.verdict.rel_rms,
                "sigma": c.verdict.rel_rms_sigma,
                "signal": c.verdict.worst_signal,
                "deciding_signal": c.verdict.deciding_signal,
            },
            "noise": {
                "k": NOISE_K,
                "replicates": self.replicates,
                "seed": BOOTSTRAP_SEED,
            },
            "remedy": self.remedy,
            "predicted": {
                "rel_rms": rel,
                "flip": flip,
                "signals": self.predicted,
            },
            "kernel_radius_mm": self.kernel_radius_mm,
            "kernel_radius_px": self.kernel_radius_mm / self.mm_per_pixel,
            "warnings": self.warnings,
            "candidates": self.best_per_model(),
            "scene": self.scene,
        })
    }
}

/// Per model variant the index of its winner by the rule of the whole
/// search, cheapest first ([`Advice::best_per_model`]).
pub(super) fn best_per_model(candidates: &[Candidate]) -> Vec<usize> {
    let mut by: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, c) in candidates.iter().enumerate() {
        by.entry(&c.label).or_default().push(i);
    }
    let mut v: Vec<usize> = by
        .into_values()
        .filter_map(|is| {
            let owned: Vec<Candidate> = is.iter().map(|&i| candidates[i].clone()).collect();
            choose(&owned).map(|k| is[k])
        })
        .collect();
    v.sort_by(|&a, &b| {
        let (a, b) = (&candidates[a], &candidates[b]);
        a.cost_order(b).then(a.label.cmp(&b.label))
    });
    v
}
