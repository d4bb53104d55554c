//! The CPU paths, deterministic (rayon over rows, no cross-thread sums): the
//! exact 2D convolution with the full 2D kernel (direct, or FFT for large
//! kernels) and Freude 2014, algorithm 4.1 per pixel, the algorithm the GPU runs, in
//! f64; the separable/rank-N application with fixed integer kernels in f64
//! or f32 ([`Precision`]).

use super::{Image, Setup, Taps};
use crate::error::{Error, Result};
use crate::kernel::{Kernel2D, Kernel2DSpec};
use crate::profile::Profile;
use rayon::prelude::*;
use rustfft::num_complex::Complex;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    Horizontal,
    Vertical,
}

/// A 1D kernel on whole pixels: `weights[k]` at pixel offset `first + k`.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelKernel {
    pub first: i64,
    pub weights: Vec<[f64; 3]>,
}

impl PixelKernel {
    /// The taps at a constant step (pixels per mm): each tap's linear
    /// interpolation between its two neighbouring pixels is folded into the
    /// integer kernel. With clamp-to-edge sampling this equals the per-pixel
    /// algorithm exactly (clamping the position or the two indices gives the
    /// same samples).
    pub fn from_taps(t: &Taps, step: f64) -> PixelKernel {
        // A tap within round-off of a whole pixel stays one entry; the
        // bounds come from the same snapped positions as the loop below.
        let pos: Vec<f64> = t
            .offsets_mm
            .iter()
            .map(|o| {
                let p = o * step;
                if (p - p.round()).abs() < 1e-9 {
                    p.round()
                } else {
                    p
                }
            })
            .collect();
        let lo = pos.iter().fold(f64::INFINITY, |a, &p| a.min(p.floor())) as i64;
        let hi = pos.iter().fold(f64::NEG_INFINITY, |a, &p| a.max(p.floor())) as i64 + 1;
        let mut weights = vec![[0.0; 3]; (hi - lo + 1) as usize];
        for (&p, w) in pos.iter().zip(&t.weights) {
            let i0 = p.floor();
            let f = p - i0;
            let k = (i0 as i64 - lo) as usize;
            for c in 0..3 {
                weights[k][c] += w[c] * (1.0 - f);
                weights[k + 1][c] += w[c] * f;
            }
        }
        PixelKernel { first: lo, weights }
    }
}

/// Working precision of the fixed-kernel (uniform-scale) path, the only
/// path that has both: the per-pixel algorithm 4.1 (strength, perspective,
/// follow-surface) and the exact 2D reference are f64 only. Output images
/// are at most f32 (EXR), so f32 accumulation over a few dozen taps (about
/// taps x 1e-7 of the peak) loses nothing the file keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    F32,
    F64,
}

impl Precision {
    /// [`apply_separable_into`] in this precision.
    pub fn separable_into(self, image: &Image, kernels: &[PixelKernel], out: &mut Image) {
        match self {
            Precision::F32 => apply_separable_into::<f32>(image, kernels, out),
            Precision::F64 => apply_separable_into::<f64>(image, kernels, out),
        }
    }
}

/// Runs `setup` on `image` in f64: [`apply_with`] at [`Precision::F64`].
pub fn apply(image: &Image, setup: &Setup) -> Result<Image> {
    apply_with(image, setup, Precision::F64)
}

/// Runs `setup` on `image`: the fixed-kernel fast path in `precision` when
/// the scale is uniform, else the per-pixel algorithm (f64 whatever
/// `precision` says); specular added after.
pub fn apply_with(image: &Image, setup: &Setup, precision: Precision) -> Result<Image> {
    setup.validate(image)?;
    let out = if setup.is_uniform() {
        let step = setup.scale.step_base(image.height);
        let kernels: Vec<PixelKernel> = setup
            .passes
            .iter()
            .map(|t| PixelKernel::from_taps(t, step))
            .collect();
        apply_separable_in(image, &kernels, precision)
    } else {
        apply_screen_space(image, setup)
    };
    Ok(add_specular(out, setup.specular.as_ref()))
}

fn add_specular(mut out: Image, specular: Option<&Image>) -> Image {
    if let Some(s) = specular {
        for c in 0..3 {
            out.rgb[c]
                .iter_mut()
                .zip(&s.rgb[c])
                .for_each(|(o, v)| *o += v);
        }
    }
    out
}

/// Rank-N separable convolution: sum over kernels of vertical(horizontal(I)),
/// borders clamped.
pub fn apply_separable(image: &Image, kernels: &[PixelKernel]) -> Image {
    apply_separable_in(image, kernels, Precision::F64)
}

/// [`apply_separable`] in `precision`, into a fresh image.
pub fn apply_separable_in(image: &Image, kernels: &[PixelKernel], precision: Precision) -> Image {
    let mut out = Image::new(image.width, image.height);
    for plane in out.rgb.iter_mut() {
        advise_huge_pages(plane);
    }
    precision.separable_into(image, kernels, &mut out);
    out.alpha = image.alpha.clone();
    out
}

/// Asks Linux for transparent huge pages on a fresh buffer before its first
/// write, as NumPy does for large arrays: a new 1080p f64 image is 48 MB,
/// and faulting it in 4 KiB pages cost more than the f32 convolution itself
/// (measured in docs/filter.md). A hint: failure changes nothing. Only whole
/// 2 MiB extents inside `v` are advised (a multiple of any page size).
fn advise_huge_pages(v: &mut [f64]) {
    #[cfg(target_os = "linux")]
    {
        use std::ffi::{c_int, c_void};
        extern "C" {
            fn madvise(addr: *mut c_void, len: usize, advice: c_int) -> c_int;
        }
        const MADV_HUGEPAGE: c_int = 14;
        const HUGE: usize = 2 << 20;
        let start = v.as_mut_ptr() as usize;
        let (lo, hi) = (
            start.next_multiple_of(HUGE),
            (start + std::mem::size_of_val(v)) / HUGE * HUGE,
        );
        if hi > lo {
            // SAFETY: [lo, hi) lies inside `v`, which we borrow mutably;
            // MADV_HUGEPAGE changes no contents, only how pages are backed.
            unsafe { madvise(lo as *mut c_void, hi - lo, MADV_HUGEPAGE) };
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}

/// [`apply_separable`] into a caller's buffer (reused frame after frame, as
/// a renderer would), working in precision `T`: f64 is the reference; f32
/// doubles the SIMD width and differs by about 1e-7 of the peak. `out` is
/// resized and overwritten.
pub fn apply_separable_into<T: Sample>(image: &Image, kernels: &[PixelKernel], out: &mut Image) {
    let (w, h) = (image.width, image.height);
    out.width = w;
    out.height = h;
    for c in 0..3 {
        if kernels.is_empty() || w == 0 || h == 0 {
            out.rgb[c].clear();
            out.rgb[c].resize(w * h, 0.0);
            continue;
        }
        // Every sample is overwritten by the first kernel: no zero fill.
        out.rgb[c].resize(w * h, 0.0);
        separable_plane::<T>(&image.rgb[c], &mut out.rgb[c], w, h, kernels, c);
    }
}

/// The working precision of the fixed-kernel path.
pub trait Sample:
    Copy
    + Default
    + Send
    + Sync
    + std::ops::Add<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::AddAssign
    + std::iter::Sum
    + 'static
{
    fn from_f64(v: f64) -> Self;
    fn to_f64(self) -> f64;
}

impl Sample for f64 {
    fn from_f64(v: f64) -> f64 {
        v
    }
    fn to_f64(self) -> f64 {
        self
    }
}

impl Sample for f32 {
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
    fn to_f64(self) -> f64 {
        self as f64
    }
}

/// Output rows per task: each task filters the rows it needs horizontally
/// into a strip, then runs the vertical pass from it, so no full-size
/// intermediate image is written.
const STRIP: usize = 96;

fn separable_plane<T: Sample>(
    src: &[f64],
    out: &mut [f64],
    w: usize,
    h: usize,
    kernels: &[PixelKernel],
    c: usize,
) {
    out.par_chunks_mut(STRIP * w).enumerate().for_each_init(
        || (Vec::<T>::new(), Vec::<T>::new(), Vec::<T>::new()),
        |(strip, pad, wts), (block, o)| {
            let y0 = block * STRIP;
            let rows = o.len() / w;
            for (i, k) in kernels.iter().enumerate() {
                wts.clear();
                wts.extend(k.weights.iter().map(|v| T::from_f64(v[c])));
                let n = wts.len();
                // Source rows y0 + first .. y0 + rows - 1 + first + n - 1.
                let lo = y0 as i64 + k.first;
                strip.resize((rows + n - 1) * w, T::default());
                for (r, srow) in strip.chunks_mut(w).enumerate() {
                    let sy = clamp(lo + r as i64, h);
                    let row = &src[sy * w..sy * w + w];
                    fill_clamped(pad, row, k.first, w + n - 1);
                    correlate_row(pad, wts, srow);
                }
                accumulate_columns(strip, w, wts, o, i > 0);
            }
        },
    );
}

/// pad[i] = row[clamp(first + i)] for i < len: clamped ends, converted middle.
fn fill_clamped<T: Sample>(pad: &mut Vec<T>, row: &[f64], first: i64, len: usize) {
    let w = row.len() as i64;
    pad.clear();
    let left = (-first).clamp(0, len as i64) as usize;
    pad.extend(std::iter::repeat_n(T::from_f64(row[0]), left));
    // A kernel shifted wholly past the row reads only its border pixels.
    let start = (first + left as i64).clamp(0, row.len() as i64) as usize;
    let mid = (len - left).min(row.len().saturating_sub(start));
    pad.extend(row[start..start + mid].iter().map(|&v| T::from_f64(v)));
    let right = len - left - mid;
    pad.extend(std::iter::repeat_n(
        T::from_f64(row[(w - 1) as usize]),
        right,
    ));
}

/// Accumulators per block: two AVX2 registers of f32, four of f64.
const LANES: usize = 16;

fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// out[x] = sum_j wts[j] pad[x + j], blocked so each output is stored once.
fn correlate_row<T: Sample>(pad: &[T], wts: &[T], out: &mut [T]) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: has_avx2 checked the CPU features.
        return unsafe { correlate_row_avx2(pad, wts, out) };
    }
    correlate_row_generic(pad, wts, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn correlate_row_avx2<T: Sample>(pad: &[T], wts: &[T], out: &mut [T]) {
    correlate_row_generic(pad, wts, out)
}

#[inline(always)]
fn correlate_row_generic<T: Sample>(pad: &[T], wts: &[T], out: &mut [T]) {
    let w = out.len();
    let mut x = 0;
    while x + LANES <= w {
        let mut acc = [T::default(); LANES];
        for (j, &wt) in wts.iter().enumerate() {
            let p = &pad[x + j..x + j + LANES];
            for l in 0..LANES {
                acc[l] += wt * p[l];
            }
        }
        out[x..x + LANES].copy_from_slice(&acc);
        x += LANES;
    }
    for (xx, o) in out.iter_mut().enumerate().skip(x) {
        *o = wts
            .iter()
            .enumerate()
            .map(|(j, &wt)| wt * pad[xx + j])
            .sum();
    }
}

/// out[r][x] (+)= sum_j wts[j] strip[r + j][x] for the rows of `out`
/// (overwriting unless `add`). Walks down one column block at a time so the
/// window of n rows stays in L1.
fn accumulate_columns<T: Sample>(strip: &[T], w: usize, wts: &[T], out: &mut [f64], add: bool) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: has_avx2 checked the CPU features.
        return unsafe { accumulate_columns_avx2(strip, w, wts, out, add) };
    }
    accumulate_columns_generic(strip, w, wts, out, add)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn accumulate_columns_avx2<T: Sample>(
    strip: &[T],
    w: usize,
    wts: &[T],
    out: &mut [f64],
    add: bool,
) {
    accumulate_columns_generic(strip, w, wts, out, add)
}

#[inline(always)]
fn accumulate_columns_generic<T: Sample>(
    strip: &[T],
    w: usize,
    wts: &[T],
    out: &mut [f64],
    add: bool,
) {
    let rows = out.len() / w;
    let mut x = 0;
    while x + LANES <= w {
        for r in 0..rows {
            let mut acc = [T::default(); LANES];
            for (j, &wt) in wts.iter().enumerate() {
                let p = &strip[(r + j) * w + x..(r + j) * w + x + LANES];
                for l in 0..LANES {
                    acc[l] += wt * p[l];
                }
            }
            let o = &mut out[r * w + x..r * w + x + LANES];
            if add {
                for l in 0..LANES {
                    o[l] += acc[l].to_f64();
                }
            } else {
                for l in 0..LANES {
                    o[l] = acc[l].to_f64();
                }
            }
        }
        x += LANES;
    }
    for r in 0..rows {
        for xx in x..w {
            let v = wts
                .iter()
                .enumerate()
                .map(|(j, &wt)| wt * strip[(r + j) * w + xx])
                .sum::<T>()
                .to_f64();
            let o = &mut out[r * w + xx];
            *o = if add { *o + v } else { v };
        }
    }
}

fn clamp(i: i64, n: usize) -> usize {
    i.clamp(0, n as i64 - 1) as usize
}

/// Freude 2014, algorithm 4.1 per pixel in f64: the twin of shaders/sss_pass.wgsl.
pub fn apply_screen_space(image: &Image, setup: &Setup) -> Image {
    let (w, h) = (image.width, image.height);
    let steps = setup.steps(w, h);
    let depth = setup.depth.as_ref().map(|d| d.data.as_slice());
    let follow = setup.follow_surface.map(|c| setup.scale.follow_factor(c));
    let mut out = Image::new(w, h);
    out.alpha = image.alpha.clone();
    for taps in &setup.passes {
        let footprints = setup.jitter.then(|| taps.footprints());
        let ctx = PassCtx {
            w,
            h,
            taps,
            steps: &steps,
            depth,
            follow,
            footprints: footprints.as_deref(),
        };
        let tmp = ctx.run(&image.rgb, Axis::Horizontal);
        let v = ctx.run(&tmp, Axis::Vertical);
        for c in 0..3 {
            out.rgb[c].iter_mut().zip(&v[c]).for_each(|(o, x)| *o += x);
        }
    }
    out
}

struct PassCtx<'a> {
    w: usize,
    h: usize,
    taps: &'a Taps,
    steps: &'a [f64],
    depth: Option<&'a [f64]>,
    follow: Option<f64>,
    /// Jittered taps: each tap's footprint (start, width) in kernel mm.
    footprints: Option<&'a [(f64, f64)]>,
}

impl PassCtx<'_> {
    fn run(&self, src: &[Vec<f64>; 3], axis: Axis) -> [Vec<f64>; 3] {
        let (w, h) = (self.w, self.h);
        let mut out: [Vec<f64>; 3] = [vec![0.0; w * h], vec![0.0; w * h], vec![0.0; w * h]];
        let [r, g, b] = &mut out;
        r.par_chunks_mut(w)
            .zip(g.par_chunks_mut(w))
            .zip(b.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, ((r, g), b))| {
                for x in 0..w {
                    let v = self.pixel(src, axis, x, y);
                    (r[x], g[x], b[x]) = (v[0], v[1], v[2]);
                }
            });
        out
    }

    fn pixel(&self, src: &[Vec<f64>; 3], axis: Axis, x: usize, y: usize) -> [f64; 3] {
        let (w, h) = (self.w, self.h);
        let centre = y * w + x;
        let (coord, n, stride, base) = match axis {
            Axis::Horizontal => (x, w, 1, y * w),
            Axis::Vertical => (y, h, w, x),
        };
        let step = self.steps[centre];
        let planes = [&src[0][..], &src[1][..], &src[2][..]];
        let centre_colour = [planes[0][centre], planes[1][centre], planes[2][centre]];
        let mut acc = [0.0; 3];
        let axis_id = match axis {
            Axis::Horizontal => 0,
            Axis::Vertical => 1,
        };
        for (i, (off, wt)) in self
            .taps
            .offsets_mm
            .iter()
            .zip(&self.taps.weights)
            .enumerate()
        {
            let off = match self.footprints {
                Some(f) => {
                    let u = super::jitter_unit(x as u32, y as u32, i as u32, axis_id);
                    f[i].0 + u * f[i].1
                }
                None => *off,
            };
            // Freude 2014, eq. 4.11: the offset scaled by the pixel's kernel size.
            let p = (coord as f64 + off * step).clamp(0.0, (n - 1) as f64);
            // p >= 0, so truncation is floor (and avoids a libm call).
            let i0 = p as usize;
            let f = p - i0 as f64;
            let i1 = (i0 + 1).min(n - 1);
            let (a, b) = (base + i0 * stride, base + i1 * stride);
            let mut o = [0.0; 3];
            for c in 0..3 {
                o[c] = planes[c][a] * (1.0 - f) + planes[c][b] * f;
            }
            if let (Some(k), Some(d)) = (self.follow, self.depth) {
                let od = d[a] * (1.0 - f) + d[b] * f;
                // Freude 2014, eq. 4.12: lerp toward the centre colour by depth difference.
                let t = (k * (d[centre] - od).abs()).clamp(0.0, 1.0);
                for c in 0..3 {
                    o[c] = o[c] * (1.0 - t) + centre_colour[c] * t;
                }
            }
            for c in 0..3 {
                acc[c] += wt[c] * o[c];
            }
        }
        acc
    }
}

/// The ground-truth 2D kernel of `profile` with cells the size of one pixel
/// (`mm_per_pixel`), covering the radius that holds 99.9% of R_d.
pub fn reference_kernel(profile: &Profile, mm_per_pixel: f64) -> Result<Kernel2D> {
    if !(mm_per_pixel > 0.0 && mm_per_pixel.is_finite()) {
        return Err(Error::invalid(
            "apply",
            "--mm-per-pixel",
            mm_per_pixel,
            "must be finite and > 0",
        ));
    }
    let radius = (0..profile.channels.len())
        .map(|c| crate::kernel::kernel2d::radius_holding(profile, c, 0.999))
        .fold(0.0, f64::max);
    let half = (radius / mm_per_pixel).ceil().max(1.0) as usize;
    let size = 2 * half + 1;
    if size > crate::kernel::kernel2d::MAX_SIZE {
        return Err(Error::Unsupported(format!(
            "the reference kernel would be {size} pixels wide at {mm_per_pixel} mm per pixel \
             (at most {}): use a coarser --mm-per-pixel",
            crate::kernel::kernel2d::MAX_SIZE
        )));
    }
    Kernel2D::from_profile(
        profile,
        &Kernel2DSpec {
            size: Some(size),
            extent_mm: Some(size as f64 * mm_per_pixel / 2.0),
        },
    )
}

/// Kernel sizes above this use the FFT.
pub const FFT_ABOVE: usize = 21;

/// Refuses an exact 2D convolution of a `width` x `height` image with a
/// `size` x `size` kernel whose padded FFT grid exceeds
/// [`crate::limits::MAX_FFT_CELLS`] (memory and minutes of work), before
/// anything is allocated.
pub fn check_reference_fits(width: usize, height: usize, size: usize) -> Result<()> {
    let r = size / 2;
    let cells = (width + 2 * r).saturating_mul(height + 2 * r);
    if size > FFT_ABOVE && cells > crate::limits::MAX_FFT_CELLS {
        return Err(Error::Unsupported(format!(
            "the exact 2D reference of a {width}x{height} image with a {size}x{size} kernel \
             needs an FFT grid of {cells} cells, above the cap of {} (3 GiB of buffers): use a \
             coarser pixel scale or a smaller image",
            crate::limits::MAX_FFT_CELLS
        )));
    }
    Ok(())
}

/// Exact 2D convolution (clamped borders) with the kernel's cells taken as
/// pixels: out(x, y) = sum K(i, j) I(x + i, y + j).
pub fn convolve_2d(image: &Image, k: &Kernel2D) -> Image {
    let mut out = Image::new(image.width, image.height);
    out.alpha = image.alpha.clone();
    if image.is_empty() {
        return out;
    }
    for c in 0..3 {
        out.rgb[c] = if k.size > FFT_ABOVE {
            convolve_2d_fft(&image.rgb[c], image.width, image.height, &k.data[c], k.size)
        } else {
            convolve_2d_direct(&image.rgb[c], image.width, image.height, &k.data[c], k.size)
        };
    }
    out
}

pub fn convolve_2d_direct(src: &[f64], w: usize, h: usize, k: &[f64], size: usize) -> Vec<f64> {
    let r = (size / 2) as i64;
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
        for j in 0..size {
            let sy = clamp(y as i64 + j as i64 - r, h);
            let row = &src[sy * w..sy * w + w];
            for i in 0..size {
                let kv = k[j * size + i];
                if kv == 0.0 {
                    continue;
                }
                for (x, a) in o.iter_mut().enumerate() {
                    *a += kv * row[clamp(x as i64 + i as i64 - r, w)];
                }
            }
        }
    });
    out
}

/// Smallest n' >= n with no prime factor above 5 (fast FFT sizes).
fn smooth_size(n: usize) -> usize {
    let mut m = n.max(1);
    loop {
        let mut v = m;
        for p in [2, 3, 5] {
            while v.is_multiple_of(p) {
                v /= p;
            }
        }
        if v == 1 {
            return m;
        }
        m += 1;
    }
}

pub fn convolve_2d_fft(src: &[f64], w: usize, h: usize, k: &[f64], size: usize) -> Vec<f64> {
    let r = size / 2;
    let (pw, ph) = (w + 2 * r, h + 2 * r);
    let (nx, ny) = (smooth_size(pw), smooth_size(ph));
    let zero = Complex::new(0.0, 0.0);
    // The image extended by clamping, zero beyond the padded extent.
    let mut a = vec![zero; nx * ny];
    a.par_chunks_mut(nx)
        .enumerate()
        .take(ph)
        .for_each(|(y, row)| {
            let sy = clamp(y as i64 - r as i64, h);
            for (x, v) in row.iter_mut().enumerate().take(pw) {
                *v = Complex::new(src[sy * w + clamp(x as i64 - r as i64, w)], 0.0);
            }
        });
    // The kernel flipped (correlation), wrapped around the origin.
    let mut b = vec![zero; nx * ny];
    for j in 0..size {
        for i in 0..size {
            let (u, v) = (i as i64 - r as i64, j as i64 - r as i64);
            let x = (-u).rem_euclid(nx as i64) as usize;
            let y = (-v).rem_euclid(ny as i64) as usize;
            b[y * nx + x] = Complex::new(k[j * size + i], 0.0);
        }
    }
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let (fx, fy) = (planner.plan_fft_forward(nx), planner.plan_fft_forward(ny));
    let (ix, iy) = (planner.plan_fft_inverse(nx), planner.plan_fft_inverse(ny));
    fft_2d(&mut a, nx, ny, &*fx, &*fy);
    fft_2d(&mut b, nx, ny, &*fx, &*fy);
    a.par_iter_mut().zip(&b).for_each(|(x, y)| *x *= y);
    fft_2d(&mut a, nx, ny, &*ix, &*iy);
    let norm = 1.0 / (nx * ny) as f64;
    let mut out = vec![0.0; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
        for (x, v) in o.iter_mut().enumerate() {
            *v = a[(y + r) * nx + x + r].re * norm;
        }
    });
    out
}

fn fft_2d(
    data: &mut [Complex<f64>],
    nx: usize,
    ny: usize,
    fx: &dyn rustfft::Fft<f64>,
    fy: &dyn rustfft::Fft<f64>,
) {
    data.par_chunks_mut(nx).for_each(|row| fx.process(row));
    let mut t = vec![Complex::new(0.0, 0.0); nx * ny];
    transpose(data, &mut t, nx, ny);
    t.par_chunks_mut(ny).for_each(|col| fy.process(col));
    transpose(&t, data, ny, nx);
}

/// `dst[x * h + y] = src[y * w + x]` for a w x h `src`.
fn transpose(src: &[Complex<f64>], dst: &mut [Complex<f64>], w: usize, h: usize) {
    dst.par_chunks_mut(h).enumerate().for_each(|(x, col)| {
        for (y, v) in col.iter_mut().enumerate() {
            *v = src[y * w + x];
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::{Scale, Setup};

    fn noise_image(w: usize, h: usize) -> Image {
        let mut img = Image::new(w, h);
        let mut s = 12345u64;
        for c in 0..3 {
            for v in img.rgb[c].iter_mut() {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                *v = (s >> 11) as f64 / (1u64 << 53) as f64;
            }
        }
        img
    }

    #[test]
    fn fft_equals_direct_convolution() {
        let img = noise_image(37, 29);
        let size = 25;
        let k: Vec<f64> = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f64 - 12.0, (i / size) as f64 - 12.0);
                // Asymmetric on purpose: catches a flipped kernel.
                (-(x * x + 0.5 * y * y) / 20.0).exp() * (1.0 + 0.1 * x)
            })
            .collect();
        let a = convolve_2d_direct(&img.rgb[0], 37, 29, &k, size);
        let b = convolve_2d_fft(&img.rgb[0], 37, 29, &k, size);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-11, "{x} {y}");
        }
    }

    #[test]
    fn reused_buffers_and_f32_give_the_fresh_f64_result() {
        let img = noise_image(45, 20);
        let t = Taps {
            offsets_mm: vec![-0.9, -0.2, 0.0, 0.5, 1.1],
            weights: vec![[0.1; 3], [0.2; 3], [0.4; 3], [0.2; 3], [0.1; 3]],
        };
        let k = [
            PixelKernel::from_taps(&t, 3.0),
            PixelKernel::from_taps(&t, 1.7),
        ];
        let fresh = apply_separable(&img, &k);
        let mut reused = noise_image(45, 20);
        apply_separable_into::<f64>(&img, &k, &mut reused);
        assert_eq!(fresh.rgb, reused.rgb);
        apply_separable_into::<f32>(&img, &k, &mut reused);
        for c in 0..3 {
            for (a, b) in fresh.rgb[c].iter().zip(&reused.rgb[c]) {
                assert!((a - b).abs() < 1e-6, "{a} {b}");
            }
        }
    }

    #[test]
    fn fixed_kernels_equal_the_per_pixel_algorithm() {
        let img = noise_image(31, 23);
        let taps = Taps {
            offsets_mm: vec![-1.7, -0.6, -0.1, 0.0, 0.25, 0.9, 2.3],
            weights: vec![
                [0.1, 0.05, 0.0],
                [0.2, 0.1, 0.3],
                [0.1, 0.2, 0.1],
                [0.3, 0.3, 0.2],
                [0.1, 0.2, 0.2],
                [0.1, 0.1, 0.1],
                [0.1, 0.05, 0.1],
            ],
        };
        let setup = Setup {
            passes: vec![taps.clone(), taps],
            scale: Scale::MmPerPixel(0.37),
            depth: None,
            strength: None,
            follow_surface: None,
            specular: None,
            jitter: false,
        };
        let fast = apply(&img, &setup).unwrap();
        let slow = apply_screen_space(&img, &setup);
        for c in 0..3 {
            for (x, y) in fast.rgb[c].iter().zip(&slow.rgb[c]) {
                assert!((x - y).abs() < 1e-12, "{x} {y}");
            }
        }
    }
}
