//! Disk kernels (`ssskit.disk/1`, `ssskit fit --model disk`): the sample
//! table as arrays, shader emission; `fit(profile, "disk", ...)` builds
//! one and `apply` runs it over frames.

use crate::args::{lang_of, one_of};
use crate::call::{pretty_json, save, to_py};
use crate::material::PyMaterial;
use crate::profile::rgb_rows;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use ssskit::kernel::disk::{DiskKernelFile, RadiusPdf};
use ssskit::kernel::disk_emit::emit_disk;

/// An importance-sampled disk kernel (ssskit.disk/1): per sample its
/// radius in mm, its angle before the per-pixel rotation and its weights.
#[pyclass(module = "ssskit", name = "DiskKernel", frozen)]
pub struct PyDiskKernel {
    pub inner: DiskKernelFile,
}

#[pymethods]
impl PyDiskKernel {
    /// The model's name ("disk").
    #[getter]
    fn model(&self) -> &str {
        &self.inner.model.name
    }
    /// Samples per pixel of one frame.
    #[getter]
    fn samples_per_pixel(&self) -> usize {
        self.inner.samples_per_pixel()
    }
    /// Radii of the samples in mm, shape (n,).
    #[getter]
    fn radius_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = self.inner.samples.iter().map(|s| s.radius_mm).collect();
        PyArray1::from_vec(py, v)
    }
    /// Angles of the samples in radians, before the per-pixel rotation, (n,).
    #[getter]
    fn angle<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = self.inner.samples.iter().map(|s| s.angle).collect();
        PyArray1::from_vec(py, v)
    }
    /// Per-sample weights (n, 3).
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rgb_rows(py, self.inner.samples.iter().map(|s| s.weight))
    }
    /// Total diffuse reflectance (r, g, b) of the profile.
    #[getter]
    fn total_rd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.total_rd)
    }
    #[getter]
    fn material(&self) -> Option<PyMaterial> {
        self.inner.material.clone().map(|m| PyMaterial { inner: m })
    }
    /// Whether the kernel carries the angular entry and exit factors.
    #[getter]
    fn has_factors(&self) -> bool {
        self.inner.angular.is_some()
    }
    /// The sample table as shader constants: lang "hlsl", "glsl" or "wgsl"
    /// (`ssskit fit --model disk --emit LANG`).
    fn emit(&self, lang: &str) -> PyResult<String> {
        emit_disk(&self.inner, lang_of(lang)?).map_err(to_py)
    }
    /// Writes the kernel file (JSON), as `ssskit fit --model disk --out`
    /// does (without the GIL).
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        save(py, path, |p| self.inner.write(p))
    }
    /// The kernel file's text, as `save` writes it (with the usage notes
    /// the library's writer adds).
    fn to_json(&self) -> PyResult<String> {
        pretty_json(&self.inner.as_written())
    }
    fn __repr__(&self) -> String {
        format!(
            "ssskit.DiskKernel({} samples per pixel)",
            self.inner.samples_per_pixel()
        )
    }
}

/// The densities by the names `--radii` takes (and `per_channel`, the
/// spelling of a Python keyword).
const RADII: [(&str, RadiusPdf); 4] = [
    ("widest", RadiusPdf::Widest),
    ("mean", RadiusPdf::Mean),
    ("per-channel", RadiusPdf::PerChannel),
    ("per_channel", RadiusPdf::PerChannel),
];

/// `--radii` as the library's density, with the CLI's names.
pub(crate) fn radii_of(name: &str) -> PyResult<RadiusPdf> {
    one_of("radii", name, &RADII, "widest, mean or per-channel")
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyDiskKernel>()
}
