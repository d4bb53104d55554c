//! `load`: any JSON file the CLI writes, by its schema, read without the
//! GIL.

use crate::call::{file_op, path_of};
use crate::disk::PyDiskKernel;
use crate::kernel::PyKernel;
use crate::profile::PyProfile;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use ssskit::kernel::disk::DiskKernelFile;
use ssskit::kernel::format::DISK_SCHEMA;
use ssskit::kernel::{KernelFile, KERNEL_SCHEMA};
use ssskit::profile::{Profile, PROFILE_SCHEMA};

/// Reads any JSON file the CLI writes, by its `schema`: a `Profile`
/// (`ssskit.profile/1`), a `Kernel` (`ssskit.kernel/1`) or a `DiskKernel`
/// (`ssskit.disk/1`). Reads without the GIL.
#[pyfunction]
fn load(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
    let path = path_of(path)?;
    let value: serde_json::Value = file_op(py, || ssskit::io::read_json(&path))?;
    let schema = value.get("schema").and_then(|s| s.as_str()).unwrap_or("");
    Ok(match schema {
        PROFILE_SCHEMA => {
            let inner = file_op(py, || Profile::read(&path))?;
            Py::new(py, PyProfile { inner })?.into_any()
        }
        KERNEL_SCHEMA => {
            let inner = file_op(py, || KernelFile::read(&path))?;
            Py::new(py, PyKernel { inner })?.into_any()
        }
        DISK_SCHEMA => {
            let inner = file_op(py, || DiskKernelFile::read(&path))?;
            Py::new(py, PyDiskKernel { inner })?.into_any()
        }
        other => {
            return Err(PyValueError::new_err(format!(
                "{}: schema '{other}' is not one ssskit.load reads ({PROFILE_SCHEMA}, \
                 {KERNEL_SCHEMA}, {DISK_SCHEMA})",
                path.display(),
            )))
        }
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(load, m)?)?;
    Ok(())
}
