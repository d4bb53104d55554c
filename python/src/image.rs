//! Images as numpy arrays: (H, W, 3) or (H, W, 4) float32 or float64 in
//! linear light, converted once to the library's planar f64 `Image` and
//! once back; `apply` (separable kernels, CPU or wgpu) and `reference` (the
//! exact 2D convolution).

use crate::disk::PyDiskKernel;
use crate::kernel::{profile_of, PyKernel};
use crate::{interruptible, path_of, to_py};
use numpy::ndarray::Array3;
use numpy::{Element, IntoPyArray, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use ssskit::filter::accumulate::Accumulate;
use ssskit::filter::angular::{
    angular_view, around_pass, factor_plan, AngularView, FactorArgs, FactorPlan, Light,
};
use ssskit::filter::cpu::{self, PixelSampling, Precision};
use ssskit::filter::disk::{apply_disk_in_place, DiskSetup};
use ssskit::filter::disk_gpu::DiskGpu;
use ssskit::filter::image::{
    read_image as lib_read_image, write_image as lib_write_image, PngDepth,
};
use ssskit::filter::kernel_setup::kernel_setup;
use ssskit::filter::{gpu, FollowSurface, Image, Plane, Scale, Setup};
use ssskit::kernel::angular::AngularFactors;
use ssskit::kernel::disk::DiskKernelFile;

/// The dtype of the arrays that come in: the output has the input's.
#[derive(Clone, Copy, PartialEq)]
enum Dtype {
    F32,
    F64,
}

/// An array argument checked for what the library needs: an ndarray of
/// `ndim` dimensions (the last of 3 or 4 samples for an image), float32 or
/// float64, C-contiguous, within the image caps; before anything is
/// allocated.
fn checked<'py>(
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
    if !arr.is_c_contiguous() {
        return Err(PyValueError::new_err(format!(
            "{what}: the array is not C-contiguous (a slice or a transpose): pass np.ascontiguousarray(...)"
        )));
    }
    ssskit::limits::check_image_size(what, shape[1], shape[0]).map_err(to_py)?;
    Ok((arr, dtype))
}

/// The samples of a checked array, read in place (no copy).
/// `f` on the array's samples, run without the GIL: a 4K image's
/// conversion takes long enough (0.4 s on a loaded 2-core machine) that
/// other Python threads must run meanwhile. Python code may still write to
/// the array as it is read, as it may during numpy's own GIL-free loops.
fn with_samples<R: Send>(
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

enum Samples<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
}

impl Samples<'_> {
    fn get(&self, i: usize) -> f64 {
        match self {
            Samples::F32(s) => f64::from(s[i]),
            Samples::F64(s) => s[i],
        }
    }
}

/// An (H, W, 3|4) array as the library's planar image, NaN and infinite
/// samples refused with the CLI's message.
fn image_of(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Image, Dtype)> {
    image_sanitized(obj, what, Sanitize::Refuse)
}

/// Non-finite samples: refused, or replaced as `ssskit apply --sanitize`
/// replaces them (0 in colour and strength, the farthest depth in depth)
/// with a Python warning saying how many.
#[derive(Clone, Copy, PartialEq)]
enum Sanitize {
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

fn image_sanitized(obj: &Bound<'_, PyAny>, what: &str, how: Sanitize) -> PyResult<(Image, Dtype)> {
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
fn plane_of(obj: &Bound<'_, PyAny>, what: &str, how: Sanitize) -> PyResult<Plane> {
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

/// The library's image as an (H, W, 3|4) array of `dtype`, interleaved
/// once (without the GIL, see [`with_samples`]) into a buffer numpy then
/// owns.
fn array_of<'py>(py: Python<'py>, image: &Image, dtype: Dtype) -> PyResult<Bound<'py, PyAny>> {
    let c = if image.alpha.is_some() { 4 } else { 3 };
    let planes: Vec<&[f64]> = image
        .rgb
        .iter()
        .map(Vec::as_slice)
        .chain(image.alpha.as_deref())
        .collect();
    let shape = (image.height, image.width, c);
    let bad = |e: numpy::ndarray::ShapeError| PyValueError::new_err(e.to_string());
    Ok(match dtype {
        Dtype::F32 => {
            let v: Vec<f32> = py.detach(|| {
                (0..image.len() * c)
                    .map(|i| planes[i % c][i / c] as f32)
                    .collect()
            });
            Array3::from_shape_vec(shape, v)
                .map_err(bad)?
                .into_pyarray(py)
                .into_any()
        }
        Dtype::F64 => {
            let v: Vec<f64> =
                py.detach(|| (0..image.len() * c).map(|i| planes[i % c][i / c]).collect());
            Array3::from_shape_vec(shape, v)
                .map_err(bad)?
                .into_pyarray(py)
                .into_any()
        }
    })
}

/// The scale `ssskit apply` takes from --mm-per-pixel or --fov-y.
fn scale_of(mm_per_pixel: Option<f64>, fov_y: Option<f64>, units_per_mm: f64) -> PyResult<Scale> {
    let scale = match (mm_per_pixel, fov_y) {
        (Some(m), None) => Scale::MmPerPixel(m),
        (None, Some(f)) => Scale::Perspective {
            fov_y_deg: f,
            sss_width: units_per_mm,
        },
        _ => {
            return Err(PyValueError::new_err(
                "give exactly one of mm_per_pixel and fov_y",
            ))
        }
    };
    scale.validate().map_err(to_py)?;
    Ok(scale)
}

/// Applies a kernel to an irradiance array (`ssskit apply`).
///
/// kernel: a separable `Kernel` or a `DiskKernel`. irradiance: (H, W, 3)
/// or (H, W, 4) float32 or float64, linear light, C-contiguous; alpha is
/// carried through. Scale: mm_per_pixel (orthographic) or fov_y in
/// degrees with a depth (H, W) array and units_per_mm. specular: an array
/// like irradiance added after the blur; strength: an (H, W) array that
/// multiplies the kernel's size per pixel; follow_surface: the
/// depth-aware lerp constant C in metres; sanitize: replace NaN/Inf
/// samples (0, the farthest depth) with a warning instead of refusing.
/// Separable kernels: full_factors (the fit's full-resolution factors
/// instead of the real-time tap table, the CLI's default), jitter,
/// precision "f32" or "f64" (CPU fixed-kernel path). Disk kernels:
/// frames (rotations accumulated) and frame_seed (the first frame's
/// index), by default those the kernel's predicted error assumes (its
/// recorded accumulation), else 1 and 0; accumulate "mean" or "ema:W". A kernel with angular entry and exit
/// factors applies them given normals ((H, W, 3) view-space unit normals)
/// and the light: light_toward (x, y, z), n_dot_l ((H, W)), or
/// entry_weighted=True; factors=False leaves them out. backend: "cpu" or
/// "gpu" (wgpu). Returns an array of the input's shape and dtype; on the
/// CPU, equal to the CLI's output bit for bit. Releases the GIL.
#[pyfunction]
#[pyo3(signature = (kernel, irradiance, mm_per_pixel=None, *, fov_y=None,
    units_per_mm=ssskit::engine::Scene::default().units_per_mm, depth=None, specular=None,
    strength=None, follow_surface=None, sanitize=false, full_factors=false, jitter=false,
    precision="f32", frames=None, frame_seed=None, accumulate="mean", normals=None,
    light_toward=None, n_dot_l=None, entry_weighted=false, factors=true, backend="cpu"))]
fn apply<'py>(
    py: Python<'py>,
    kernel: &Bound<'py, PyAny>,
    irradiance: &Bound<'py, PyAny>,
    mm_per_pixel: Option<f64>,
    fov_y: Option<f64>,
    units_per_mm: f64,
    depth: Option<&Bound<'py, PyAny>>,
    specular: Option<&Bound<'py, PyAny>>,
    strength: Option<&Bound<'py, PyAny>>,
    follow_surface: Option<f64>,
    sanitize: bool,
    full_factors: bool,
    jitter: bool,
    precision: &str,
    frames: Option<u32>,
    frame_seed: Option<u32>,
    accumulate: &str,
    normals: Option<&Bound<'py, PyAny>>,
    light_toward: Option<[f64; 3]>,
    n_dot_l: Option<&Bound<'py, PyAny>>,
    entry_weighted: bool,
    factors: bool,
    backend: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let precision = precision_of(precision)?;
    let gpu_backend = gpu_of(backend)?;
    let accumulate = Accumulate::parse(accumulate).map_err(to_py)?;
    let how = if sanitize {
        Sanitize::Replace
    } else {
        Sanitize::Refuse
    };
    let scale = scale_of(mm_per_pixel, fov_y, units_per_mm)?;
    let (image, dtype) = image_sanitized(irradiance, "irradiance", how)?;
    let depth = depth.map(|d| plane_of(d, "depth", how)).transpose()?;
    let strength = strength.map(|d| plane_of(d, "strength", how)).transpose()?;
    let specular = specular
        .map(|s| image_sanitized(s, "specular", how).map(|x| x.0))
        .transpose()?;
    let mut view = Setup {
        passes: Vec::new(),
        scale,
        depth,
        strength,
        follow_surface: follow_surface.map(FollowSurface::InMetres),
        specular,
        jitter,
    };
    view.validate_view(&image).map_err(to_py)?;
    let light = Lights {
        normals,
        toward: light_toward,
        n_dot_l,
        entry_weighted,
        factors,
    };
    if let Ok(disk) = kernel.cast::<PyDiskKernel>() {
        if full_factors || jitter || precision != Precision::F32 {
            return Err(PyValueError::new_err(
                "full_factors, jitter and precision apply to separable kernels; a disk kernel's \
                 samples are its table, turned per pixel and frame",
            ));
        }
        let (frames, frame_seed) = disk.get().inner.frames_to_run(frames, frame_seed);
        let frames = (frame_seed, frames, accumulate);
        let out = run_disk(
            py,
            &disk.get().inner,
            view,
            image,
            &light,
            frames,
            gpu_backend,
        )?;
        return array_of(py, &out, dtype);
    }
    let kernel = kernel.cast::<PyKernel>().map_err(|_| {
        PyTypeError::new_err("kernel: expected an ssskit.Kernel or ssskit.DiskKernel")
    })?;
    if frames.is_some_and(|n| n != 1)
        || accumulate != Accumulate::Mean
        || frame_seed.is_some_and(|n| n != 0)
    {
        return Err(PyValueError::new_err(
            "frames, frame_seed and accumulate apply to disk kernels; a separable kernel is the \
             same every frame",
        ));
    }
    let kernel = &kernel.get().inner;
    let around = light.view(py, kernel.angular.as_ref(), &image, &view.scale)?;
    // The exit factor weighs the subsurface light only: the specular is
    // added after it, outside the pass.
    let specular = if around.is_some() {
        view.specular.take()
    } else {
        None
    };
    let (setup, warnings) = kernel_setup(kernel, full_factors, view, &image).map_err(to_py)?;
    if !warnings.is_empty() {
        let warn = py.import("warnings")?;
        for w in warnings {
            warn.call_method1("warn", (w.to_string(),))?;
        }
    }
    let out = interruptible(py, |_| {
        around_pass(around.as_ref(), image, specular, |img| {
            if gpu_backend {
                gpu::Gpu::new()?.apply(&img, &setup)
            } else {
                let mut img = img;
                cpu::apply_in_place(&mut img, &setup, precision)?;
                Ok(img)
            }
        })
    })?;
    array_of(py, &out, dtype)
}

/// `--precision`'s values.
fn precision_of(name: &str) -> PyResult<Precision> {
    match name {
        "f32" => Ok(Precision::F32),
        "f64" => Ok(Precision::F64),
        p => Err(PyValueError::new_err(format!(
            "precision: invalid value '{p}': expected f32 or f64"
        ))),
    }
}

/// `--backend`'s values (without auto): whether it is the wgpu pass.
fn gpu_of(name: &str) -> PyResult<bool> {
    match name {
        "cpu" => Ok(false),
        "gpu" => Ok(true),
        b => Err(PyValueError::new_err(format!(
            "backend: invalid value '{b}': expected cpu or gpu"
        ))),
    }
}

/// `ssskit apply` with a disk kernel: the disk pass over `frames` (first
/// frame's index, count, accumulation) on the CPU (f64) or with wgpu, the
/// kernel's angular factors around it.
fn run_disk(
    py: Python<'_>,
    k: &DiskKernelFile,
    mut view: Setup,
    image: Image,
    light: &Lights,
    (seed, frames, accumulate): (u32, u32, Accumulate),
    gpu_backend: bool,
) -> PyResult<Image> {
    let around = light.view(py, k.angular.as_ref(), &image, &view.scale)?;
    // The exit factor weighs the subsurface light only: the specular is
    // added after it, outside the pass.
    let specular = if around.is_some() {
        view.specular.take()
    } else {
        None
    };
    let setup = DiskSetup::new(k, view, seed, frames).accumulated_by(accumulate);
    setup.validate(&image).map_err(to_py)?;
    if gpu_backend && setup.accumulate != Accumulate::Mean {
        return Err(PyValueError::new_err(format!(
            "accumulate {}: the wgpu disk pass takes the plain mean; use backend=\"cpu\"",
            setup.accumulate.name()
        )));
    }
    interruptible(py, |_| {
        around_pass(around.as_ref(), image, specular, |img| {
            if gpu_backend {
                DiskGpu::new()?.apply(&img, &setup)
            } else {
                let mut img = img;
                apply_disk_in_place(&mut img, &setup)?;
                Ok(img)
            }
        })
    })
}

/// The angular factors' arguments of `apply`.
struct Lights<'a, 'py> {
    normals: Option<&'a Bound<'py, PyAny>>,
    toward: Option<[f64; 3]>,
    n_dot_l: Option<&'a Bound<'py, PyAny>>,
    entry_weighted: bool,
    factors: bool,
}

impl Lights<'_, '_> {
    /// The argument that only the factors use, if one was given.
    fn any_given(&self) -> Option<&'static str> {
        if self.normals.is_some() {
            Some("normals")
        } else if self.n_dot_l.is_some() {
            Some("n_dot_l")
        } else if self.toward.is_some() {
            Some("light_toward")
        } else if self.entry_weighted {
            Some("entry_weighted")
        } else {
            None
        }
    }

    /// The cosines the kernel's factors take, by the library's
    /// `factor_plan` (the rule `ssskit apply` follows): none without
    /// factors or with factors=False; a warning and none without normals;
    /// the light from exactly one of light_toward, n_dot_l and
    /// entry_weighted.
    fn view<'f>(
        &self,
        py: Python<'_>,
        f: Option<&'f AngularFactors>,
        image: &Image,
        scale: &Scale,
    ) -> PyResult<Option<AngularView<'f>>> {
        let (w, h) = (image.width, image.height);
        let plan = factor_plan(
            f.is_some(),
            &FactorArgs {
                first_given: self.any_given(),
                has_normals: self.normals.is_some(),
                leave_out: !self.factors,
                normals_hint: "normals=(H, W, 3) array",
            },
        )
        .map_err(to_py)?;
        if plan == FactorPlan::WithoutNormals {
            py.import("warnings")?.call_method1(
                "warn",
                (
                    "the kernel carries angular entry and exit factors, but no normals are given: \
                  applied without them (factors=False says so)",
                ),
            )?;
        }
        let (FactorPlan::With, Some(f), Some(normals)) = (plan, f, self.normals) else {
            return Ok(None);
        };
        let (n, _) = image_of(normals, "normals")?;
        let given = [
            self.toward.is_some(),
            self.n_dot_l.is_some(),
            self.entry_weighted,
        ];
        let light = match (self.toward, self.n_dot_l, self.entry_weighted) {
            _ if given.iter().filter(|g| **g).count() > 1 => {
                return Err(PyValueError::new_err(
                    "give one of light_toward, n_dot_l and entry_weighted",
                ))
            }
            (Some(v), _, _) => Light::Toward(v),
            (_, Some(p), _) => Light::Cosines(plane_of(p, "n_dot_l", Sanitize::Refuse)?.data),
            (_, _, true) => Light::EntryWeighted,
            _ => {
                return Err(PyValueError::new_err(
                    "the kernel's entry factor needs the light: give light_toward=(x, y, z), \
                     n_dot_l=(H, W) array or entry_weighted=True (or factors=False to leave the \
                     factors out)",
                ))
            }
        };
        let view = angular_view(f, &n.rgb, light, (w, h), scale).map_err(to_py)?;
        Ok(Some(view))
    }
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
    mm_per_pixel: f64,
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
        let k = cpu::reference_kernel_sampled(&profile, mm_per_pixel, sampling)?;
        cpu::check_reference_fits(image.width, image.height, k.size)?;
        Ok(cpu::convolve_2d(&image, &k))
    })?;
    array_of(py, &out, dtype)
}

/// Reads an image file as the CLI does (.exr as stored, .png sRGB decoded
/// to linear): an (H, W, 3|4) array of dtype "float32" or "float64".
#[pyfunction]
#[pyo3(signature = (path, dtype="float32"))]
fn read_image<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    dtype: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let dtype = match dtype {
        "float32" => Dtype::F32,
        "float64" => Dtype::F64,
        d => {
            return Err(PyValueError::new_err(format!(
                "dtype: invalid value '{d}': expected float32 or float64"
            )))
        }
    };
    let (image, _) = lib_read_image(&path_of(path)?, None).map_err(to_py)?;
    array_of(py, &image, dtype)
}

/// Writes an (H, W, 3|4) array as the CLI writes its outputs: .exr (32-bit
/// float) or .png (sRGB, png_bits 8 or 16), atomically.
#[pyfunction]
#[pyo3(signature = (path, image, *, png_bits=8))]
fn write_image(path: &Bound<'_, PyAny>, image: &Bound<'_, PyAny>, png_bits: u32) -> PyResult<()> {
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
    lib_write_image(&path_of(path)?, &image, depth).map_err(to_py)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(apply, m)?)?;
    m.add_function(wrap_pyfunction!(reference, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    Ok(())
}
