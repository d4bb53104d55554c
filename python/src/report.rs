//! `compare` and `advise` as plain data: the rows of compare.json and the
//! answer of `advise --json`, computed by the same library calls.

use crate::kernel::{profile_of, PyKernel};
use crate::{interruptible, json_to_py, to_py};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssskit::filter::signals::Signal;
use ssskit::report::eval::advise::{self, Budget};
use ssskit::report::eval::evaluate::{self, ImageCase, Options};
use ssskit::report::eval::kernel_compare::{self, parse_ranks, Config, MaterialInput};

fn signal_of(name: &str) -> PyResult<Signal> {
    Ok(match name {
        "edge" => Signal::Edge,
        "shapes" => Signal::Shapes,
        "dirac" => Signal::Dirac,
        "checker" => Signal::Checker,
        other => {
            return Err(PyValueError::new_err(format!(
                "signals: invalid value '{other}': expected edge, shapes, dirac or checker"
            )))
        }
    })
}

fn to_value<T: serde::Serialize>(v: &T) -> PyResult<serde_json::Value> {
    serde_json::to_value(v).map_err(|e| PyValueError::new_err(e.to_string()))
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
/// and for each tap table).
#[pyfunction]
#[pyo3(signature = (profiles, *, models=None, ranks="1-3", taps=vec![ssskit::kernel::taps::DEFAULT_TAPS],
    signals=vec!["edge".to_string(), "shapes".to_string()], mm_per_pixel=evaluate::DEFAULT_MM_PER_PIXEL,
    signal_size=evaluate::DEFAULT_SIGNAL_SIZE, extent=None, pixels_per_degree=None))]
fn compare<'py>(
    py: Python<'py>,
    profiles: &Bound<'py, PyAny>,
    models: Option<Vec<String>>,
    ranks: &str,
    taps: Vec<usize>,
    signals: Vec<String>,
    mm_per_pixel: f64,
    signal_size: usize,
    extent: Option<f64>,
    pixels_per_degree: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let inputs = inputs(profiles)?;
    let mut cases = Vec::new();
    for s in &signals {
        cases.push(ImageCase::signal(signal_of(s)?, signal_size, mm_per_pixel).map_err(to_py)?);
    }
    let defaults = Options::default();
    let cfg = Config {
        families: models.unwrap_or_else(|| {
            kernel_compare::FAMILIES
                .iter()
                .map(|s| s.to_string())
                .collect()
        }),
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
    let cmp = interruptible(py, |progress| kernel_compare::run(&inputs, &cfg, progress))?;
    json_to_py(py, &to_value(&cmp.rows)?)
}

/// The cheapest kernel configuration that meets an image-space error at a
/// pixel scale (`ssskit advise`): returns (answer, candidates, kernel):
/// the dict `advise --json` prints, every configuration evaluated (list of
/// dicts), and the chosen kernel.
#[pyfunction]
#[pyo3(signature = (profile, mm_per_pixel, *, image_error=advise::DEFAULT_TARGET, models=None,
    max_passes=Some(advise::DEFAULT_MAX_PASSES), max_samples=None, max_taps=None,
    signal_size=evaluate::DEFAULT_SIGNAL_SIZE))]
#[pyo3(name = "advise")]
fn advise_kernel<'py>(
    py: Python<'py>,
    profile: &Bound<'py, PyAny>,
    mm_per_pixel: f64,
    image_error: f64,
    models: Option<Vec<String>>,
    max_passes: Option<usize>,
    max_samples: Option<usize>,
    max_taps: Option<usize>,
    signal_size: usize,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, PyKernel)> {
    // `advise --image-error`'s checks: a fraction in (0, 1).
    if !(image_error > 0.0 && image_error < 1.0) {
        return Err(PyValueError::new_err(format!(
            "image_error: invalid value {image_error}: a fraction in (0, 1): 0.05 is 5%"
        )));
    }
    let profile = profile_of(profile)?;
    let mut cfg = advise::Config::new(mm_per_pixel, image_error);
    cfg.size = signal_size;
    cfg.budget = Budget {
        max_passes: max_passes.filter(|&n| n > 0),
        max_samples: max_samples.filter(|&n| n > 0),
        max_taps: max_taps.filter(|&n| n > 0),
    };
    if let Some(m) = models {
        cfg.families = m;
    }
    let advice = interruptible(py, |progress| advise::advise(&profile, &cfg, progress))?;
    if !advice.warnings.is_empty() {
        let warn = py.import("warnings")?;
        for w in &advice.warnings {
            warn.call_method1("warn", (w.to_string(),))?;
        }
    }
    Ok((
        json_to_py(py, &advice.to_json())?,
        json_to_py(py, &to_value(&advice.candidates)?)?,
        PyKernel {
            inner: advice.kernel,
        },
    ))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(advise_kernel, m)?)?;
    Ok(())
}
