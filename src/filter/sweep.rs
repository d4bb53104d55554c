//! The fixed-kernel separable filter's inner engine: one plane, swept in
//! strips of rows, each strip top to bottom through a ring buffer of
//! horizontally filtered rows (the scheme of OpenCV's `FilterEngine`: the
//! row filter fills a ring of `n` rows, the column filter reads it), so the
//! working set of a strip is `n` rows (in L2 for a 1080p row of f32) and no
//! intermediate image exists. Because a row is filtered horizontally
//! before the output row of the same index is written, the sweep can write
//! into its own source: only the rows a strip reads from its neighbours
//! (its halo, at most 1/8 of the plane) are copied first. Every output is
//! the same sum in the same order whatever the partition into strips, so
//! the result does not depend on the thread count.

use super::sample::{PixelKernel, Sample, Scratch};
use rayon::prelude::*;

/// Fewest rows per strip: the ring's start-up rows are filtered once per
/// strip, so a strip much shorter than the kernel wastes work.
const MIN_STRIP_ROWS: usize = 32;

/// In place, strips are at least this many times the kernel's row span, so
/// that the halos copied before the sweep are at most 1/8 of the plane
/// (each strip copies `span` rows: above and below together).
const HALO_FRACTION_INV: usize = 8;

/// Strips per thread: enough to balance rows of uneven cost (none today,
/// but the machine is shared), few enough that start-up rows stay cheap.
const STRIPS_PER_THREAD: usize = 4;

/// Outputs per block, by sample size: eight AVX2 registers of
/// accumulators, f32 or f64, so that eight independent sums hide the
/// latency of the adds (with two, each tap waited on the previous one).
/// The order of every output's sum is the same whatever the block.
const LANES_F32: usize = 64;
const LANES_F64: usize = 32;

/// Whether `T` is the 4-byte sample (the wider block).
fn is_f32<T>() -> bool {
    std::mem::size_of::<T>() == 4
}

/// Channel `c` of `k` with the taps beyond the image folded in: with
/// clamp-to-edge sampling a tap at offset o <= -(n - 1) reads the first row
/// (column) from every output of an image whose sides are at most n, and
/// one at o >= n - 1 the last, so their weights sum into those two offsets
/// with the same result, and the work is bounded by the image, not by the
/// kernel (a kernel a million pixels wide on a 16-pixel image). A kernel
/// within the bounds is returned unchanged, bit for bit.
fn folded(k: &PixelKernel, c: usize, n: usize) -> (i64, Vec<f64>) {
    let b = n.max(1) as i64 - 1;
    let last = k.first + k.weights.len() as i64 - 1;
    let (lo, hi) = (k.first.clamp(-b, b), last.clamp(-b, b));
    let mut out = vec![0.0; (hi - lo + 1) as usize];
    for (i, v) in k.weights.iter().enumerate() {
        let o = (k.first + i as i64).clamp(lo, hi);
        out[(o - lo) as usize] += v[c];
    }
    (lo, out)
}

/// One plane's filter: the kernels' weights for this channel in the working
/// precision `T`, and the union of their row spans.
pub(crate) struct Job<T> {
    pub w: usize,
    pub h: usize,
    /// Per kernel: its first pixel offset and its weights.
    kernels: Vec<(i64, Vec<T>)>,
    /// Lowest offset any kernel reads (at most 0) and highest (at least 0):
    /// including 0 keeps the row of an output index filtered before that
    /// output is written.
    lo: i64,
    hi: i64,
}

impl<T: Sample> Job<T> {
    pub fn new(kernels: &[PixelKernel], c: usize, w: usize, h: usize) -> Job<T> {
        let kernels: Vec<(i64, Vec<T>)> = kernels
            .iter()
            .map(|k| {
                let (first, weights) = folded(k, c, w.max(h));
                (first, weights.into_iter().map(T::from_f64).collect())
            })
            .collect();
        let lo = kernels.iter().map(|k| k.0).min().unwrap_or(0).min(0);
        let hi = kernels
            .iter()
            .map(|k| k.0 + k.1.len() as i64 - 1)
            .max()
            .unwrap_or(0)
            .max(0);
        Job {
            w,
            h,
            kernels,
            lo,
            hi,
        }
    }

    /// Rows of the ring: every row any kernel reads for one output row.
    fn ring_rows(&self) -> usize {
        (self.hi - self.lo + 1) as usize
    }

    /// Rows per strip for this plane (in place: long enough to keep the
    /// halos small).
    fn strip_rows(&self, in_place: bool) -> usize {
        let threads = rayon::current_num_threads().max(1);
        let mut rows = self
            .h
            .div_ceil(threads * STRIPS_PER_THREAD)
            .max(MIN_STRIP_ROWS);
        if in_place {
            rows = rows.max(HALO_FRACTION_INV * (self.ring_rows() - 1));
        }
        rows.min(self.h.max(1))
    }
}

/// Where a strip reads rows that are not its own.
enum Source<'a, S> {
    /// A separate source plane (every row read from it).
    Plane(&'a [S]),
    /// In place: rows `top_first..` above the strip and `bottom_first..`
    /// below it, copied before the sweep.
    Halo {
        top_first: usize,
        top: &'a [S],
        bottom_first: usize,
        bottom: &'a [S],
    },
}

/// Filters `src` into `out` (both `w` x `h`).
pub(crate) fn plane<T: Sample, S: Sample>(job: &Job<T>, src: &[S], out: &mut [S]) {
    let rows = job.strip_rows(false);
    out.par_chunks_mut(rows * job.w)
        .enumerate()
        .for_each(|(i, chunk)| {
            T::with_scratch(|s| strip(job, i * rows, chunk, &Source::Plane(src), false, s))
        });
}

/// Filters `plane` in place: the halo rows of every strip are copied
/// first (into `halo`, reused), then the strips run in parallel.
pub(crate) fn plane_in_place<T: Sample, S: Sample>(
    job: &Job<T>,
    plane: &mut [S],
    halo: &mut Vec<S>,
) {
    let (w, h) = (job.w, job.h);
    let rows = job.strip_rows(true);
    let strips = h.div_ceil(rows);
    // Per strip: (top_first, top range in halo, bottom_first, bottom range).
    let mut spans = Vec::with_capacity(strips);
    halo.clear();
    for i in 0..strips {
        let (y0, y1) = (i * rows, ((i + 1) * rows).min(h));
        let top_first = (y0 as i64 + job.lo).max(0) as usize;
        let bottom_end = ((y1 as i64 + job.hi) as usize).min(h);
        let t0 = halo.len();
        halo.extend_from_slice(&plane[top_first * w..y0 * w]);
        let b0 = halo.len();
        halo.extend_from_slice(&plane[y1 * w..bottom_end * w]);
        spans.push((top_first, t0..b0, y1, b0..halo.len()));
    }
    let halo = &halo[..];
    plane
        .par_chunks_mut(rows * w)
        .zip(spans.into_par_iter())
        .enumerate()
        .for_each(|(i, (chunk, (top_first, t, bottom_first, b)))| {
            let source = Source::Halo {
                top_first,
                top: &halo[t],
                bottom_first,
                bottom: &halo[b],
            };
            T::with_scratch(|s| strip(job, i * rows, chunk, &source, true, s))
        });
}

/// One strip: output rows `y0..` (as many as `chunk` holds), top to bottom.
fn strip<T: Sample, S: Sample>(
    job: &Job<T>,
    y0: usize,
    chunk: &mut [S],
    source: &Source<S>,
    in_place: bool,
    s: &mut Scratch<T>,
) {
    let (w, h) = (job.w, job.h);
    let n_rows = chunk.len() / w;
    let ring_rows = job.ring_rows();
    let k_count = job.kernels.len();
    s.ring.resize(k_count * ring_rows * w, T::default());
    // Ring slot of source row r (r may be negative: clamped when read).
    let slot = |r: i64| r.rem_euclid(ring_rows as i64) as usize;
    let fill = |r: i64, chunk: &[S], s: &mut Scratch<T>| {
        let sc = r.clamp(0, h as i64 - 1) as usize;
        let row: &[S] = if in_place && sc >= y0 && sc < y0 + n_rows {
            // Not yet overwritten: r is never below the output row.
            &chunk[(sc - y0) * w..(sc - y0 + 1) * w]
        } else {
            source_row(source, sc, w)
        };
        fill_clamped(&mut s.pad, row, job.lo, w + ring_rows - 1);
        let at = slot(r) * w;
        for (k, (first, wts)) in job.kernels.iter().enumerate() {
            let pad = &s.pad[(first - job.lo) as usize..];
            let dst = &mut s.ring[(k * ring_rows) * w + at..][..w];
            correlate_row(pad, wts, dst);
        }
    };
    let y0i = y0 as i64;
    for r in y0i + job.lo..y0i + job.hi {
        fill(r, chunk, s);
    }
    for y in 0..n_rows {
        let yi = y0i + y as i64;
        fill(yi + job.hi, chunk, s);
        let out = &mut chunk[y * w..(y + 1) * w];
        for (k, (first, wts)) in job.kernels.iter().enumerate() {
            s.offsets.clear();
            let base = k * ring_rows * w;
            s.offsets
                .extend((0..wts.len() as i64).map(|j| base + slot(yi + first + j) * w));
            accumulate_row(&s.ring, &s.offsets, wts, out, k > 0);
        }
    }
}

fn source_row<'a, S>(source: &'a Source<S>, sc: usize, w: usize) -> &'a [S] {
    match source {
        Source::Plane(p) => &p[sc * w..(sc + 1) * w],
        Source::Halo {
            top_first,
            top,
            bottom_first,
            bottom,
        } => {
            if sc < *bottom_first {
                &top[(sc - top_first) * w..(sc - top_first + 1) * w]
            } else {
                &bottom[(sc - bottom_first) * w..(sc - bottom_first + 1) * w]
            }
        }
    }
}

/// pad[i] = row[clamp(first + i)] for i < len: clamped ends, converted middle.
fn fill_clamped<T: Sample, S: Sample>(pad: &mut Vec<T>, row: &[S], first: i64, len: usize) {
    let w = row.len() as i64;
    pad.clear();
    let left = (-first).clamp(0, len as i64) as usize;
    pad.extend(std::iter::repeat_n(T::from_sample(row[0]), left));
    // A kernel shifted wholly past the row reads only its border pixels.
    let start = (first + left as i64).clamp(0, w) as usize;
    let mid = (len - left).min(row.len().saturating_sub(start));
    pad.extend(row[start..start + mid].iter().map(|&v| T::from_sample(v)));
    let right = len - left - mid;
    pad.extend(std::iter::repeat_n(
        T::from_sample(row[(w - 1) as usize]),
        right,
    ));
}

/// out[x] = sum_j wts[j] pad[x + j], blocked so each output is stored once.
fn correlate_row<T: Sample>(pad: &[T], wts: &[T], out: &mut [T]) {
    #[cfg(target_arch = "x86_64")]
    if crate::numerics::has_avx2() {
        // SAFETY: has_avx2 checked the CPU features.
        return unsafe { correlate_row_avx2(pad, wts, out) };
    }
    correlate_row_lanes(pad, wts, out)
}

#[inline(always)]
fn correlate_row_lanes<T: Sample>(pad: &[T], wts: &[T], out: &mut [T]) {
    if is_f32::<T>() {
        correlate_row_generic::<T, LANES_F32>(pad, wts, out)
    } else {
        correlate_row_generic::<T, LANES_F64>(pad, wts, out)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn correlate_row_avx2<T: Sample>(pad: &[T], wts: &[T], out: &mut [T]) {
    correlate_row_lanes(pad, wts, out)
}

#[inline(always)]
fn correlate_row_generic<T: Sample, const LANES: usize>(pad: &[T], wts: &[T], out: &mut [T]) {
    let w = out.len();
    let n = wts.len();
    let sym = is_symmetric(wts);
    let mut x = 0;
    while x + LANES <= w {
        let window = &pad[x..x + n - 1 + LANES];
        let acc = if sym {
            // Mirrored taps share a weight: one product for two samples
            // (what OpenCV's symmetric column filter does).
            let mut acc = [T::default(); LANES];
            for j in 0..n / 2 {
                let (a, b) = (&window[j..j + LANES], &window[n - 1 - j..n - 1 - j + LANES]);
                for l in 0..LANES {
                    acc[l] += wts[j] * (a[l] + b[l]);
                }
            }
            if n % 2 == 1 {
                let m = &window[n / 2..n / 2 + LANES];
                for l in 0..LANES {
                    acc[l] += wts[n / 2] * m[l];
                }
            }
            acc
        } else {
            let mut acc = [T::default(); LANES];
            for (j, &wt) in wts.iter().enumerate() {
                let p = &window[j..j + LANES];
                for l in 0..LANES {
                    acc[l] += wt * p[l];
                }
            }
            acc
        };
        out[x..x + LANES].copy_from_slice(&acc);
        x += LANES;
    }
    for (xx, o) in out.iter_mut().enumerate().skip(x) {
        *o = tap_sum(wts, sym, |j| pad[xx + j]);
    }
}

/// Equal weights at mirrored taps (exactly, in the working precision).
fn is_symmetric<T: Sample>(wts: &[T]) -> bool {
    let n = wts.len();
    (0..n / 2).all(|j| wts[j].to_f64() == wts[n - 1 - j].to_f64())
}

/// sum_j wts[j] v(j), in the order the blocked loops use, for the samples
/// past the last whole block.
#[inline(always)]
fn tap_sum<T: Sample>(wts: &[T], sym: bool, v: impl Fn(usize) -> T) -> T {
    let n = wts.len();
    if !sym {
        return wts
            .iter()
            .enumerate()
            .fold(T::default(), |a, (j, &wt)| a + wt * v(j));
    }
    let mut acc = T::default();
    for j in 0..n / 2 {
        acc += wts[j] * (v(j) + v(n - 1 - j));
    }
    if n % 2 == 1 {
        acc += wts[n / 2] * v(n / 2);
    }
    acc
}

/// out[x] (+)= sum_j wts[j] ring[offsets[j] + x] (overwriting unless `add`).
fn accumulate_row<T: Sample, S: Sample>(
    ring: &[T],
    offsets: &[usize],
    wts: &[T],
    out: &mut [S],
    add: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if crate::numerics::has_avx2() {
        // SAFETY: has_avx2 checked the CPU features.
        return unsafe { accumulate_row_avx2(ring, offsets, wts, out, add) };
    }
    accumulate_row_lanes(ring, offsets, wts, out, add)
}

#[inline(always)]
fn accumulate_row_lanes<T: Sample, S: Sample>(
    ring: &[T],
    offsets: &[usize],
    wts: &[T],
    out: &mut [S],
    add: bool,
) {
    if is_f32::<T>() {
        accumulate_row_generic::<T, S, LANES_F32>(ring, offsets, wts, out, add)
    } else {
        accumulate_row_generic::<T, S, LANES_F64>(ring, offsets, wts, out, add)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn accumulate_row_avx2<T: Sample, S: Sample>(
    ring: &[T],
    offsets: &[usize],
    wts: &[T],
    out: &mut [S],
    add: bool,
) {
    accumulate_row_lanes(ring, offsets, wts, out, add)
}

#[inline(always)]
fn accumulate_row_generic<T: Sample, S: Sample, const LANES: usize>(
    ring: &[T],
    offsets: &[usize],
    wts: &[T],
    out: &mut [S],
    add: bool,
) {
    let w = out.len();
    let n = wts.len();
    let rows: &[usize] = &offsets[..n];
    let sym = is_symmetric(wts);
    let mut x = 0;
    while x + LANES <= w {
        let mut acc = [T::default(); LANES];
        if sym {
            for j in 0..n / 2 {
                let a = &ring[rows[j] + x..rows[j] + x + LANES];
                let b = &ring[rows[n - 1 - j] + x..rows[n - 1 - j] + x + LANES];
                for l in 0..LANES {
                    acc[l] += wts[j] * (a[l] + b[l]);
                }
            }
            if n % 2 == 1 {
                let m = &ring[rows[n / 2] + x..rows[n / 2] + x + LANES];
                for l in 0..LANES {
                    acc[l] += wts[n / 2] * m[l];
                }
            }
        } else {
            for (&off, &wt) in rows.iter().zip(wts) {
                let p = &ring[off + x..off + x + LANES];
                for l in 0..LANES {
                    acc[l] += wt * p[l];
                }
            }
        }
        store(&mut out[x..x + LANES], &acc, add);
        x += LANES;
    }
    for xx in x..w {
        let v = tap_sum(wts, sym, |j| ring[rows[j] + xx]);
        store(&mut out[xx..xx + 1], &[v], add);
    }
}

#[inline(always)]
fn store<T: Sample, S: Sample>(out: &mut [S], acc: &[T], add: bool) {
    if add {
        for (o, a) in out.iter_mut().zip(acc) {
            *o += S::from_sample(*a);
        }
    } else {
        for (o, a) in out.iter_mut().zip(acc) {
            *o = S::from_sample(*a);
        }
    }
}
