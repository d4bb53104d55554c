//! Freude 2014, algorithm 4.1 per pixel in f64, the CPU twin of
//! shaders/sss_pass.wgsl: per rank a horizontal then a vertical 1D pass whose
//! tap offsets are scaled by the pixel's own step (strength, perspective
//! depth; Freude 2014, eq. 4.11), optionally jittered inside each tap's
//! footprint, with the depth-aware lerp toward the centre colour (Freude
//! 2014, eq. 4.12; Jimenez et al. 2009).
//!
//! Swept in place, top to bottom in bands of rows: per rank, a window of
//! horizontally filtered rows (the rows a band's vertical taps can reach)
//! slides down the image, and each band's output replaces its input rows,
//! which no later horizontal row reads. Besides the image, the sweep holds
//! one window per rank (about four times the vertical reach, in rows),
//! not the full-size intermediate and output images of a two-pass
//! filter (796 MB each at 8K in f64). Rayon over the rows of a band; each
//! output pixel is the same sum in the same order whatever the band or the
//! thread count (deterministic).
//!
//! Where every pixel has the same step and nothing is jittered or lerped
//! (a uniform scale without depth or strength: the advice scores its
//! candidates so), the rows are summed tap by tap ([`super::uniform_pass`]),
//! the same products added in the same order as [`PassCtx::pixel`] (bit for
//! bit, tested).

use super::bands::Bands;
use super::rows::par_span_rows;
use super::uniform_pass::{Lerp, Src, Uniform};
use super::{Image, Setup, Taps};

/// The direction of a 1D pass; the jitter of a tap differs between the two.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Axis {
    Horizontal,
    Vertical,
}

/// The blurred diffuse image: the sum over ranks of the vertical pass of the
/// horizontal pass. `setup` is taken as valid and the specular image is
/// not added (see `cpu::apply`, which does both).
pub fn apply_screen_space(image: &Image, setup: &Setup) -> Image {
    let mut out = image.clone();
    apply_screen_space_in_place(&mut out, setup);
    out
}

/// [`apply_screen_space`] overwriting `image` (its alpha kept).
pub fn apply_screen_space_in_place(image: &mut Image, setup: &Setup) {
    sweep(image, setup, None);
}

/// The sweep, in bands of `band` rows (None: from the vertical reach).
fn sweep(image: &mut Image, setup: &Setup, band: Option<usize>) {
    sweep_with(image, setup, band, true)
}

/// [`sweep`], with `uniform` false summing every pixel apart even where
/// the step is uniform (the tests' yardstick for the uniform path).
fn sweep_with(image: &mut Image, setup: &Setup, band: Option<usize>, uniform: bool) {
    let (w, h) = (image.width, image.height);
    if setup.passes.is_empty() || w * h == 0 {
        image.rgb.iter_mut().for_each(|p| p.fill(0.0));
        return;
    }
    let footprints = footprints_of(setup);
    let ctxs = contexts(setup, &footprints, w, h, uniform);
    let bands = bands_of(setup, &ctxs, w, h, band);
    let reach = bands.reach;
    let mut windows: Vec<Window> = ctxs.iter().map(|_| Window::new(bands.rows(2), w)).collect();
    bands.sweep(|a, b| {
        // Every rank's rows first: a band's output overwrites rows that
        // the horizontal pass of a later rank would otherwise read.
        for (win, ctx) in windows.iter_mut().zip(&ctxs) {
            win.advance(a.saturating_sub(reach), (b + reach).min(h), ctx, image);
        }
        for (k, (win, ctx)) in windows.iter().zip(&ctxs).enumerate() {
            ctx.vertical_rows(win, image, a, b, k > 0);
        }
    });
}

/// Per rank, the footprints of its taps when they are jittered.
fn footprints_of(setup: &Setup) -> Vec<Option<Vec<(f64, f64)>>> {
    setup
        .passes
        .iter()
        .map(|t| setup.jitter.then(|| t.footprints()))
        .collect()
}

/// Each rank's pass over a `w` x `h` image (`uniform` false: every pixel
/// summed apart even where the step is uniform).
fn contexts<'a>(
    setup: &'a Setup,
    footprints: &'a [Option<Vec<(f64, f64)>>],
    w: usize,
    h: usize,
    uniform: bool,
) -> Vec<PassCtx<'a>> {
    setup
        .passes
        .iter()
        .zip(footprints)
        .map(|(taps, f)| PassCtx {
            w,
            h,
            taps,
            setup,
            base: setup.scale.step_base(h),
            depth: setup.depth.as_ref().map(|d| d.data.as_slice()),
            follow: setup.follow_surface.map(|f| f.rate(&setup.scale)),
            footprints: f.as_deref(),
            uniform: Uniform::new(setup, taps, w, h).filter(|_| uniform),
        })
        .collect()
}

/// The bands of the sweep: the reach is the largest |offset| (with jitter,
/// anywhere in a tap's footprint) times the largest step.
fn bands_of(setup: &Setup, ctxs: &[PassCtx], w: usize, h: usize, band: Option<usize>) -> Bands {
    let widest = setup.steps_iter(w, h).fold(0.0, f64::max);
    let offset = ctxs
        .iter()
        .flat_map(|c| match c.footprints {
            Some(f) => f.iter().map(|(s, d)| s.abs() + d.abs()).collect::<Vec<_>>(),
            None => c.taps.offsets_mm.iter().map(|o| o.abs()).collect(),
        })
        .fold(0.0, f64::max);
    Bands::new(offset, widest, h, band)
}

/// One rank's horizontally filtered rows `first..first + rows`, each
/// plane's row `r` at `(r - first) * w`.
struct Window {
    planes: [Vec<f64>; 3],
    first: usize,
    rows: usize,
    w: usize,
}

impl Window {
    fn new(cap: usize, w: usize) -> Window {
        Window {
            planes: std::array::from_fn(|_| vec![0.0; cap * w]),
            first: 0,
            rows: 0,
            w,
        }
    }

    /// Holds rows `lo..hi`: drops the rows above `lo` (the rest moves to
    /// the front) and filters the new ones from `image`, whose rows from
    /// the old end on are still the input.
    fn advance(&mut self, lo: usize, hi: usize, ctx: &PassCtx, image: &Image) {
        let w = self.w;
        let drop = lo.saturating_sub(self.first).min(self.rows);
        for p in &mut self.planes {
            p.copy_within(drop * w..self.rows * w, 0);
        }
        self.first += drop;
        self.rows -= drop;
        let start = self.first + self.rows;
        if hi <= start {
            return;
        }
        let span = self.rows * w..(hi - self.first) * w;
        let [r, g, b] = &mut self.planes;
        if let Some(u) = &ctx.uniform {
            let out = [&mut r[span.clone()], &mut g[span.clone()], &mut b[span]];
            u.horizontal_rows(ctx.taps, image, start, hi, out);
            self.rows = hi - self.first;
            return;
        }
        par_span_rows(&mut self.planes, span, w, |j, [r, g, b]| {
            let y = start + j;
            let row = y * w..(y + 1) * w;
            let src = Src {
                planes: std::array::from_fn(|c| &image.rgb[c][row.clone()]),
                first: y,
            };
            for x in 0..w {
                let v = ctx.pixel(&src, Axis::Horizontal, x, y);
                (r[x], g[x], b[x]) = (v[0], v[1], v[2]);
            }
        });
        self.rows = hi - self.first;
    }
}

struct PassCtx<'a> {
    w: usize,
    h: usize,
    taps: &'a Taps,
    setup: &'a Setup,
    /// [`super::Scale::step_base`] of the image's height.
    base: f64,
    depth: Option<&'a [f64]>,
    follow: Option<f64>,
    /// Jittered taps: each tap's footprint (start, width) in kernel mm.
    footprints: Option<&'a [(f64, f64)]>,
    /// The rows' sums tap by tap, where every pixel has the same step.
    uniform: Option<Uniform>,
}

impl PassCtx<'_> {
    /// Rows `a..b` of the vertical pass over `win`, written into `image`
    /// (`add`: added to what the earlier ranks left there).
    fn vertical_rows(&self, win: &Window, image: &mut Image, a: usize, b: usize, add: bool) {
        let w = self.w;
        let src = Src {
            planes: std::array::from_fn(|c| &win.planes[c][..win.rows * w]),
            first: win.first,
        };
        par_span_rows(&mut image.rgb, a * w..b * w, w, |j, [r, g, bl]| {
            if let Some(u) = &self.uniform {
                return u.vertical_row(self.taps, &src, a + j, [r, g, bl], add);
            }
            for x in 0..w {
                let v = self.pixel(&src, Axis::Vertical, x, a + j);
                if add {
                    (r[x], g[x], bl[x]) = (r[x] + v[0], g[x] + v[1], bl[x] + v[2]);
                } else {
                    (r[x], g[x], bl[x]) = (v[0], v[1], v[2]);
                }
            }
        });
    }

    fn pixel(&self, src: &Src, axis: Axis, x: usize, y: usize) -> [f64; 3] {
        let (w, h) = (self.w, self.h);
        let centre = y * w + x;
        let shift = src.first * w;
        let (coord, n, stride, base) = match axis {
            Axis::Horizontal => (x, w, 1, y * w),
            Axis::Vertical => (y, h, w, x),
        };
        let step = self.setup.step_at(self.base, centre);
        let planes = src.planes;
        let local = centre - shift;
        let centre_colour = [planes[0][local], planes[1][local], planes[2][local]];
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
            let Lerp { i0, i1, f, g } = Lerp::at(coord, off * step, n);
            let (a, b) = (base + i0 * stride, base + i1 * stride);
            let mut o = [0.0; 3];
            for c in 0..3 {
                o[c] = planes[c][a - shift] * g + planes[c][b - shift] * f;
            }
            if let (Some(k), Some(d)) = (self.follow, self.depth) {
                let od = d[a] * (1.0 - f) + d[b] * f;
                // Freude 2014, eq. 4.12: lerp toward the centre colour by depth difference.
                let t = super::follow_t(k, d[centre], od);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::disk_error::view;
    use crate::filter::signals::noise;
    use crate::filter::{FollowSurface, Plane, Scale};

    /// Two ranks of a small asymmetric kernel with every per-pixel feature
    /// on (perspective depth, strength, jitter, the depth-aware lerp): a
    /// reach of a few rows on an image of 70, so small bands slide the
    /// window and drop rows.
    fn busy_setup(w: usize, h: usize) -> Setup {
        let taps = Taps {
            offsets_mm: vec![-0.9, -0.3, 0.0, 0.4, 1.1],
            weights: vec![
                [0.1, 0.2, 0.05],
                [0.2, 0.2, 0.25],
                [0.4, 0.3, 0.4],
                [0.2, 0.2, 0.2],
                [0.1, 0.1, 0.1],
            ],
        };
        let mut other = taps.clone();
        other.offsets_mm.iter_mut().for_each(|o| *o *= -0.7);
        let plane = |f: &dyn Fn(usize) -> f64| Plane::from_index(w, h, f);
        Setup {
            passes: vec![taps, other],
            scale: Scale::Perspective {
                fov_y_deg: 40.0,
                sss_width: 0.01,
            },
            depth: Some(plane(&|i| 0.5 + ((i * 7919) % 13) as f64 * 0.05)),
            strength: Some(plane(&|i| 0.5 + ((i * 104729) % 5) as f64 * 0.25)),
            follow_surface: Some(FollowSurface::InSceneUnits(2.0)),
            specular: None,
            jitter: true,
        }
    }

    #[test]
    fn bands_of_any_height_give_the_one_band_result_bit_for_bit() {
        let (w, h) = (19, 70);
        let img = noise(w, h, 99);
        let setup = busy_setup(w, h);
        assert!(setup.jitter, "the reach holds the jittered footprints");
        let f = footprints_of(&setup);
        let ctxs_reach = bands_of(&setup, &contexts(&setup, &f, w, h, false), w, h, None).reach;
        // The window must be shorter than the image for the test to mean
        // anything: rows are dropped and filtered again never.
        assert!(4 * ctxs_reach < h, "reach {ctxs_reach}");
        crate::filter::band_check::assert_bands_agree(&img, &[1, 2, 5, 13, 31], |out, band| {
            sweep(out, &setup, Some(band))
        });
    }

    /// The uniform path sums what the per-pixel one does, bit for bit: two
    /// ranks of asymmetric taps at fractional positions, some past either
    /// edge (clamped), on a wide and a tall image, in several band heights.
    #[test]
    fn the_uniform_path_is_the_per_pixel_sum_bit_for_bit() {
        let taps = Taps {
            offsets_mm: vec![-7.3, -0.91, -0.3, 0.0, 0.37, 1.13, 2.9],
            weights: vec![
                [0.05, 0.1, 0.02],
                [0.1, 0.2, 0.05],
                [0.2, 0.2, 0.25],
                [0.3, 0.3, 0.4],
                [0.2, 0.1, 0.2],
                [0.1, 0.05, 0.1],
                [-0.02, 0.05, 0.01],
            ],
        };
        let mut other = taps.clone();
        other.offsets_mm.iter_mut().for_each(|o| *o *= -0.6);
        for (w, h) in [(150, 37), (23, 90)] {
            let img = noise(w, h, 7);
            let setup = Setup {
                passes: vec![taps.clone(), other.clone()],
                ..view(0.37)
            };
            for band in [None, Some(3), Some(40)] {
                let (mut fast, mut slow) = (img.clone(), img.clone());
                sweep_with(&mut fast, &setup, band, true);
                sweep_with(&mut slow, &setup, band, false);
                for c in 0..3 {
                    for (i, (a, b)) in fast.rgb[c].iter().zip(&slow.rgb[c]).enumerate() {
                        assert_eq!(
                            a.to_bits(),
                            b.to_bits(),
                            "{w}x{h} band {band:?} c {c} px {i}"
                        );
                    }
                }
                assert_ne!(fast.rgb[0], img.rgb[0]);
            }
        }
    }
}
