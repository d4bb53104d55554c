//! Error in image space (Freude 2014, ch. 6): per-channel RMS and maximum absolute
//! difference, also relative to the peak of the reference image, and a false
//! colour difference image (like Freude 2014, figures 5.11 and 6.17).

use super::image::srgb_to_linear;
use super::Image;
use crate::error::{Error, Result};
use serde::Serialize;

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiffStats {
    pub rms: [f64; 3],
    pub max_abs: [f64; 3],
    /// Divided by the peak of A per channel (by the largest peak when a
    /// channel of A is zero everywhere).
    pub rms_rel: [f64; 3],
    pub max_rel: [f64; 3],
}

pub fn compare(a: &Image, b: &Image) -> Result<DiffStats> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Unsupported(format!(
            "the images differ in size: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let scale = rel_scale(a);
    let mut s = DiffStats {
        rms: [0.0; 3],
        max_abs: [0.0; 3],
        rms_rel: [0.0; 3],
        max_rel: [0.0; 3],
    };
    let n = a.len().max(1) as f64;
    for c in 0..3 {
        let mut sq = 0.0;
        let mut mx = 0.0f64;
        for (x, y) in a.rgb[c].iter().zip(&b.rgb[c]) {
            let d = x - y;
            sq += d * d;
            mx = mx.max(d.abs());
        }
        s.rms[c] = (sq / n).sqrt();
        s.max_abs[c] = mx;
        s.rms_rel[c] = s.rms[c] / scale[c];
        s.max_rel[c] = mx / scale[c];
    }
    Ok(s)
}

/// What [`compare`] divides channel c by to make an error relative: the
/// peak of `a`'s channel, the largest peak where that channel is zero
/// everywhere, 1 where all are.
pub fn rel_scale(a: &Image) -> [f64; 3] {
    let peak = a.peak();
    let any_peak = peak.iter().fold(0.0f64, |m, &p| m.max(p));
    peak.map(|p| {
        let p = if p > 0.0 { p } else { any_peak };
        if p > 0.0 {
            p
        } else {
            1.0
        }
    })
}

/// Reference images of one size packed pixel by pixel, so that one image
/// is compared with all of them in one pass: [`RefStack::rms_rel`] gives
/// each reference's `compare(reference, b).rms_rel` bit for bit (each
/// reference's sum runs over the pixels in the same order; the references'
/// sums advance side by side instead of one after the other).
#[derive(Clone, Debug)]
pub struct RefStack {
    width: usize,
    height: usize,
    count: usize,
    /// Per channel, pixel i of reference r at `i * count + r`.
    planes: [Vec<f64>; 3],
    scales: Vec<[f64; 3]>,
}

impl RefStack {
    /// Packs `refs` (at least one, all of one size).
    pub fn new(refs: &[&Image]) -> Result<RefStack> {
        let Some(first) = refs.first() else {
            return Err(Error::Unsupported("no reference image to compare".into()));
        };
        for r in refs {
            super::image::check_same_size("a reference", r.width, r.height, first)?;
        }
        let count = refs.len();
        let planes = std::array::from_fn(|c| {
            let mut p = Vec::with_capacity(first.len() * count);
            for i in 0..first.len() {
                p.extend(refs.iter().map(|r| r.rgb[c][i]));
            }
            p
        });
        Ok(RefStack {
            width: first.width,
            height: first.height,
            count,
            planes,
            scales: refs.iter().map(|r| rel_scale(r)).collect(),
        })
    }

    /// References packed.
    pub fn len(&self) -> usize {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// `compare(reference, b).rms_rel` for every reference, in order (in
    /// AVX2 where the CPU has it).
    pub fn rms_rel(&self, b: &Image) -> Result<Vec<[f64; 3]>> {
        if (self.width, self.height) != (b.width, b.height) {
            return Err(Error::Unsupported(format!(
                "the images differ in size: {}x{} and {}x{}",
                self.width, self.height, b.width, b.height
            )));
        }
        #[cfg(target_arch = "x86_64")]
        if crate::numerics::has_avx2() {
            // SAFETY: has_avx2 checked the CPU features.
            return Ok(unsafe { self.rms_rel_avx2(b) });
        }
        Ok(self.rms_rel_lanes(b))
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn rms_rel_avx2(&self, b: &Image) -> Vec<[f64; 3]> {
        self.rms_rel_lanes(b)
    }

    #[inline(always)]
    fn rms_rel_lanes(&self, b: &Image) -> Vec<[f64; 3]> {
        let n = b.len().max(1) as f64;
        let mut out = vec![[0.0; 3]; self.count];
        let mut sq = vec![0.0f64; self.count];
        for c in 0..3 {
            sq.fill(0.0);
            for (refs, &y) in self.planes[c].chunks_exact(self.count).zip(&b.rgb[c]) {
                for (s, &x) in sq.iter_mut().zip(refs) {
                    let d = x - y;
                    *s += d * d;
                }
            }
            for ((o, s), scale) in out.iter_mut().zip(&sq).zip(&self.scales) {
                o[c] = (s / n).sqrt() / scale[c];
            }
        }
        out
    }
}

/// A colour ramp black - purple - red - yellow - white, for t in [0, 1],
/// as sRGB-encoded values.
pub fn heat(t: f64) -> [f64; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.35, 0.05, 0.55],
        [0.9, 0.15, 0.1],
        [1.0, 0.85, 0.0],
        [1.0, 1.0, 1.0],
    ];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mut c = [0.0; 3];
    for k in 0..3 {
        c[k] = STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f;
    }
    c
}

/// The largest per-channel |A - B| of each pixel through the heat ramp,
/// normalised by `scale` (default: the largest difference in the image).
/// Returned in linear light so a PNG written from it shows the ramp exactly.
pub fn false_colour(a: &Image, b: &Image, scale: Option<f64>) -> Image {
    let d = largest_per_pixel(a, b);
    let s = ramp_top(a, b, scale);
    let mut out = Image::new(a.width, a.height);
    for (i, v) in d.iter().enumerate() {
        let col = heat(if s > 0.0 { v / s } else { 0.0 });
        for c in 0..3 {
            out.rgb[c][i] = srgb_to_linear(col[c]);
        }
    }
    out
}

/// The largest per-channel |A - B| of each pixel.
fn largest_per_pixel(a: &Image, b: &Image) -> Vec<f64> {
    (0..a.len())
        .map(|i| (0..3).fold(0.0f64, |m, c| m.max((a.rgb[c][i] - b.rgb[c][i]).abs())))
        .collect()
}

/// The top of [`false_colour`]'s ramp: `scale`, or the largest difference
/// in the image.
pub fn ramp_top(a: &Image, b: &Image, scale: Option<f64>) -> f64 {
    scale.unwrap_or_else(|| largest_per_pixel(a, b).into_iter().fold(0.0f64, f64::max))
}

/// |A - B| per channel (for EXR output).
pub fn abs_difference(a: &Image, b: &Image) -> Image {
    let mut out = Image::new(a.width, a.height);
    for c in 0..3 {
        for i in 0..a.len() {
            out.rgb[c][i] = (a.rgb[c][i] - b.rgb[c][i]).abs();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_a_known_difference() {
        let mut a = Image::new(2, 2);
        a.rgb[0] = vec![2.0, 2.0, 2.0, 2.0];
        a.rgb[1] = vec![1.0, 0.0, 0.0, 0.0];
        let mut b = a.clone();
        b.rgb[0][3] = 0.0;
        let s = compare(&a, &b).unwrap();
        assert_eq!(s.max_abs, [2.0, 0.0, 0.0]);
        assert!((s.rms[0] - 1.0).abs() < 1e-15);
        assert!((s.rms_rel[0] - 0.5).abs() < 1e-15);
        assert_eq!(s.max_rel[0], 1.0);
    }

    /// The stack's relative RMS is `compare`'s bit for bit, for each
    /// reference (one with a dark channel, divided by the largest peak).
    #[test]
    fn the_stack_gives_compare_bit_for_bit() {
        use crate::filter::signals::noise;
        let mut refs: Vec<Image> = (0..5).map(|k| noise(13, 7, k)).collect();
        refs[2].rgb[1].fill(0.0);
        let b = noise(13, 7, 99);
        let stack = RefStack::new(&refs.iter().collect::<Vec<_>>()).unwrap();
        let got = stack.rms_rel(&b).unwrap();
        assert_eq!(got.len(), refs.len());
        let plain = stack.rms_rel_lanes(&b);
        for ((r, g), p) in refs.iter().zip(&got).zip(&plain) {
            let want = compare(r, &b).unwrap().rms_rel;
            assert_eq!(want.map(f64::to_bits), g.map(f64::to_bits));
            assert_eq!(want.map(f64::to_bits), p.map(f64::to_bits));
        }
        assert!(stack.rms_rel(&noise(7, 13, 1)).is_err());
    }
}
