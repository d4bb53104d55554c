//! Kernel models compared across materials, in kernel space and image space
//! (Freude 2014, tables 6.3, 6.4 and 6.5): for every material x model x
//! channel, the kernel metrics of the fit (kernel RMS, 1-norm error,
//! asymmetry, passes, fit time) and the image-space errors of
//! [`super::evaluate`] on each test image, with the full factors and each
//! tap table.
//!
//! Work is spread over (material, model) pairs with rayon; every number
//! except the timings is a pure function of the inputs, so the rows are the
//! same for any thread count.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::evaluate::{self, Exact, ImageCase, KernelImageErrors, Options, Which};
use crate::error::{Error, Result};
use crate::filter::Image;
use crate::kernel::guided::GuidedParams;
use crate::kernel::jimenez::JimenezParams;
use crate::kernel::model::{assemble, fit_model};
use crate::kernel::preintegrate::PreMethod;
use crate::kernel::{Kernel2D, Kernel2DSpec, KernelFile, Model};
use crate::profile::Profile;
use crate::progress::Progress;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::collections::BTreeMap;

/// The model families, spelled as the kernel fit spells them.
pub const FAMILIES: [&str; 6] = [
    "svd",
    "preintegrate",
    "guided",
    "manual",
    "gaussians",
    "jimenez",
];

/// One model variant of the comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelSpec {
    /// Short unique label: "svd1", "svd1-renorm", "guided-k1", ...
    pub label: String,
    pub model: Model,
}

/// The variants of `families` for `material`: SVD at each rank raw and
/// renormalised (Freude 2014, eq. 5.12), pre-integration (Abel), guided
/// k = 1 (b = 0) and k = 1.55, b = 50 (Freude 2014, fig. 5.15), manual with
/// the table A.1 preset (when the material has one) and fitted, `gaussians`
/// with each count in `ranks` (plus d'Eon's six-Gaussian skin profile for
/// skin1), Jimenez's skin model.
pub fn model_specs(families: &[String], ranks: &[usize], material: &str) -> Result<Vec<ModelSpec>> {
    let mut out = Vec::new();
    let mut push = |label: String, model: Model| out.push(ModelSpec { label, model });
    for f in families {
        match f.as_str() {
            "svd" => {
                for &r in ranks {
                    for renormalize in [false, true] {
                        let label = if renormalize {
                            format!("svd{r}-renorm")
                        } else {
                            format!("svd{r}")
                        };
                        push(
                            label,
                            Model::Svd {
                                rank: r,
                                renormalize,
                            },
                        );
                    }
                }
            }
            "preintegrate" => push(
                "preintegrate".into(),
                Model::Preintegrate {
                    method: PreMethod::Abel,
                },
            ),
            "guided" => {
                push("guided-k1".into(), Model::Guided(GuidedParams::default()));
                push(
                    "guided-k1.55-b50".into(),
                    Model::Guided(GuidedParams {
                        k: 1.55,
                        b: 50.0,
                        ..GuidedParams::default()
                    }),
                );
            }
            "manual" => {
                if crate::kernel::manual::preset(material).is_ok() {
                    push("manual".into(), Model::ManualPreset(material.to_string()));
                }
                push("manual-fit".into(), Model::ManualFit);
            }
            "gaussians" => {
                for &n in ranks {
                    push(format!("gaussians{n}"), Model::Gaussians { count: n });
                }
                if material.eq_ignore_ascii_case("skin1") {
                    push("deon-skin".into(), Model::DeonSkin);
                }
            }
            "jimenez" => push("jimenez".into(), Model::Jimenez(JimenezParams::default())),
            other => {
                return Err(Error::invalid(
                    "compare",
                    "model",
                    other,
                    format!("known models: {}, all", FAMILIES.join(", ")),
                ))
            }
        }
    }
    Ok(out)
}

/// Parses "1-6", "1,3,5" or "2" into sorted distinct ranks in 1..=32.
pub fn parse_ranks(s: &str) -> Result<Vec<usize>> {
    let bad = |why: &str| Error::invalid("compare", "ranks", s, why.to_string());
    let mut v = Vec::new();
    for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (a.trim(), b.trim()),
            None => (part, part),
        };
        let a: usize = a.parse().map_err(|_| bad("expected N, N-M or a list"))?;
        let b: usize = b.parse().map_err(|_| bad("expected N, N-M or a list"))?;
        if a == 0 || b < a || b > 32 {
            return Err(bad("ranks must satisfy 1 <= N <= M <= 32"));
        }
        v.extend(a..=b);
    }
    if v.is_empty() {
        return Err(bad("no rank given"));
    }
    v.sort_unstable();
    v.dedup();
    Ok(v)
}

/// A material's profile.
#[derive(Clone, Debug)]
pub struct MaterialInput {
    pub name: String,
    pub profile: Profile,
}

/// What to compare.
#[derive(Clone, Debug)]
pub struct Config {
    /// Model families (see [`FAMILIES`]).
    pub families: Vec<String>,
    /// SVD ranks and Gaussian counts.
    pub ranks: Vec<usize>,
    /// Images, each at its own scale.
    pub cases: Vec<ImageCase>,
    /// Tap counts of the real-time tables (odd).
    pub taps: Vec<usize>,
    pub options: Options,
    /// Keep each model's filtered image of this factor (contact sheets).
    pub keep: Option<Which>,
}

/// Errors of one channel of one filtered image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChannelImageError {
    pub rel_rms: f64,
    pub flip: f64,
    /// FLIP of the colour image (the same for the three channel rows).
    pub flip_rgb: f64,
    pub ms_per_megapixel: f64,
}

/// One signal's errors for one channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SignalErrors {
    pub mm_per_pixel: f64,
    pub full: ChannelImageError,
    /// Keyed by tap count ("17").
    pub taps: BTreeMap<String, ChannelImageError>,
}

/// One row: material x model x channel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub material: String,
    /// As the kernel fit spells it: svd, preintegrate, guided, manual,
    /// gaussians, jimenez.
    pub model: String,
    /// The variant, unique per material.
    pub label: String,
    pub params: serde_json::Value,
    /// "r", "g" or "b".
    pub channel: String,
    pub kernel_rms: f64,
    pub norm1_error: f64,
    pub asymmetry: f64,
    pub passes: usize,
    pub fit_seconds: f64,
    /// Keyed by signal name.
    pub image: BTreeMap<String, SignalErrors>,
}

/// One fitted model with its evaluations.
#[derive(Clone, Debug)]
pub struct Fitted {
    pub material: String,
    pub spec: ModelSpec,
    pub kernel: KernelFile,
    /// One per case, in the order of `Config::cases`.
    pub images: Vec<KernelImageErrors>,
    /// The kept filtered image per case (when `Config::keep` is set).
    pub kept: Vec<Option<Image>>,
}

/// Everything a comparison produced.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub materials: Vec<String>,
    /// The ground-truth kernel of each material (kernel grid).
    pub truths: Vec<Kernel2D>,
    /// Per material, per case.
    pub exact: Vec<Vec<Exact>>,
    /// Material-major, models in [`model_specs`] order.
    pub fitted: Vec<Fitted>,
    pub rows: Vec<Row>,
}

pub const CHANNELS: [&str; 3] = ["r", "g", "b"];

/// Runs the comparison: fits every model of `cfg` to every material's
/// ground-truth kernel (default grid) with the first tap count as the
/// stored table, and evaluates it on every case.
pub fn run(inputs: &[MaterialInput], cfg: &Config, progress: &dyn Progress) -> Result<Comparison> {
    if inputs.is_empty() {
        return Err(Error::Unsupported("no material to compare".into()));
    }
    if cfg.taps.is_empty() {
        return Err(Error::Unsupported("give at least one tap count".into()));
    }
    let stored_taps = cfg.taps[0];
    let specs: Vec<Vec<ModelSpec>> = inputs
        .iter()
        .map(|m| model_specs(&cfg.families, &cfg.ranks, &m.name))
        .collect::<Result<_>>()?;
    let truths: Vec<Kernel2D> = inputs
        .par_iter()
        .map(|m| Kernel2D::from_profile(&m.profile, &Kernel2DSpec::default()))
        .collect::<Result<_>>()?;
    let exact: Vec<Vec<Exact>> = inputs
        .par_iter()
        .map(|m| {
            cfg.cases
                .par_iter()
                .map(|c| Exact::new(&m.profile, c))
                .collect::<Result<Vec<_>>>()
        })
        .collect::<Result<_>>()?;
    let tasks: Vec<(usize, &ModelSpec)> = specs
        .iter()
        .enumerate()
        .flat_map(|(i, s)| s.iter().map(move |spec| (i, spec)))
        .collect();
    progress.start(tasks.len() as u64, "material x model");
    let fitted: Vec<Fitted> = tasks
        .par_iter()
        .map(|&(i, spec)| {
            let m = &inputs[i];
            let with = |e: Error| Error::Unsupported(format!("{} {}: {e}", m.name, spec.label));
            let f = fit_model(&truths[i], &m.profile, &spec.model).map_err(with)?;
            let kernel =
                assemble(&m.profile, &truths[i], &spec.model, f, stored_taps).map_err(with)?;
            let mut images = Vec::with_capacity(cfg.cases.len());
            let mut kept = Vec::with_capacity(cfg.cases.len());
            for ex in &exact[i] {
                let (e, k) =
                    evaluate::evaluate_keeping(ex, &kernel, &cfg.taps, &cfg.options, cfg.keep)
                        .map_err(with)?;
                images.push(e);
                kept.push(k);
            }
            progress.advance(1);
            Ok(Fitted {
                material: m.name.clone(),
                spec: spec.clone(),
                kernel,
                images,
                kept,
            })
        })
        .collect::<Result<_>>()?;
    progress.finish();
    let rows = fitted.iter().flat_map(rows_of).collect();
    Ok(Comparison {
        materials: inputs.iter().map(|m| m.name.clone()).collect(),
        truths,
        exact,
        fitted,
        rows,
    })
}

fn channel_error(e: &evaluate::ImageErrors, c: usize) -> ChannelImageError {
    ChannelImageError {
        rel_rms: e.rel_rms[c],
        flip: e.flip[c],
        flip_rgb: e.flip_rgb,
        ms_per_megapixel: e.ms_per_megapixel,
    }
}

fn rows_of(f: &Fitted) -> Vec<Row> {
    let k = &f.kernel;
    let mut params = k.model.params.clone();
    if !params.is_object() {
        params = json!({ "method": params });
    }
    if let Model::DeonSkin = f.spec.model {
        let n = params["variances_mm2"].as_array().map_or(0, |v| v.len());
        params["count"] = json!(n);
    }
    (0..3)
        .map(|c| Row {
            material: f.material.clone(),
            model: k.model.name.clone(),
            label: f.spec.label.clone(),
            params: params.clone(),
            channel: CHANNELS[c].into(),
            kernel_rms: k.metrics.kernel_rms[c],
            norm1_error: k.metrics.norm1_error[c],
            asymmetry: k.metrics.asymmetry[c],
            passes: k.metrics.passes,
            fit_seconds: k.metrics.fit_seconds,
            image: f
                .images
                .iter()
                .map(|e| {
                    (
                        e.signal.clone(),
                        SignalErrors {
                            mm_per_pixel: e.mm_per_pixel,
                            full: channel_error(&e.full, c),
                            taps: e
                                .taps
                                .iter()
                                .map(|(n, t)| (n.to_string(), channel_error(t, c)))
                                .collect(),
                        },
                    )
                })
                .collect(),
        })
        .collect()
}

/// Which image-space error a table shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Factor {
    Full,
    Taps(usize),
}

impl Factor {
    pub fn describe(&self) -> String {
        match self {
            Factor::Full => "full-resolution factors".into(),
            Factor::Taps(n) => format!("{n}-tap table"),
        }
    }
}

impl Row {
    /// The image-space errors of `signal` with `factor`, if evaluated.
    pub fn image_error(&self, signal: &str, factor: Factor) -> Option<&ChannelImageError> {
        let s = self.image.get(signal)?;
        match factor {
            Factor::Full => Some(&s.full),
            Factor::Taps(n) => s.taps.get(&n.to_string()),
        }
    }
}

/// Per (material, label): the three channel rows, in row order.
pub fn grouped(rows: &[Row]) -> Vec<(&str, &str, [&Row; 3])> {
    rows.chunks(3)
        .filter(|c| c.len() == 3)
        .map(|c| {
            (
                c[0].material.as_str(),
                c[0].label.as_str(),
                [&c[0], &c[1], &c[2]],
            )
        })
        .collect()
}
