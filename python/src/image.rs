//! Images as numpy arrays: (H, W, 3) or (H, W, 4) float32 or float64 in
//! linear light, converted once to the library's planar f64 `Image` and
//! once back; image files read and written as the CLI does; `reference`
//! (the exact 2D convolution) and `diff` (`ssskit diff`).

use crate::args::{kw, one_of};
use crate::call::{file_op, interruptible, json_to_py, path_of, to_py};
use crate::profile::profile_of;
use numpy::ndarray::Array3;
use numpy::{
    Element, IntoPyArray, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use ssskit::filter::exact::{self, PixelSampling};
use ssskit::filter::image::{
    read_image as lib_read_image, write_image as lib_write_image, PngDepth,
};
use ssskit::filter::{Image, Plane, Scale};

/// The dtype of the arrays that come in: the output has the input's.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Dtype {
    F32,
    F64,
}

impl Dtype {
    /// The `dtype` keyword's values.
    const NAMES: [(&str, Dtype); 2] = [("float32", Dtype::F32), ("float64", Dtype::F64)];
}

/// An array argument checked for what the library needs: an ndarray of
/// `ndim` dimensions (the last of 3 or 4 samples for an image), float32 or
/// float64, within the image caps, before anything is allocated. A
/// non-contiguous array (a slice, a transpose) is copied once into a
/// C-contiguous one (`numpy.ascontiguousarray`); others are read in place.
pub(crate) fn checked<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    image: bool,
) -> PyResult<(Bound<'py, PyUntypedArray>, Dtype)> {
    let expect = if image {
        "a numpy array of shape (H, W, 3) or (H, W, 4)"
    } else {
        "a numpy array of shape (H, W)"
    };
    let arr = obj
        .cast::<PyUntypedArray>()
        .map_err(|_| {
            PyTypeError::new_err(format!("{what}: expected {expect}, float32 or float64"))
        })?
        .clone();
    let shape = arr.shape().to_vec();
    let ok = if image {
        shape.len() == 3 && (shape[2] == 3 || shape[2] == 4)
    } else {
        shape.len() == 2
    };
    if !ok {
        return Err(PyValueError::new_err(format!(
            "{what}: expected {expect}, got shape {shape:?}"
        )));
    }
    let dtype = if arr.cast::<numpy::PyArrayDyn<f32>>().is_ok() {
        Dtype::F32
    } else if arr.cast::<numpy::PyArrayDyn<f64>>().is_ok() {
        Dtype::F64
    } else {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected float32 or float64 samples, got {}",
            arr.dtype()
        )));
    };
    ssskit::limits::check_image_size(what, shape[1], shape[0]).map_err(to_py)?;
    if arr.is_c_contiguous() {
        return Ok((arr, dtype));
    }
    let copy = obj
        .py()
        .import("numpy")?
        .call_method1("ascontiguousarray", (&arr,))?;
    Ok((copy.cast_into::<PyUntypedArray>()?, dtype))
}

/// `f` on the samples of a checked array, read in place (no copy), run
/// without the GIL: a 4K image's conversion takes long enough (0.4 s on a
/// loaded 2-core machine) that other Python threads must run meanwhile.
/// Python code may still write to the array as it is read, as it may
/// during numpy's own GIL-free loops.
pub(crate) fn with_samples<R: Send>(
    arr: &Bound<'_, PyUntypedArray>,
    dtype: Dtype,
    f: impl FnOnce(Samples<'_>) -> R + Send,
) -> PyResult<R> {
    let py = arr.py();
    fn slice<'a, T: Element>(r: &'a numpy::PyReadonlyArrayDyn<'_, T>) -> PyResult<&'a [T]> {
        r.as_slice()
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }
    Ok(match dtype {
        Dtype::F32 => {
            let r = arr.cast::<numpy::PyArrayDyn<f32>>()?.try_readonly()?;
            let s = slice(&r)?;
            py.detach(|| f(Samples::F32(s)))
        }
        Dtype::F64 => {
            let r = arr.cast::<numpy::PyArrayDyn<f64>>()?.try_readonly()?;
            let s = slice(&r)?;
            py.detach(|| f(Samples::F64(s)))
        }
    })
}

/// The samples of an array, interleaved as numpy holds them.
pub(crate) enum Samples<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
}

impl Samples<'_> {
    pub(crate) fn get(&self, i: usize) -> f64 {
        match self {
            Samples::F32(s) => f64::from(s[i]),
            Samples::F64(s) => s[i],
        }
    }
}

/// An (H, W, 3|4) array as the library's planar image, NaN and infinite
/// samples refused with the CLI's message.
pub(crate) fn image_of(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Image, Dtype)> {
    image_sanitized(obj, what, Sanitize::Refuse)
}

/// Non-finite samples: refused, or replaced as `ssskit apply --sanitize`
/// replaces them (0 in colour and strength, the farthest depth in depth)
/// with a Python warning saying how many.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Sanitize {
    Refuse,
    Replace,
}

fn warn_replaced(obj: &Bound<'_, PyAny>, what: &str, n: usize) -> PyResult<()> {
    if n > 0 {
        obj.py().import("warnings")?.call_method1(
            "warn",
            (format!(
                "{what}: replaced {n} NaN/Inf samples (sanitize=True)"
            ),),
        )?;
    }
    Ok(())
}

pub(crate) fn image_sanitized(
    obj: &Bound<'_, PyAny>,
    what: &str,
    how: Sanitize,
) -> PyResult<(Image, Dtype)> {
    let (arr, dtype) = checked(obj, what, true)?;
    let shape = arr.shape().to_vec();
    let (h, w, c) = (shape[0], shape[1], shape[2]);
    let (image, n) = with_samples(&arr, dtype, |s| {
        let plane = |k: usize| (0..w * h).map(|i| s.get(i * c + k)).collect::<Vec<f64>>();
        let mut image = Image {
            width: w,
            height: h,
            rgb: [plane(0), plane(1), plane(2)],
            alpha: (c == 4).then(|| plane(3)),
        };
        let n = image.check_finite(what, how == Sanitize::Replace);
        n.map(|n| (image, n))
    })?
    .map_err(to_py)?;
    warn_replaced(obj, what, n)?;
    Ok((image, dtype))
}

/// An (H, W) array as a plane (depth, strength, N.L), NaN and infinite
/// values refused, or with `Replace` filled as [`Sanitize`] says.
pub(crate) fn plane_of(obj: &Bound<'_, PyAny>, what: &str, how: Sanitize) -> PyResult<Plane> {
    let (arr, dtype) = checked(obj, what, false)?;
    let shape = arr.shape().to_vec();
    let data = with_samples(&arr, dtype, |s| {
        (0..shape[0] * shape[1]).map(|i| s.get(i)).collect()
    })?;
    let mut plane = Plane {
        width: shape[1],
        height: shape[0],
        data,
    };
    let replace = how == Sanitize::Replace;
    let n = if what == "depth" {
        plane.check_finite_depth(what, replace)
    } else {
        plane.check_finite(what, replace, 0.0)
    }
    .map_err(to_py)?;
    warn_replaced(obj, what, n)?;
    Ok(plane)
}

/// The library's image as an (H, W, 3|4) array of `dtype`: written into
/// `out` when given (and returned), else a new array interleaved once
/// (without the GIL, see [`with_samples`]) into a buffer numpy then owns.
pub(crate) fn array_of<'py>(
    py: Python<'py>,
    image: &Image,
    dtype: Dtype,
    out: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let c = if image.alpha.is_some() { 4 } else { 3 };
    let planes: Vec<&[f64]> = image
        .rgb
        .iter()
        .map(Vec::as_slice)
        .chain(image.alpha.as_deref())
        .collect();
    let sample = |i: usize| planes[i % c][i / c];
    let shape = [image.height, image.width, c];
    let n = image.len() * c;
    let Some(out) = out else {
        return match dtype {
            Dtype::F32 => new_array(
                py,
                shape,
                py.detach(|| (0..n).map(|i| sample(i) as f32).collect()),
            ),
            Dtype::F64 => new_array(py, shape, py.detach(|| (0..n).map(sample).collect())),
        };
    };
    let arr = out_array(out, &shape, dtype)?;
    match dtype {
        Dtype::F32 => fill(py, &arr.cast_into::<PyArrayDyn<f32>>()?, |i| {
            sample(i) as f32
        }),
        Dtype::F64 => fill(py, &arr.cast_into::<PyArrayDyn<f64>>()?, sample),
    }?;
    Ok(out.clone())
}

/// `out`: a writeable C-contiguous array of the result's shape and dtype.
pub(crate) fn out_array<'py>(
    out: &Bound<'py, PyAny>,
    shape: &[usize],
    dtype: Dtype,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let arr = out.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err("out: expected a numpy array of the input's shape and dtype")
    })?;
    let same_dtype = match dtype {
        Dtype::F32 => arr.cast::<PyArrayDyn<f32>>().is_ok(),
        Dtype::F64 => arr.cast::<PyArrayDyn<f64>>().is_ok(),
    };
    if arr.shape() != shape || !same_dtype || !arr.is_c_contiguous() {
        return Err(PyValueError::new_err(format!(
            "out: expected a C-contiguous array of shape {shape:?} and the input's dtype, got \
             shape {:?}, {}",
            arr.shape(),
            arr.dtype()
        )));
    }
    Ok(arr.clone())
}

fn new_array<'py, T: Element>(
    py: Python<'py>,
    [h, w, c]: [usize; 3],
    v: Vec<T>,
) -> PyResult<Bound<'py, PyAny>> {
    let a =
        Array3::from_shape_vec((h, w, c), v).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

fn fill<T: Element + Send>(
    py: Python<'_>,
    arr: &Bound<'_, PyArrayDyn<T>>,
    sample: impl Fn(usize) -> T + Sync,
) -> PyResult<()> {
    let mut rw = arr.try_readwrite()?;
    let buf = rw
        .as_slice_mut()
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    py.detach(|| buf.iter_mut().enumerate().for_each(|(i, v)| *v = sample(i)));
    Ok(())
}

/// The exact 2D convolution of an irradiance array with the profile's full
/// 2D kernel (`ssskit apply --reference`, CPU, f64): sampling "average"
/// (over each pixel) or "centre".
#[pyfunction]
#[pyo3(signature = (profile, irradiance, mm_per_pixel, *, sampling="average"))]
fn reference<'py>(
    py: Python<'py>,
    profile: &Bound<'py, PyAny>,
    irradiance: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::mm_per_pixel)] mm_per_pixel: f64,
    sampling: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let sampling = match sampling {
        "average" => PixelSampling::Average,
        "centre" | "center" => PixelSampling::Centre,
        s => {
            return Err(PyValueError::new_err(format!(
                "sampling: invalid value '{s}': expected average or centre"
            )))
        }
    };
    let profile = profile_of(profile)?;
    Scale::MmPerPixel(mm_per_pixel).validate().map_err(to_py)?;
    let (image, dtype) = image_of(irradiance, "irradiance")?;
    let out = interruptible(py, |_| {
        let k = exact::reference_kernel_sampled(&profile, mm_per_pixel, sampling)?;
        exact::check_reference_fits(image.width, image.height, k.size)?;
        Ok(exact::convolve_2d(&image, &k))
    })?;
    array_of(py, &out, dtype, None)
}

/// Reads an image file as the CLI does (.exr as stored, .png sRGB decoded
/// to linear), without the GIL: an (H, W, 3|4) array of dtype "float32"
/// or "float64".
#[pyfunction]
#[pyo3(signature = (path, dtype="float32"))]
fn read_image<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    dtype: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let dtype = one_of("dtype", dtype, &Dtype::NAMES, "float32 or float64")?;
    let path = path_of(path)?;
    let (image, _) = file_op(py, || lib_read_image(&path, None))?;
    array_of(py, &image, dtype, None)
}

/// Writes an (H, W, 3|4) array as the CLI writes its outputs: .exr (32-bit
/// float) or .png (sRGB, png_bits 8 or 16), atomically, without the GIL.
/// A named pipe is written only while a program reads it: one with no
/// reader is refused at once (OSError), never waited for.
#[pyfunction]
#[pyo3(signature = (path, image, *, png_bits=8))]
fn write_image(
    py: Python<'_>,
    path: &Bound<'_, PyAny>,
    image: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = kw::png_bits)] png_bits: u32,
) -> PyResult<()> {
    let depth = match png_bits {
        8 => PngDepth::Eight,
        16 => PngDepth::Sixteen,
        b => {
            return Err(PyValueError::new_err(format!(
                "png_bits: invalid value {b}: expected 8 or 16"
            )))
        }
    };
    let (image, _) = image_of(image, "image")?;
    let path = path_of(path)?;
    file_op(py, || lib_write_image(&path, &image, depth))
}

/// An image argument of `diff`: an array, or an image file read as the
/// CLI reads it (named by its path in messages).
fn image_or_file(py: Python<'_>, obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Image> {
    if obj.cast::<PyUntypedArray>().is_ok() {
        return Ok(image_of(obj, what)?.0);
    }
    let path = path_of(obj).map_err(|_| {
        PyTypeError::new_err(format!(
            "{what}: expected an (H, W, 3|4) array or the path of an image file"
        ))
    })?;
    file_op(py, || {
        let (mut image, _) = lib_read_image(&path, None)?;
        image.check_finite(&path.display().to_string(), false)?;
        Ok(image)
    })
}

/// The image-space error between a reference `a` and an image `b`
/// (`ssskit diff A B --json`): arrays or image files; returns a dict of
/// per-channel (r, g, b) lists: rms, max_abs, and rms_rel and max_rel
/// relative to A's peak in that channel.
#[pyfunction]
fn diff<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let a = image_or_file(py, a, "a")?;
    let b = image_or_file(py, b, "b")?;
    let stats = py
        .detach(|| ssskit::filter::diff::compare(&a, &b))
        .map_err(to_py)?;
    json_to_py(py, &stats)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(reference, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(diff, m)?)?;
    Ok(())
}
