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
    let peak = a.peak();
    let any_peak = peak.iter().fold(0.0f64, |m, &p| m.max(p));
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
        let p = if peak[c] > 0.0 { peak[c] } else { any_peak };
        let p = if p > 0.0 { p } else { 1.0 };
        s.rms_rel[c] = s.rms[c] / p;
        s.max_rel[c] = mx / p;
    }
    Ok(s)
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
}
