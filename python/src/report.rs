//! `compare` and `advise` as plain data: the rows of compare.json and the
//! answer of `advise --json`, computed by the same library calls.

use crate::args::{kw, one_of};
use crate::call::{interruptible, json_to_py, to_py, to_value};
use crate::disk::PyDiskKernel;
use crate::kernel::PyKernel;
use crate::profile::profile_of;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssskit::engine::Scene;
use ssskit::filter::signals::Signal;
use ssskit::report::eval::advise::{self, Budget, ViewScale};
use ssskit::report::eval::compare::disk::compare_rows;
use ssskit::report::eval::compare::kernel::{parse_ranks, Config, MaterialInput, FAMILIES};
use ssskit::report::eval::disk::{check_frames, DEFAULT_FRAMES, DISK};
use ssskit::report::eval::evaluate::{self, ImageCase, Options};

fn signal_of(name: &str) -> PyResult<Signal> {
    let names = [
        ("edge", Signal::Edge),
        ("shapes", Signal::Shapes),
        ("dirac", Signal::Dirac),
        ("checker", Signal::Checker),
    ];
    one_of("signals", name, &names, "edge, shapes, dirac or checker")
}

/// A `models` argument: one name, names separated by commas (as
/// `--models` takes them), or a list of names; "all" stands for every
/// family of the comparison, as `--models all` does. None: `default`.
fn models_of(obj: Option<&Bound<'_, PyAny>>, default: &[&str]) -> PyResult<Vec<String>> {
    let names: Vec<String> = match obj {
        None => return Ok(default.iter().map(|s| s.to_string()).collect()),
        Some(o) if o.is_none() => return Ok(default.iter().map(|s| s.to_string()).collect()),
        Some(o) => match o.extract::<String>() {
            Ok(s) => s.split(',').map(|m| m.trim().to_string()).collect(),
            Err(_) => o.extract::<Vec<String>>().map_err(|_| {
                PyTypeError::new_err(
                    "models: expected a model name, names separated by commas, or a list of names",
                )
            })?,
        },
    };
    if names.iter().any(|m| m.is_empty()) || names.is_empty() {
        return Err(PyValueError::new_err(format!(
            "models: invalid value {names:?}: an empty model name"
        )));
    }
    if names.iter().any(|m| m == "all") {
        return Ok(FAMILIES.iter().map(|s| s.to_string()).collect());
    }
    Ok(names)
}

/// The profiles to compare: a dict {name: Profile} or a list of profiles
/// (named by their material).
fn inputs(obj: &Bound<'_, PyAny>) -> PyResult<Vec<MaterialInput>> {
    if let Ok(d) = obj.cast::<PyDict>() {
        return d
            .iter()
            .map(|(k, v)| {
                Ok(MaterialInput {
                    name: k.extract()?,
                    profile: profile_of(&v)?,
                })
            })
            .collect();
    }
    let list = obj.try_iter().map_err(|_| {
        PyTypeError::new_err("profiles: expected a dict {name: Profile} or a list of profiles")
    })?;
    list.map(|p| {
        let profile = profile_of(&p?)?;
        Ok(MaterialInput {
            name: profile.material.name.clone(),
            profile,
        })
    })
    .collect()
}

/// Kernel models across materials in kernel and image space (`ssskit
/// compare`): one dict per material, model variant and channel, the rows
/// of the CLI's compare.json (errors in kernel space, on each test signal
/// and for each tap table). With "disk" among the models, the disk rows
/// the CLI prints follow them, one dict per material and test signal
/// ("material", "signal", "rows"), as the CLI's disk.json holds them: the
/// separable and the disk kernel at the samples per pixel of each tap
/// count, the disk's noise after `frames` frames.
#[pyfunction]
#[pyo3(signature = (profiles, *, models=None, ranks="1-3", taps=vec![ssskit::kernel::taps::DEFAULT_TAPS],
    signals=vec!["edge".to_string(), "shapes".to_string()], mm_per_pixel=evaluate::DEFAULT_MM_PER_PIXEL,
    signal_size=evaluate::DEFAULT_SIGNAL_SIZE, extent=None, pixels_per_degree=None,
    frames=DEFAULT_FRAMES))]
#[allow(clippy::too_many_arguments)] // the keywords of a Python function
fn compare<'py>(
    py: Python<'py>,
    profiles: &Bound<'py, PyAny>,
    models: Option<&Bound<'py, PyAny>>,
    ranks: &str,
    #[pyo3(from_py_with = kw::taps)] taps: Vec<usize>,
    signals: Vec<String>,
    #[pyo3(from_py_with = kw::mm_per_pixel)] mm_per_pixel: f64,
    #[pyo3(from_py_with = kw::signal_size)] signal_size: usize,
    #[pyo3(from_py_with = kw::extent)] extent: Option<f64>,
    #[pyo3(from_py_with = kw::pixels_per_degree)] pixels_per_degree: Option<f64>,
    #[pyo3(from_py_with = kw::frames)] frames: u32,
) -> PyResult<Bound<'py, PyAny>> {
    let inputs = inputs(profiles)?;
    // Disk kernels are not separable: rows of their own, as the CLI's.
    let (disks, families): (Vec<String>, Vec<String>) = models_of(models, &FAMILIES)?
        .into_iter()
        .partition(|f| f == DISK);
    let mut cases = Vec::new();
    for s in &signals {
        cases.push(ImageCase::signal(signal_of(s)?, signal_size, mm_per_pixel).map_err(to_py)?);
    }
    let defaults = Options::default();
    let cfg = Config {
        families,
        ranks: parse_ranks(ranks).map_err(to_py)?,
        cases,
        taps,
        options: Options {
            round_to_f32: defaults.round_to_f32,
            pixels_per_degree: pixels_per_degree.unwrap_or(defaults.pixels_per_degree),
        },
        keep: None,
        extent_mm: extent,
    };
    let cmp = interruptible(py, |progress| {
        ssskit::report::eval::compare::kernel::run(&inputs, &cfg, progress)
    })?;
    let mut rows: Vec<serde_json::Value> =
        cmp.rows.iter().map(to_value).collect::<PyResult<_>>()?;
    if !disks.is_empty() {
        let disk = interruptible(py, |_| compare_rows(&inputs, &cfg.cases, &cfg.taps, frames))?;
        rows.extend(disk.iter().map(to_value).collect::<PyResult<Vec<_>>>()?);
    }
    json_to_py(py, &serde_json::Value::Array(rows))
}

/// The chosen kernel, as the class of its model: a `DiskKernel` where the
/// answer is a disk kernel, else a `Kernel`.
fn chosen_kernel(py: Python<'_>, advice: advise::Advice) -> PyResult<Py<PyAny>> {
    Ok(match advice.disk_kernel {
        Some(inner) => Py::new(py, PyDiskKernel { inner })?.into_any(),
        None => Py::new(
            py,
            PyKernel {
                inner: advice.kernel,
            },
        )?
        .into_any(),
    })
}

/// The cheapest kernel configuration that meets an image-space error at a
/// pixel scale (`ssskit advise`): returns (answer, candidates, kernel):
/// the dict `advise --json` prints, every configuration evaluated (list of
/// dicts), and the chosen kernel, a `DiskKernel` where the answer is
/// "disk", else a `Kernel` (what `advise --out` writes). The scale:
/// mm_per_pixel (orthographic), or fov_y (degrees) with view_depth (the
/// surface's linear view depth, scene units), image_height (pixels) and
/// units_per_mm (scene units per mm, default 0.001: metres), as the CLI's
/// --fov-y, --view-depth, --image-height and --units-per-mm. models: a
/// name, names separated by commas, or a list (default: the CLI's, disk
/// included); frames: the frames a disk kernel's noise is scored after
/// (a temporal filter's history, 1 to 64); max_passes, max_samples,
/// max_taps: the budget (None or 0: no limit); factors=False leaves the
/// profile's entry and exit factors out of every kernel and score (the
/// CLI's --no-factors). Releases the GIL; Ctrl-C stops it with
/// KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (profile, mm_per_pixel=None, *, image_error=advise::DEFAULT_TARGET, models=None,
    max_passes=Some(advise::DEFAULT_MAX_PASSES), max_samples=None, max_taps=None,
    signal_size=evaluate::DEFAULT_SIGNAL_SIZE, frames=DEFAULT_FRAMES, fov_y=None,
    view_depth=None, image_height=None, units_per_mm=Scene::default().units_per_mm,
    factors=true))]
#[pyo3(name = "advise")]
#[allow(clippy::too_many_arguments)] // the keywords of a Python function
fn advise_kernel<'py>(
    py: Python<'py>,
    profile: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::mm_per_pixel)] mm_per_pixel: Option<f64>,
    #[pyo3(from_py_with = kw::image_error)] image_error: f64,
    models: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = kw::max_passes)] max_passes: Option<usize>,
    #[pyo3(from_py_with = kw::max_samples)] max_samples: Option<usize>,
    #[pyo3(from_py_with = kw::max_taps)] max_taps: Option<usize>,
    #[pyo3(from_py_with = kw::signal_size)] signal_size: usize,
    #[pyo3(from_py_with = kw::frames)] frames: u32,
    #[pyo3(from_py_with = kw::fov_y)] fov_y: Option<f64>,
    #[pyo3(from_py_with = kw::view_depth)] view_depth: Option<f64>,
    #[pyo3(from_py_with = kw::image_height)] image_height: Option<usize>,
    #[pyo3(from_py_with = kw::units_per_mm)] units_per_mm: f64,
    factors: bool,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Py<PyAny>)> {
    // `advise --image-error`'s checks: a fraction in (0, 1).
    if !(image_error > 0.0 && image_error < 1.0) {
        return Err(PyValueError::new_err(format!(
            "image_error: invalid value {image_error}: a fraction in (0, 1): 0.05 is 5%"
        )));
    }
    let view = match (mm_per_pixel, fov_y, view_depth, image_height) {
        (Some(m), None, None, None) => ViewScale::MmPerPixel(m),
        (None, Some(f), Some(d), Some(h)) => ViewScale::Perspective {
            fov_y_deg: f,
            depth: d,
            height: h,
            scene_units_per_mm: units_per_mm,
        },
        _ => {
            return Err(PyTypeError::new_err(
                "give mm_per_pixel, or fov_y with view_depth and image_height",
            ))
        }
    };
    let mm = view.mm_per_pixel().map_err(to_py)?;
    check_frames(frames).map_err(to_py)?;
    let mut profile = profile_of(profile)?;
    if !factors {
        // Said on the profile, as the CLI's --no-factors does, so that the
        // kernels and their scores leave them out too.
        ssskit::kernel::angular::leave_out(&mut profile);
    }
    let mut cfg = advise::Config::new(mm, image_error);
    cfg.size = signal_size;
    cfg.frames = frames;
    cfg.budget = Budget {
        max_passes: max_passes.filter(|&n| n > 0),
        max_samples: max_samples.filter(|&n| n > 0),
        max_taps: max_taps.filter(|&n| n > 0),
    };
    cfg.families = models_of(models, &advise::ADVISED_FAMILIES)?;
    let advice = interruptible(py, |progress| advise::advise(&profile, &cfg, progress))?;
    if !advice.warnings.is_empty() {
        let warn = py.import("warnings")?;
        for w in &advice.warnings {
            warn.call_method1("warn", (w.to_string(),))?;
        }
    }
    let answer = json_to_py(py, &advice.to_json())?;
    let candidates = json_to_py(py, &advice.candidates)?;
    Ok((answer, candidates, chosen_kernel(py, advice)?))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(advise_kernel, m)?)?;
    Ok(())
}
