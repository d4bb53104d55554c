//! The separable path under a uniform scale: each rank's 1D factor becomes
//! a fixed kernel on whole pixels, and the image is filtered as the sum over
//! ranks of vertical(horizontal(I)) (Freude 2014, eq. 5.10; the two 1D
//! passes of Jimenez et al. 2015), borders clamped. The per-pixel algorithm
//! reduces to this when every pixel has the same step and no depth lerp
//! (see `PixelKernel::from_taps`), and this path is then much faster: f64 or
//! f32 ([`Precision`]), SIMD-friendly row and column loops, rayon over
//! strips of rows with no cross-thread sums (deterministic).

use super::sample::{PixelKernel, Sample};
use super::sweep::{self, Job};
use super::Image;

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
        apply_separable_plane_in_place::<T, f64>(&mut image.rgb[c], &mut halo, (w, h), kernels, c);
    }
}

/// [`apply_separable_in_place`] for the plane of channel `c` alone (`w` x
/// `h` samples, row-major), computing in `T` and storing in `S`: with `T`
/// f32, f32 samples give what f64 ones holding the same values give, bit
/// for bit (the sweep computes in `T` either way, and `T`'s results are
/// stored exactly in either).
pub fn apply_separable_plane_in_place<T: Sample, S: Sample>(
    plane: &mut [S],
    halo: &mut Vec<S>,
    (w, h): (usize, usize),
    kernels: &[PixelKernel],
    c: usize,
) {
    if kernels.is_empty() || w == 0 || h == 0 {
        plane.fill(S::default());
        return;
    }
    sweep::plane_in_place(&Job::<T>::new(kernels, c, w, h), plane, halo);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::signals::noise;
    use crate::filter::Taps;

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

#[cfg(test)]
mod sweep_tests {
    use super::*;
    use crate::filter::signals::noise;
    use crate::filter::{Image, Taps};

    /// f32 against the f64 sweep: each output sums at most a few dozen
    /// products of f32 round-off 6e-8 each, relative to the plane's peak
    /// (a normalised kernel never exceeds it); 1e-6 leaves a factor of
    /// about 1.5 over 11 taps x 6e-8.
    const F32_REL: f64 = 1e-6;

    /// Direct clamp-to-edge convolution, rows then columns, in f64: the
    /// definition, with no ring, strip or halo.
    fn naive(img: &Image, kernels: &[PixelKernel]) -> Image {
        let (w, h) = (img.width, img.height);
        let mut out = Image::new(w, h);
        let at = |i: i64, n: usize| i.clamp(0, n as i64 - 1) as usize;
        for c in 0..3 {
            for k in kernels {
                let mut rows = vec![0.0; w * h];
                for y in 0..h {
                    for x in 0..w {
                        rows[y * w + x] = (k.weights.iter().enumerate())
                            .map(|(j, v)| {
                                v[c] * img.rgb[c][y * w + at(x as i64 + k.first + j as i64, w)]
                            })
                            .sum();
                    }
                }
                for y in 0..h {
                    for x in 0..w {
                        out.rgb[c][y * w + x] += (k.weights.iter().enumerate())
                            .map(|(j, v)| v[c] * rows[at(y as i64 + k.first + j as i64, h) * w + x])
                            .sum::<f64>();
                    }
                }
            }
        }
        out
    }

    fn kernels() -> Vec<PixelKernel> {
        let t = Taps {
            offsets_mm: vec![-0.9, -0.2, 0.0, 0.5, 1.1],
            weights: vec![
                [0.1, 0.2, 0.3],
                [0.2; 3],
                [0.4, 0.3, 0.1],
                [0.2; 3],
                [0.1; 3],
            ],
        };
        // Rank 4: two asymmetric kernels, one wholly below the pixel
        // (offsets -9..-7: the ring must still hold the output's own row)
        // and a symmetric one.
        vec![
            PixelKernel::from_taps(&t, 3.0),
            PixelKernel::from_taps(&t, 1.7),
            PixelKernel {
                first: -9,
                weights: vec![[0.3; 3], [-0.1; 3], [0.2; 3]],
            },
            // Symmetric in every channel: the folded loops.
            PixelKernel {
                first: -2,
                weights: vec![
                    [0.1, 0.2, 0.05],
                    [0.2; 3],
                    [0.4; 3],
                    [0.2; 3],
                    [0.1, 0.2, 0.05],
                ],
            },
        ]
    }

    fn max_rel(a: &Image, b: &Image) -> f64 {
        let peak = a.peak().iter().fold(0.0f64, |m, &p| m.max(p));
        (0..3)
            .flat_map(|c| a.rgb[c].iter().zip(&b.rgb[c]).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max)
            / peak
    }

    #[test]
    fn in_place_and_into_equal_the_direct_convolution_at_any_thread_count() {
        let k = kernels();
        // 41 rows: one strip; 300 rows: several strips with halos (rows
        // per strip at least 8 x the 20-row span); 3 x 2: smaller than
        // the kernel in both directions. Widths 150 and 70: whole blocks
        // (64 f32 or 32 f64 outputs) and a tail.
        for (w, h) in [(150, 41), (70, 300), (3, 2)] {
            let img = noise(w, h, 12345);
            let exact = naive(&img, &k);
            let mut results = Vec::new();
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| {
                    let mut into = Image::new(1, 1);
                    apply_separable_into::<f64>(&img, &k, &mut into);
                    let mut in_place = img.clone();
                    apply_separable_in_place::<f64>(&mut in_place, &k);
                    assert_eq!(into.rgb, in_place.rgb, "{w}x{h}, {threads} threads");
                    // The sweep sums in another order than the definition.
                    assert!(max_rel(&exact, &into) < 1e-14, "{w}x{h}");
                    let mut f32_place = img.clone();
                    apply_separable_in_place::<f32>(&mut f32_place, &k);
                    assert!(max_rel(&exact, &f32_place) < F32_REL, "{w}x{h}");
                    let mut out = [vec![0f32; w * h], vec![0f32; w * h], vec![0f32; w * h]];
                    for c in 0..3 {
                        let src: Vec<f32> = img.rgb[c].iter().map(|&v| v as f32).collect();
                        apply_separable_f32(&src, &mut out[c], (w, h), &k, c);
                    }
                    let planes = out.map(|p| p.iter().map(|&v| v as f64).collect());
                    let f32_frame = Image {
                        rgb: planes,
                        ..img.clone()
                    };
                    assert!(max_rel(&exact, &f32_frame) < F32_REL, "{w}x{h}");
                    results.push((into.rgb, f32_place.rgb, f32_frame.rgb));
                });
            }
            assert!(
                results[0] == results[1],
                "{w}x{h}: thread count changed the result"
            );
        }
    }

    /// A kernel far wider than the image (its taps beyond the image folded
    /// onto the border offsets) gives the direct convolution's image.
    #[test]
    fn a_kernel_wider_than_the_image_gives_the_direct_result() {
        let img = noise(9, 7, 77);
        let k = vec![PixelKernel {
            first: -40,
            weights: (0..95).map(|i| [0.01 + 1e-4 * i as f64; 3]).collect(),
        }];
        let want = naive(&img, &k);
        let got = apply_separable(&img, &k);
        for c in 0..3 {
            for (a, b) in got.rgb[c].iter().zip(&want.rgb[c]) {
                assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{a} {b}");
            }
        }
    }
}
