//! The separable path under a uniform scale: each rank's 1D factor becomes
//! a fixed kernel on whole pixels, and the image is filtered as the sum over
//! ranks of vertical(horizontal(I)) (Freude 2014, eq. 5.10; the two 1D
//! passes of Jimenez et al. 2015), borders clamped. The per-pixel algorithm
//! reduces to this when every pixel has the same step and no depth lerp
//! (see `PixelKernel::from_taps`), and this path is then much faster: f64 or
//! f32 ([`Precision`]), SIMD-friendly row and column loops, rayon over
//! strips of rows with no cross-thread sums (deterministic).

use super::sweep::{self, Job, Scratch};
use super::{Image, Taps};

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

    /// [`apply_separable_in_place`] in this precision.
    pub fn separable_in_place(self, image: &mut Image, kernels: &[PixelKernel]) {
        match self {
            Precision::F32 => apply_separable_in_place::<f32>(image, kernels),
            Precision::F64 => apply_separable_in_place::<f64>(image, kernels),
        }
    }
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
        // Every sample is overwritten by the first kernel: no zero fill.
        out.rgb[c].resize(w * h, 0.0);
        if kernels.is_empty() || w == 0 || h == 0 {
            out.rgb[c].fill(0.0);
            continue;
        }
        sweep::plane(
            &Job::<T>::new(kernels, c, w, h),
            &image.rgb[c],
            &mut out.rgb[c],
        );
    }
}

/// [`apply_separable`] in place, in precision `T`: each plane is swept
/// through a ring of filtered rows and overwritten row by row, so the only
/// memory beyond the image is the ring per thread and the strips' halo rows
/// (at most 1/8 of one plane, reused across planes). The same result as
/// [`apply_separable_into`], bit for bit.
pub fn apply_separable_in_place<T: Sample>(image: &mut Image, kernels: &[PixelKernel]) {
    let (w, h) = (image.width, image.height);
    let mut halo = Vec::new();
    for c in 0..3 {
        if kernels.is_empty() || w == 0 || h == 0 {
            image.rgb[c].fill(0.0);
            continue;
        }
        let job = Job::<T>::new(kernels, c, w, h);
        sweep::plane_in_place(&job, &mut image.rgb[c], &mut halo);
    }
}

/// One f32 plane `src` (`w` x `h`, row-major) filtered into `out` with
/// channel `c` of `kernels`: the renderer's frame, f32 in and out as
/// OpenCV's `sepFilter2D` on a float image; nothing is allocated once the
/// worker threads have run a frame of this size. Differs from the f64
/// reference by f32 round-off (about taps x 6e-8 of the peak).
pub fn apply_separable_f32(
    src: &[f32],
    out: &mut [f32],
    (w, h): (usize, usize),
    kernels: &[PixelKernel],
    c: usize,
) {
    assert!(
        src.len() == w * h && out.len() == w * h,
        "planes of {w}x{h} samples"
    );
    if kernels.is_empty() || w == 0 || h == 0 {
        out.fill(0.0);
        return;
    }
    sweep::plane(&Job::<f32>::new(kernels, c, w, h), src, out);
}

/// The working precision of the fixed-kernel path (and the sample type of
/// the planes it reads and writes).
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
    /// The same value in this precision (exact when widening; an f32 to
    /// f32 round trip through f64 compiles to nothing).
    #[inline(always)]
    fn from_sample<S: Sample>(v: S) -> Self {
        Self::from_f64(v.to_f64())
    }
    /// Runs `f` with this thread's buffers of this precision.
    fn with_scratch<R>(f: impl FnOnce(&mut Scratch<Self>) -> R) -> R;
}

thread_local! {
    static SCRATCH_F64: std::cell::RefCell<Scratch<f64>> =
        const { std::cell::RefCell::new(Scratch::new()) };
    static SCRATCH_F32: std::cell::RefCell<Scratch<f32>> =
        const { std::cell::RefCell::new(Scratch::new()) };
}

impl Sample for f64 {
    #[inline(always)]
    fn from_f64(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    fn with_scratch<R>(f: impl FnOnce(&mut Scratch<f64>) -> R) -> R {
        SCRATCH_F64.with_borrow_mut(f)
    }
}

impl Sample for f32 {
    #[inline(always)]
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn with_scratch<R>(f: impl FnOnce(&mut Scratch<f32>) -> R) -> R {
        SCRATCH_F32.with_borrow_mut(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::signals::noise;

    #[test]
    fn reused_buffers_and_f32_give_the_fresh_f64_result() {
        let img = noise(45, 20, 12345);
        let t = Taps {
            offsets_mm: vec![-0.9, -0.2, 0.0, 0.5, 1.1],
            weights: vec![[0.1; 3], [0.2; 3], [0.4; 3], [0.2; 3], [0.1; 3]],
        };
        let k = [
            PixelKernel::from_taps(&t, 3.0),
            PixelKernel::from_taps(&t, 1.7),
        ];
        let fresh = apply_separable(&img, &k);
        let mut reused = noise(45, 20, 12345);
        apply_separable_into::<f64>(&img, &k, &mut reused);
        assert_eq!(fresh.rgb, reused.rgb);
        apply_separable_into::<f32>(&img, &k, &mut reused);
        for c in 0..3 {
            for (a, b) in fresh.rgb[c].iter().zip(&reused.rgb[c]) {
                assert!((a - b).abs() < 1e-6, "{a} {b}");
            }
        }
    }
}
