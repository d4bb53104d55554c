//! Materials: the presets, TOML files, and materials from coefficients.

use crate::args::{kw, real, rgb};
use crate::call::{file_op, json_to_py, path_of, pretty_json, to_py};
use numpy::PyArray1;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use ssskit::material::{preset, preset_names, Channel, Layer, Material, Medium};

/// A translucent material: a stack of layers between two ambient media.
///
/// Coefficients are per channel (r, g, b) in mm^-1; `g` is the
/// Henyey-Greenstein anisotropy, `eta` the refractive index of a layer.
#[pyclass(module = "ssskit", name = "Material", frozen)]
#[derive(Clone)]
pub struct PyMaterial {
    pub inner: Material,
}

fn layer_of(d: &Bound<'_, PyAny>) -> PyResult<Layer> {
    let get = |k: &str| d.get_item(k);
    let thickness = match d.get_item("thickness") {
        Ok(t) if !t.is_none() => Some(real(&t, "thickness")?),
        _ => None,
    };
    Ok(Layer {
        sigma_a: rgb(&get("sigma_a")?, "sigma_a")?,
        sigma_s: rgb(&get("sigma_s")?, "sigma_s")?,
        g: rgb(&get("g")?, "g")?,
        eta: real(&get("eta")?, "eta")?,
        thickness,
    })
}

impl PyMaterial {
    fn per_channel<'py>(
        &self,
        py: Python<'py>,
        f: impl Fn(Medium) -> f64,
    ) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = Channel::ALL.iter().map(|&c| f(self.inner.top(c))).collect();
        PyArray1::from_vec(py, v)
    }
}

#[pymethods]
impl PyMaterial {
    /// A one-layer semi-infinite material (thickness None) or one slab.
    ///
    /// sigma_a, sigma_s, g: a number or (r, g, b); eta: the layer's index.
    /// Checked as the CLI checks a material file (ValueError).
    #[new]
    #[pyo3(signature = (sigma_a, sigma_s, g, eta, *, name="custom", thickness=None, eta_above=1.0, eta_below=1.0))]
    #[allow(clippy::too_many_arguments)] // the keywords of a Python constructor
    fn new(
        sigma_a: &Bound<'_, PyAny>,
        sigma_s: &Bound<'_, PyAny>,
        g: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = kw::eta)] eta: f64,
        name: &str,
        #[pyo3(from_py_with = kw::thickness)] thickness: Option<f64>,
        #[pyo3(from_py_with = kw::eta_above)] eta_above: f64,
        #[pyo3(from_py_with = kw::eta_below)] eta_below: f64,
    ) -> PyResult<Self> {
        let layer = Layer {
            sigma_a: rgb(sigma_a, "sigma_a")?,
            sigma_s: rgb(sigma_s, "sigma_s")?,
            g: rgb(g, "g")?,
            eta,
            thickness,
        };
        Self::build(name, vec![layer], eta_above, eta_below)
    }

    /// A layered material from a list of dicts with keys sigma_a, sigma_s,
    /// g, eta and thickness (mm; None or absent: semi-infinite, last only).
    #[staticmethod]
    #[pyo3(signature = (layers, *, name="custom", eta_above=1.0, eta_below=1.0))]
    fn layered(
        layers: &Bound<'_, PyAny>,
        name: &str,
        #[pyo3(from_py_with = kw::eta_above)] eta_above: f64,
        #[pyo3(from_py_with = kw::eta_below)] eta_below: f64,
    ) -> PyResult<Self> {
        let layers = layers
            .try_iter()?
            .map(|d| layer_of(&d?))
            .collect::<PyResult<Vec<Layer>>>()?;
        Self::build(name, layers, eta_above, eta_below)
    }

    #[getter]
    fn name(&self) -> &str {
        &self.inner.name
    }
    #[getter]
    fn eta_above(&self) -> f64 {
        self.inner.eta_above
    }
    #[getter]
    fn eta_below(&self) -> f64 {
        self.inner.eta_below
    }
    /// The layers as dicts (sigma_a, sigma_s, g, eta, thickness).
    #[getter]
    fn layers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.inner.layers)
    }
    /// The top layer's absorption coefficient (r, g, b), mm^-1.
    #[getter]
    fn sigma_a<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.per_channel(py, |m| m.sigma_a)
    }
    /// The top layer's scattering coefficient (r, g, b), mm^-1.
    #[getter]
    fn sigma_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.per_channel(py, |m| m.sigma_s)
    }
    /// The top layer's albedo sigma_s / sigma_t (r, g, b).
    #[getter]
    fn albedo<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.per_channel(py, |m| m.albedo())
    }
    /// The top layer's reduced albedo sigma_s' / sigma_t' (r, g, b).
    #[getter]
    fn reduced_albedo<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.per_channel(py, |m| m.reduced_albedo())
    }
    /// The top layer's mean free path 1 / sigma_t' in mm (r, g, b).
    #[getter]
    fn mfp_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.per_channel(py, |m| m.mfp())
    }
    /// The material as the JSON its profiles and kernels embed.
    fn to_json(&self) -> PyResult<String> {
        pretty_json(&self.inner)
    }
    fn __repr__(&self) -> String {
        format!(
            "ssskit.Material('{}', {} layer(s))",
            self.inner.name,
            self.inner.layers.len()
        )
    }
    fn __eq__(&self, other: &Self) -> bool {
        self.inner == other.inner
    }
}

impl PyMaterial {
    fn build(name: &str, layers: Vec<Layer>, eta_above: f64, eta_below: f64) -> PyResult<Self> {
        let m = Material {
            name: name.to_string(),
            eta_above,
            eta_below,
            layers,
        };
        m.validate(&format!("material '{name}'")).map_err(to_py)?;
        Ok(PyMaterial { inner: m })
    }
}

/// A material argument: a `Material`, or a preset name or TOML path (read
/// without the GIL).
pub(crate) fn material_of(obj: &Bound<'_, PyAny>) -> PyResult<Material> {
    if let Ok(m) = obj.cast::<PyMaterial>() {
        return Ok(m.get().inner.clone());
    }
    let spec: String = obj.extract().map_err(|_| {
        PyTypeError::new_err("material: expected an ssskit.Material, a preset name or a TOML path")
    })?;
    file_op(obj.py(), || Material::load(&spec))
}

/// The preset materials, in the order `ssskit materials` lists them.
#[pyfunction]
fn materials() -> Vec<PyMaterial> {
    preset_names()
        .iter()
        .filter_map(|n| preset(n))
        .map(|m| PyMaterial { inner: m })
        .collect()
}

/// A preset by name ("skin1", "marble", ...) or a material TOML file.
#[pyfunction]
fn material(py: Python<'_>, spec: &Bound<'_, PyAny>) -> PyResult<PyMaterial> {
    let spec = path_of(spec)?.to_string_lossy().into_owned();
    let inner = file_op(py, || Material::load(&spec))?;
    Ok(PyMaterial { inner })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMaterial>()?;
    m.add_function(wrap_pyfunction!(materials, m)?)?;
    m.add_function(wrap_pyfunction!(material, m)?)?;
    Ok(())
}
