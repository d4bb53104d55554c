//! How far a filtered image's mean colour lies from the exact image's, in
//! hue and chroma only: what a contact sheet flags when a model tints the
//! whole tile (manual-fit's hue on the shapes sheet).
//!
//! The mean linear RGB of each tile, times the sheet's exposure, is taken
//! to CIELAB (sRGB primaries and D65 white, Wyszecki and Stiles 1982) after
//! the result's mean is scaled to the exact mean's luminance Y, so that a
//! brighter or darker tile (a kernel that loses energy at the border) is
//! not counted: with equal L*, the CIELAB colour difference Delta E*ab is
//! sqrt(Delta a*^2 + Delta b*^2), chroma and hue together.

use crate::filter::Image;

/// Largest Delta E*ab (at equal lightness) a tile's mean colour may lie
/// from the exact tile's before the sheet and report.md flag it: 2.3 is the
/// just noticeable difference of CIELAB (Mahy et al. 1994), so an
/// unflagged model's tint is one no viewer can tell from the exact one's.
pub const COLOUR_TOLERANCE_DE: f64 = 2.3;

/// sRGB (linear, D65) to CIE XYZ: the matrix of the sRGB standard, IEC
/// 61966-2-1.
const RGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// The mean of each channel over the image.
pub fn mean_rgb(img: &Image) -> [f64; 3] {
    let n = img.len().max(1) as f64;
    std::array::from_fn(|c| img.rgb[c].iter().sum::<f64>() / n)
}

fn xyz(rgb: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|c| RGB_TO_XYZ[i][c] * rgb[c]).sum())
}

/// CIELAB of XYZ (Wyszecki and Stiles 1982, with the linear segment below
/// (6/29)^3).
fn lab(xyz: [f64; 3]) -> [f64; 3] {
    const D: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > D * D * D {
            t.cbrt()
        } else {
            t / (3.0 * D * D) + 4.0 / 29.0
        }
    };
    // The reference white is sRGB's own (RGB 1, 1, 1: D65 at Y = 1), so
    // that a grey has a* = b* = 0 exactly with the rounded matrix.
    let white: [f64; 3] = std::array::from_fn(|i| RGB_TO_XYZ[i].iter().sum());
    let [fx, fy, fz] = std::array::from_fn(|i| f(xyz[i] / white[i]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Delta E*ab between the mean colours `exact` and `result` (linear RGB,
/// exposed so that 1 is the display's white) at equal luminance: the
/// difference in chroma and hue. 0 when either is black.
pub fn hue_chroma_difference(exact: [f64; 3], result: [f64; 3]) -> f64 {
    let (xe, xr) = (xyz(exact), xyz(result));
    if !(xe[1] > 0.0 && xr[1] > 0.0) {
        return 0.0;
    }
    let scaled = xr.map(|v| v * xe[1] / xr[1]);
    let (a, b) = (lab(xe), lab(scaled));
    ((a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// [`hue_chroma_difference`] of two images' mean colours under `exposure`.
pub fn tile_difference(exact: &Image, result: &Image, exposure: f64) -> f64 {
    let e = mean_rgb(exact).map(|v| v * exposure);
    let r = mean_rgb(result).map(|v| v * exposure);
    hue_chroma_difference(e, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_is_the_origin_of_a_and_b() {
        let l = lab(xyz([1.0, 1.0, 1.0]));
        assert!((l[0] - 100.0).abs() < 1e-3, "{l:?}");
        assert!(l[1].abs() < 1e-12 && l[2].abs() < 1e-12, "{l:?}");
    }

    #[test]
    fn brightness_is_not_a_colour_difference_but_a_tint_is() {
        let grey = [0.4, 0.4, 0.4];
        // Half as bright: the same chromaticity, nothing to flag.
        assert!(hue_chroma_difference(grey, [0.2, 0.2, 0.2]) < 1e-9);
        // 10% more red: a visible tint, well past the tolerance.
        let d = hue_chroma_difference(grey, [0.44, 0.4, 0.4]);
        assert!(d > COLOUR_TOLERANCE_DE, "{d}");
        // 0.5% more red: below the just noticeable difference.
        let d = hue_chroma_difference(grey, [0.402, 0.4, 0.4]);
        assert!(d < COLOUR_TOLERANCE_DE, "{d}");
        assert_eq!(hue_chroma_difference([0.0; 3], grey), 0.0);
    }
}
