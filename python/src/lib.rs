//! The Python binding of ssskit (`import ssskit`): converts Python values
//! and numpy arrays, calls the library, converts back. No physics, fitting
//! or filtering lives here; every computation is a call of the library the
//! CLI makes for the same flags.
//!
//! The files import each other one way: `call` and `args` (how the library
//! is called, how arguments are read) below everything; then `material`,
//! `profile`, `disk`, `kernel`, `files`; then `image` (arrays), `apply`
//! and `report`. This file only declares them and builds the module.

mod apply;
mod args;
mod call;
mod disk;
mod files;
mod image;
mod kernel;
mod light;
mod material;
mod options;
mod profile;
mod report;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    material::register(m)?;
    profile::register(m)?;
    kernel::register(m)?;
    disk::register(m)?;
    files::register(m)?;
    image::register(m)?;
    apply::register(m)?;
    report::register(m)?;
    Ok(())
}
