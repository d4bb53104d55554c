//! `apply` (`ssskit apply`): a separable or disk kernel over an irradiance
//! array with [`ApplyOptions`], on the CPU or with wgpu, the kernel's
//! angular factors around the pass. The default separable pass (a uniform
//! scale, f32, the CPU) filters one channel at a time in f32 into the
//! output array, never holding the f64 image: an 8K RGB frame then peaks
//! at the input, the output and one plane.

use crate::args::kw;
use crate::call::{interruptible, to_py, warn_all};
use crate::disk::PyDiskKernel;
use crate::image::{array_of, checked, image_sanitized, out_array, plane_of, Dtype, Sanitize};
use crate::kernel::PyKernel;
use crate::light::light_view;
use crate::options::{ApplyOptions, Backend};
use numpy::PyUntypedArrayMethods;
use numpy::{PyArrayDyn, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssskit::error::finite_positive;
use ssskit::filter::accumulate::Accumulate;
use ssskit::filter::angular::{around_pass, AngularView};
use ssskit::filter::cpu;
use ssskit::filter::disk::{apply_disk_in_place, DiskSetup};
use ssskit::filter::disk_gpu::DiskGpu;
use ssskit::filter::kernel_setup::kernel_setup;
use ssskit::filter::separable::Precision;
use ssskit::filter::{gpu, FollowSurface, Image, Scale, Setup};
use ssskit::kernel::angular::AngularFactors;
use ssskit::kernel::disk::DiskKernelFile;
use ssskit::kernel::KernelFile;

/// The backend when none is given: the CPU, not the CLI's `auto`. A
/// library call is one of many in a process: the CPU result is the f64
/// reference's to f32 round-off and equal to the CLI's `--backend cpu`
/// bit for bit on every machine, and no call pays for opening a GPU
/// adapter (as `auto` does to learn whether the one there is hardware).
const DEFAULT_BACKEND: Backend = Backend::Cpu;

/// Applies a kernel to an irradiance array (`ssskit apply`).
///
/// kernel: a separable `Kernel` or a `DiskKernel`. irradiance: (H, W, 3)
/// or (H, W, 4) float32 or float64, linear light (a non-contiguous array is
/// copied once); alpha is carried through. The options are keywords, or an
/// `ApplyOptions` given as options= (keywords beside it replace its
/// values). Scale: mm_per_pixel (orthographic) or fov_y in degrees with a
/// depth (H, W) array and units_per_mm (default 0.001, a scene in metres).
/// specular: an array like irradiance added after the blur; strength: an
/// (H, W) array that multiplies the kernel's size per pixel;
/// follow_surface: the depth-aware lerp constant C in metres; sanitize:
/// replace NaN/Inf samples (0, the farthest depth) with a warning instead
/// of refusing. Separable kernels: full_factors (the fit's full-resolution
/// factors instead of the real-time tap table, the CLI's default), jitter,
/// precision "f32" or "f64" (CPU fixed-kernel path). Disk kernels: frames
/// (rotations accumulated) and frame_seed (the first frame's index), by
/// default those the kernel's predicted error assumes (its recorded
/// accumulation), else 1 and 0; accumulate "mean" or "ema:W". A kernel with angular entry and exit
/// factors applies them given normals ((H, W, 3) view-space unit normals)
/// and the light: light_toward (x, y, z), n_dot_l ((H, W)), or
/// entry_weighted=True; factors=False leaves them out. backend: "cpu"
/// (the default, unlike the CLI's auto: the same bits as the CLI's
/// --backend cpu on every machine, and no GPU adapter opened per call),
/// "gpu" (wgpu) or "auto" (a hardware GPU if there is one, else the CPU,
/// as the CLI decides). out: an array of the input's shape and dtype to
/// write the result into (it may be the input itself: filtered in place),
/// else a new array. Returns the result; on the CPU, equal to the CLI's
/// output bit for bit. Releases the GIL; Ctrl-C raises KeyboardInterrupt
/// when the pass returns.
#[pyfunction]
#[pyo3(signature = (kernel, irradiance, mm_per_pixel=None, *, options=None, out=None, **keywords))]
#[pyo3(
    text_signature = "(kernel, irradiance, mm_per_pixel=None, *, options=None, out=None, \
    fov_y=None, units_per_mm=None, depth=None, specular=None, strength=None, \
    follow_surface=None, sanitize=False, full_factors=False, jitter=False, precision='f32', \
    frames=None, frame_seed=None, accumulate=None, normals=None, light_toward=None, n_dot_l=None, \
    entry_weighted=False, factors=True, backend='cpu')"
)]
fn apply<'py>(
    py: Python<'py>,
    kernel: &Bound<'py, PyAny>,
    irradiance: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = kw::mm_per_pixel)] mm_per_pixel: Option<f64>,
    options: Option<&Bound<'py, ApplyOptions>>,
    out: Option<&Bound<'py, PyAny>>,
    keywords: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let mut o = match options {
        Some(opts) => opts.get().with(py, keywords)?,
        None => ApplyOptions::default().with(py, keywords)?,
    };
    if mm_per_pixel.is_some() {
        o.mm_per_pixel = mm_per_pixel;
    }
    let scale = scale_of(&o)?;
    let call = Call {
        target: Target { irradiance, out },
        o: &o,
        scale,
    };
    if let Ok(disk) = kernel.cast::<PyDiskKernel>() {
        return apply_disk(py, &disk.get().inner, call);
    }
    let kernel = kernel.cast::<PyKernel>().map_err(|_| {
        PyTypeError::new_err("kernel: expected an ssskit.Kernel or ssskit.DiskKernel")
    })?;
    let d = &o.disk;
    let weighed = d.accumulate.is_some_and(|a| a != Accumulate::Mean);
    if d.frames.is_some_and(|n| n != 1) || weighed || d.frame_seed.is_some_and(|n| n != 0) {
        return Err(PyValueError::new_err(
            "frames, frame_seed and accumulate apply to disk kernels; a separable kernel is the \
             same every frame",
        ));
    }
    apply_separable(py, &kernel.get().inner, call)
}

/// The scale `ssskit apply` takes from --mm-per-pixel, or --fov-y with
/// --units-per-mm (which the orthographic scale does not take).
fn scale_of(o: &ApplyOptions) -> PyResult<Scale> {
    let scale = match (o.mm_per_pixel, o.fov_y, o.units_per_mm) {
        (Some(_), None, Some(_)) => {
            return Err(PyValueError::new_err(
                "units_per_mm: the perspective scale's (with fov_y); mm_per_pixel is a scale \
                 of its own",
            ))
        }
        (Some(m), None, None) => Scale::MmPerPixel(m),
        (None, Some(f), u) => Scale::Perspective {
            fov_y_deg: f,
            // The library's check, under the keyword's name.
            sss_width: match u {
                Some(u) => finite_positive("apply", "units_per_mm", u, "").map_err(to_py)?,
                None => ssskit::engine::Scene::default().units_per_mm,
            },
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

/// Whether the pass runs with wgpu: `auto` opens the adapter to learn
/// whether it is hardware, as `ssskit apply` does.
fn on_gpu(backend: Option<Backend>) -> bool {
    match backend.unwrap_or(DEFAULT_BACKEND) {
        Backend::Cpu => false,
        Backend::Gpu => true,
        Backend::Auto => ssskit::gpu::GpuContext::open().is_ok_and(|ctx| !ctx.is_software()),
    }
}

fn sanitize_of(o: &ApplyOptions) -> Sanitize {
    if o.sanitize {
        Sanitize::Replace
    } else {
        Sanitize::Refuse
    }
}

/// The input array and where the result goes.
#[derive(Clone, Copy)]
struct Target<'a, 'py> {
    irradiance: &'a Bound<'py, PyAny>,
    out: Option<&'a Bound<'py, PyAny>>,
}

/// One call's array, options and scale, as each pass takes them.
#[derive(Clone, Copy)]
struct Call<'a, 'py> {
    target: Target<'a, 'py>,
    o: &'a ApplyOptions,
    scale: Scale,
}

/// The view of `--mm-per-pixel`/`--fov-y`, `--depth`, `--strength`,
/// `--specular`, `--follow-surface` and `--jitter`, checked against
/// `image` (no passes yet).
fn view_of(o: &ApplyOptions, scale: Scale, image: &Image, py: Python<'_>) -> PyResult<Setup> {
    let how = sanitize_of(o);
    let plane = |a: &Option<Py<PyAny>>, what: &str| {
        a.as_ref()
            .map(|a| plane_of(a.bind(py), what, how))
            .transpose()
    };
    let specular = o
        .specular
        .as_ref()
        .map(|s| image_sanitized(s.bind(py), "specular", how).map(|x| x.0))
        .transpose()?;
    let view = Setup {
        passes: Vec::new(),
        scale,
        depth: plane(&o.depth, "depth")?,
        strength: plane(&o.strength, "strength")?,
        follow_surface: o.follow_surface.map(FollowSurface::InMetres),
        specular,
        jitter: o.separable.jitter,
    };
    view.validate_view(image).map_err(to_py)?;
    Ok(view)
}

/// What a pass through the library's f64 image takes beside its view: the
/// image, the kernel's angular factors around the pass and the specular
/// added after them.
struct Prepared<'f> {
    image: Image,
    dtype: Dtype,
    around: Option<AngularView<'f>>,
    specular: Option<Image>,
}

/// The irradiance as the library's image and its view (no passes yet).
fn prepare<'f>(
    py: Python<'_>,
    call: Call<'_, '_>,
    angular: Option<&'f AngularFactors>,
) -> PyResult<(Prepared<'f>, Setup)> {
    let Call { target, o, scale } = call;
    let (image, dtype) = image_sanitized(target.irradiance, "irradiance", sanitize_of(o))?;
    let mut view = view_of(o, scale, &image, py)?;
    let around = light_view(py, &o.light, angular, &image, &view.scale)?;
    // The exit factor weighs the subsurface light only: the specular is
    // added after it, outside the pass.
    let specular = around.as_ref().and_then(|_| view.specular.take());
    let prepared = Prepared {
        image,
        dtype,
        around,
        specular,
    };
    Ok((prepared, view))
}

/// Runs `pass` on the prepared image with the factors around it (without
/// the GIL, Ctrl-C raised when it returns): the result as `target` asks.
fn run<'py>(
    py: Python<'py>,
    p: Prepared<'_>,
    target: Target<'_, 'py>,
    pass: impl FnOnce(Image) -> ssskit::Result<Image> + Send,
) -> PyResult<Bound<'py, PyAny>> {
    let Prepared {
        image,
        dtype,
        around,
        specular,
    } = p;
    let result = interruptible(py, |_| around_pass(around.as_ref(), image, specular, pass))?;
    array_of(py, &result, dtype, target.out)
}

/// A separable kernel's pass: in f32 planes where it can ([`in_planes`]),
/// else through the library's f64 image.
fn apply_separable<'py>(
    py: Python<'py>,
    kernel: &KernelFile,
    call: Call<'_, 'py>,
) -> PyResult<Bound<'py, PyAny>> {
    let Call { target, o, .. } = call;
    let gpu_backend = on_gpu(o.backend);
    if !gpu_backend {
        if let Some(done) = in_planes(py, kernel, call)? {
            return Ok(done);
        }
    }
    let (p, view) = prepare(py, call, kernel.angular.as_ref())?;
    let full = o.separable.full_factors;
    let (setup, warnings) = kernel_setup(kernel, full, view, &p.image).map_err(to_py)?;
    warn_all(py, warnings.iter().map(|w| w.to_string()))?;
    let precision = o.separable.precision;
    run(
        py,
        p,
        target,
        gpu_or_cpu(
            gpu_backend,
            |img| gpu::Gpu::new()?.apply(img, &setup),
            |img| cpu::apply_in_place(img, &setup, precision),
        ),
    )
}

/// One pass: with wgpu (`gpu_pass`, a new image) where `gpu_backend`,
/// else on the CPU in place (`cpu_pass`).
fn gpu_or_cpu(
    gpu_backend: bool,
    gpu_pass: impl FnOnce(&Image) -> ssskit::Result<Image> + Send,
    cpu_pass: impl FnOnce(&mut Image) -> ssskit::Result<()> + Send,
) -> impl FnOnce(Image) -> ssskit::Result<Image> + Send {
    move |mut img| {
        if gpu_backend {
            gpu_pass(&img)
        } else {
            cpu_pass(&mut img)?;
            Ok(img)
        }
    }
}

/// The default pass without the f64 image: under a uniform scale, with no
/// per-pixel planes, specular, jitter or angular factors, on the CPU in
/// f32, for a finite float32 input. The input is copied into the output
/// array (or filtered there, when `out` is the input) and each channel is
/// filtered in turn as one f32 plane (`filter::cpu::apply_plane_f32_in_place`,
/// the CLI's samples bit for bit). None where the pass needs more.
fn in_planes<'py>(
    py: Python<'py>,
    kernel: &KernelFile,
    call: Call<'_, 'py>,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let Call { target, o, scale } = call;
    let plain = matches!(scale, Scale::MmPerPixel(_))
        && o.depth.is_none()
        && o.strength.is_none()
        && o.specular.is_none()
        && o.follow_surface.is_none()
        && !o.separable.jitter
        && o.separable.precision == Precision::F32
        && o.light.normals.is_none();
    if !plain {
        return Ok(None);
    }
    let (arr, dtype) = checked(target.irradiance, "irradiance", true)?;
    if dtype != Dtype::F32 {
        return Ok(None);
    }
    let input = arr.cast::<PyArrayDyn<f32>>()?;
    let finite = {
        let r = input.try_readonly()?;
        let s = r
            .as_slice()
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        py.detach(|| s.iter().all(|v| v.is_finite()))
    };
    if !finite {
        return Ok(None);
    }
    let shape = arr.shape().to_vec();
    let (h, w, c) = (shape[0], shape[1], shape[2]);
    // The library's checks read only the image's size: no samples needed.
    let size = Image {
        width: w,
        height: h,
        rgb: Default::default(),
        alpha: None,
    };
    let view = view_of(o, scale, &size, py)?;
    // Without normals a kernel's factors are left out (with a warning).
    light_view(py, &o.light, kernel.angular.as_ref(), &size, &view.scale)?;
    let full = o.separable.full_factors;
    let (setup, warnings) = kernel_setup(kernel, full, view, &size).map_err(to_py)?;
    warn_all(py, warnings.iter().map(|w| w.to_string()))?;
    let dest = match target.out {
        Some(out) => out_array(out, &shape, Dtype::F32)?.cast_into::<PyArrayDyn<f32>>()?,
        None => PyArrayDyn::<f32>::zeros(py, &[h, w, c][..], false),
    };
    let in_place = dest.is(&arr);
    {
        let src = (!in_place).then(|| input.try_readonly()).transpose()?;
        let mut rw = dest.try_readwrite()?;
        let buf = rw
            .as_slice_mut()
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let src = src
            .as_ref()
            .map(|r| {
                r.as_slice()
                    .map_err(|e| PyValueError::new_err(e.to_string()))
            })
            .transpose()?;
        interruptible(py, |_| {
            if let Some(src) = src {
                buf.copy_from_slice(src);
            }
            let (mut plane, mut halo) = (vec![0.0f32; w * h], Vec::new());
            for ch in 0..3 {
                plane
                    .iter_mut()
                    .enumerate()
                    .for_each(|(i, p)| *p = buf[i * c + ch]);
                cpu::apply_plane_f32_in_place(&mut plane, &mut halo, (w, h), &setup, ch)?;
                plane
                    .iter()
                    .enumerate()
                    .for_each(|(i, p)| buf[i * c + ch] = *p);
            }
            Ok(())
        })?;
    }
    Ok(Some(dest.into_any()))
}

/// `ssskit apply` with a disk kernel: the disk pass over `frames` (first
/// frame's index, count, accumulation) on the CPU (f64) or with wgpu, the
/// kernel's angular factors around it.
fn apply_disk<'py>(
    py: Python<'py>,
    k: &DiskKernelFile,
    call: Call<'_, 'py>,
) -> PyResult<Bound<'py, PyAny>> {
    let o = call.o;
    let s = &o.separable;
    if s.full_factors || s.jitter || s.precision != Precision::F32 {
        return Err(PyValueError::new_err(
            "full_factors, jitter and precision apply to separable kernels; a disk kernel's \
             samples are its table, turned per pixel and frame",
        ));
    }
    let accumulate = o.disk.accumulate.unwrap_or(Accumulate::Mean);
    let ema = accumulate != Accumulate::Mean;
    // `auto` runs an EMA on the CPU, as the CLI does; `gpu` refuses it.
    let gpu_backend = match o.backend {
        Some(Backend::Auto) if ema => false,
        b => on_gpu(b),
    };
    if gpu_backend && ema {
        return Err(PyValueError::new_err(format!(
            "accumulate {}: the wgpu disk pass takes the plain mean; use backend=\"cpu\"",
            accumulate.name()
        )));
    }
    let (p, view) = prepare(py, call, k.angular.as_ref())?;
    let (frames, first) = k.frames_to_run(o.disk.frames, o.disk.frame_seed);
    let setup = DiskSetup::new(k, view, first, frames).accumulated_by(accumulate);
    setup.validate(&p.image).map_err(to_py)?;
    run(
        py,
        p,
        call.target,
        gpu_or_cpu(
            gpu_backend,
            |img| DiskGpu::new()?.apply(img, &setup),
            |img| apply_disk_in_place(img, &setup),
        ),
    )
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<ApplyOptions>()?;
    m.add_function(wrap_pyfunction!(apply, m)?)?;
    Ok(())
}
