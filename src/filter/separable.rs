//! The separable path under a uniform scale: each rank's 1D factor becomes
//! a fixed kernel on whole pixels, and the image is filtered as the sum over
//! ranks of vertical(horizontal(I)) (Freude 2014, eq. 5.10; the two 1D
//! passes of Jimenez et al. 2015), borders clamped. The per-pixel algorithm
//! reduces to this when every pixel has the same step and no depth lerp
//! (see `PixelKernel::from_taps`), and this path is then much faster: f64 or
//! f32 ([`Precision`]), SIMD-friendly row and column loops, rayon over
//! strips of rows with no cross-thread sums (deterministic).

use super::{clamp_index, Image, Taps};
use rayon::prelude::*;

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
                    let sy = clamp_index(lo + r as i64, h);
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
