//! The speed/accuracy study of one material: every knob a user turns,
//! measured in one run against one reference profile.
//!
//! 1. Monte Carlo photons vs profile error vs time: simulations of growing
//!    photon counts on the reference's radial grid; error = the relative L2
//!    error of r R_d(r) inside r99 ([`crate::report::eval::compare::profile`]), largest channel.
//! 2. Profile model (Monte Carlo, photon beam diffusion, dipole, Burley) vs
//!    kernel and image error vs time: each profile's 2D kernel on the
//!    reference's kernel grid against the reference's (kernel RMS), and the
//!    pre-integrated kernel of each profile filtered and compared with the
//!    exact convolution by the reference profile.
//! 3. Taps (5..33) of the pre-integrated kernel vs image error, with the
//!    tap extent chosen for the count and with the kernel's full extent.
//! 4. SVD rank (renormalised, Freude 2014 eq. 5.12) vs image error vs
//!    samples per pixel (the CPU filter time in the table).
//! 5. Kernel model vs kernel and image error vs samples per pixel (the fit
//!    time, offline and irrelevant to shipping, in the table).
//! 6. Disk kernels (`kernel::disk`, one pass of N samples) vs image error
//!    after 8 frames (bias and noise in quadrature) vs samples per pixel,
//!    beside the kernel models at the same cost.
//!
//! Every entry filtered with separable passes records its kernel model,
//! its one-dimensional passes (2 per separable term) and its samples per
//! pixel: the cost a renderer pays each frame.
//!
//! Image errors: the largest relative RMS over channels (as `ssskit diff`)
//! and the colour FLIP, on the edge and shapes signals at one scale
//! ([`crate::report::eval::evaluate`]); reported as the larger of the two signals.

use crate::error::Result;
use crate::filter::disk::DiskSetup;
use crate::filter::disk_error::{disk_error_with_first, view};
use crate::filter::signals::Signal;
use crate::filter::Taps;
use crate::kernel::model::{assemble_with, fit_model};
use crate::kernel::preintegrate::PreMethod;
use crate::kernel::taps::{tap_table_with, DEFAULT_TAPS};
use crate::kernel::{metrics, Kernel2D, Kernel2DSpec, KernelFile, Model};
use crate::profile::analytic::Model as AnalyticModel;
use crate::profile::source::{make_profile_on, ProfileSource};
use crate::profile::{Profile, RadialGrid};
use crate::progress::{NoProgress, Progress};
use crate::report::eval::compare;
use crate::report::eval::compare::kernel::{Config as CompareConfig, MaterialInput, FAMILIES};
use crate::report::eval::disk::DEFAULT_FRAMES;
use crate::report::eval::disk::{disk_kernel, DISK_SAMPLES, DISK_SEED, WINDOWS};
use crate::report::eval::evaluate::{self, Exact, ImageCase, ImageErrors, Options};
use serde::{Deserialize, Serialize};

/// What to measure.
#[derive(Clone, Debug)]
pub struct Settings {
    pub mm_per_pixel: f64,
    /// Side of the test signals, pixels.
    pub size: usize,
    /// Photon counts per channel of the Monte Carlo sweep.
    pub photons: Vec<u64>,
    pub seed: u64,
    pub taps: Vec<usize>,
    pub ranks: Vec<usize>,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            mm_per_pixel: evaluate::DEFAULT_MM_PER_PIXEL,
            size: evaluate::DEFAULT_SIGNAL_SIZE,
            photons: vec![10_000, 30_000, 100_000, 300_000],
            seed: 7,
            taps: vec![5, 7, 9, 11, 13, 17, 21, 25, 33],
            ranks: vec![1, 2, 3, 4, 5, 6],
        }
    }
}

/// One measured configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// "photons", "profile_model", "taps", "rank", "kernel_model".
    pub section: String,
    pub config: String,
    /// The cost axis of the section and its unit.
    pub cost: f64,
    pub cost_unit: String,
    /// Profile error (photons), kernel RMS (profile model, kernel model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub profile_or_kernel_error: Option<f64>,
    /// Image space (none for the photon sweep).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_rms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip: Option<f64>,
    /// The kernel model the images were filtered with.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// One-dimensional passes (2 per separable term) and samples per
    /// pixel of the filter: what a renderer pays per frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub passes: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples_per_pixel: Option<usize>,
    /// CPU filter time on this machine (table only, not a plotted cost).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ms_per_megapixel: Option<f64>,
    /// Wall time of the section's work for this entry, seconds.
    pub seconds: f64,
}

/// A model filtered with separable passes (`terms` terms, two passes
/// each) and scored on the study's images.
struct Separable<'a> {
    model: &'a str,
    errs: &'a [ImageErrors],
    terms: usize,
}

impl Separable<'_> {
    /// Its entry: the worst relative RMS and FLIP over the images, passes
    /// and samples per pixel; the cost is `cost` (value, unit), or where
    /// None its samples per pixel.
    fn entry(
        &self,
        section: &str,
        config: String,
        cost: Option<(f64, &str)>,
        kernel_error: Option<f64>,
        ms_per_megapixel: Option<f64>,
        seconds: f64,
    ) -> Entry {
        let (rel, flip) = worst(self.errs);
        let samples_per_pixel = self.errs.iter().map(|e| e.samples_per_pixel).max();
        Entry {
            section: section.into(),
            config,
            cost: cost.map_or(samples_per_pixel.unwrap_or(0) as f64, |c| c.0),
            cost_unit: cost.map_or("samples/pixel", |c| c.1).into(),
            profile_or_kernel_error: kernel_error,
            rel_rms: Some(rel),
            flip: Some(flip),
            model: Some(self.model.to_string()),
            passes: Some(2 * self.terms),
            samples_per_pixel,
            ms_per_megapixel,
            seconds,
        }
    }
}

/// Everything the study measured.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Study {
    pub material: String,
    pub reference: String,
    pub mm_per_pixel: f64,
    pub entries: Vec<Entry>,
}

fn worst(errs: &[ImageErrors]) -> (f64, f64) {
    let rel = errs
        .iter()
        .flat_map(|e| e.rel_rms.iter().cloned())
        .fold(0.0, f64::max);
    let flip = errs.iter().map(|e| e.flip_rgb).fold(0.0, f64::max);
    (rel, flip)
}

fn grid_of(p: &Profile) -> RadialGrid {
    RadialGrid {
        edges: p.r_edges.clone(),
    }
}

fn max_l2(rows: &[compare::profile::Row]) -> f64 {
    rows.iter().map(|r| r.rel_l2_error).fold(0.0, f64::max)
}

fn max3(v: &[f64]) -> f64 {
    v.iter().cloned().fold(0.0, f64::max)
}

const PREINTEGRATE: Model = Model::Preintegrate {
    method: PreMethod::Abel,
};

/// A profile made for one section and the seconds it took.
struct Made {
    name: String,
    profile: Profile,
    seconds: f64,
}

/// What every section measures against: the reference, its test images
/// and their exact convolutions, its 2D kernel.
struct Bench<'a> {
    reference: &'a Profile,
    cases: Vec<ImageCase>,
    exact: Vec<Exact>,
    options: Options,
    truth: Kernel2D,
    /// The reference kernel's grid, for every other profile's kernel.
    spec: Kernel2DSpec,
}

impl<'a> Bench<'a> {
    fn new(reference: &'a Profile, s: &Settings) -> Result<Bench<'a>> {
        let cases: Vec<ImageCase> = [Signal::Edge, Signal::Shapes]
            .iter()
            .map(|&g| ImageCase::signal(g, s.size, s.mm_per_pixel))
            .collect::<Result<_>>()?;
        let exact: Vec<Exact> = cases
            .iter()
            .map(|c| Exact::new(reference, c))
            .collect::<Result<_>>()?;
        let truth = Kernel2D::from_profile(reference, &Kernel2DSpec::default())?;
        let spec = Kernel2DSpec {
            size: Some(truth.size),
            extent_mm: Some(truth.extent_mm()),
        };
        Ok(Bench {
            reference,
            cases,
            exact,
            options: Options::default(),
            truth,
            spec,
        })
    }

    fn eval(&self, k: &KernelFile, taps: &[usize]) -> Result<Vec<evaluate::KernelImageErrors>> {
        self.exact
            .iter()
            .map(|e| evaluate::evaluate(e, k, taps, &self.options))
            .collect()
    }

    /// 1. Monte Carlo photons vs profile error vs time, on the reference's
    ///    grid; the last (largest) simulation is returned for section 2.
    fn photons(&self, s: &Settings) -> Result<(Vec<Entry>, Option<Made>)> {
        let grid = grid_of(self.reference);
        let mut entries = Vec::new();
        let mut last = None;
        for &n in &s.photons {
            let source = ProfileSource::photons(n, s.seed);
            let (p, secs) =
                make_profile_on(&self.reference.material, &source, Some(&grid), &NoProgress)?;
            let rows = compare::profile::compare(&p, self.reference, secs)?;
            entries.push(Entry {
                section: "photons".into(),
                config: format!("{n} photons"),
                cost: secs,
                cost_unit: "s".into(),
                profile_or_kernel_error: Some(max_l2(&rows)),
                rel_rms: None,
                flip: None,
                model: None,
                passes: None,
                samples_per_pixel: None,
                ms_per_megapixel: None,
                seconds: secs,
            });
            last = Some(Made {
                name: format!("mc {n}"),
                profile: p,
                seconds: secs,
            });
        }
        Ok((entries, last))
    }

    /// 2. Profile models (the last Monte Carlo run and, on a half-space,
    ///    the analytic models) vs kernel and image error vs time.
    fn profile_models(&self, mc: Option<Made>) -> Result<Vec<Entry>> {
        let material = &self.reference.material;
        let grid = grid_of(self.reference);
        let mut sources: Vec<Made> = mc.into_iter().collect();
        if material.is_half_space() {
            for m in [
                AnalyticModel::Pbd,
                AnalyticModel::Dipole,
                AnalyticModel::Burley,
            ] {
                let source = ProfileSource::analytic(m);
                let (profile, seconds) =
                    make_profile_on(material, &source, Some(&grid), &NoProgress)?;
                sources.push(Made {
                    name: m.name().into(),
                    profile,
                    seconds,
                });
            }
        }
        let mut entries = Vec::new();
        for made in &sources {
            let k = Kernel2D::from_profile(&made.profile, &self.spec)?;
            let krms = (0..3)
                .map(|c| metrics::kernel_rms(&self.truth.data[c], &k.data[c]))
                .fold(0.0, f64::max);
            let kf = crate::kernel::fit_kernel_file(
                &made.profile,
                &self.spec,
                &PREINTEGRATE,
                DEFAULT_TAPS,
            )?;
            let errs: Vec<ImageErrors> = self.eval(&kf, &[])?.into_iter().map(|e| e.full).collect();
            let scored = Separable {
                model: "preintegrate",
                errs: &errs,
                terms: kf.taps.passes.len(),
            };
            let cost = Some((made.seconds, "s"));
            let (config, secs) = (made.name.clone(), made.seconds);
            entries.push(scored.entry("profile_model", config, cost, Some(krms), None, secs));
        }
        Ok(entries)
    }

    /// 3. Taps, extent chosen for the count and the full extent.
    fn taps(&self, s: &Settings) -> Result<Vec<Entry>> {
        let pre_factors = fit_model(&self.truth, self.reference, &PREINTEGRATE)?.factors;
        let mut entries = Vec::new();
        for &n in &s.taps {
            for (label, extent) in [
                ("auto extent", None),
                ("full extent", Some(self.truth.extent_mm())),
            ] {
                let table = tap_table_with(&self.truth, &pre_factors, n, extent)?;
                let passes: Vec<Taps> = table.passes.iter().map(Taps::from).collect();
                let mut errs = Vec::new();
                let mut secs = 0.0;
                for e in &self.exact {
                    let (img, t) = evaluate::filter(&e.case, passes.clone())?;
                    secs += t;
                    errs.push(evaluate::errors(e, &img, &self.options)?);
                }
                let scored = Separable {
                    model: "preintegrate",
                    errs: &errs,
                    terms: table.passes.len(),
                };
                let config = format!(
                    "{n} taps, {label} (+-{:.2} mm)",
                    table.extent_mm.unwrap_or(f64::NAN)
                );
                let cost = Some(((2 * n) as f64, "samples/pixel"));
                entries.push(scored.entry("taps", config, cost, None, None, secs));
            }
        }
        Ok(entries)
    }

    /// 4. SVD ranks (renormalised), full factors and [`DEFAULT_TAPS`] taps.
    fn ranks(&self, s: &Settings) -> Result<Vec<Entry>> {
        let mut entries = Vec::new();
        for &r in &s.ranks {
            let model = Model::Svd {
                rank: r,
                renormalize: true,
            };
            let f = fit_model(&self.truth, self.reference, &model)?;
            let kf = assemble_with(self.reference, &self.truth, &model, f, DEFAULT_TAPS, None)?;
            let ev = self.eval(&kf, &[DEFAULT_TAPS])?;
            let taps = format!("{DEFAULT_TAPS} taps");
            for (label, errs) in [
                (
                    "full",
                    ev.iter().map(|e| e.full.clone()).collect::<Vec<_>>(),
                ),
                (
                    taps.as_str(),
                    ev.iter().map(|e| e.taps[&DEFAULT_TAPS].clone()).collect(),
                ),
            ] {
                let ms = errs.iter().map(|e| e.ms_per_megapixel).sum::<f64>() / errs.len() as f64;
                // The filter's wall time over the study's images, seconds
                // (ms per megapixel times each image's megapixels).
                let secs: f64 = errs
                    .iter()
                    .zip(&self.exact)
                    .map(|(e, x)| 1e-3 * e.ms_per_megapixel * x.case.image.len() as f64 / 1e6)
                    .sum();
                let scored = Separable {
                    model: &format!("svd{r}-renorm"),
                    errs: &errs,
                    terms: kf.taps.passes.len(),
                };
                let config = format!("svd rank {r} renormalised, {label}");
                let kernel_error = Some(max3(&kf.metrics.kernel_rms));
                entries.push(scored.entry("rank", config, None, kernel_error, Some(ms), secs));
            }
        }
        Ok(entries)
    }

    /// 5. Kernel models of the comparison at [`DEFAULT_TAPS`] taps: image
    ///    error against samples per pixel (fit time in the table only).
    fn kernel_models(&self) -> Result<Vec<Entry>> {
        let cfg = CompareConfig {
            families: FAMILIES.iter().map(|f| f.to_string()).collect(),
            ranks: vec![1, 2, 3],
            cases: self.cases.clone(),
            taps: vec![DEFAULT_TAPS],
            options: self.options,
            keep: None,
            extent_mm: None,
        };
        let input = MaterialInput {
            name: self.reference.material.name.clone(),
            profile: self.reference.clone(),
        };
        let cmp = compare::kernel::run(std::slice::from_ref(&input), &cfg, &NoProgress)?;
        let mut entries = Vec::new();
        for f in &cmp.fitted {
            let errs: Vec<ImageErrors> = f
                .images
                .iter()
                .map(|e| e.taps[&DEFAULT_TAPS].clone())
                .collect();
            let scored = Separable {
                model: &f.spec.label,
                errs: &errs,
                terms: f.kernel.taps.passes.len(),
            };
            let kernel_error = Some(max3(&f.kernel.metrics.kernel_rms));
            let secs = f.kernel.metrics.fit_seconds;
            entries.push(scored.entry(
                "kernel_model",
                f.spec.label.clone(),
                None,
                kernel_error,
                None,
                secs,
            ));
        }
        Ok(entries)
    }
}

impl Bench<'_> {
    /// 6. Disk kernels of [`DISK_SAMPLES`] samples (one pass): the image
    ///    error and FLIP a temporal filter shows after [`DEFAULT_FRAMES`]
    ///    frames, on the first accumulation of that many frames as
    ///    advise scores it ([`crate::report::eval::advise::disk`]), with the bias and the
    ///    noise after K frames of its worst channel.
    fn disk(&self) -> Result<Vec<Entry>> {
        let k = DEFAULT_FRAMES;
        let mut entries = Vec::new();
        for n in DISK_SAMPLES {
            let t0 = std::time::Instant::now();
            let kernel = disk_kernel(self.reference, n)?;
            let (mut rel, mut flip, mut bias, mut noise) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            for x in &self.exact {
                let mm = x.case.mm_per_pixel;
                let setup = DiskSetup::new(&kernel, view(mm), DISK_SEED, 1);
                let (e, first) =
                    disk_error_with_first(&x.case.image, &setup, &x.image, WINDOWS * k, k)?;
                let errs = evaluate::errors(x, &first.image, &self.options)?;
                let c = (0..3).fold(0, |b, c| {
                    if errs.rel_rms[c] > errs.rel_rms[b] {
                        c
                    } else {
                        b
                    }
                });
                if errs.rel_rms[c] > rel {
                    (rel, bias, noise) = (errs.rel_rms[c], e.bias[c], e.noise_after[c]);
                }
                flip = flip.max(errs.flip_rgb);
            }
            entries.push(Entry {
                section: "disk".into(),
                config: format!(
                    "disk {n} samples, {k} frames (in the worst case's channel: bias {:.2}%, \
                     noise after {k} frames {:.2}%)",
                    100.0 * bias,
                    100.0 * noise
                ),
                cost: n as f64,
                cost_unit: "samples/pixel".into(),
                profile_or_kernel_error: None,
                rel_rms: Some(rel),
                flip: Some(flip),
                model: Some("disk".into()),
                passes: Some(1),
                samples_per_pixel: Some(n),
                ms_per_megapixel: None,
                seconds: t0.elapsed().as_secs_f64(),
            });
        }
        Ok(entries)
    }
}

/// Runs the study of `reference`'s material against `reference`.
pub fn run(reference: &Profile, s: &Settings, progress: &dyn Progress) -> Result<Study> {
    let bench = Bench::new(reference, s)?;
    progress.start(6, "study sections");
    let (mut entries, mc) = bench.photons(s)?;
    progress.advance(1);
    entries.extend(bench.profile_models(mc)?);
    progress.advance(1);
    entries.extend(bench.taps(s)?);
    progress.advance(1);
    entries.extend(bench.ranks(s)?);
    progress.advance(1);
    entries.extend(bench.kernel_models()?);
    progress.advance(1);
    entries.extend(bench.disk()?);
    progress.advance(1);
    progress.finish();
    Ok(Study {
        material: reference.material.name.clone(),
        reference: reference
            .source
            .model
            .clone()
            .unwrap_or_else(|| reference.source.kind.clone()),
        mm_per_pixel: s.mm_per_pixel,
        entries,
    })
}
