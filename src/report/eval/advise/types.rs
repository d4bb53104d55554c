//! The advice's plain data, apart from the search that fills it: what to
//! search ([`Config`], [`ViewScale`], the tap counts and signals), one
//! scored configuration ([`Candidate`]) and what would make one pass
//! ([`Remedy`]). The search ([`super::search`]) and the answer
//! ([`crate::report::eval::advise`]) both read these; this file reads neither.

use super::decide::{Budget, Cost, Verdict};
use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::filter::Scale;
use crate::report::eval::disk::DEFAULT_FRAMES;
use crate::report::eval::evaluate::Options;
use serde::{Deserialize, Serialize};
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
                crate::error::finite_positive("advise", "depth", depth, " (scene units)")?;
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
    /// Model families (see [`ADVISED_FAMILIES`]).
    pub families: Vec<String>,
    pub options: Options,
    /// What a candidate may cost.
    pub budget: Budget,
    /// Frames a temporal filter accumulates: the noise of a disk kernel is
    /// scored after this many.
    pub frames: u32,
}

impl Config {
    pub fn new(mm_per_pixel: f64, target: f64) -> Config {
        Config {
            mm_per_pixel,
            target,
            signals: vec![Signal::Edge, Signal::Shapes, Signal::Checker],
            size: 128,
            taps: TAP_COUNTS.to_vec(),
            families: ADVISED_FAMILIES.iter().map(|s| s.to_string()).collect(),
            options: Options::default(),
            budget: Budget::default(),
            frames: DEFAULT_FRAMES,
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
    /// One-dimensional passes: 2 x rank (a horizontal and a vertical pass
    /// per term).
    pub passes: usize,
    /// Taps per pass; None: full factors resampled to pixels.
    pub taps: Option<usize>,
    /// The most taps one pass reads (the pixels full factors span).
    pub taps_per_pass: usize,
    pub extent_rule: Option<ExtentRule>,
    /// Half-width the taps span, mm.
    pub extent_mm: f64,
    /// 1D samples per pixel: the taps of every pass.
    pub cost: usize,
    /// Whether a weight is negative: the tap table then needs a signed
    /// float target format.
    pub signed: bool,
    /// The scores and the decision on them.
    #[serde(flatten)]
    pub verdict: Verdict,
    /// A disk kernel's bias and noise per signal (None: separable).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disk: Option<DiskScores>,
    /// A separable row's passes as scored
    /// ([`super::search::fingerprint`]; None: a disk row).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fingerprint: Option<String>,
}

impl Cost for Candidate {
    fn samples(&self) -> usize {
        self.cost
    }
    fn passes(&self) -> usize {
        self.passes
    }
    fn verdict(&self) -> &Verdict {
        &self.verdict
    }
}

impl Candidate {
    pub fn describe(&self) -> String {
        if let Some(d) = &self.disk {
            return format!(
                "disk, {} samples within {:.3} mm, mean of {} frames",
                self.cost, self.extent_mm, d.frames
            );
        }
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

    /// The render target the tap weights need.
    pub fn target_format(&self) -> &'static str {
        if self.signed {
            "signed float"
        } else {
            "unsigned"
        }
    }
}

/// Where none meets the target within the budget: what would make one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Remedy {
    /// The loosest target the best within the budget meets (its deciding
    /// score less the noise margin).
    pub target_met_by_best: f64,
    /// The cheapest candidate outside the budget that meets the target
    /// (None: none does, or the budget is already unbounded).
    pub outside_budget: Option<Candidate>,
    /// Whether candidates outside the budget were searched.
    pub searched_outside: bool,
    /// The finest of the coarser scales tried ([`COARSER_SCALES`]) at
    /// which a kernel within the budget meets the target, and that kernel
    /// (None: none of them does).
    #[serde(default)]
    pub coarser: Option<CoarserScale>,
}

/// A scale at which the budget suffices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CoarserScale {
    pub mm_per_pixel: f64,
    pub candidate: Candidate,
}

/// The coarser scales the remedy tries, as multiples of the one asked. At
/// a coarser scale the kernel spans fewer pixels, so a tap table of the
/// same length samples it more densely and a fine checker is averaged more
/// evenly; the steps reach 4x (an object at four times the distance, or a
/// quarter of the resolution), and three of them bound the extra work of a
/// run that misses to three searches with the fits reused.
pub const COARSER_SCALES: [f64; 3] = [1.5, 2.0, 4.0];

/// The model families advise tries by default: every family of the
/// comparison ([`crate::report::eval::compare::kernel::FAMILIES`]) but
/// Jimenez's fixed skin model, which is not fitted, and the
/// importance-sampled disk (`kernel::disk`, not separable): a different
/// set, so a different name.
pub const ADVISED_FAMILIES: [&str; 6] = [
    "svd",
    "preintegrate",
    "guided",
    "manual",
    "gaussians",
    "disk",
];

/// A disk row's measures on one signal, all in the channel of its score
/// (the largest error), relative to the exact image's peak
/// ([`super::disk`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskScore {
    /// The score's channel: r, g or b.
    pub channel: String,
    /// The score: the error of the first accumulation of `frames` frames.
    pub error: f64,
    /// The standard deviation of that error over the accumulations of
    /// `frames` consecutive frames measured.
    pub error_sd: f64,
    /// The bias: the mean of every rotation against the exact image, with
    /// that mean's residual noise.
    pub bias: f64,
    /// One frame.
    pub noise: f64,
    /// The mean of `frames` frames.
    pub noise_after: f64,
}

/// A disk row's measurements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskScores {
    /// Frames accumulated (K).
    pub frames: u32,
    /// Rotations the bias is the mean over.
    pub rotations: u32,
    /// Per signal scored.
    pub signals: BTreeMap<String, DiskScore>,
}
