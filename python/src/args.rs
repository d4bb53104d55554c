//! Python arguments as the CLI's flags take them: a number is a number (a
//! bool is refused, as `True` is no 1.0 mm), reals are finite (the CLI's
//! `real` parser), counts are whole and non-negative (an integral float
//! such as `1e6` is a count, as the CLI reads `1e6`), and every refusal
//! names the keyword. Each keyword has its extractor in [`kw`], used as
//! `#[pyo3(from_py_with = kw::NAME)]`, so the name is written once.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt};

/// Whether `o` is a boolean: Python's, or numpy's (`numpy.bool`, named
/// `bool_` before numpy 2), which converts to a number just as silently.
fn is_bool(o: &Bound<'_, PyAny>) -> bool {
    o.is_instance_of::<PyBool>()
        || o.get_type()
            .name()
            .is_ok_and(|n| n.to_string_lossy() == "bool" || n.to_string_lossy() == "bool_")
}

fn type_name(o: &Bound<'_, PyAny>) -> String {
    o.get_type()
        .name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|_| "?".into())
}

/// A real keyword: a finite number, not a bool.
pub(crate) fn real(o: &Bound<'_, PyAny>, name: &str) -> PyResult<f64> {
    if is_bool(o) {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a number, got a bool ({})",
            o.repr()?
        )));
    }
    let v: f64 = o.extract().map_err(|_| {
        PyTypeError::new_err(format!("{name}: expected a number, got {}", type_name(o)))
    })?;
    if !v.is_finite() {
        return Err(PyValueError::new_err(format!(
            "{name}: invalid value {v}: must be a finite number"
        )));
    }
    Ok(v)
}

/// The integer types a count keyword converts to, with their largest
/// value (for the message).
pub(crate) trait Count: TryFrom<u64> {
    const MAX: u64;
}

impl Count for u32 {
    const MAX: u64 = u32::MAX as u64;
}

impl Count for u64 {
    const MAX: u64 = u64::MAX;
}

impl Count for usize {
    const MAX: u64 = usize::MAX as u64;
}

/// A count keyword: a whole number >= 0 (an int, or an integral float
/// such as 1e6) that fits `T`; not a bool.
pub(crate) fn count<T: Count>(o: &Bound<'_, PyAny>, name: &str) -> PyResult<T> {
    let whole = || {
        PyValueError::new_err(format!(
            "{name}: invalid value {}: expected a whole number >= 0, e.g. 1000000 or 1e6",
            o.repr().map(|r| r.to_string()).unwrap_or_default()
        ))
    };
    let too_large = |v: &str| {
        PyValueError::new_err(format!(
            "{name}: invalid value {v}: too large (at most {})",
            T::MAX
        ))
    };
    if is_bool(o) {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a whole number, got a bool ({})",
            o.repr()?
        )));
    }
    let n: u64 = if let Ok(n) = o.extract::<u64>() {
        n
    } else if o.is_instance_of::<PyFloat>() {
        let v: f64 = o.extract()?;
        // 2^64 is exactly representable; every f64 below it converts exactly.
        if !(v >= 0.0 && v.fract() == 0.0 && v < 18_446_744_073_709_551_616.0) {
            return Err(whole());
        }
        v as u64
    } else if o.is_instance_of::<PyInt>() || o.hasattr("__index__")? {
        // An integer beyond u64: negative, or too large for any count.
        if o.lt(0).unwrap_or(true) {
            return Err(whole());
        }
        return Err(too_large(&o.repr()?.to_string()));
    } else {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a whole number, got {}",
            type_name(o)
        )));
    };
    T::try_from(n).map_err(|_| too_large(&n.to_string()))
}

/// A keyword's value, converted as the CLI converts its flag.
pub(crate) trait Strict: Sized {
    fn strict(o: &Bound<'_, PyAny>, name: &str) -> PyResult<Self>;
}

impl Strict for f64 {
    fn strict(o: &Bound<'_, PyAny>, name: &str) -> PyResult<f64> {
        real(o, name)
    }
}

macro_rules! counts {
    ($($t:ty),*) => {$(
        impl Strict for $t {
            fn strict(o: &Bound<'_, PyAny>, name: &str) -> PyResult<$t> {
                count(o, name)
            }
        }
    )*};
}
counts!(u32, u64, usize);

impl<T: Strict> Strict for Vec<T> {
    /// A list (or any iterable) of values, or one value alone.
    fn strict(o: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<T>> {
        match o.try_iter() {
            Ok(items) => items.map(|x| T::strict(&x?, name)).collect(),
            Err(_) => T::strict(o, name).map(|v| vec![v]),
        }
    }
}

impl<T: Strict> Strict for Option<T> {
    fn strict(o: &Bound<'_, PyAny>, name: &str) -> PyResult<Option<T>> {
        if o.is_none() {
            return Ok(None);
        }
        T::strict(o, name).map(Some)
    }
}

/// A colour argument: one number for all channels or three (r, g, b),
/// each a finite number, not a bool.
pub(crate) fn rgb(o: &Bound<'_, PyAny>, name: &str) -> PyResult<[f64; 3]> {
    if !is_bool(o) && o.extract::<f64>().is_ok() {
        return Ok([real(o, name)?; 3]);
    }
    let items: Vec<Bound<'_, PyAny>> = o
        .try_iter()
        .and_then(|it| it.collect::<PyResult<Vec<_>>>())
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "{name}: expected a number or three numbers (r, g, b)"
            ))
        })?;
    let v = items
        .iter()
        .map(|x| real(x, name))
        .collect::<PyResult<Vec<f64>>>()?;
    <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
        PyValueError::new_err(format!(
            "{name}: expected three values (r, g, b), got {}",
            v.len()
        ))
    })
}

/// A keyword's value by name: the `T` of `value` among `names`, else the
/// one message naming the keyword and what it takes (`expected`).
pub(crate) fn one_of<T: Copy>(
    keyword: &str,
    value: &str,
    names: &[(&str, T)],
    expected: &str,
) -> PyResult<T> {
    match names.iter().find(|(n, _)| *n == value) {
        Some(&(_, t)) => Ok(t),
        None => Err(PyValueError::new_err(format!(
            "{keyword}: invalid value '{value}': expected {expected}"
        ))),
    }
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

/// One extractor per keyword, named as the keyword: the name in every
/// message is the one the caller typed.
pub(crate) mod kw {
    use super::Strict;
    use pyo3::prelude::*;

    macro_rules! named {
        ($($name:ident),* $(,)?) => {$(
            pub(crate) fn $name<T: Strict>(o: &Bound<'_, PyAny>) -> PyResult<T> {
                T::strict(o, stringify!($name))
            }
        )*};
    }

    named!(
        photons,
        max_work,
        shard,
        mc_error,
        kernel_error,
        max_photons,
        seed,
        threads,
        dr,
        rmax,
        taps,
        tap_extent,
        grid_size,
        extent,
        units_per_mm,
        mm_per_pixel,
        fov_y,
        view_depth,
        image_height,
        image_error,
        max_passes,
        max_samples,
        max_taps,
        signal_size,
        frames,
        pixels_per_degree,
        eta,
        thickness,
        eta_above,
        eta_below,
        png_bits,
    );
}
