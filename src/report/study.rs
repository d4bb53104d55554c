//! The speed/accuracy study of one material: every knob a user turns,
//! measured in one run against one reference profile.
//!
//! 1. Monte Carlo photons vs profile error vs time: simulations of growing
//!    photon counts on the reference's radial grid; error = the relative L2
//!    error of r R_d(r) inside r99 ([`super::compare`]), largest channel.
//! 2. Profile model (Monte Carlo, photon beam diffusion, dipole, Burley) vs
//!    kernel and image error vs time: each profile's 2D kernel on the
//!    reference's kernel grid against the reference's (kernel RMS), and the
//!    pre-integrated kernel of each profile filtered and compared with the
//!    exact convolution by the reference profile.
//! 3. Taps (5..33) vs image error, with the tap extent chosen for the count
//!    and with the kernel's full extent.
//! 4. SVD rank (renormalised, Freude 2014 eq. 5.12) vs image error vs
//!    filter time.
//! 5. Kernel model vs kernel and image error vs fit time.
//!
//! Image errors: the largest relative RMS over channels (as `ssskit diff`)
//! and the colour FLIP, on the edge and shapes signals at one scale
//! ([`super::evaluate`]); reported as the larger of the two signals.

use super::compare as profile_compare;
use super::evaluate::{self, Exact, ImageCase, ImageErrors, Options};
use super::kernel_compare::{self, Config as CompareConfig, MaterialInput, FAMILIES};
use super::pareto::{self, ParetoPanel, Point, Series};
use super::table::Table;
use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::filter::Taps;
use crate::kernel::model::{assemble_with, fit_model};
use crate::kernel::preintegrate::PreMethod;
use crate::kernel::taps::tap_table_with;
use crate::kernel::{metrics, Kernel2D, Kernel2DSpec, KernelFile, Model};
use crate::material::Channel;
use crate::profile::analytic::{self, Model as AnalyticModel};
use crate::profile::mc::{self, McConfig, PhotonBudget};
use crate::profile::{Profile, RadialGrid};
use crate::progress::{NoProgress, Progress};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

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
    pub seconds: f64,
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

fn max_l2(rows: &[profile_compare::Row]) -> f64 {
    rows.iter().map(|r| r.rel_l2_error).fold(0.0, f64::max)
}

fn preintegrated(profile: &Profile, spec: &Kernel2DSpec, taps: usize) -> Result<KernelFile> {
    crate::kernel::fit_kernel_file(
        profile,
        spec,
        &Model::Preintegrate {
            method: PreMethod::Abel,
        },
        taps,
    )
}

/// Runs the study of `reference`'s material against `reference`.
pub fn run(reference: &Profile, s: &Settings, progress: &dyn Progress) -> Result<Study> {
    let material = reference.material.clone();
    let mut entries = Vec::new();
    let cases: Vec<ImageCase> = [Signal::Edge, Signal::Shapes]
        .iter()
        .map(|&g| ImageCase::signal(g, s.size, s.mm_per_pixel))
        .collect::<Result<_>>()?;
    let exact: Vec<Exact> = cases
        .iter()
        .map(|c| Exact::new(reference, c))
        .collect::<Result<_>>()?;
    let options = Options::default();
    let eval = |k: &KernelFile, taps: &[usize]| -> Result<Vec<evaluate::KernelImageErrors>> {
        exact
            .iter()
            .map(|e| evaluate::evaluate(e, k, taps, &options))
            .collect()
    };
    let truth = Kernel2D::from_profile(reference, &Kernel2DSpec::default())?;
    let spec = Kernel2DSpec {
        size: Some(truth.size),
        extent_mm: Some(truth.extent_mm()),
    };
    progress.start(5, "study sections");

    // 1. Photons.
    let grid = grid_of(reference);
    let mut mc_profiles = Vec::new();
    for &n in &s.photons {
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(n),
            seed: s.seed,
            threads: None,
            channels: Channel::ALL.to_vec(),
            grid: Some(grid.clone()),
        };
        let t0 = Instant::now();
        let p = mc::simulate(&material, &cfg, &NoProgress)?;
        let secs = t0.elapsed().as_secs_f64();
        let rows = profile_compare::compare(&p, reference, secs)?;
        entries.push(Entry {
            section: "photons".into(),
            config: format!("{n} photons"),
            cost: secs,
            cost_unit: "s".into(),
            profile_or_kernel_error: Some(max_l2(&rows)),
            rel_rms: None,
            flip: None,
            seconds: secs,
        });
        mc_profiles.push((n, p, secs));
    }
    progress.advance(1);

    // 2. Profile models.
    let mut sources: Vec<(String, Profile, f64)> = Vec::new();
    if let Some((n, p, secs)) = mc_profiles.last() {
        sources.push((format!("mc {n}"), p.clone(), *secs));
    }
    if material.is_half_space() {
        for m in [
            AnalyticModel::Pbd,
            AnalyticModel::Dipole,
            AnalyticModel::Burley,
        ] {
            let t0 = Instant::now();
            let p = analytic::profile(&material, m, &grid, &analytic::Options::default())?;
            sources.push((m.name().into(), p, t0.elapsed().as_secs_f64()));
        }
    }
    for (name, p, secs) in &sources {
        let k = Kernel2D::from_profile(p, &spec)?;
        let krms = (0..3)
            .map(|c| metrics::kernel_rms(&truth.data[c], &k.data[c]))
            .fold(0.0, f64::max);
        let kf = preintegrated(p, &spec, 17)?;
        let errs: Vec<ImageErrors> = eval(&kf, &[])?.into_iter().map(|e| e.full).collect();
        let (rel, flip) = worst(&errs);
        entries.push(Entry {
            section: "profile_model".into(),
            config: name.clone(),
            cost: *secs,
            cost_unit: "s".into(),
            profile_or_kernel_error: Some(krms),
            rel_rms: Some(rel),
            flip: Some(flip),
            seconds: *secs,
        });
    }
    progress.advance(1);

    // 3. Taps, extent chosen for the count and the full extent.
    let pre_factors = fit_model(
        &truth,
        reference,
        &Model::Preintegrate {
            method: PreMethod::Abel,
        },
    )?
    .factors;
    for &n in &s.taps {
        for (label, extent) in [
            ("auto extent", None),
            ("full extent", Some(truth.extent_mm())),
        ] {
            let table = tap_table_with(&truth, &pre_factors, n, extent)?;
            let passes: Vec<Taps> = table.passes.iter().map(Taps::from).collect();
            let mut errs = Vec::new();
            let mut secs = 0.0;
            for e in &exact {
                let (img, t) = evaluate::filter(&e.case, passes.clone())?;
                secs += t;
                errs.push(evaluate::errors(e, &img, &options)?);
            }
            let (rel, flip) = worst(&errs);
            entries.push(Entry {
                section: "taps".into(),
                config: format!(
                    "{n} taps, {label} (+-{:.2} mm)",
                    table.extent_mm.unwrap_or(f64::NAN)
                ),
                cost: (2 * n) as f64,
                cost_unit: "samples/pixel".into(),
                profile_or_kernel_error: None,
                rel_rms: Some(rel),
                flip: Some(flip),
                seconds: secs,
            });
        }
    }
    progress.advance(1);

    // 4. Ranks.
    for &r in &s.ranks {
        let model = Model::Svd {
            rank: r,
            renormalize: true,
        };
        let f = fit_model(&truth, reference, &model)?;
        let kf = assemble_with(reference, &truth, &model, f, 17, None)?;
        let ev = eval(&kf, &[17])?;
        for (label, errs) in [
            (
                "full",
                ev.iter().map(|e| e.full.clone()).collect::<Vec<_>>(),
            ),
            ("17 taps", ev.iter().map(|e| e.taps[&17].clone()).collect()),
        ] {
            let (rel, flip) = worst(&errs);
            let ms = errs.iter().map(|e| e.ms_per_megapixel).sum::<f64>() / errs.len() as f64;
            entries.push(Entry {
                section: "rank".into(),
                config: format!("svd rank {r} renormalised, {label}"),
                cost: ms,
                cost_unit: "ms/megapixel".into(),
                profile_or_kernel_error: Some(
                    kf.metrics.kernel_rms.iter().cloned().fold(0.0, f64::max),
                ),
                rel_rms: Some(rel),
                flip: Some(flip),
                seconds: ms,
            });
        }
    }
    progress.advance(1);

    // 5. Kernel models.
    let cfg = CompareConfig {
        families: FAMILIES.iter().map(|f| f.to_string()).collect(),
        ranks: vec![1, 2, 3],
        cases: cases.clone(),
        taps: vec![17],
        options,
        keep: None,
        extent_mm: None,
    };
    let input = MaterialInput {
        name: material.name.clone(),
        profile: reference.clone(),
    };
    let cmp = kernel_compare::run(std::slice::from_ref(&input), &cfg, &NoProgress)?;
    for f in &cmp.fitted {
        let errs: Vec<ImageErrors> = f.images.iter().map(|e| e.taps[&17].clone()).collect();
        let (rel, flip) = worst(&errs);
        let secs = f.kernel.metrics.fit_seconds;
        entries.push(Entry {
            section: "kernel_model".into(),
            config: f.spec.label.clone(),
            cost: secs.max(1e-6),
            cost_unit: "s (fit)".into(),
            profile_or_kernel_error: Some(
                f.kernel
                    .metrics
                    .kernel_rms
                    .iter()
                    .cloned()
                    .fold(0.0, f64::max),
            ),
            rel_rms: Some(rel),
            flip: Some(flip),
            seconds: secs,
        });
    }
    progress.advance(1);
    progress.finish();
    Ok(Study {
        material: material.name.clone(),
        reference: reference
            .source
            .model
            .clone()
            .unwrap_or_else(|| reference.source.kind.clone()),
        mm_per_pixel: s.mm_per_pixel,
        entries,
    })
}

fn fmt(v: Option<f64>) -> String {
    v.map_or("-".into(), super::kernel_report::sig)
}

/// The table of every entry.
pub fn table(study: &Study) -> Table {
    let mut t = Table::new(&[
        "section",
        "configuration",
        "cost",
        "cost unit",
        "profile or kernel error",
        "image rel. RMS",
        "image FLIP",
    ]);
    for e in &study.entries {
        t.push(vec![
            e.section.clone(),
            e.config.clone(),
            super::kernel_report::sig(e.cost),
            e.cost_unit.clone(),
            fmt(e.profile_or_kernel_error),
            fmt(e.rel_rms),
            fmt(e.flip),
        ]);
    }
    t
}

fn series(study: &Study, section: &str, name: &str, err: impl Fn(&Entry) -> Option<f64>) -> Series {
    Series {
        name: name.into(),
        points: study
            .entries
            .iter()
            .filter(|e| e.section == section)
            .filter_map(|e| {
                Some(Point {
                    cost: e.cost,
                    error: err(e)?,
                    label: e.config.clone(),
                })
            })
            .collect(),
    }
}

/// The Pareto panels, one per section.
pub fn panels(study: &Study) -> Vec<ParetoPanel> {
    let m = &study.material;
    let split = |section: &str, key: &str, name: &str| Series {
        name: name.into(),
        points: series(study, section, name, |e| e.rel_rms)
            .points
            .into_iter()
            .filter(|p| p.label.contains(key))
            .map(|p| Point {
                label: p.label.split(',').next().unwrap_or("").to_string(),
                ..p
            })
            .collect(),
    };
    vec![
        ParetoPanel {
            title: format!("{m}: Monte Carlo photons"),
            x_label: "simulation time (s)".into(),
            y_label: "profile rel. L2 error".into(),
            series: vec![series(study, "photons", "Monte Carlo", |e| {
                e.profile_or_kernel_error
            })],
        },
        ParetoPanel {
            title: format!("{m}: profile model"),
            x_label: "profile time (s)".into(),
            y_label: "error".into(),
            series: vec![
                series(study, "profile_model", "kernel RMS", |e| {
                    e.profile_or_kernel_error
                }),
                series(study, "profile_model", "image rel. RMS", |e| e.rel_rms),
            ],
        },
        ParetoPanel {
            title: format!("{m}: taps (pre-integration)"),
            x_label: "samples per pixel".into(),
            y_label: "image rel. RMS".into(),
            series: vec![
                split("taps", "auto extent", "extent chosen for the count"),
                split("taps", "full extent", "full kernel extent"),
            ],
        },
        ParetoPanel {
            title: format!("{m}: SVD rank (renormalised)"),
            x_label: "filter time (ms per megapixel, CPU)".into(),
            y_label: "image rel. RMS".into(),
            series: vec![
                split("rank", "full", "full factors"),
                split("rank", "17 taps", "17 taps"),
            ],
        },
        ParetoPanel {
            title: format!("{m}: kernel model (17 taps)"),
            x_label: "fit time (s)".into(),
            y_label: "image rel. RMS".into(),
            series: vec![series(study, "kernel_model", "models", |e| e.rel_rms)],
        },
    ]
}

/// Writes study.md, study.json (read back), study.csv and pareto.png.
pub fn write(study: &Study, dir: &Path, command: &str, plots: bool) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::format(dir, format!("cannot create the output folder: {e}")))?;
    let t = table(study);
    let md = format!(
        "# Speed/accuracy study: {}\n\n`{command}`\n\nReference profile: {}. Images: edge and \
         shapes at {} mm per pixel; image errors are the largest relative RMS over channels \
         and signals and the colour FLIP (see docs). Times are wall times on this machine and \
         its load.\n\n{}",
        study.material,
        study.reference,
        study.mm_per_pixel,
        t.markdown()
    );
    crate::io::write_atomic(&dir.join("study.md"), md.as_bytes())?;
    t.write_csv(&dir.join("study.csv"))?;
    crate::io::write_json_atomic(&dir.join("study.json"), study)?;
    let back: Study = crate::io::read_json(&dir.join("study.json"))?;
    if back.entries.len() != study.entries.len() {
        return Err(Error::format(
            dir.join("study.json"),
            "read back fewer entries",
        ));
    }
    let mut files = vec!["study.md".into(), "study.csv".into(), "study.json".into()];
    if plots {
        pareto::render(
            &panels(study),
            2,
            &format!(
                "Speed/accuracy of {} (log-log; lines join the Pareto front)",
                study.material
            ),
            &dir.join("pareto.png"),
        )?;
        files.push("pareto.png".into());
    }
    Ok(files)
}
