//! advise's search: the tap layouts of each kernel model within a budget,
//! filtered on the test images cheapest first, and the kernel file of the
//! one chosen ([`crate::report::eval::advise`] says where each model and layout stops).

use super::decide::{choose, Budget, Verdict, NOISE_K};
use super::noise::Reference;
use super::types::{Candidate, Config, ExtentRule, Remedy, FULL_MAX_PIXELS};
use crate::error::{Error, Result};
use crate::filter::{resample_to_pixels, Taps};
use crate::kernel::model::{assemble_with, fit_model, tap_table, Fitted, Model};
use crate::kernel::taps::{auto_extent, factor_radius_holding};
use crate::kernel::{Factors, Kernel2D, KernelFile, Pass, TapTable};
use crate::profile::Profile;
use crate::progress::Progress;
use crate::report::eval::compare::kernel::ModelSpec;
use crate::report::eval::evaluate::{self, ImageErrors};
use rayon::prelude::*;
use std::collections::BTreeMap;

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

/// A fingerprint of the passes a candidate runs (SHA-256 of every
/// offset's and weight's bits, in order): the advice carries the chosen
/// one's, so a kernel file can be checked to run exactly what was scored
/// ([`scored_passes`]).
pub fn fingerprint(passes: &[Taps]) -> String {
    use sha2::{Digest, Sha256};
    let mut h = Sha256::new();
    for t in passes {
        h.update((t.offsets_mm.len() as u64).to_le_bytes());
        for (o, w) in t.offsets_mm.iter().zip(&t.weights) {
            h.update(o.to_bits().to_le_bytes());
            w.iter().for_each(|v| h.update(v.to_bits().to_le_bytes()));
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The passes a separable kernel file runs as advise scored it: its tap
/// table, or with `full` its full factors resampled to whole pixels at
/// `mm_per_pixel`.
pub fn scored_passes(kernel: &KernelFile, full: bool, mm_per_pixel: f64) -> Vec<Taps> {
    let table = if full {
        &kernel.passes
    } else {
        &kernel.taps.passes
    };
    table
        .iter()
        .map(|p| {
            let t = Taps::from(p);
            if full {
                resample_to_pixels(&t, mm_per_pixel)
            } else {
                t
            }
        })
        .collect()
}

/// The tap table of full factors resampled to whole pixels (`passes`, at
/// `mm` per pixel), so that the file's default table (what `apply` and an
/// engine run) is what the advice scored: offsets j x `mm`, every pass
/// padded with zero weights to one odd count centred on 0 (a zero tap
/// adds nothing; an engine may skip it).
fn pixel_table(passes: &[Taps], mm: f64) -> TapTable {
    let pixel = |o: f64| (o / mm).round() as i64;
    let half = passes
        .iter()
        .flat_map(|t| t.offsets_mm.iter())
        .map(|&o| pixel(o).unsigned_abs())
        .max()
        .unwrap_or(0) as i64;
    let count = (2 * half + 1) as usize;
    let passes = passes
        .iter()
        .map(|t| {
            let mut weights = vec![[0.0; 3]; count];
            for (&o, w) in t.offsets_mm.iter().zip(&t.weights) {
                weights[(pixel(o) + half) as usize] = *w;
            }
            Pass {
                offsets_mm: (-half..=half).map(|j| j as f64 * mm).collect(),
                weights,
            }
        })
        .collect();
    TapTable {
        count,
        passes,
        extent_mm: Some(half as f64 * mm),
    }
}

/// One tap layout of one model.
struct Layout {
    taps: Option<usize>,
    rule: Option<ExtentRule>,
    extent_mm: f64,
    passes: Vec<Taps>,
}

impl Layout {
    /// (one-dimensional passes, taps of the widest pass, samples per pixel):
    /// each separable term runs a horizontal and a vertical pass.
    fn cost(&self) -> (usize, usize, usize) {
        let per_term = self.passes.iter().map(|t| t.offsets_mm.len());
        (
            2 * self.passes.len(),
            per_term.clone().max().unwrap_or(0),
            2 * per_term.sum::<usize>(),
        )
    }
}

fn layouts(model: &Model, k: &Kernel2D, f: &Factors, cfg: &Config) -> Result<Vec<Layout>> {
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
            // The table the written kernel file stores ([`tap_table`]).
            let t = tap_table(model, k, f, n, Some(e))?;
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

/// What one search runs over.
pub(super) struct Search<'a> {
    pub profile: &'a Profile,
    pub truth: Kernel2D,
    pub specs: Vec<ModelSpec>,
    pub refs: Vec<Reference>,
    pub cfg: &'a Config,
    pub progress: &'a dyn Progress,
    /// Each model's fit, made once (the search outside the budget and the
    /// chosen kernel reuse it: a guided fit takes seconds).
    pub fits: std::sync::Mutex<BTreeMap<String, Fitted>>,
}

/// A score on one test image: (signal, relative RMS, standard deviation).
type Scored = (String, f64, f64);

impl Search<'_> {
    /// Progress units of one search: a model variant each, and the disk
    /// kernels one.
    pub fn units(&self) -> u64 {
        self.specs.len() as u64 + u64::from(self.with_disk())
    }

    /// `spec` fitted to the truth, from the cache when it was before (or
    /// was handed in: [`crate::report::eval::advise::Prepared`]).
    pub fn fitted(&self, spec: &ModelSpec) -> Result<Fitted> {
        let lock = || {
            self.fits
                .lock()
                .map_err(|_| Error::Unsupported("advise: a fit panicked".into()))
        };
        if let Some(f) = lock()?.get(&spec.label) {
            return Ok(f.clone());
        }
        let f = fit_model(&self.truth, self.profile, &spec.model)
            .map_err(|e| Error::Unsupported(format!("{}: {e}", spec.label)))?;
        lock()?.insert(spec.label.clone(), f.clone());
        Ok(f)
    }

    /// The layouts of one model variant that `fits` allows, filtered
    /// cheapest first (module doc: where each stops).
    fn model_candidates(
        &self,
        spec: &ModelSpec,
        fits: &(dyn Fn(usize, usize, usize) -> bool + Sync),
        only_meeting: bool,
    ) -> Result<(Vec<Candidate>, usize)> {
        let fitted = self.fitted(spec)?;
        let f = fitted.factors.clone();
        let file = assemble_with(self.profile, &self.truth, &spec.model, fitted, 17, None)?;
        let all = layouts(&spec.model, &self.truth, &f, self.cfg)?;
        let total = all.len();
        let mut kept: Vec<Layout> = all
            .into_iter()
            .filter(|l| {
                let (p, t, s) = l.cost();
                fits(p, t, s)
            })
            .collect();
        let skipped = total - kept.len();
        kept.sort_by_key(|l| {
            let (p, _, s) = l.cost();
            (s, p)
        });
        let target = self.cfg.target;
        // Phase 1, cheapest first: each layout stops at its first missed
        // signal; the first that misses none is the model's answer.
        let mut scored: Vec<(Layout, Vec<Scored>)> = Vec::new();
        for l in kept {
            let mut scores = Vec::new();
            self.extend(&l, &mut scores, |v| v.failed(target))?;
            let meets = Verdict::new(&scores, target, scores.len() == self.refs.len()).meets;
            scored.push((l, scores));
            if meets {
                return self.finish(spec, &f, &file, scored, skipped);
            }
        }
        if !only_meeting {
            // Phase 2, none meets: the most accurate, by branch and bound.
            // A partial worst case is a lower bound on the whole one, so
            // layouts are completed in order of it until the next bound is
            // past the best complete worst case by more than a tie.
            let mut order: Vec<usize> = (0..scored.len()).collect();
            let bound = |s: &[Scored]| Verdict::new(s, target, false);
            order.sort_by(|&i, &j| {
                bound(&scored[i].1)
                    .rel_rms
                    .total_cmp(&bound(&scored[j].1).rel_rms)
            });
            let mut best: Option<Verdict> = None;
            for i in order {
                let lb = bound(&scored[i].1);
                if let Some(b) = &best {
                    if lb.rel_rms > b.rel_rms + NOISE_K * b.rel_rms_sigma.hypot(lb.rel_rms_sigma) {
                        break;
                    }
                }
                let (l, scores) = &mut scored[i];
                self.extend(l, scores, |_| false)?;
                let v = Verdict::new(scores, target, true);
                if best.as_ref().is_none_or(|b| v.rel_rms < b.rel_rms) {
                    best = Some(v);
                }
            }
        }
        self.finish(spec, &f, &file, scored, skipped)
    }

    /// Scores `l` on the references `scores` lacks, in order, until `stop`
    /// says so on the scores so far.
    fn extend(
        &self,
        l: &Layout,
        scores: &mut Vec<Scored>,
        stop: impl Fn(&Verdict) -> bool,
    ) -> Result<()> {
        while let Some(r) = self.refs.get(scores.len()) {
            let s = r.score(l.passes.clone())?;
            scores.push((r.exact.case.name.clone(), s.rel_rms, s.sigma));
            if stop(&Verdict::new(scores, self.cfg.target, false)) {
                break;
            }
        }
        Ok(())
    }

    /// The candidates of one model's scored layouts.
    fn finish(
        &self,
        spec: &ModelSpec,
        f: &Factors,
        file: &KernelFile,
        scored: Vec<(Layout, Vec<Scored>)>,
        skipped: usize,
    ) -> Result<(Vec<Candidate>, usize)> {
        let out = scored
            .into_iter()
            .map(|(l, scores)| {
                let (passes, taps_per_pass, cost) = l.cost();
                Candidate {
                    label: spec.label.clone(),
                    model: file.model.name.clone(),
                    params: file.model.params.clone(),
                    rank: f.len(),
                    passes,
                    taps: l.taps,
                    taps_per_pass,
                    extent_rule: l.rule,
                    extent_mm: l.extent_mm,
                    cost,
                    signed: l
                        .passes
                        .iter()
                        .flat_map(|t| &t.weights)
                        .flatten()
                        .any(|&w| w < 0.0),
                    verdict: Verdict::new(
                        &scores,
                        self.cfg.target,
                        scores.len() == self.refs.len(),
                    ),
                    disk: None,
                    fingerprint: Some(fingerprint(&l.passes)),
                }
            })
            .collect();
        self.progress.advance(1);
        Ok((out, skipped))
    }

    /// Every candidate `fits` allows of every model variant, and how many
    /// layouts it left out; with `only_meeting` a layout stops at its first
    /// missed signal (only one that meets the target is wanted).
    pub fn candidates(
        &self,
        fits: &(dyn Fn(usize, usize, usize) -> bool + Sync),
        only_meeting: bool,
    ) -> Result<(Vec<Candidate>, usize)> {
        let (per_model, disk) = rayon::join(
            || {
                self.specs
                    .par_iter()
                    .map(|spec| self.model_candidates(spec, fits, only_meeting))
                    .collect::<Result<Vec<(Vec<Candidate>, usize)>>>()
            },
            || self.disk_candidates(fits, only_meeting),
        );
        let (per_model, (disk, disk_skipped)) = (per_model?, disk?);
        let skipped = per_model.iter().map(|(_, s)| s).sum::<usize>() + disk_skipped;
        let mut all: Vec<Candidate> = per_model.into_iter().flat_map(|(c, _)| c).collect();
        all.extend(disk);
        Ok((all, skipped))
    }

    /// The kernel file of candidate `c` (its tap table as chosen, the
    /// default table for full factors) and the passes it runs.
    pub fn chosen_kernel(&self, c: &Candidate) -> Result<(KernelFile, Vec<Taps>)> {
        let spec = self
            .specs
            .iter()
            .find(|s| s.label == c.label)
            .ok_or_else(|| Error::Unsupported(format!("lost model {}", c.label)))?;
        let fitted = self.fitted(spec)?;
        let (count, extent) = match c.taps {
            Some(n) => (n, Some(c.extent_mm)),
            None => (crate::kernel::taps::DEFAULT_TAPS, None),
        };
        let mut kernel = assemble_with(
            self.profile,
            &self.truth,
            &spec.model,
            fitted,
            count,
            extent,
        )?;
        // What the file runs, checked against what was scored.
        let passes = scored_passes(&kernel, c.taps.is_none(), self.cfg.mm_per_pixel);
        if c.fingerprint.as_deref() != Some(fingerprint(&passes).as_str()) {
            return Err(Error::Unsupported(format!(
                "advise: the kernel file of {} runs other passes than the ones scored",
                c.describe()
            )));
        }
        if c.taps.is_none() {
            kernel.taps = pixel_table(&passes, self.cfg.mm_per_pixel);
        }
        Ok((kernel, passes))
    }

    /// The errors of `passes` on every signal, with FLIP and timing.
    pub fn predict(&self, passes: &[Taps], cost: usize) -> Result<BTreeMap<String, ImageErrors>> {
        // Each signal on its own (FLIP runs on one thread): all at once.
        self.refs
            .par_iter()
            .map(|r| {
                let e = &r.exact;
                let (img, secs) = evaluate::filter(&e.case, passes.to_vec())?;
                let mut errs = evaluate::errors(e, &img, &self.cfg.options)?;
                errs.ms_per_megapixel = 1e3 * secs / (img.len() as f64 / 1e6);
                errs.samples_per_pixel = cost;
                Ok((e.case.name.clone(), errs))
            })
            .collect()
    }

    /// The same search at another scale: its configuration and test
    /// images, this search's fits (a fit is made on the truth in mm, so it
    /// does not depend on the scale).
    pub fn at_scale<'b>(&'b self, cfg: &'b Config, refs: Vec<Reference>) -> Result<Search<'b>> {
        let fits = self
            .fits
            .lock()
            .map_err(|_| Error::Unsupported("advise: a fit panicked".into()))?
            .clone();
        Ok(Search {
            profile: self.profile,
            truth: self.truth.clone(),
            specs: self.specs.clone(),
            refs,
            cfg,
            progress: self.progress,
            fits: std::sync::Mutex::new(fits),
        })
    }

    /// Where the best within the budget misses: the target it meets, and
    /// the cheapest outside the budget that meets the target.
    pub fn remedy(&self, best: &Candidate) -> Result<Remedy> {
        let budget = self.cfg.budget;
        let searched_outside = budget != Budget::UNBOUNDED;
        let outside = if searched_outside {
            let (c, _) = self.candidates(&|p, t, s| !budget.allows(p, t, s), true)?;
            choose(&c).map(|i| c[i].clone()).filter(|c| c.verdict.meets)
        } else {
            None
        };
        Ok(Remedy {
            target_met_by_best: best.verdict.decided_at,
            outside_budget: outside,
            searched_outside,
            coarser: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::disk_error::view;
    use crate::filter::kernel_setup::kernel_setup;
    use crate::filter::signals::{generate, Signal};
    use crate::filter::{cpu, separable, Setup};
    use crate::kernel::preintegrate::PreMethod;

    /// A full-factor answer's file runs by default what was scored: its
    /// pixel table, as `apply` runs a tap table, gives the image of the
    /// full factors resampled to pixels (`apply --full-factors`), and the
    /// file it makes is a valid kernel file.
    #[test]
    fn a_full_factor_answer_ships_the_passes_scored() {
        let profile = crate::kernel::reference::dipole_uniform("skin1", 0.02, 6.0);
        let model = Model::Preintegrate {
            method: PreMethod::Abel,
        };
        let mm = 0.5;
        let mut kernel = crate::kernel::fit_kernel_file(
            &profile,
            &crate::kernel::Kernel2DSpec::default(),
            &model,
            17,
        )
        .unwrap();
        let passes = scored_passes(&kernel, true, mm);
        let full = kernel.clone();
        kernel.taps = pixel_table(&passes, mm);
        assert_eq!(kernel.taps.count % 2, 1);
        kernel.validate("pixel table").unwrap();
        let image = generate(Signal::Shapes, 40, 40, 3).unwrap();
        let run = |k: &KernelFile, full_factors: bool| {
            let v: Setup = view(mm);
            let (setup, _) = kernel_setup(k, full_factors, v, &image).unwrap();
            cpu::apply_with(&image, &setup, separable::Precision::F64).unwrap()
        };
        let (table, scored) = (run(&kernel, false), run(&full, true));
        for c in 0..3 {
            for (a, b) in table.rgb[c].iter().zip(&scored.rgb[c]) {
                assert!((a - b).abs() <= 1e-12, "{a} {b}");
            }
        }
        // The stored 17-tap table runs something else.
        let stored = run(&full, false);
        assert!(stored.rgb[0]
            .iter()
            .zip(&scored.rgb[0])
            .any(|(a, b)| (a - b).abs() > 1e-6));
    }
}
