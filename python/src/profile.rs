//! Reflectance profiles: Monte Carlo (`simulate`) and analytic (`profile`).

use crate::args::{kw, one_of};
use crate::call::{file_op, interruptible, json_to_py, path_of, pretty_json, save, to_py};
use crate::material::{material_of, PyMaterial};
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use ssskit::material::Channel;
use ssskit::profile::analytic::{self, Options};
use ssskit::profile::fresnel::FresnelMode;
use ssskit::profile::mc::{self, McConfig, McOptions, PhotonBudget, Shard};
use ssskit::profile::{GridSpec, Profile};

/// A radial reflectance profile R_d(r) per channel (ssskit.profile/1).
///
/// `r` holds the bin centres in mm, `r_edges` the bin edges, `rd` one row
/// per channel (mm^-2), `rd_stderr` the Monte Carlo standard errors (None
/// for an analytic profile).
#[pyclass(module = "ssskit", name = "Profile", frozen)]
pub struct PyProfile {
    pub inner: Profile,
}

fn rows<'py>(py: Python<'py>, v: &[Vec<f64>]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray2::from_vec2(py, v).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Weights of three channels, one row per sample or tap, as an (n, 3)
/// array ((0, 3) when there are none).
pub(crate) fn rgb_rows<'py>(
    py: Python<'py>,
    w: impl Iterator<Item = [f64; 3]>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let w: Vec<Vec<f64>> = w.map(|w| w.to_vec()).collect();
    if w.is_empty() {
        return Ok(PyArray2::zeros(py, [0, 3], false));
    }
    rows(py, &w)
}

#[pymethods]
impl PyProfile {
    /// Bin centres, mm.
    #[getter]
    fn r<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.r)
    }
    /// Bin edges, mm (one more than `r`).
    #[getter]
    fn r_edges<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.r_edges)
    }
    /// R_d(r), shape (channels, bins), mm^-2.
    #[getter]
    fn rd<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, &self.inner.rd)
    }
    /// Standard errors of `rd` (Monte Carlo), or None.
    #[getter]
    fn rd_stderr<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        self.inner
            .rd_stderr
            .as_deref()
            .map(|e| rows(py, e))
            .transpose()
    }
    /// Total diffuse reflectance per channel.
    #[getter]
    fn total_rd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.total_rd)
    }
    /// Standard errors of `total_rd` (Monte Carlo), or None.
    #[getter]
    fn total_rd_stderr<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .total_rd_stderr
            .as_deref()
            .map(|e| PyArray1::from_slice(py, e))
    }
    /// The channels, e.g. ["r", "g", "b"].
    #[getter]
    fn channels(&self) -> Vec<&'static str> {
        self.inner.channels.iter().map(|c| c.name()).collect()
    }
    #[getter]
    fn material(&self) -> PyMaterial {
        PyMaterial {
            inner: self.inner.material.clone(),
        }
    }
    /// Where the profile came from (kind, photons, seed, model, params).
    #[getter]
    fn source<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.inner.source)
    }
    /// Seconds the computation took.
    #[getter]
    fn elapsed_s(&self) -> f64 {
        self.inner.elapsed_s
    }
    /// The library's warnings about this profile (e.g. light beyond r_max).
    fn warnings(&self) -> PyResult<Vec<String>> {
        self.inner.warnings().map_err(to_py)
    }
    /// Writes the profile file (JSON), as `ssskit simulate --out` does
    /// (without the GIL).
    fn save(&self, py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        save(py, path, |p| self.inner.write(p))
    }
    /// The profile file's text.
    fn to_json(&self) -> PyResult<String> {
        pretty_json(&self.inner)
    }
    /// The profile of a profile file's text, checked as `load` checks the
    /// file.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<PyProfile> {
        let inner: Profile = serde_json::from_str(text)
            .map_err(|e| PyValueError::new_err(format!("not a profile: {e}")))?;
        inner.validate("the profile text").map_err(to_py)?;
        Ok(PyProfile { inner })
    }
    /// Pickled as its file's text (which round-trips every number exactly),
    /// so a profile crosses processes (multiprocessing, Dask) unchanged.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_json = slf.get_type().getattr("from_json")?;
        Ok((from_json, (slf.get().to_json()?,)))
    }
    fn __repr__(&self) -> String {
        format!(
            "ssskit.Profile('{}', {}, {} bins to {:.4} mm)",
            self.inner.material.name,
            self.inner.source.kind,
            self.inner.r.len(),
            self.inner.r_edges.last().copied().unwrap_or(0.0)
        )
    }
}

/// A profile argument: a `Profile`, or the path of a profile file (read
/// without the GIL).
pub(crate) fn profile_of(obj: &Bound<'_, PyAny>) -> PyResult<Profile> {
    if let Ok(p) = obj.cast::<PyProfile>() {
        return Ok(p.get().inner.clone());
    }
    if let Ok(path) = path_of(obj) {
        return file_op(obj.py(), || Profile::read(&path));
    }
    Err(PyTypeError::new_err(
        "profile: expected an ssskit.Profile or the path of a profile file",
    ))
}

fn grid_spec(dr: Option<f64>, rmax: Option<f64>, log_bins: bool) -> GridSpec {
    GridSpec {
        dr,
        r_max: rmax,
        log_bins,
    }
}

/// When the run stops, as `ssskit simulate` decides it from its flags: a
/// fixed photon count, else a target error, else the kernel-factor rule
/// (its default target when nothing is given).
fn budget(
    photons: Option<u64>,
    mc_error: Option<f64>,
    kernel_error: Option<f64>,
    max_photons: u64,
) -> PyResult<PhotonBudget> {
    Ok(match (photons, mc_error, kernel_error) {
        (Some(n), None, None) => PhotonBudget::Fixed(n),
        (None, Some(rel), None) => PhotonBudget::TargetError { rel, max_photons },
        (None, None, rel) => PhotonBudget::KernelFactor {
            rel: rel.unwrap_or(mc::DEFAULT_KERNEL_ERROR),
            max_photons,
        },
        _ => {
            return Err(PyValueError::new_err(
                "give at most one of photons, mc_error and kernel_error",
            ))
        }
    })
}

/// Monte Carlo reflectance profile of a material (`ssskit simulate`).
///
/// The budget: `photons` per channel, or `mc_error` (relative standard
/// error of total R_d and profile), or `kernel_error` (the kernel-factor
/// rule, the default); `max_photons` caps the error targets. The same
/// `seed` gives the same profile, bit for bit, for any `threads`, and the
/// same as the CLI with the same flags. `shard=(k, n)` traces part k of n
/// of a fixed `photons` run (`--shard K/N`; `merge` adds the parts),
/// `max_work` caps each channel's events (`--max-work`; every shard of a
/// run needs the same). Releases the GIL; Ctrl-C stops it with
/// KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (material, *, photons=None, mc_error=None, kernel_error=None,
    max_photons=mc::DEFAULT_MAX_PHOTONS, seed=mc::DEFAULT_SEED, threads=None, channels="rgb",
    dr=None, rmax=None, log_bins=false, shard=None, max_work=mc::DEFAULT_MAX_WORK))]
#[allow(clippy::too_many_arguments)] // the keywords of a Python function
fn simulate(
    py: Python<'_>,
    material: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = kw::photons)] photons: Option<u64>,
    #[pyo3(from_py_with = kw::mc_error)] mc_error: Option<f64>,
    #[pyo3(from_py_with = kw::kernel_error)] kernel_error: Option<f64>,
    #[pyo3(from_py_with = kw::max_photons)] max_photons: u64,
    #[pyo3(from_py_with = kw::seed)] seed: u64,
    #[pyo3(from_py_with = kw::threads)] threads: Option<usize>,
    channels: &str,
    #[pyo3(from_py_with = kw::dr)] dr: Option<f64>,
    #[pyo3(from_py_with = kw::rmax)] rmax: Option<f64>,
    log_bins: bool,
    #[pyo3(from_py_with = kw::shard)] shard: Option<Vec<u64>>,
    #[pyo3(from_py_with = kw::max_work)] max_work: u64,
) -> PyResult<PyProfile> {
    let material = material_of(material)?;
    let shard = shard.map(shard_of).transpose()?;
    let channels = Channel::parse_list(channels).map_err(to_py)?;
    let spec = grid_spec(dr, rmax, log_bins);
    let grid = if spec == GridSpec::default() {
        None
    } else {
        Some(spec.grid(&material, &channels).map_err(to_py)?)
    };
    let cfg = McConfig {
        budget: budget(photons, mc_error, kernel_error, max_photons)?,
        seed,
        threads,
        channels,
        grid,
    };
    let opts = McOptions {
        shard,
        max_work,
        ..McOptions::default()
    };
    let p = interruptible(py, |progress| {
        mc::simulate_with(&material, &cfg, &opts, progress)
    })?;
    Ok(PyProfile { inner: p })
}

/// `shard=(k, n)`: part k of n (1 <= k <= n), as `--shard K/N`.
fn shard_of(v: Vec<u64>) -> PyResult<Shard> {
    match v[..] {
        [k, n] => Ok(Shard { k, n }),
        _ => Err(PyValueError::new_err(format!(
            "shard: expected (k, n), part k of n, got {} values",
            v.len()
        ))),
    }
}

/// The profile of the single run from all its shards (`ssskit merge`):
/// `parts` are `Profile`s or paths of part files, in any order, read and
/// added one at a time without the GIL; the result equals the single run
/// bit for bit but for `elapsed_s` (the parts' sum). Refused, naming the
/// part: parts of different runs, a shard given twice or missing, a part
/// that is not a shard or was changed after it was written.
#[pyfunction]
fn merge(py: Python<'_>, parts: &Bound<'_, PyAny>) -> PyResult<PyProfile> {
    let mut merger = mc::ShardMerger::new();
    for (i, part) in parts.try_iter()?.enumerate() {
        let part = part?;
        let (name, p) = match part.cast::<PyProfile>() {
            Ok(p) => (format!("parts[{i}]"), p.get().inner.clone()),
            Err(_) => {
                let path = path_of(&part)?;
                (
                    path.display().to_string(),
                    file_op(py, || Profile::read(&path))?,
                )
            }
        };
        py.detach(|| merger.add(&name, p)).map_err(to_py)?;
    }
    let inner = py.detach(|| merger.finish()).map_err(to_py)?;
    Ok(PyProfile { inner })
}

/// Analytic reflectance profile (`ssskit profile`): model "dipole", "pbd",
/// "burley" or the others `ssskit profile --profile-model` lists; fresnel
/// "fit" or "exact".
#[pyfunction]
#[pyo3(signature = (material, model="pbd", *, channels="rgb", dr=None, rmax=None, fresnel="fit"))]
fn profile(
    py: Python<'_>,
    material: &Bound<'_, PyAny>,
    model: &str,
    channels: &str,
    #[pyo3(from_py_with = kw::dr)] dr: Option<f64>,
    #[pyo3(from_py_with = kw::rmax)] rmax: Option<f64>,
    fresnel: &str,
) -> PyResult<PyProfile> {
    let material = material_of(material)?;
    let model = analytic::Model::parse(model).map_err(to_py)?;
    let fresnel = one_of(
        "fresnel",
        fresnel,
        &[("fit", FresnelMode::Fit), ("exact", FresnelMode::Exact)],
        "'fit' or 'exact'",
    )?;
    let channels = Channel::parse_list(channels).map_err(to_py)?;
    let grid = grid_spec(dr, rmax, false)
        .grid(&material, &channels)
        .map_err(to_py)?;
    let options = Options { fresnel, channels };
    let p = interruptible(py, |_| analytic::profile(&material, model, &grid, &options))?;
    p.validate("the analytic profile").map_err(to_py)?;
    Ok(PyProfile { inner: p })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyProfile>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(profile, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    Ok(())
}
