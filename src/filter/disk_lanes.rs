//! The disk pass's samples four at a time (AVX2), for a frame without the
//! depth-aware lerp over an image packed [r, g, b, 0] per pixel
//! (`disk::disk_frames`, the advice's scoring). Each sample's rotated
//! position, clamp, corners and bilinear weights are the scalar pass's
//! operations on four lanes (IEEE operations one by one, no fused
//! multiply-add; truncation where it truncates), and the samples are then
//! added to the frame one by one in their order: the same frame bit for
//! bit (`disk`'s tests hold the two side by side).
//!
//! Also the two layouts a disk pass reads the image in ([`Texels`]).

use super::Image;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Where a pass reads the image: the fetch of four pixels with their
/// bilinear weights, per channel (a fourth lane, zero, pads the channels to
/// one 32-byte vector). Every channel's sum is p0 w0 + p1 w1 + p2 w2 + p3 w3
/// in that order, whatever the layout.
pub(super) trait Texels: Sync {
    fn bilinear(&self, idx: &[usize; 4], wt: &[f64; 4]) -> [f64; 4];
    /// The packed texels, where the image is packed.
    fn packed(&self) -> Option<&[[f64; 4]]> {
        None
    }
}

/// The image's own planes (the in-place sweep, whose rows change between
/// bands).
pub(super) struct Planes<'a>(pub &'a [Vec<f64>; 3]);

impl Texels for Planes<'_> {
    #[inline(always)]
    fn bilinear(&self, idx: &[usize; 4], wt: &[f64; 4]) -> [f64; 4] {
        let mut o = [0.0; 4];
        for (o, p) in o.iter_mut().zip(self.0) {
            *o = p[idx[0]] * wt[0] + p[idx[1]] * wt[1] + p[idx[2]] * wt[2] + p[idx[3]] * wt[3];
        }
        o
    }
}

/// The image packed [r, g, b, 0] per pixel (passes over an image that does
/// not change, `disk::disk_frames`): a fetch reads four texels and sums the
/// channels side by side.
pub(super) struct Packed(Vec<[f64; 4]>);

impl Packed {
    pub fn new(image: &Image) -> Packed {
        let [r, g, b] = &image.rgb;
        Packed((0..image.len()).map(|i| [r[i], g[i], b[i], 0.0]).collect())
    }
}

impl Texels for Packed {
    fn packed(&self) -> Option<&[[f64; 4]]> {
        Some(&self.0)
    }

    #[inline(always)]
    fn bilinear(&self, idx: &[usize; 4], wt: &[f64; 4]) -> [f64; 4] {
        let t = idx.map(|i| self.0[i]);
        std::array::from_fn(|l| {
            t[0][l] * wt[0] + t[1][l] * wt[1] + t[2][l] * wt[2] + t[3][l] * wt[3]
        })
    }
}

/// One frame's rotation and scale at one pixel, and the image read.
pub(super) struct Frame<'a> {
    pub texels: &'a [[f64; 4]],
    pub w: usize,
    pub h: usize,
    pub x: usize,
    pub y: usize,
    pub step: f64,
    pub sin: f64,
    pub cos: f64,
}

/// Whether [`add_samples`] may run on an image of `w` x `h` pixels: the CPU
/// has AVX2 and a pixel's index fits the 32-bit lanes.
pub(super) fn usable(w: usize, h: usize) -> bool {
    crate::numerics::has_avx2() && w.saturating_mul(h) < i32::MAX as usize
}

/// Adds samples `tx`, `ty` (mm, unrotated, a multiple of four of them)
/// with per-channel `weights` to `frame`, in order.
///
/// # Safety
/// The CPU must have AVX2 ([`usable`]), and the image fewer than 2^31
/// pixels.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn add_samples(
    f: &Frame,
    tx: &[f64],
    ty: &[f64],
    weights: &[[f64; 4]],
    frame: &mut [f64; 4],
) {
    let (step, sin, cos) = (
        _mm256_set1_pd(f.step),
        _mm256_set1_pd(f.sin),
        _mm256_set1_pd(f.cos),
    );
    let (px0, py0) = (_mm256_set1_pd(f.x as f64), _mm256_set1_pd(f.y as f64));
    let zero = _mm256_setzero_pd();
    let (xmax, ymax) = (
        _mm256_set1_pd((f.w - 1) as f64),
        _mm256_set1_pd((f.h - 1) as f64),
    );
    let one = _mm256_set1_pd(1.0);
    let (ione, iw) = (_mm_set1_epi32(1), _mm_set1_epi32(f.w as i32));
    let (iwm, ihm) = (
        _mm_set1_epi32(f.w as i32 - 1),
        _mm_set1_epi32(f.h as i32 - 1),
    );
    let mut acc = _mm256_loadu_pd(frame.as_ptr());
    for ((tx, ty), tw) in tx
        .chunks_exact(4)
        .zip(ty.chunks_exact(4))
        .zip(weights.chunks_exact(4))
    {
        let (vx, vy) = (_mm256_loadu_pd(tx.as_ptr()), _mm256_loadu_pd(ty.as_ptr()));
        // step (x cos - y sin), step (x sin + y cos), as the scalar pass.
        let dx = _mm256_mul_pd(
            step,
            _mm256_sub_pd(_mm256_mul_pd(vx, cos), _mm256_mul_pd(vy, sin)),
        );
        let dy = _mm256_mul_pd(
            step,
            _mm256_add_pd(_mm256_mul_pd(vx, sin), _mm256_mul_pd(vy, cos)),
        );
        // The clamp to [0, n - 1]: a position is never NaN or -0 here (a
        // whole pixel plus a finite offset), where max/min and clamp differ.
        let px = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(px0, dx), zero), xmax);
        let py = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(py0, dy), zero), ymax);
        let (x0, y0) = (_mm256_cvttpd_epi32(px), _mm256_cvttpd_epi32(py));
        let fx = _mm256_sub_pd(px, _mm256_cvtepi32_pd(x0));
        let fy = _mm256_sub_pd(py, _mm256_cvtepi32_pd(y0));
        let x1 = _mm_min_epi32(_mm_add_epi32(x0, ione), iwm);
        let y1 = _mm_min_epi32(_mm_add_epi32(y0, ione), ihm);
        let (r0, r1) = (_mm_mullo_epi32(y0, iw), _mm_mullo_epi32(y1, iw));
        let mut idx = [[0i32; 4]; 4];
        for (i, v) in idx.iter_mut().zip([
            _mm_add_epi32(r0, x0),
            _mm_add_epi32(r0, x1),
            _mm_add_epi32(r1, x0),
            _mm_add_epi32(r1, x1),
        ]) {
            _mm_storeu_si128(i.as_mut_ptr().cast(), v);
        }
        let (gx, gy) = (_mm256_sub_pd(one, fx), _mm256_sub_pd(one, fy));
        let mut wt = [[0.0f64; 4]; 4];
        for (o, v) in wt.iter_mut().zip([
            _mm256_mul_pd(gx, gy),
            _mm256_mul_pd(fx, gy),
            _mm256_mul_pd(gx, fy),
            _mm256_mul_pd(fx, fy),
        ]) {
            _mm256_storeu_pd(o.as_mut_ptr(), v);
        }
        for (l, tw) in tw.iter().enumerate() {
            let texel = |k: usize| _mm256_loadu_pd(f.texels[idx[k][l] as usize].as_ptr());
            let part = |k: usize| _mm256_mul_pd(texel(k), _mm256_set1_pd(wt[k][l]));
            let o = _mm256_add_pd(
                _mm256_add_pd(_mm256_add_pd(part(0), part(1)), part(2)),
                part(3),
            );
            acc = _mm256_add_pd(acc, _mm256_mul_pd(_mm256_loadu_pd(tw.as_ptr()), o));
        }
    }
    _mm256_storeu_pd(frame.as_mut_ptr(), acc);
}
