//! The screen-space pass (`screen_space`) where every pixel has the same
//! step and nothing is jittered or lerped: a uniform scale without depth or
//! strength, as the advice scores its candidates. A tap then reads the same
//! rows for a whole output row of the vertical pass, and the same columns
//! in every row of the horizontal one, so the sums run tap by tap over runs
//! of [`RUN`] pixels of a row (contiguous loads, vector lanes in AVX2 where
//! the CPU has it); the horizontal pass runs so over the transposed rows.
//! Each pixel adds the same products in the same order as the per-pixel
//! algorithm (`screen_space::PassCtx::pixel`): the same bits (tested there).

use super::{Image, Setup, Taps};
use rayon::prelude::*;

/// Pixels of a row summed together: their sums stay in a small buffer
/// while the taps are added in turn.
const RUN: usize = 64;

/// Where a pass reads: three planes whose row 0 is the image's row `first`.
pub(super) struct Src<'a> {
    pub planes: [&'a [f64]; 3],
    pub first: usize,
}

/// The two pixels a sample at `coord + shift` (pixels, clamped to the
/// image's `n` pixels along the pass) lies between and their weights: `g`
/// for `i0`, `f` for `i1`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Lerp {
    pub i0: usize,
    pub i1: usize,
    pub f: f64,
    pub g: f64,
}

impl Lerp {
    #[inline]
    pub fn at(coord: usize, shift: f64, n: usize) -> Lerp {
        let p = (coord as f64 + shift).clamp(0.0, (n - 1) as f64);
        // p >= 0, so truncation is floor (and avoids a libm call).
        let i0 = p as usize;
        let f = p - i0 as f64;
        Lerp {
            i0,
            i1: (i0 + 1).min(n - 1),
            f,
            g: 1.0 - f,
        }
    }
}

/// One pass at a step shared by every pixel: each tap's shift in pixels.
pub(super) struct Uniform {
    shifts: Vec<f64>,
    w: usize,
    h: usize,
}

impl Uniform {
    /// None where a pixel's step or samples depend on the pixel (strength,
    /// depth, jitter).
    pub fn new(setup: &Setup, taps: &Taps, w: usize, h: usize) -> Option<Uniform> {
        if setup.jitter || setup.strength.is_some() || setup.depth.is_some() {
            return None;
        }
        let step = setup.step_at(setup.scale.step_base(h), 0);
        Some(Uniform {
            shifts: taps.offsets_mm.iter().map(|o| o * step).collect(),
            w,
            h,
        })
    }

    /// Rows `lo..hi` of the horizontal pass of `image` into `out` (those
    /// rows, `w` each): the rows transposed, summed as the vertical pass
    /// sums rows (a column of the image is a row there, its coordinate x
    /// along the pass of `w` pixels), transposed back.
    pub fn horizontal_rows(
        &self,
        taps: &Taps,
        image: &Image,
        lo: usize,
        hi: usize,
        out: [&mut [f64]; 3],
    ) {
        let (w, rows) = (self.w, hi - lo);
        let t: [Vec<f64>; 3] =
            std::array::from_fn(|c| transposed(&image.rgb[c][lo * w..hi * w], rows, w));
        let mut sums: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; w * rows]);
        let src = Src {
            planes: [&t[0], &t[1], &t[2]],
            first: 0,
        };
        let [r, g, b] = &mut sums;
        r.par_chunks_mut(rows)
            .zip(g.par_chunks_mut(rows))
            .zip(b.par_chunks_mut(rows))
            .enumerate()
            .for_each(|(x, ((r, g), b))| self.rows(taps, &src, (rows, w), x, [r, g, b], false));
        for (o, s) in out.into_iter().zip(&sums) {
            o.copy_from_slice(&transposed(s, w, rows));
        }
    }

    /// Row `y` of the vertical pass over the window `src`, written into
    /// `out` (`add`: added to it).
    pub fn vertical_row(&self, taps: &Taps, src: &Src, y: usize, out: [&mut [f64]; 3], add: bool) {
        self.rows(taps, src, (self.w, self.h), y, out, add)
    }

    /// Output row `y` of a pass along the rows of `src` (`len` values a
    /// row, `n` rows along the pass), into `out` (`add`: added to it), in
    /// AVX2 where the CPU has it.
    fn rows(
        &self,
        taps: &Taps,
        src: &Src,
        (len, n): (usize, usize),
        y: usize,
        out: [&mut [f64]; 3],
        add: bool,
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::numerics::has_avx2() {
            // SAFETY: has_avx2 checked the CPU features.
            return unsafe { self.rows_avx2(taps, src, (len, n), y, out, add) };
        }
        self.rows_lanes(taps, src, (len, n), y, out, add)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn rows_avx2(
        &self,
        taps: &Taps,
        src: &Src,
        len_n: (usize, usize),
        y: usize,
        out: [&mut [f64]; 3],
        add: bool,
    ) {
        self.rows_lanes(taps, src, len_n, y, out, add)
    }

    #[inline(always)]
    fn rows_lanes(
        &self,
        taps: &Taps,
        src: &Src,
        (len, n): (usize, usize),
        y: usize,
        mut out: [&mut [f64]; 3],
        add: bool,
    ) {
        for x0 in (0..len).step_by(RUN) {
            let m = RUN.min(len - x0);
            let mut acc = [[0.0f64; RUN]; 3];
            for (&d, wt) in self.shifts.iter().zip(&taps.weights) {
                let l = Lerp::at(y, d, n);
                let (ra, rb) = ((l.i0 - src.first) * len + x0, (l.i1 - src.first) * len + x0);
                for c in 0..3 {
                    let (a, b) = (&src.planes[c][ra..ra + m], &src.planes[c][rb..rb + m]);
                    for ((s, &a), &b) in acc[c].iter_mut().zip(a).zip(b) {
                        *s += wt[c] * (a * l.g + b * l.f);
                    }
                }
            }
            for (o, a) in out.iter_mut().zip(&acc) {
                let o = &mut o[x0..x0 + m];
                if add {
                    o.iter_mut().zip(a).for_each(|(o, a)| *o += a);
                } else {
                    o.copy_from_slice(&a[..m]);
                }
            }
        }
    }
}

/// `v` (`rows` rows of `cols`) by columns: `cols` rows of `rows`.
fn transposed(v: &[f64], rows: usize, cols: usize) -> Vec<f64> {
    let mut t = vec![0.0; rows * cols];
    t.par_chunks_mut(rows.max(1))
        .enumerate()
        .for_each(|(x, col)| {
            for (k, o) in col.iter_mut().enumerate() {
                *o = v[k * cols + x];
            }
        });
    t
}
