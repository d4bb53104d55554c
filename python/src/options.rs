//! `apply`'s options as one type, `ssskit.ApplyOptions`: the flags of
//! `ssskit apply`, each read and checked as the CLI reads it, so a call
//! passes one value rather than two dozen arguments, and a set of options
//! can be kept and reused (`apply(k, img, options=opts)`).

use crate::args::Strict;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssskit::filter::accumulate::Accumulate;
use ssskit::filter::separable::Precision;

/// Where the pass runs: `--backend`'s values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Backend {
    Cpu,
    Gpu,
    /// A hardware GPU where there is one, else the CPU (a software
    /// rasteriser is slower than the CPU path), as `ssskit apply` decides.
    Auto,
}

/// The options of `ssskit apply` (see `help(ssskit.apply)` for each):
/// `ApplyOptions(fov_y=30.0, units_per_mm=0.001, backend="auto")`, then
/// `apply(kernel, image, options=opts, depth=d)`; keywords given to
/// `apply` beside `options` replace the options' values. Each value is
/// checked as it is given, as the CLI checks its flag.
#[pyclass(module = "ssskit", name = "ApplyOptions", frozen)]
#[derive(Default)]
pub struct ApplyOptions {
    pub(crate) mm_per_pixel: Option<f64>,
    pub(crate) fov_y: Option<f64>,
    pub(crate) units_per_mm: Option<f64>,
    pub(crate) depth: Option<Py<PyAny>>,
    pub(crate) specular: Option<Py<PyAny>>,
    pub(crate) strength: Option<Py<PyAny>>,
    pub(crate) follow_surface: Option<f64>,
    pub(crate) sanitize: bool,
    pub(crate) separable: SeparableOptions,
    pub(crate) disk: DiskOptions,
    pub(crate) light: LightOptions,
    pub(crate) backend: Option<Backend>,
    /// The keywords given and their values' repr, in the order given.
    given: Vec<(String, String)>,
}

/// The settings of a separable kernel's pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SeparableOptions {
    pub(crate) full_factors: bool,
    pub(crate) jitter: bool,
    pub(crate) precision: Precision,
}

impl Default for SeparableOptions {
    fn default() -> Self {
        SeparableOptions {
            full_factors: false,
            jitter: false,
            precision: Precision::F32,
        }
    }
}

/// The settings of a disk kernel's pass: frames and the first frame's
/// index (None: the CLI's default, the kernel's recorded accumulation, else
/// 1 and 0), how frames accumulate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct DiskOptions {
    pub(crate) frames: Option<u32>,
    pub(crate) frame_seed: Option<u32>,
    pub(crate) accumulate: Option<Accumulate>,
}

/// The angular factors' arguments: normals and the light.
#[derive(Default)]
pub(crate) struct LightOptions {
    pub(crate) normals: Option<Py<PyAny>>,
    pub(crate) toward: Option<[f64; 3]>,
    pub(crate) n_dot_l: Option<Py<PyAny>>,
    pub(crate) entry_weighted: bool,
    /// False: leave a kernel's factors out (`--no-factors`).
    pub(crate) leave_out: bool,
}

/// An array keyword: kept as given (checked when applied, against the
/// image), None for None.
fn array(v: &Bound<'_, PyAny>) -> Option<Py<PyAny>> {
    (!v.is_none()).then(|| v.clone().unbind())
}

fn flag(v: &Bound<'_, PyAny>, key: &str) -> PyResult<bool> {
    v.extract::<bool>()
        .map_err(|_| PyTypeError::new_err(format!("{key}: expected True or False")))
}

fn text(v: &Bound<'_, PyAny>, key: &str) -> PyResult<String> {
    v.extract::<String>()
        .map_err(|_| PyTypeError::new_err(format!("{key}: expected a string")))
}

/// `--precision`'s values.
fn precision_of(name: &str) -> PyResult<Precision> {
    match name {
        "f32" => Ok(Precision::F32),
        "f64" => Ok(Precision::F64),
        p => Err(PyValueError::new_err(format!(
            "precision: invalid value '{p}': expected f32 or f64"
        ))),
    }
}

/// `--backend`'s values.
fn backend_of(name: &str) -> PyResult<Backend> {
    match name {
        "cpu" => Ok(Backend::Cpu),
        "gpu" => Ok(Backend::Gpu),
        "auto" => Ok(Backend::Auto),
        b => Err(PyValueError::new_err(format!(
            "backend: invalid value '{b}': expected cpu, gpu or auto"
        ))),
    }
}

/// `light_toward`: three finite numbers (x, y, z).
fn vector(v: &Bound<'_, PyAny>, key: &str) -> PyResult<Option<[f64; 3]>> {
    let v = Option::<Vec<f64>>::strict(v, key)?;
    v.map(|v| {
        <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
            PyValueError::new_err(format!(
                "{key}: expected three numbers (x, y, z), got {}",
                v.len()
            ))
        })
    })
    .transpose()
}

impl ApplyOptions {
    /// Sets one keyword, checked as the CLI checks its flag.
    fn set(&mut self, key: &str, v: &Bound<'_, PyAny>) -> PyResult<()> {
        let s = &mut self.separable;
        match key {
            "mm_per_pixel" => self.mm_per_pixel = Strict::strict(v, key)?,
            "fov_y" => self.fov_y = Strict::strict(v, key)?,
            "units_per_mm" => self.units_per_mm = Strict::strict(v, key)?,
            "depth" => self.depth = array(v),
            "specular" => self.specular = array(v),
            "strength" => self.strength = array(v),
            "follow_surface" => self.follow_surface = Strict::strict(v, key)?,
            "sanitize" => self.sanitize = flag(v, key)?,
            "full_factors" => s.full_factors = flag(v, key)?,
            "jitter" => s.jitter = flag(v, key)?,
            "precision" => s.precision = precision_of(&text(v, key)?)?,
            "frames" => self.disk.frames = Strict::strict(v, key)?,
            "frame_seed" => self.disk.frame_seed = Strict::strict(v, key)?,
            "accumulate" => {
                let a = v.extract::<Option<String>>().map_err(|_| {
                    PyTypeError::new_err(format!("{key}: expected \"mean\" or \"ema:W\""))
                })?;
                self.disk.accumulate = a
                    .map(|a| Accumulate::parse(&a))
                    .transpose()
                    .map_err(crate::call::to_py)?;
            }
            "normals" => self.light.normals = array(v),
            "light_toward" => self.light.toward = vector(v, key)?,
            "n_dot_l" => self.light.n_dot_l = array(v),
            "entry_weighted" => self.light.entry_weighted = flag(v, key)?,
            "factors" => self.light.leave_out = !flag(v, key)?,
            "backend" => self.backend = Some(backend_of(&text(v, key)?)?),
            _ => {
                return Err(PyTypeError::new_err(format!(
                    "apply() got an unexpected keyword argument '{key}'"
                )))
            }
        }
        let shown = match v.getattr("shape") {
            Ok(shape) => format!("<array of shape {}>", shape.repr()?),
            Err(_) => v.repr()?.to_string(),
        };
        self.given.retain(|(k, _)| k != key);
        self.given.push((key.to_string(), shown));
        Ok(())
    }

    /// These options with the `keywords` set over them.
    pub(crate) fn with(
        &self,
        py: Python<'_>,
        keywords: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mut o = self.clone_ref(py);
        for (k, v) in keywords.into_iter().flat_map(|d| d.iter()) {
            o.set(&k.extract::<String>()?, &v)?;
        }
        Ok(o)
    }

    fn clone_ref(&self, py: Python<'_>) -> Self {
        let arr = |a: &Option<Py<PyAny>>| a.as_ref().map(|a| a.clone_ref(py));
        ApplyOptions {
            depth: arr(&self.depth),
            specular: arr(&self.specular),
            strength: arr(&self.strength),
            light: LightOptions {
                normals: arr(&self.light.normals),
                n_dot_l: arr(&self.light.n_dot_l),
                ..self.light
            },
            given: self.given.clone(),
            ..*self
        }
    }
}

#[pymethods]
impl ApplyOptions {
    #[new]
    #[pyo3(signature = (**keywords))]
    fn new(py: Python<'_>, keywords: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        ApplyOptions::default().with(py, keywords)
    }

    /// A copy with the `keywords` set over these options.
    #[pyo3(signature = (**keywords))]
    fn replace(&self, py: Python<'_>, keywords: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        self.with(py, keywords)
    }

    fn __repr__(&self) -> String {
        let items: Vec<String> = self.given.iter().map(|(k, v)| format!("{k}={v}")).collect();
        format!("ssskit.ApplyOptions({})", items.join(", "))
    }
}
