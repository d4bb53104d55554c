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
//! ([`crate::report::eval::evaluate`]). The checkers are there because edge and shapes
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
//! in mm. FLIP is reported for the chosen configuration.
//!
//! Only candidates within the [`Budget`] (passes, samples, taps) are
//! filtered; the decision respects the Monte Carlo noise of the profile
//! ([`super::noise`], [`super::decide`]). Each model's
//! layouts are filtered cheapest first, each on the signals in order (the
//! finest checker first) up to its first missed signal; the first layout
//! that misses none is the model's answer (its costlier layouts cannot be
//! chosen). Where none does, the model's most accurate layout is found by
//! branch and bound: a partial worst case is a lower bound on the whole,
//! layouts are completed in order of it, and the search stops when the
//! next bound lies past the best complete worst case by more than a tie.
//! Every row shown (each model's winner) is filtered on every signal.
//!
//! Candidates: the kernel models of the comparison (SVD at ranks 1-3 raw and
//! renormalised, pre-integration, guided, manual, sums of 2-3 Gaussians)
//! with tap tables of 5 to 33 taps, each over three extents: the one chosen
//! for the tap count ([`crate::kernel::taps::auto_extent`]) and the radii
//! holding 95% and 99.9% of the factor's mass; and the full factors when
//! they cover at most [`FULL_MAX_PIXELS`] pixels. Beside them, with the
//! family `disk`, importance-sampled disk kernels of
//! [`crate::report::eval::disk::DISK_SAMPLES`] samples, one pass each, scored on
//! their bias and their noise after `Config::frames` frames
//! ([`super::disk`] says how); the budget counts a disk kernel as
//! one pass of N taps, N samples per pixel.

use super::advice::{best_per_model, Advice};
use super::decide::choose;
use super::noise::Reference;
use super::scene::{check_on_scene, SceneCandidate, SceneCheck, ScenePass};
use super::search::Search;
use super::types::{Candidate, CoarserScale, Config, ExtentRule, CHECKER_PX, COARSER_SCALES};
use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::filter::warnings::{scale_warnings, ScaleWarning};
use crate::filter::Scale;
use crate::kernel::disk::DiskKernelFile;
use crate::kernel::model::Fitted;
use crate::kernel::taps::{factor_radius_holding, hold_for_taps};
use crate::kernel::{Kernel2D, Kernel2DSpec, KernelFile};
use crate::profile::Profile;
use crate::progress::Progress;
use crate::report::eval::compare::kernel::{model_specs, ModelSpec};
use crate::report::eval::disk::{check_frames, disk_kernel, with_frames, DISK};
use crate::report::eval::evaluate::{ImageCase, ImageErrors};
use crate::scene::{Render, Scene};
use std::collections::BTreeMap;

/// The model variants of `families` at ranks 1-3. Left out: a single
/// Gaussian (a rank-1 Gaussian is what every other rank-1 model improves
/// on) and the least-squares manual fit, whose search takes seconds (7.6 s
/// on skin1, loaded machine) and whose image error never led on skin1 at
/// 0.02, 0.2 and 2 mm per pixel (the table A.1 preset stays).
pub fn candidate_models(families: &[String], material: &str) -> Result<Vec<ModelSpec>> {
    let separable: Vec<String> = families.iter().filter(|f| *f != DISK).cloned().collect();
    Ok(model_specs(&separable, &[1, 2, 3], material)?
        .into_iter()
        .filter(|s| s.label != "gaussians1" && s.label != "manual-fit")
        .collect())
}

/// The kernel file an advice holds when only disk rows were searched: the
/// rank-1 pre-integration (Freude 2014, sec. 5.2) with the default tap
/// table, the separable model `kernels` lists first.
fn separable_fallback(search: &Search) -> Result<KernelFile> {
    let profile = search.profile;
    let spec = model_specs(&["preintegrate".to_string()], &[1], &profile.material.name)?
        .into_iter()
        .next()
        .ok_or_else(|| Error::Unsupported("no pre-integration model".into()))?;
    let fitted = search.fitted(&spec)?;
    crate::kernel::model::assemble_with(
        profile,
        &search.truth,
        &spec.model,
        fitted,
        crate::kernel::taps::DEFAULT_TAPS,
        None,
    )
}

/// `cfg`'s target, lists and budget are usable.
fn validate(cfg: &Config) -> Result<()> {
    Scale::MmPerPixel(cfg.mm_per_pixel).validate()?;
    check_frames(cfg.frames)?;
    if !(cfg.target > 0.0 && cfg.target < 1.0) {
        return Err(Error::invalid(
            "advise",
            "target error",
            cfg.target,
            "must be in (0, 1): a fraction, 0.05 is 5%",
        ));
    }
    if cfg.signals.is_empty() || cfg.taps.is_empty() {
        return Err(Error::Unsupported(
            "advise needs at least one signal and one tap count".into(),
        ));
    }
    // The cheapest kernels there are: a disk kernel runs one pass; a
    // separable one two (one tap each, two samples per pixel).
    for (field, v, least, why) in [
        (
            "max_passes",
            cfg.budget.max_passes,
            1,
            "a disk kernel runs one pass, a separable kernel two (horizontal and vertical)",
        ),
        (
            "max_samples",
            cfg.budget.max_samples,
            2,
            "the cheapest kernel, one tap in each of two passes, takes 2 samples per pixel",
        ),
        ("max_taps", cfg.budget.max_taps, 1, "every pass has a tap"),
    ] {
        if v.is_some_and(|v| v < least) {
            return Err(Error::invalid(
                "advise",
                field,
                v.unwrap_or(0),
                format!("must be >= {least}: {why}"),
            ));
        }
    }
    Ok(())
}

/// The test images of `cfg`: each signal, the checker once per cell size
/// of [`CHECKER_PX`]; the finest checker first (it fails most candidates
/// soonest).
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
    cases.sort_by_key(|c| {
        CHECKER_PX
            .iter()
            .position(|px| c.name == format!("checker{px}px"))
            .unwrap_or(CHECKER_PX.len())
    });
    Ok(cases)
}

/// The finest of [`COARSER_SCALES`] at which the search within the budget
/// meets the target, and its choice there (the remedy "a coarser
/// --mm-per-pixel"). A scale the filter refuses ends the walk.
fn coarser_scale(search: &Search) -> Result<Option<CoarserScale>> {
    let budget = search.cfg.budget;
    for f in COARSER_SCALES {
        let cfg = Config {
            mm_per_pixel: f * search.cfg.mm_per_pixel,
            ..search.cfg.clone()
        };
        if validate(&cfg).is_err() {
            break;
        }
        let refs = Reference::all(search.profile, &test_cases(&cfg)?)?;
        let at = search.at_scale(&cfg, refs)?;
        let (c, _) = at.candidates(&|p, t, s| budget.allows(p, t, s), true)?;
        if let Some(i) = choose(&c).filter(|&i| c[i].verdict.meets) {
            return Ok(Some(CoarserScale {
                mm_per_pixel: cfg.mm_per_pixel,
                candidate: c[i].clone(),
            }));
        }
    }
    Ok(None)
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

/// Searches every candidate within `cfg`'s budget for `profile` at its
/// scale.
pub fn advise(profile: &Profile, cfg: &Config, progress: &dyn Progress) -> Result<Advice> {
    advise_on_scene(profile, cfg, None, progress)
}

/// [`advise`], and with a path-traced scene and its render, each model's
/// answer within the budget (and the chosen configuration) run through the
/// screen-space pass on it ([`super::scene`]).
pub fn advise_on_scene(
    profile: &Profile,
    cfg: &Config,
    scene: Option<(&Scene, &Render)>,
    progress: &dyn Progress,
) -> Result<Advice> {
    advise_prepared(profile, cfg, scene, None, progress)
}

/// What a caller made already for `profile`: the ground truth on the
/// default grid and model fits to it by label. [`advise_prepared`] scores
/// these fits and builds the kernel it returns from them, fitting only a
/// variant missing here.
pub struct Prepared {
    pub truth: Kernel2D,
    pub fits: BTreeMap<String, Fitted>,
}

/// What the chosen row ships: its kernel file (the best separable row's
/// where a disk row wins, so `kernel` is always separable), its disk
/// kernel, the errors predicted on the test images and the scale warnings
/// of its passes.
struct Shipped {
    kernel: KernelFile,
    disk_kernel: Option<DiskKernelFile>,
    predicted: BTreeMap<String, ImageErrors>,
    warnings: Vec<ScaleWarning>,
}

fn shipped_kernels(search: &Search, candidates: &[Candidate], c: &Candidate) -> Result<Shipped> {
    // Where a disk row wins, the best separable row still gives `kernel`.
    let separable: Vec<Candidate> = candidates
        .iter()
        .filter(|c| c.disk.is_none())
        .cloned()
        .collect();
    let best_separable = choose(&separable).map(|i| &separable[i]);
    let (kernel, passes) = match (c.disk.is_some(), best_separable) {
        (false, _) => search.chosen_kernel(c)?,
        (true, Some(s)) => search.chosen_kernel(s)?,
        (true, None) => (separable_fallback(search)?, Vec::new()),
    };
    let (disk_kernel, predicted) = if c.disk.is_some() {
        let (k, p) = search.predict_disk(c)?;
        (Some(k), p)
    } else {
        (None, search.predict(&passes, c.cost)?)
    };
    let warnings = if c.disk.is_some() {
        Vec::new()
    } else {
        scale_warnings(&passes, 1.0 / search.cfg.mm_per_pixel, c.taps.is_some())
    };
    Ok(Shipped {
        kernel,
        disk_kernel,
        predicted,
        warnings,
    })
}

/// [`advise_on_scene`] on the truth and fits of `prepared` (None: made
/// here).
pub fn advise_prepared(
    profile: &Profile,
    cfg: &Config,
    scene: Option<(&Scene, &Render)>,
    prepared: Option<Prepared>,
    progress: &dyn Progress,
) -> Result<Advice> {
    validate(cfg)?;
    // A scene whose seen object is of another material is refused before
    // the search, not after it.
    if let Some((scene, render)) = scene {
        super::scene::scored_pixels(scene, render, profile)?;
    }
    let prepared = match prepared {
        Some(p) => p,
        None => Prepared {
            truth: Kernel2D::from_profile(profile, &Kernel2DSpec::default())?,
            fits: BTreeMap::new(),
        },
    };
    let refs = Reference::all(profile, &test_cases(cfg)?)?;
    let search = Search {
        profile,
        specs: candidate_models(&cfg.families, &profile.material.name)?,
        refs,
        truth: prepared.truth,
        cfg,
        progress,
        fits: std::sync::Mutex::new(prepared.fits),
    };
    // A unit per model variant searched and one for the disk kernels.
    let units = search.units();
    progress.start(units, "advice: kernel models searched");
    let budget = cfg.budget;
    let (candidates, out_of_budget) =
        search.candidates(&|p, t, s| budget.allows(p, t, s), false)?;
    let chosen = choose(&candidates).ok_or_else(|| {
        Error::invalid(
            "advise",
            "budget",
            budget.describe(),
            "no kernel model fits it: allow more passes, samples or taps",
        )
    })?;
    let c = candidates[chosen].clone();
    let remedy = if c.verdict.meets {
        None
    } else {
        // The remedy searches outside the budget and at up to every
        // coarser scale: the work it may do.
        progress.set_total(units * (2 + COARSER_SCALES.len() as u64));
        let mut r = search.remedy(&c)?;
        r.coarser = coarser_scale(&search)?;
        Some(r)
    };
    let shipped = shipped_kernels(&search, &candidates, &c)?;
    let scene = match scene {
        Some((scene, render)) => Some(scene_check(&search, &candidates, chosen, scene, render)?),
        None => None,
    };
    progress.finish();
    Ok(Advice {
        mm_per_pixel: cfg.mm_per_pixel,
        taps: cfg.taps.clone(),
        target: cfg.target,
        budget,
        out_of_budget,
        replicates: search.refs.first().map_or(0, |r| r.replicates()),
        meets_target: c.verdict.meets,
        remedy,
        candidates,
        chosen,
        kernel: shipped.kernel,
        disk_kernel: shipped.disk_kernel,
        frames: cfg.frames,
        predicted: shipped.predicted,
        warnings: shipped.warnings,
        kernel_radius_mm: kernel_radius(&search.truth),
        auto_extent_hold: match c.taps {
            Some(n) if c.extent_rule == Some(ExtentRule::Auto) => Some(hold_for_taps(n)),
            _ => None,
        },
        scene,
    })
}

/// Each model's answer and the chosen configuration on the scene.
fn scene_check(
    search: &Search,
    candidates: &[Candidate],
    chosen: usize,
    scene: &Scene,
    render: &Render,
) -> Result<SceneCheck> {
    let mut rows = best_per_model(candidates);
    if !rows.contains(&chosen) {
        rows.push(chosen);
    }
    let run = rows
        .iter()
        .map(|&i| {
            let c = &candidates[i];
            let pass = if c.disk.is_some() {
                ScenePass::Disk(Box::new(with_frames(
                    disk_kernel(search.profile, c.cost)?,
                    search.cfg.frames,
                )))
            } else {
                ScenePass::Separable(search.chosen_kernel(c)?.1)
            };
            Ok(SceneCandidate {
                configuration: c.describe(),
                passes: c.passes,
                samples_per_pixel: c.cost,
                pass,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let at = rows.iter().position(|&i| i == chosen).unwrap_or(0);
    let c = &candidates[chosen];
    let accepted = if c.verdict.meets {
        search.cfg.target
    } else {
        c.verdict.rel_rms
    };
    check_on_scene(scene, render, search.profile, &run, at, accepted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::model::fit_model;
    use crate::progress::NoProgress;
    use crate::report::eval::advise::search::{fingerprint, scored_passes};
    use crate::report::eval::advise::types::DEFAULT_TARGET;

    /// A fit time no real fit reports: a kernel carrying it was assembled
    /// from the handed fit, not from a fit made again.
    const MARKED_SECONDS: f64 = 1234.5;

    /// The advice scores the fits it is handed (no variant is fitted
    /// again: the kernel carries the handed fit's marked time and its
    /// factors), and the kernel it returns, written and read back, runs
    /// exactly the passes the chosen row was scored on.
    #[test]
    fn the_advice_scores_and_returns_the_fits_it_is_handed() {
        let profile = crate::kernel::reference::dipole_uniform("skin1", 0.02, 6.0);
        let truth = Kernel2D::from_profile(&profile, &Kernel2DSpec::default()).unwrap();
        let mut cfg = Config::new(0.5, DEFAULT_TARGET);
        cfg.size = 32;
        cfg.families = vec!["preintegrate".into()];
        let spec = candidate_models(&cfg.families, "skin1").unwrap().remove(0);
        let mut fit = fit_model(&truth, &profile, &spec.model).unwrap();
        fit.seconds = MARKED_SECONDS;
        let prepared = Prepared {
            truth: truth.clone(),
            fits: BTreeMap::from([(spec.label.clone(), fit.clone())]),
        };
        let a = advise_prepared(&profile, &cfg, None, Some(prepared), &NoProgress).unwrap();
        assert_eq!(a.kernel.metrics.fit_seconds, MARKED_SECONDS);
        let handed: Vec<[f64; 3]> = (0..truth.size)
            .map(|i| std::array::from_fn(|c| fit.factors[0][c][i]))
            .collect();
        assert_eq!(a.kernel.passes[0].weights, handed);
        let (_dir, path) = crate::io::scratch("recommended.json");
        a.kernel.write(&path).unwrap();
        let back = KernelFile::read(&path).unwrap();
        let c = a.chosen();
        let written = scored_passes(&back, c.taps.is_none(), cfg.mm_per_pixel);
        assert_eq!(
            Some(fingerprint(&written)),
            c.fingerprint,
            "{}",
            c.describe()
        );
    }
}
