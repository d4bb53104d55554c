//! The Python binding of ssskit (`import ssskit`): converts Python values
//! and numpy arrays, calls the library, converts back. No physics, fitting
//! or filtering lives here; every computation is a call of the library the
//! CLI makes for the same flags.

// A Python function's keyword arguments are the Rust function's parameters.
#![allow(clippy::too_many_arguments)]

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use ssskit::progress::Progress;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

mod disk;
mod image;
mod kernel;
mod material;
mod profile;
mod report;

/// How often a long call, waiting without the GIL, looks for Ctrl-C: a
/// twentieth of a second is below what a person notices, and the wake-ups
/// cost nothing measurable (the result is delivered at once, not polled).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// The stack of the thread a long call runs on: a process's main thread's
/// (8 MiB on Linux), where the CLI runs the same code.
const WORK_STACK: usize = 8 << 20;

/// A library error as the Python exception a caller expects: files that
/// cannot be read or written are `OSError` (`FileNotFoundError` when
/// missing), everything else (bad parameters, NaN pixels, malformed files)
/// is `ValueError`, with the library's message.
pub(crate) fn to_py(e: ssskit::Error) -> PyErr {
    let msg = ssskit::error::short_numbers(&e.to_string());
    match &e {
        ssskit::Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(msg)
        }
        ssskit::Error::Io { .. } => PyOSError::new_err(msg),
        _ => PyValueError::new_err(msg),
    }
}

/// The library's progress hook, used only to carry a cancel request.
#[derive(Default)]
struct Cancel(AtomicBool);

impl Progress for Cancel {
    fn cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Runs `work` on a scoped thread while the calling thread waits without
/// the GIL (other Python threads run), waking every [`SIGNAL_POLL`] to run
/// Python's signal handlers: a Ctrl-C asks the work to stop through
/// [`Progress::cancelled`] and raises `KeyboardInterrupt` once it has.
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&dyn Progress) -> ssskit::Result<T> + Send,
) -> PyResult<T> {
    let cancel = Cancel::default();
    let cancel_ref = &cancel;
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel::<()>();
        let handle = std::thread::Builder::new()
            .name("ssskit".into())
            .stack_size(WORK_STACK)
            .spawn_scoped(s, move || {
                let r = work(cancel_ref);
                let _ = tx.send(());
                r
            })
            .map_err(|e| PyRuntimeError::new_err(format!("ssskit: cannot start a thread: {e}")))?;
        // The receiver is not Sync; the closures given to `detach` must be Send.
        let rx = std::sync::Mutex::new(rx);
        let wait = |timeout: Duration| {
            rx.lock()
                .map(|r| r.recv_timeout(timeout).is_ok())
                .unwrap_or(true)
        };
        let mut interrupt = None;
        loop {
            let done = py.detach(|| wait(SIGNAL_POLL));
            if done {
                break;
            }
            if handle.is_finished() {
                break;
            }
            if let Err(e) = py.check_signals() {
                cancel.0.store(true, Ordering::Relaxed);
                interrupt = Some(e);
                py.detach(|| while !handle.is_finished() && !wait(SIGNAL_POLL) {});
                break;
            }
        }
        let result = py.detach(|| handle.join());
        let result =
            result.map_err(|_| PyRuntimeError::new_err("ssskit: the computation panicked"))?;
        match interrupt {
            Some(e) => Err(e),
            None => result.map_err(to_py),
        }
    })
}

/// A JSON value of the library (parameters, metrics, sources) as plain
/// Python data through the standard `json` module.
pub(crate) fn json_to_py<'py>(
    py: Python<'py>,
    v: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Pretty JSON of a library object, as its files hold it.
pub(crate) fn pretty_json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string_pretty(v).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// A shader language by the name `--emit` takes.
pub(crate) fn lang_of(lang: &str) -> PyResult<ssskit::kernel::emit::Lang> {
    use ssskit::kernel::emit::Lang;
    match lang.to_ascii_lowercase().as_str() {
        "hlsl" => Ok(Lang::Hlsl),
        "glsl" => Ok(Lang::Glsl),
        "wgsl" => Ok(Lang::Wgsl),
        other => Err(PyValueError::new_err(format!(
            "emit: invalid language '{other}': expected hlsl, glsl or wgsl"
        ))),
    }
}

/// A path argument: `str` or `os.PathLike`.
pub(crate) fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    obj.extract::<std::path::PathBuf>()
}

/// Reads any JSON file the CLI writes, by its `schema`: a `Profile`
/// (`ssskit.profile/1`), a `Kernel` (`ssskit.kernel/1`) or a `DiskKernel`
/// (`ssskit.disk/1`).
#[pyfunction]
fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
    let path = path_of(path)?;
    let value: serde_json::Value = ssskit::io::read_json(&path).map_err(to_py)?;
    let schema = value.get("schema").and_then(|s| s.as_str()).unwrap_or("");
    match schema {
        ssskit::profile::PROFILE_SCHEMA => {
            let p = ssskit::profile::Profile::read(&path).map_err(to_py)?;
            Ok(Py::new(py, profile::PyProfile { inner: p })?.into_any())
        }
        ssskit::kernel::KERNEL_SCHEMA => {
            let k = ssskit::kernel::KernelFile::read(&path).map_err(to_py)?;
            Ok(Py::new(py, kernel::PyKernel { inner: k })?.into_any())
        }
        ssskit::kernel::disk::DISK_SCHEMA => {
            let k = ssskit::kernel::disk::DiskKernelFile::read(&path).map_err(to_py)?;
            Ok(Py::new(py, disk::PyDiskKernel { inner: k })?.into_any())
        }
        other => Err(PyValueError::new_err(format!(
            "{}: schema '{other}' is not one ssskit.load reads ({}, {}, {})",
            path.display(),
            ssskit::profile::PROFILE_SCHEMA,
            ssskit::kernel::KERNEL_SCHEMA,
            ssskit::kernel::disk::DISK_SCHEMA
        ))),
    }
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    material::register(m)?;
    profile::register(m)?;
    kernel::register(m)?;
    m.add_class::<disk::PyDiskKernel>()?;
    image::register(m)?;
    report::register(m)?;
    Ok(())
}
