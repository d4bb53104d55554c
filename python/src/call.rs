//! How the binding calls the library: library errors as the Python
//! exceptions a caller expects, long work on a thread of its own while the
//! caller waits without the GIL (Ctrl-C honoured), files opened, read and
//! written without the GIL, and the library's JSON as plain Python data.

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use ssskit::progress::Progress;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

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

/// A library object (parameters, metrics, sources) as plain Python data
/// through the standard `json` module, by way of a JSON value (objects
/// with their keys in order, as the CLI's JSON holds them).
pub(crate) fn json_to_py<'py, T: serde::Serialize + ?Sized>(
    py: Python<'py>,
    v: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let text =
        serde_json::to_string(&to_value(v)?).map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A library object as a JSON value, a serialisation error as ValueError.
pub(crate) fn to_value<T: serde::Serialize + ?Sized>(v: &T) -> PyResult<serde_json::Value> {
    serde_json::to_value(v).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Pretty JSON of a library object, as its files hold it.
pub(crate) fn pretty_json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string_pretty(v).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// A file operation of the library (open, read, write) run without the
/// GIL: a file that makes the call wait (a named pipe whose other end is
/// slow, a network mount) stops only this call, never the interpreter's
/// other threads. A pipe with nobody at its other end is not waited for:
/// the library reads it as empty, or refuses to write it.
pub(crate) fn file_op<T: Send>(
    py: Python<'_>,
    op: impl FnOnce() -> ssskit::Result<T> + Send,
) -> PyResult<T> {
    py.detach(op).map_err(to_py)
}

/// A path argument: `str` or `os.PathLike`.
pub(crate) fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<std::path::PathBuf> {
    obj.extract::<std::path::PathBuf>()
}

/// Writes a library object's file (`save`) without the GIL.
pub(crate) fn save(
    py: Python<'_>,
    path: &Bound<'_, PyAny>,
    write: impl FnOnce(&std::path::Path) -> ssskit::Result<()> + Send,
) -> PyResult<()> {
    let path = path_of(path)?;
    file_op(py, || write(&path))
}

/// Each of `warnings` as a Python `UserWarning`.
pub(crate) fn warn_all(py: Python<'_>, warnings: impl IntoIterator<Item = String>) -> PyResult<()> {
    let warn = py.import("warnings")?;
    for w in warnings {
        warn.call_method1("warn", (w,))?;
    }
    Ok(())
}
