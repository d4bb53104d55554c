//! Which kernel to ship at a pixel scale: the cheapest (model, rank, taps,
//! tap extent) whose image-space error on the test signals at that scale
//! meets a target.
//!
//! Cost is GPU work: 1D samples per pixel, 2 x separable terms x taps per
//! pass (a horizontal and a vertical pass per term). Full-resolution
//! factors resampled to whole pixels count one tap per pixel they cover.
//! Error is the largest relative RMS (as `ssskit diff` reports it, per
//! channel, divided by the exact image's peak) over the three channels and
//! the signals chosen on (edge, shapes and checkers of [`CHECKER_PX`]-pixel
//! cells), against the exact 2D convolution with the profile
//! ([`super::evaluate`]). The checkers are there because edge and shapes
//! alone under-state the error on sharp detail: measured on skin1 at 0.2 mm
//! per pixel, 5 guided taps chosen at 7.1% on edge and shapes gave 10.4% on
//! a checker of 1 mm cells. One checker is not enough either: a tap table
//! whose gaps are a multiple of the checker's period reads only one colour
//! (aliasing), so a choice made on 8-pixel cells alone measured 14% on
//! 5-pixel cells where it met 6.7% on its own checker (skin1, 0.02 mm per
//! pixel). Cells of 2 to 8 pixels span the periodic detail the screen
//! can hold, from the finest (a 2-pixel cell, period 4 pixels; 1-pixel
//! cells are what the renderer's own sampling averages away) to the coarse.
//! The cells are fixed in pixels (detail at the screen's resolution), not
//! in mm. A candidate is filtered on the finest checker first and not on
//! the remaining signals once it is over the target (it cannot be chosen);
//! when no candidate meets the target every one is filtered on every
//! signal and the most accurate is chosen. FLIP is reported for the chosen
//! configuration.
//!
//! Candidates: the kernel models of the comparison (SVD at ranks 1-3 raw and
//! renormalised, pre-integration, guided, manual, sums of 2-3 Gaussians)
//! with tap tables of 5 to 33 taps, each over three extents: the one chosen
//! for the tap count ([`crate::kernel::taps::auto_extent`]) and the radii
//! holding 95% and 99.9% of the factor's mass; and the full factors when
//! they cover at most [`FULL_MAX_PIXELS`] pixels.

use super::evaluate::{self, Exact, ImageCase, ImageErrors, Options};
use super::kernel_compare::{model_specs, ModelSpec};
use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::filter::warnings::{scale_warnings, ScaleWarning};
use crate::filter::{cpu, diff, resample_to_pixels, Image, Scale, Setup, Taps};
use crate::kernel::model::{assemble_with, fit_model};
use crate::kernel::taps::{auto_extent, factor_radius_holding, tap_table_with};
use crate::kernel::{Factors, Kernel2D, Kernel2DSpec, KernelFile};
use crate::profile::Profile;
use crate::progress::Progress;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::collections::BTreeMap;

/// Cell widths of the checker signals advise chooses on, pixels.
pub const CHECKER_PX: [usize; 5] = [2, 3, 4, 6, 8];

/// Tap counts considered.
pub const TAP_COUNTS: [usize; 11] = [1, 3, 5, 7, 9, 11, 13, 17, 21, 25, 33];

/// Full factors wider than this (pixels) are not considered: a tap table
/// of the largest count is always cheaper.
pub const FULL_MAX_PIXELS: usize = 65;

/// Default target: 5% relative RMS (on the shapes signal the model error
/// of every rank-1 kernel alone is 1-4% at 0.05-0.2 mm per pixel).
pub const DEFAULT_TARGET: f64 = 0.05;

/// The extent of a tap table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExtentRule {
    /// Chosen for the tap count.
    Auto,
    /// The radius holding this fraction of the factor's mass.
    Hold(f64),
}

/// The mm <-> pixel scale of a view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewScale {
    MmPerPixel(f64),
    /// Perspective view: vertical field of view, linear view depth of the
    /// surface (scene units), image height, scene units per millimetre.
    Perspective {
        fov_y_deg: f64,
        depth: f64,
        height: usize,
        scene_units_per_mm: f64,
    },
}

impl ViewScale {
    /// Surface millimetres per pixel, with the filter's own formula
    /// ([`Scale::step_base`], Freude 2014, eq. 4.11: pixels per kernel
    /// millimetre = step_base / depth).
    pub fn mm_per_pixel(&self) -> Result<f64> {
        match *self {
            ViewScale::MmPerPixel(m) => {
                Scale::MmPerPixel(m).validate()?;
                Ok(m)
            }
            ViewScale::Perspective {
                fov_y_deg,
                depth,
                height,
                scene_units_per_mm,
            } => {
                let s = Scale::Perspective {
                    fov_y_deg,
                    sss_width: scene_units_per_mm,
                };
                s.validate()?;
                if !(depth > 0.0 && depth.is_finite()) {
                    return Err(Error::invalid(
                        "advise",
                        "depth",
                        depth,
                        "must be finite and > 0 (scene units)",
                    ));
                }
                if height == 0 {
                    return Err(Error::invalid("advise", "height", height, "must be > 0"));
                }
                Ok(depth / s.step_base(height))
            }
        }
    }
}

/// What to search.
#[derive(Clone, Debug)]
pub struct Config {
    pub mm_per_pixel: f64,
    /// Largest relative RMS accepted (fraction, 0.02 = 2%).
    pub target: f64,
    /// Signals the choice is made on.
    pub signals: Vec<Signal>,
    /// Side of the square test signals, pixels.
    pub size: usize,
    pub taps: Vec<usize>,
    /// Model families (see [`FAMILIES`]).
    pub families: Vec<String>,
    pub options: Options,
}

impl Config {
    pub fn new(mm_per_pixel: f64, target: f64) -> Config {
        Config {
            mm_per_pixel,
            target,
            signals: vec![Signal::Edge, Signal::Shapes, Signal::Checker],
            size: 128,
            taps: TAP_COUNTS.to_vec(),
            families: FAMILIES.iter().map(|s| s.to_string()).collect(),
            options: Options::default(),
        }
    }
}

/// One configuration and its errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// The model variant ("preintegrate", "svd2-renorm", ...).
    pub label: String,
    /// As the kernel fit spells it.
    pub model: String,
    pub params: serde_json::Value,
    /// Separable terms (SVD rank, Gaussian count, 1 otherwise).
    pub rank: usize,
    /// Taps per pass; None: full factors resampled to pixels.
    pub taps: Option<usize>,
    pub extent_rule: Option<ExtentRule>,
    /// Half-width the taps span, mm.
    pub extent_mm: f64,
    /// 1D samples per pixel: 2 x rank x taps per pass.
    pub cost: usize,
    /// Largest relative RMS over channels and the chosen-on signals.
    pub rel_rms: f64,
    /// Per signal, the largest relative RMS over channels. A candidate
    /// over the target on one signal is not filtered on the signals after
    /// it (finest checker first): those are missing, and `rel_rms` is then
    /// a lower bound.
    pub per_signal: BTreeMap<String, f64>,
}

impl Candidate {
    pub fn describe(&self) -> String {
        let taps = match self.taps {
            Some(n) => format!("{n} taps"),
            None => "full factors".into(),
        };
        let ext = match self.extent_rule {
            Some(ExtentRule::Auto) => " (auto extent)".to_string(),
            Some(ExtentRule::Hold(h)) => format!(" (extent holding {:.1}%)", 100.0 * h),
            None => String::new(),
        };
        format!(
            "{}, {taps} over +-{:.3} mm{ext}",
            self.label, self.extent_mm
        )
    }
}

/// The answer.
#[derive(Clone, Debug)]
pub struct Advice {
    pub mm_per_pixel: f64,
    /// Tap counts searched.
    pub taps: Vec<usize>,
    pub target: f64,
    /// Every configuration evaluated, cheapest first.
    pub candidates: Vec<Candidate>,
    /// Index into `candidates`.
    pub chosen: usize,
    pub meets_target: bool,
    /// The chosen kernel, its tap table as chosen (the stored 17-tap table
    /// when full factors were chosen).
    pub kernel: KernelFile,
    /// The chosen configuration's errors on each signal with FLIP.
    pub predicted: BTreeMap<String, ImageErrors>,
    pub warnings: Vec<ScaleWarning>,
    /// Kernel radius holding 99% of the ground truth's 1D projection, mm.
    pub kernel_radius_mm: f64,
}

impl Advice {
    pub fn chosen(&self) -> &Candidate {
        &self.candidates[self.chosen]
    }

    /// Per model variant, its cheapest configuration meeting the target
    /// (or, when none does, its most accurate on the signals filtered
    /// before it went over the target), cheapest first.
    pub fn best_per_model(&self) -> Vec<&Candidate> {
        let mut by: BTreeMap<&str, &Candidate> = BTreeMap::new();
        for c in &self.candidates {
            let e = by.entry(&c.label).or_insert(c);
            if better(c, e, self.target) {
                *e = c;
            }
        }
        let mut v: Vec<&Candidate> = by.into_values().collect();
        v.sort_by(|a, b| order(a, b, self.target));
        v
    }

    /// The JSON answer: model, params, taps, rank, extent, scale, predicted
    /// errors (largest over channels and signals), and why.
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
            "taps": c.taps,
            "rank": c.rank,
            "extent_mm": c.extent_mm,
            "extent_rule": c.extent_rule,
            "mm_per_pixel": self.mm_per_pixel,
            "cost_samples_per_pixel": c.cost,
            "target_rel_rms": self.target,
            "meets_target": self.meets_target,
            "predicted": {
                "rel_rms": rel,
                "flip": flip,
                "signals": self.predicted,
            },
            "kernel_radius_mm": self.kernel_radius_mm,
            "kernel_radius_px": self.kernel_radius_mm / self.mm_per_pixel,
            "warnings": self.warnings,
            "candidates": self.best_per_model(),
        })
    }
}

pub(crate) fn meets(c: &Candidate, target: f64) -> bool {
    c.rel_rms <= target
}

/// Meeting the target first, then cheaper, then more accurate.
fn order(a: &Candidate, b: &Candidate, target: f64) -> std::cmp::Ordering {
    meets(b, target)
        .cmp(&meets(a, target))
        .then(if meets(a, target) {
            a.cost.cmp(&b.cost)
        } else {
            std::cmp::Ordering::Equal
        })
        .then(a.rel_rms.total_cmp(&b.rel_rms))
        .then(a.cost.cmp(&b.cost))
}

fn better(a: &Candidate, b: &Candidate, target: f64) -> bool {
    order(a, b, target) == std::cmp::Ordering::Less
}

/// The model families advise tries by default: every family of the
/// comparison but Jimenez's fixed skin model, which is not fitted.
pub const FAMILIES: [&str; 5] = ["svd", "preintegrate", "guided", "manual", "gaussians"];

/// The model variants of `families` at ranks 1-3. Left out: a single
/// Gaussian (a rank-1 Gaussian is what every other rank-1 model improves
/// on) and the least-squares manual fit, whose search takes seconds (7.6 s
/// on skin1, loaded machine) and whose image error never led on skin1 at
/// 0.02, 0.2 and 2 mm per pixel (the table A.1 preset stays).
pub fn candidate_models(families: &[String], material: &str) -> Result<Vec<ModelSpec>> {
    Ok(model_specs(families, &[1, 2, 3], material)?
        .into_iter()
        .filter(|s| s.label != "gaussians1" && s.label != "manual-fit")
        .collect())
}

fn full_passes(k: &Kernel2D, f: &Factors, mm: f64) -> Vec<Taps> {
    let offsets = k.offsets();
    f.iter()
        .map(|t| {
            resample_to_pixels(
                &Taps {
                    offsets_mm: offsets.clone(),
                    weights: (0..k.size).map(|i| [t[0][i], t[1][i], t[2][i]]).collect(),
                },
                mm,
            )
        })
        .collect()
}

/// One tap layout of one model.
struct Layout {
    taps: Option<usize>,
    rule: Option<ExtentRule>,
    extent_mm: f64,
    passes: Vec<Taps>,
}

fn layouts(k: &Kernel2D, f: &Factors, cfg: &Config) -> Result<Vec<Layout>> {
    let mut out = Vec::new();
    for &n in &cfg.taps {
        let mut seen: Vec<f64> = Vec::new();
        let rules = [
            (ExtentRule::Auto, auto_extent(k, f, n)),
            (ExtentRule::Hold(0.95), factor_radius_holding(k, f, 0.95)),
            (ExtentRule::Hold(0.999), factor_radius_holding(k, f, 0.999)),
        ];
        // A single tap sits at 0 whatever the extent.
        for (rule, e) in rules.into_iter().take(if n == 1 { 1 } else { 3 }) {
            if seen.iter().any(|s| (s - e).abs() <= 1e-9 * e) {
                continue;
            }
            seen.push(e);
            let t = tap_table_with(k, f, n, Some(e))?;
            out.push(Layout {
                taps: Some(n),
                rule: Some(rule),
                extent_mm: e,
                passes: t.passes.iter().map(Taps::from).collect(),
            });
        }
    }
    let full = full_passes(k, f, cfg.mm_per_pixel);
    if full[0].offsets_mm.len() <= FULL_MAX_PIXELS {
        out.push(Layout {
            taps: None,
            rule: None,
            extent_mm: k.extent_mm(),
            passes: full,
        });
    }
    Ok(out)
}

/// Largest relative RMS over channels of `passes` on `exact`'s case (the
/// images rounded to f32 as [`evaluate::errors`] does). The search filters
/// with the per-pixel algorithm, whose work grows with the taps, not with
/// the span in pixels as the fixed-kernel path's does; both give the same
/// image (`PixelKernel::from_taps`), up to the order of the sums.
fn rel_rms(exact: &Exact, exact_f32: &Image, passes: Vec<Taps>) -> Result<f64> {
    let setup = Setup {
        passes,
        scale: Scale::MmPerPixel(exact.case.mm_per_pixel),
        depth: None,
        strength: None,
        follow_surface: None,
        specular: None,
        jitter: false,
    };
    setup.validate(&exact.case.image)?;
    let mut f = cpu::apply_screen_space(&exact.case.image, &setup);
    for p in f.rgb.iter_mut() {
        p.iter_mut().for_each(|v| *v = *v as f32 as f64);
    }
    Ok(diff::compare(exact_f32, &f)?
        .rms_rel
        .iter()
        .cloned()
        .fold(0.0, f64::max))
}

/// `cfg`'s target and lists are usable.
fn validate(cfg: &Config) -> Result<()> {
    Scale::MmPerPixel(cfg.mm_per_pixel).validate()?;
    if !(cfg.target > 0.0 && cfg.target.is_finite()) {
        return Err(Error::invalid(
            "advise",
            "target error",
            cfg.target,
            "must be finite and > 0 (a fraction: 0.02 is 2%)",
        ));
    }
    if cfg.signals.is_empty() || cfg.taps.is_empty() {
        return Err(Error::Unsupported(
            "advise needs at least one signal and one tap count".into(),
        ));
    }
    Ok(())
}

/// The test images of `cfg`: each signal, the checker once per cell size
/// of [`CHECKER_PX`].
fn test_cases(cfg: &Config) -> Result<Vec<ImageCase>> {
    let mut cases: Vec<ImageCase> = Vec::new();
    for &s in &cfg.signals {
        if s != Signal::Checker {
            cases.push(ImageCase::signal(s, cfg.size, cfg.mm_per_pixel)?);
            continue;
        }
        for px in CHECKER_PX {
            cases.push(ImageCase {
                name: format!("checker{px}px"),
                image: crate::filter::signals::generate(s, cfg.size, cfg.size, px)?,
                mm_per_pixel: cfg.mm_per_pixel,
            });
        }
    }
    Ok(cases)
}

/// The exact convolutions the candidates are measured against, in the
/// order they are filtered.
struct References {
    exact: Vec<Exact>,
    /// `exact`'s images rounded to f32 as [`evaluate::errors`] does.
    exact_f32: Vec<Image>,
    /// Indices into `exact`, the finest checker first.
    order: Vec<usize>,
}

impl References {
    fn new(profile: &Profile, cases: &[ImageCase]) -> Result<References> {
        let exact: Vec<Exact> = cases
            .par_iter()
            .map(|c| Exact::new(profile, c))
            .collect::<Result<_>>()?;
        let exact_f32: Vec<Image> = exact
            .iter()
            .map(|e| {
                let mut i = e.image.clone();
                for p in i.rgb.iter_mut() {
                    p.iter_mut().for_each(|v| *v = *v as f32 as f64);
                }
                i
            })
            .collect();
        // The finest detail first: it fails most candidates soonest.
        let mut order: Vec<usize> = (0..exact.len()).collect();
        order.sort_by_key(|&i| {
            CHECKER_PX
                .iter()
                .position(|px| exact[i].case.name == format!("checker{px}px"))
                .unwrap_or(CHECKER_PX.len())
        });
        Ok(References {
            exact,
            exact_f32,
            order,
        })
    }
}

/// What one search runs over.
struct Search<'a> {
    profile: &'a Profile,
    truth: Kernel2D,
    specs: Vec<ModelSpec>,
    refs: References,
    cfg: &'a Config,
    progress: &'a dyn Progress,
}

impl Search<'_> {
    /// Every layout of one model variant, filtered on the signals in order
    /// (stopping at the first over the target when `stop_over_target`).
    fn model_candidates(&self, spec: &ModelSpec, stop_over_target: bool) -> Result<Vec<Candidate>> {
        let fitted = fit_model(&self.truth, self.profile, &spec.model)
            .map_err(|e| Error::Unsupported(format!("{}: {e}", spec.label)))?;
        let f = fitted.factors.clone();
        let file = assemble_with(self.profile, &self.truth, &spec.model, fitted, 17, None)?;
        let mut out = Vec::new();
        for l in layouts(&self.truth, &f, self.cfg)? {
            let mut per_signal = BTreeMap::new();
            let mut worst: f64 = 0.0;
            for &i in &self.refs.order {
                let (e, ef) = (&self.refs.exact[i], &self.refs.exact_f32[i]);
                let v = rel_rms(e, ef, l.passes.clone())?;
                worst = worst.max(v);
                per_signal.insert(e.case.name.clone(), v);
                if stop_over_target && worst > self.cfg.target {
                    break;
                }
            }
            let per_pass = l.passes.iter().map(|t| t.offsets_mm.len()).sum::<usize>();
            out.push(Candidate {
                label: spec.label.clone(),
                model: file.model.name.clone(),
                params: file.model.params.clone(),
                rank: f.len(),
                taps: l.taps,
                extent_rule: l.rule,
                extent_mm: l.extent_mm,
                cost: 2 * per_pass,
                rel_rms: worst,
                per_signal,
            });
        }
        if stop_over_target {
            self.progress.advance(1);
        }
        Ok(out)
    }

    /// Every candidate of every model variant.
    fn candidates(&self, stop_over_target: bool) -> Result<Vec<Candidate>> {
        let per_model: Vec<Vec<Candidate>> = self
            .specs
            .par_iter()
            .map(|spec| self.model_candidates(spec, stop_over_target))
            .collect::<Result<_>>()?;
        Ok(per_model.into_iter().flatten().collect())
    }

    /// The kernel file of candidate `c` (its tap table as chosen, the
    /// default table for full factors) and the passes it runs.
    fn chosen_kernel(&self, c: &Candidate) -> Result<(KernelFile, Vec<Taps>)> {
        let spec = self
            .specs
            .iter()
            .find(|s| s.label == c.label)
            .ok_or_else(|| Error::Unsupported(format!("lost model {}", c.label)))?;
        let fitted = fit_model(&self.truth, self.profile, &spec.model)?;
        let factors = fitted.factors.clone();
        let (count, extent) = match c.taps {
            Some(n) => (n, Some(c.extent_mm)),
            None => (crate::kernel::taps::DEFAULT_TAPS, None),
        };
        let kernel = assemble_with(
            self.profile,
            &self.truth,
            &spec.model,
            fitted,
            count,
            extent,
        )?;
        let passes = match c.taps {
            Some(_) => kernel.taps.passes.iter().map(Taps::from).collect(),
            None => full_passes(&self.truth, &factors, self.cfg.mm_per_pixel),
        };
        Ok((kernel, passes))
    }

    /// The errors of `passes` on every signal, with FLIP and timing.
    fn predict(&self, passes: &[Taps], cost: usize) -> Result<BTreeMap<String, ImageErrors>> {
        let mut predicted = BTreeMap::new();
        for e in &self.refs.exact {
            let (img, secs) = evaluate::filter(&e.case, passes.to_vec())?;
            let mut errs = evaluate::errors(e, &img, &self.cfg.options)?;
            errs.ms_per_megapixel = 1e3 * secs / (img.len() as f64 / 1e6);
            errs.samples_per_pixel = cost;
            predicted.insert(e.case.name.clone(), errs);
        }
        Ok(predicted)
    }
}

/// Radius holding 99% of the ground truth's 1D projection, mm.
fn kernel_radius(truth: &Kernel2D) -> f64 {
    factor_radius_holding(
        truth,
        &vec![std::array::from_fn(|ch| {
            crate::kernel::preintegrate::grid_projection(truth, ch)
        })],
        0.99,
    )
}

/// Searches every candidate for `profile` at `cfg`'s scale.
pub fn advise(profile: &Profile, cfg: &Config, progress: &dyn Progress) -> Result<Advice> {
    validate(cfg)?;
    let truth = Kernel2D::from_profile(profile, &Kernel2DSpec::default())?;
    let search = Search {
        profile,
        specs: candidate_models(&cfg.families, &profile.material.name)?,
        refs: References::new(profile, &test_cases(cfg)?)?,
        truth,
        cfg,
        progress,
    };
    progress.start(search.specs.len() as u64, "kernel models");
    let mut candidates = search.candidates(true)?;
    if !candidates.iter().any(|c| meets(c, cfg.target)) {
        // None meets the target: the most accurate is chosen, on every
        // signal.
        candidates = search.candidates(false)?;
    }
    progress.finish();
    candidates.sort_by(|a, b| order(a, b, cfg.target));
    let chosen = 0;
    let c = candidates[chosen].clone();
    let (kernel, passes) = search.chosen_kernel(&c)?;
    let predicted = search.predict(&passes, c.cost)?;
    let warnings = scale_warnings(&passes, 1.0 / cfg.mm_per_pixel, c.taps.is_some());
    Ok(Advice {
        mm_per_pixel: cfg.mm_per_pixel,
        taps: cfg.taps.clone(),
        target: cfg.target,
        meets_target: meets(&c, cfg.target),
        candidates,
        chosen,
        kernel,
        predicted,
        warnings,
        kernel_radius_mm: kernel_radius(&search.truth),
    })
}

pub use crate::report::present::advice_text::{explain, extent_rule_text, screen_space_note};
