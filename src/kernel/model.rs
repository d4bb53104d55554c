//! The model dispatcher: from a profile and a model choice to a complete
//! `KernelFile` (factors on the kernel grid, tap table, metrics).

use super::factors::Factors;
use super::gaussians;
use super::guided::{self, GuidedParams};
use super::jimenez::{self, JimenezParams};
use super::manual::{self, ManualParams};
use super::metrics;
use super::preintegrate::{self, PreMethod};
use super::svd;
use super::taps;
use super::{Kernel2D, Kernel2DSpec, KernelFile, Metrics, ModelInfo, Pass, KERNEL_SCHEMA};
use crate::error::Result;
use crate::profile::Profile;
use serde_json::json;
use std::time::Instant;

#[derive(Clone, Debug, PartialEq)]
pub enum Model {
    Svd {
        rank: usize,
        renormalize: bool,
    },
    Preintegrate {
        method: PreMethod,
    },
    Guided(GuidedParams),
    Manual(ManualParams),
    /// `preset`: the table A.1 row the parameters came from, if any.
    ManualPreset(String),
    ManualFit,
    Gaussians {
        count: usize,
    },
    DeonSkin,
    Jimenez(JimenezParams),
}

impl Model {
    /// Short name for the file's `model.name` (and file names).
    pub fn name(&self) -> &'static str {
        match self {
            Model::Svd { .. } => "svd",
            Model::Preintegrate { .. } => "preintegrate",
            Model::Guided(_) => "guided",
            Model::Manual(_) | Model::ManualPreset(_) | Model::ManualFit => "manual",
            Model::Gaussians { .. } | Model::DeonSkin => "gaussians",
            Model::Jimenez(_) => "jimenez",
        }
    }
}

/// A fitted model before export.
#[derive(Clone, Debug)]
pub struct Fitted {
    pub factors: Factors,
    pub params: serde_json::Value,
    pub extra: serde_json::Value,
    pub seconds: f64,
}

/// Fits `model` to the kernel `k` built from `profile`.
pub fn fit_model(k: &Kernel2D, profile: &Profile, model: &Model) -> Result<Fitted> {
    let t0 = Instant::now();
    let (factors, params, extra) = match model {
        Model::Svd { rank, renormalize } => {
            let (f, e) = svd::svd(k, *rank, *renormalize)?;
            (f, json!({"rank": rank, "renormalize": renormalize}), e)
        }
        Model::Preintegrate { method } => {
            let (f, e) = preintegrate::preintegrate(k, profile, *method)?;
            (f, e["method"].clone(), e)
        }
        Model::Guided(p) => {
            let pre = preintegrate::preintegrate(k, profile, PreMethod::Grid)?.0;
            let sv = svd::svd(k, 1, false)?.0;
            let starts = [("preintegrate", pre[0].clone()), ("svd1", sv[0].clone())];
            let (f, e) = guided::guided(k, p, &starts)?;
            (f, json!({"k": p.k, "b": p.b}), e)
        }
        Model::Manual(p) => (manual::manual(k, p)?, p.to_json(), serde_json::Value::Null),
        Model::ManualPreset(name) => {
            let p = manual::preset(name)?;
            let mut params = p.to_json();
            params["preset"] = json!(name.to_ascii_lowercase());
            (manual::manual(k, &p)?, params, serde_json::Value::Null)
        }
        Model::ManualFit => {
            let (p, e) = manual::fit(k)?;
            let mut params = p.to_json();
            params["fitted"] = json!(true);
            (manual::manual(k, &p)?, params, e)
        }
        Model::Gaussians { count } => {
            let (f, p) = gaussians::fit_gaussians(k, *count)?;
            (f, p, serde_json::Value::Null)
        }
        Model::DeonSkin => {
            let (f, p) = gaussians::deon_skin(k);
            (f, p, serde_json::Value::Null)
        }
        Model::Jimenez(p) => {
            let (f, params) = jimenez::jimenez(k, p)?;
            (f, params, serde_json::Value::Null)
        }
    };
    Ok(Fitted {
        factors,
        params,
        extra,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Builds the kernel from the profile, fits, measures and assembles the file.
pub fn fit_kernel_file(
    profile: &Profile,
    spec: &Kernel2DSpec,
    model: &Model,
    tap_count: usize,
) -> Result<KernelFile> {
    fit_kernel_file_with(profile, spec, model, tap_count, None)
}

/// [`fit_kernel_file`] with the tap table over +-`tap_extent_mm` (None:
/// chosen for the tap count, [`taps::auto_extent`]).
pub fn fit_kernel_file_with(
    profile: &Profile,
    spec: &Kernel2DSpec,
    model: &Model,
    tap_count: usize,
    tap_extent_mm: Option<f64>,
) -> Result<KernelFile> {
    let t0 = Instant::now();
    let k = Kernel2D::from_profile(profile, spec)?;
    k.check_resolves()?;
    let build = t0.elapsed().as_secs_f64();
    let fitted = fit_model(&k, profile, model)?;
    let mut file = assemble_with(profile, &k, model, fitted, tap_count, tap_extent_mm)?;
    file.metrics.extra["kernel_build_seconds"] = json!(build);
    Ok(file)
}

pub fn assemble(
    profile: &Profile,
    k: &Kernel2D,
    model: &Model,
    fitted: Fitted,
    tap_count: usize,
) -> Result<KernelFile> {
    assemble_with(profile, k, model, fitted, tap_count, None)
}

/// The tap table of `model` with `factors` fitted to `k`: the one a kernel
/// file stores and the one a search scores, so the two cannot differ.
pub fn tap_table(
    model: &Model,
    k: &Kernel2D,
    factors: &Factors,
    tap_count: usize,
    tap_extent_mm: Option<f64>,
) -> Result<super::TapTable> {
    match model {
        // Jimenez's model is defined by its own table (iryoku's calculateKernel).
        Model::Jimenez(p) => jimenez::table(p, tap_count, tap_extent_mm),
        _ => taps::tap_table_with(k, factors, tap_count, tap_extent_mm),
    }
}

/// [`assemble`] with an explicit tap extent (None: chosen for the count).
pub fn assemble_with(
    profile: &Profile,
    k: &Kernel2D,
    model: &Model,
    fitted: Fitted,
    tap_count: usize,
    tap_extent_mm: Option<f64>,
) -> Result<KernelFile> {
    let taps = tap_table(model, k, &fitted.factors, tap_count, tap_extent_mm)?;
    let m = metrics::measure(k, &fitted.factors);
    let offsets = k.offsets();
    let passes: Vec<Pass> = fitted
        .factors
        .iter()
        .map(|t| Pass {
            offsets_mm: offsets.clone(),
            weights: (0..k.size).map(|i| [t[0][i], t[1][i], t[2][i]]).collect(),
        })
        .collect();
    let mut extra = match fitted.extra {
        serde_json::Value::Object(o) => serde_json::Value::Object(o),
        serde_json::Value::Null => json!({}),
        other => json!({ "model": other }),
    };
    extra["truth_asymmetry"] = json!(m.truth_asymmetry);
    extra["max_abs_error"] = json!(m.max_abs_error);
    extra["separable_terms"] = json!(passes.len());
    let profile_summary = json!({
        "source": profile.source,
        "bins": profile.r.len(),
        "r_max_mm": profile.r_edges.last(),
        "total_rd": profile.total_rd,
        "kernel_size": k.size,
        "kernel_cell_mm": k.cell_mm,
        "kernel_extent_mm": k.extent_mm(),
        "captured": k.captured,
    });
    let file = KernelFile {
        schema: KERNEL_SCHEMA.to_string(),
        material: Some(profile.material.clone()),
        profile: profile_summary,
        model: ModelInfo {
            name: model.name().to_string(),
            params: fitted.params,
        },
        units: "mm".into(),
        total_rd: k.total_rd,
        passes,
        taps,
        metrics: Metrics {
            kernel_rms: m.kernel_rms,
            norm1_error: m.norm1_error,
            asymmetry: m.asymmetry,
            passes: 2 * fitted.factors.len(),
            fit_seconds: fitted.seconds,
            extra,
        },
        usage: None,
        angular: super::angular::AngularFactors::from_profile(profile)?,
        transmission: None,
    };
    file.validate("fitted kernel")?;
    Ok(file)
}
