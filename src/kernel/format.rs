//! The `ssskit.kernel/1` file: plain data shared by the fitting models (which
//! write it) and the filters (which read it).
//!
//! A kernel is a sum of separable terms ("passes"): the 2D kernel is
//! sum_i a_i(x) a_i(y), applied as a horizontal then a vertical 1D
//! convolution with the same factor a_i, results summed over i. Offsets are in
//! millimetres on the surface; weights are per RGB channel.

use crate::error::{Error, Result};
use crate::material::Material;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const KERNEL_SCHEMA: &str = "ssskit.kernel/1";

/// One separable term: a 1D factor sampled at `offsets_mm`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pass {
    pub offsets_mm: Vec<f64>,
    /// `weights[k] = [r, g, b]` at `offsets_mm[k]`.
    pub weights: Vec<[f64; 3]>,
}

/// The real-time table: `count` taps per pass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TapTable {
    pub count: usize,
    pub passes: Vec<Pass>,
    /// Half-width in mm the taps span (the outermost offsets); absent in
    /// files written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extent_mm: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    pub name: String,
    #[serde(default)]
    pub params: serde_json::Value,
}

/// Quality measures of a kernel against its ground truth (issue 4, item 3).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    pub kernel_rms: [f64; 3],
    pub norm1_error: [f64; 3],
    pub asymmetry: [f64; 3],
    pub passes: usize,
    pub fit_seconds: f64,
    /// Model-specific extras (singular values, objective, iterations, ...).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub extra: serde_json::Value,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KernelFile {
    pub schema: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<Material>,
    /// Summary of the profile the kernel came from.
    #[serde(default)]
    pub profile: serde_json::Value,
    pub model: ModelInfo,
    pub units: String,
    /// Total diffuse reflectance per channel: the colour factor kept apart
    /// from the kernel, whose 2D sum is 1 per channel for an exact model.
    pub total_rd: [f64; 3],
    pub passes: Vec<Pass>,
    pub taps: TapTable,
    pub metrics: Metrics,
}

impl Pass {
    fn validate(&self, what: &str) -> std::result::Result<(), String> {
        if self.offsets_mm.is_empty() {
            return Err(format!("{what}: no offsets"));
        }
        if self.offsets_mm.len() != self.weights.len() {
            return Err(format!(
                "{what}: {} offsets but {} weights",
                self.offsets_mm.len(),
                self.weights.len()
            ));
        }
        if let Some(x) = self.offsets_mm.iter().find(|x| !x.is_finite()) {
            return Err(format!("{what}: offset {x} is not finite"));
        }
        if self.offsets_mm.windows(2).any(|w| !(w[1] > w[0])) {
            return Err(format!("{what}: offsets must increase strictly"));
        }
        if let Some(w) = self
            .weights
            .iter()
            .find(|w| w.iter().any(|x| !x.is_finite()))
        {
            return Err(format!("{what}: weight {w:?} is not finite"));
        }
        Ok(())
    }
}

impl KernelFile {
    pub fn validate(&self, context: &str) -> Result<()> {
        let bad = |m: String| Err(Error::format(context, m));
        if self.schema != KERNEL_SCHEMA {
            return bad(format!(
                "schema is '{}', expected '{KERNEL_SCHEMA}'",
                self.schema
            ));
        }
        if self.units != "mm" {
            return bad(format!("units is '{}', expected 'mm'", self.units));
        }
        if self.passes.is_empty() {
            return bad("kernel has no passes".into());
        }
        if let Some(x) = self.total_rd.iter().find(|x| !x.is_finite() || **x < 0.0) {
            return bad(format!("total_rd holds {x}: must be finite and >= 0"));
        }
        for (i, p) in self.passes.iter().enumerate() {
            p.validate(&format!("passes[{i}]")).or_else(bad)?;
        }
        if self.taps.count == 0 || self.taps.count.is_multiple_of(2) {
            return bad(format!(
                "taps.count is {}: must be odd (a centre tap and pairs around it)",
                self.taps.count
            ));
        }
        if self.model.name.trim().is_empty() {
            return bad("model.name is empty".into());
        }
        let m = &self.metrics;
        if let Some(x) = m
            .kernel_rms
            .iter()
            .chain(&m.norm1_error)
            .chain(&m.asymmetry)
            .chain(std::iter::once(&m.fit_seconds))
            .find(|x| !x.is_finite())
        {
            return bad(format!("metrics hold {x}: must be finite"));
        }
        if self.taps.passes.len() != self.passes.len() {
            return bad(format!(
                "taps has {} passes but the kernel has {}",
                self.taps.passes.len(),
                self.passes.len()
            ));
        }
        for (i, p) in self.taps.passes.iter().enumerate() {
            p.validate(&format!("taps.passes[{i}]")).or_else(bad)?;
            if p.offsets_mm.len() != self.taps.count {
                return bad(format!(
                    "taps.passes[{i}] has {} taps, count says {}",
                    p.offsets_mm.len(),
                    self.taps.count
                ));
            }
        }
        Ok(())
    }

    pub fn read(path: &Path) -> Result<KernelFile> {
        let k: KernelFile = crate::io::read_json(path)?;
        k.validate(&path.display().to_string())?;
        Ok(k)
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        crate::io::write_json_atomic(path, self)
    }
}
