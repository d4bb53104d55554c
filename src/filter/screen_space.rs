//! Freude 2014, algorithm 4.1 per pixel in f64, the CPU twin of
//! shaders/sss_pass.wgsl: per rank a horizontal then a vertical 1D pass whose
//! tap offsets are scaled by the pixel's own step (strength, perspective
//! depth; Freude 2014, eq. 4.11), optionally jittered inside each tap's
//! footprint, with the depth-aware lerp toward the centre colour (Freude
//! 2014, eq. 4.12; Jimenez et al. 2009). Rayon over rows; each output pixel
//! is computed by one thread (deterministic).

use super::image::par_planes;
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
    let (w, h) = (image.width, image.height);
    let steps = setup.steps(w, h);
    let depth = setup.depth.as_ref().map(|d| d.data.as_slice());
    let follow = setup.follow_surface.map(|f| f.rate(&setup.scale));
    // The first rank's result becomes the sum (no zeroed image beside it:
    // at 8K each f64 image is 796 MB).
    let mut sum: Option<[Vec<f64>; 3]> = None;
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
        drop(tmp);
        match sum.as_mut() {
            None => sum = Some(v),
            Some(s) => {
                for c in 0..3 {
                    s[c].iter_mut().zip(&v[c]).for_each(|(o, x)| *o += x);
                }
            }
        }
    }
    let mut out = Image::new(0, 0);
    (out.width, out.height) = (w, h);
    out.rgb = sum.unwrap_or_else(|| Image::new(w, h).rgb);
    out.alpha = image.alpha.clone();
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
        par_planes(self.w, self.h, |x, y| self.pixel(src, axis, x, y))
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
