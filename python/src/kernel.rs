//! Kernels: `fit` for every separable model the CLI fits, the tap table
//! and factors as arrays, shader emission, the engines' parameters.

use crate::args::{kw, lang_of, one_of, rgb, Strict};
use crate::call::{interruptible, json_to_py, pretty_json, save, to_py};
use crate::material::PyMaterial;
use crate::profile::{profile_of, rgb_rows};
use numpy::PyArray1;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssskit::engine::method::SubsurfaceMethod;
use ssskit::engine::{self, Engine, Scene};
use ssskit::kernel::disk_fit::fit_disk;
use ssskit::kernel::emit::emit;
use ssskit::kernel::guided::GuidedParams;
use ssskit::kernel::jimenez::JimenezParams;
use ssskit::kernel::manual::ManualParams;
use ssskit::kernel::preintegrate::PreMethod;
use ssskit::kernel::{fit_kernel_file_with, Kernel2DSpec, KernelFile, Model, Pass};

/// A separable screen-space kernel (ssskit.kernel/1): per separable term
/// (pass) its 1D factor on the kernel grid and its real-time tap table.
#[pyclass(module = "ssskit", name = "Kernel", frozen)]
pub struct PyKernel {
    pub inner: KernelFile,
}

/// A pass as a dict of arrays: offsets_mm (n,) and weights (n, 3).
fn pass_dict<'py>(py: Python<'py>, p: &Pass) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("offsets_mm", PyArray1::from_slice(py, &p.offsets_mm))?;
    d.set_item("weights", rgb_rows(py, p.weights.iter().copied())?)?;
    Ok(d)
}

#[pymethods]
impl PyKernel {
    /// The model's name ("svd", "preintegrate", ...).
    #[getter]
    fn model(&self) -> &str {
        &self.inner.model.name
    }
    /// The model's parameters.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.inner.model.params)
    }
    /// The full-resolution factors: one dict per pass, offsets_mm (n,) and
    /// weights (n, 3) on the kernel grid.
    #[getter]
    fn passes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner.passes.iter().map(|p| pass_dict(py, p)).collect()
    }
    /// The real-time tap table: one dict per pass, offsets_mm (taps,) and
    /// weights (taps, 3).
    #[getter]
    fn taps<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner
            .taps
            .passes
            .iter()
            .map(|p| pass_dict(py, p))
            .collect()
    }
    /// Taps per pass of the tap table.
    #[getter]
    fn tap_count(&self) -> usize {
        self.inner.taps.count
    }
    /// Total diffuse reflectance (r, g, b) the kernel integrates to.
    #[getter]
    fn total_rd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.total_rd)
    }
    /// The fit's metrics (kernel_rms, norm1_error, asymmetry, ...).
    #[getter]
    fn metrics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.inner.metrics)
    }
    #[getter]
    fn material(&self) -> Option<PyMaterial> {
        self.inner.material.clone().map(|m| PyMaterial { inner: m })
    }
    /// The tap table as a shader constant array: lang "hlsl", "glsl" or
    /// "wgsl" (`ssskit fit --emit LANG`).
    fn emit(&self, lang: &str) -> PyResult<String> {
        emit(&self.inner, lang_of(lang)?).map_err(to_py)
    }
    /// Writes the kernel file (JSON), as `ssskit fit --out` does (without
    /// the GIL).
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
            "ssskit.Kernel('{}', {} pass(es), {} taps)",
            self.inner.model.name,
            self.inner.passes.len(),
            self.inner.taps.count
        )
    }
}

/// The model's parameters as `fit` takes them (the flags of `ssskit fit`).
#[derive(Default)]
struct ModelArgs {
    rank: Option<usize>,
    renormalize: Option<bool>,
    method: Option<String>,
    k: Option<f64>,
    b: Option<f64>,
    max_iters: Option<u64>,
    w: Option<f64>,
    near: Option<Py<PyAny>>,
    far: Option<Py<PyAny>>,
    preset: Option<String>,
    manual_fit: Option<bool>,
    count: Option<usize>,
    jimenez_width: Option<f64>,
    jimenez_strength: Option<Py<PyAny>>,
    jimenez_falloff: Option<Py<PyAny>>,
    samples: Option<usize>,
    radii: Option<String>,
}

/// The keyword arguments `fit` passes on to the model.
const MODEL_KEYS: [&str; 17] = [
    "rank",
    "renormalize",
    "method",
    "k",
    "b",
    "max_iters",
    "w",
    "near",
    "far",
    "preset",
    "manual_fit",
    "count",
    "jimenez_width",
    "jimenez_strength",
    "jimenez_falloff",
    "samples",
    "radii",
];

impl ModelArgs {
    fn from_kwargs(d: Option<&Bound<'_, PyDict>>) -> PyResult<ModelArgs> {
        let Some(d) = d else {
            return Ok(ModelArgs::default());
        };
        for key in d.keys() {
            let key: String = key.extract()?;
            if !MODEL_KEYS.contains(&key.as_str()) {
                return Err(PyTypeError::new_err(format!(
                    "fit() got an unexpected keyword argument '{key}'"
                )));
            }
        }
        fn get<'py, T: pyo3::conversion::FromPyObjectOwned<'py>>(
            d: &Bound<'py, PyDict>,
            key: &str,
        ) -> PyResult<Option<T>> {
            match d.get_item(key)? {
                Some(v) if !v.is_none() => Ok(Some(v.extract::<T>().map_err(|e| {
                    let e: PyErr = e.into();
                    PyTypeError::new_err(format!("{key}: {e}"))
                })?)),
                _ => Ok(None),
            }
        }
        // Numbers as the CLI's flags take them (no bools; named errors).
        fn num<T: Strict>(d: &Bound<'_, PyDict>, key: &str) -> PyResult<Option<T>> {
            match d.get_item(key)? {
                Some(v) => Option::<T>::strict(&v, key),
                None => Ok(None),
            }
        }
        Ok(ModelArgs {
            rank: num(d, "rank")?,
            renormalize: get(d, "renormalize")?,
            method: get(d, "method")?,
            k: num(d, "k")?,
            b: num(d, "b")?,
            max_iters: num(d, "max_iters")?,
            w: num(d, "w")?,
            near: get(d, "near")?,
            far: get(d, "far")?,
            preset: get(d, "preset")?,
            manual_fit: get(d, "manual_fit")?,
            count: num(d, "count")?,
            jimenez_width: num(d, "jimenez_width")?,
            jimenez_strength: get(d, "jimenez_strength")?,
            jimenez_falloff: get(d, "jimenez_falloff")?,
            samples: num(d, "samples")?,
            radii: get(d, "radii")?,
        })
    }
}

fn bad(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

fn rgb_opt(py: Python<'_>, v: &Option<Py<PyAny>>, what: &str) -> PyResult<Option<[f64; 3]>> {
    v.as_ref().map(|o| rgb(o.bind(py), what)).transpose()
}

/// The model `ssskit fit --model NAME` builds from the same parameters,
/// with its messages.
fn model_of(py: Python<'_>, name: &str, a: &ModelArgs) -> PyResult<Model> {
    Ok(match name {
        "svd" => Model::Svd {
            rank: a.rank.unwrap_or(1),
            renormalize: a.renormalize.unwrap_or(false),
        },
        "preintegrate" => {
            let method = a.method.as_deref().unwrap_or("abel");
            let methods = [("abel", PreMethod::Abel), ("grid", PreMethod::Grid)];
            Model::Preintegrate {
                method: one_of("method", method, &methods, "abel or grid")?,
            }
        }
        "guided" => {
            let d = GuidedParams::default();
            Model::Guided(GuidedParams {
                k: a.k.unwrap_or(d.k),
                b: a.b.unwrap_or(d.b),
                max_iters: a.max_iters.unwrap_or(d.max_iters),
            })
        }
        "manual" => {
            let near = rgb_opt(py, &a.near, "near")?;
            let far = rgb_opt(py, &a.far, "far")?;
            let explicit = a.w.is_some() || near.is_some() || far.is_some();
            match (a.preset.as_deref(), a.manual_fit.unwrap_or(false), explicit) {
                (Some(p), false, false) if p.eq_ignore_ascii_case("deon-skin") => {
                    return Err(bad(
                        "manual: preset deon-skin is a preset of model gaussians",
                    ))
                }
                (Some(p), false, false) => Model::ManualPreset(p.to_ascii_lowercase()),
                (None, true, false) => Model::ManualFit,
                (None, false, true) => match (a.w, near, far) {
                    (Some(w), Some(n), Some(f)) => Model::Manual(ManualParams {
                        w,
                        sqrt_tau_near: n,
                        sqrt_tau_far: f,
                    }),
                    _ => {
                        return Err(bad(
                            "manual: give all of w, near and far (or preset / manual_fit)",
                        ))
                    }
                },
                _ => return Err(bad(
                    "manual: give exactly one of preset=NAME, manual_fit=True, or w, near and far",
                )),
            }
        }
        "gaussians" => match a.preset.as_deref() {
            None => Model::Gaussians {
                count: a.count.unwrap_or(ssskit::kernel::gaussians::DEFAULT_COUNT),
            },
            Some(p) if p.eq_ignore_ascii_case("deon-skin") => Model::DeonSkin,
            Some(p) => {
                return Err(bad(format!(
                    "gaussians: preset {p} is a preset of model manual (gaussians has deon-skin)"
                )))
            }
        },
        "jimenez" => {
            let d = JimenezParams::default();
            Model::Jimenez(JimenezParams {
                width: a.jimenez_width.unwrap_or(d.width),
                strength: rgb_opt(py, &a.jimenez_strength, "jimenez_strength")?
                    .unwrap_or(d.strength),
                falloff: rgb_opt(py, &a.jimenez_falloff, "jimenez_falloff")?.unwrap_or(d.falloff),
            })
        }
        other => {
            return Err(bad(format!(
                "model: invalid value '{other}': expected one of {}, disk",
                MODELS.join(", ")
            )))
        }
    })
}

/// The separable models `fit` knows (those of `ssskit fit --model`): the
/// comparison's families, from the library.
const MODELS: [&str; 6] = ssskit::report::eval::compare::kernel::FAMILIES;

/// Fits a kernel to a profile (`ssskit fit`).
///
/// model: "svd" (rank, renormalize), "preintegrate" (method "abel" or
/// "grid"), "guided" (k, b, max_iters), "manual" (preset=NAME,
/// manual_fit=True, or w, near, far), "gaussians" (count, or
/// preset="deon-skin"), "jimenez" (jimenez_width, jimenez_strength,
/// jimenez_falloff): a separable `Kernel`; taps: odd tap count of the
/// real-time table (default 17); tap_extent: its half-width in mm;
/// grid_size, extent: the kernel grid. "disk" (samples, default 32;
/// radii "widest", "mean" or "per-channel"): an importance-sampled
/// `DiskKernel`. The result equals the CLI's for the same parameters.
/// Releases the GIL.
#[pyfunction]
#[pyo3(signature = (profile, model="preintegrate", *, taps=None,
    tap_extent=None, grid_size=None, extent=None, **params))]
#[allow(clippy::too_many_arguments)] // the keywords of a Python function
fn fit(
    py: Python<'_>,
    profile: &Bound<'_, PyAny>,
    model: &str,
    #[pyo3(from_py_with = kw::taps)] taps: Option<usize>,
    #[pyo3(from_py_with = kw::tap_extent)] tap_extent: Option<f64>,
    #[pyo3(from_py_with = kw::grid_size)] grid_size: Option<usize>,
    #[pyo3(from_py_with = kw::extent)] extent: Option<f64>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<Py<PyAny>> {
    let profile = profile_of(profile)?;
    let args = ModelArgs::from_kwargs(params)?;
    if model == "disk" {
        let separable = [
            ("taps", taps.is_some()),
            ("tap_extent", tap_extent.is_some()),
            ("grid_size", grid_size.is_some()),
            ("extent", extent.is_some()),
        ];
        if let Some((name, _)) = separable.iter().find(|(_, given)| *given) {
            return Err(bad(format!(
                "{name}: a separable kernel's setting; a disk kernel takes samples and radii"
            )));
        }
        let samples = args
            .samples
            .unwrap_or(ssskit::kernel::disk::DEFAULT_SAMPLES);
        let radii = crate::disk::radii_of(args.radii.as_deref().unwrap_or("widest"))?;
        let inner = interruptible(py, |_| fit_disk(&profile, samples, radii))?;
        return Ok(Py::new(py, crate::disk::PyDiskKernel { inner })?.into_any());
    }
    if args.samples.is_some() || args.radii.is_some() {
        return Err(bad(format!(
            "samples and radii are a disk kernel's settings; model '{model}' is separable"
        )));
    }
    let m = model_of(py, model, &args)?;
    let spec = Kernel2DSpec {
        size: grid_size,
        extent_mm: extent,
    };
    let taps = taps.unwrap_or(ssskit::kernel::taps::DEFAULT_TAPS);
    let k = interruptible(py, |_| {
        fit_kernel_file_with(&profile, &spec, &m, taps, tap_extent)
    })?;
    Ok(Py::new(py, PyKernel { inner: k })?.into_any())
}

/// An engine's own diffusion model fitted to a profile (`ssskit engine`):
/// engine "unreal", "unity-hdrp", "blender", "godot" or "iryoku";
/// subsurface_method "christensen-burley" or "random-walk" (blender; None:
/// the version's default, as the CLI's); returns the parameters, units,
/// errors and warnings as a dict.
#[pyfunction]
#[pyo3(signature = (profile, engine, *, version=None, units_per_mm=None, subsurface_method=None))]
fn engine_params<'py>(
    py: Python<'py>,
    profile: &Bound<'_, PyAny>,
    engine: &str,
    version: Option<&str>,
    #[pyo3(from_py_with = kw::units_per_mm)] units_per_mm: Option<f64>,
    subsurface_method: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    let profile = profile_of(profile)?;
    let e: Engine = engine.parse().map_err(to_py)?;
    let scene = units_per_mm.map_or(Scene::native(e), |units_per_mm| Scene { units_per_mm });
    let asked = subsurface_method
        .map(str::parse::<SubsurfaceMethod>)
        .transpose()
        .map_err(to_py)?;
    let method = SubsurfaceMethod::resolve(e, version, asked).map_err(to_py)?;
    // As `ssskit engine` fits: the default priority (colour), and the other
    // priority's error beside it (what keeping one costs the other).
    let req = engine::request::Request {
        version,
        method: Some(method),
        other: true,
        ..engine::request::Request::default()
    };
    let fit = interruptible(py, |_| {
        engine::request::fit_with(e, &profile, scene, &req, &ssskit::progress::NoProgress)
    })?;
    json_to_py(py, &fit)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyKernel>()?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(engine_params, m)?)?;
    m.add("MODELS", MODELS.to_vec())?;
    Ok(())
}
