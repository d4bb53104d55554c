//! Kernel-to-pixel checks: whether a kernel at a given scale has anything
//! to blur, and whether its taps sit so far apart that the result bands.
//!
//! A separable pass samples the image at `offset x step` pixels with linear
//! interpolation between the two nearest pixels (Freude 2014, algorithm
//! 4.1), so each tap reads two neighbouring pixels: once two taps are more
//! than [`BANDING_GAP_PX`] pixels apart, the pixels between them are never
//! read and an edge comes out as a staircase of shifted copies (the banded
//! rings of a large kernel with few taps).

use super::Taps;
use serde::{Deserialize, Serialize};

/// Largest tap gap (pixels) with no pixel skipped between two taps.
pub const BANDING_GAP_PX: f64 = 2.0;

/// Kernel radius (pixels) under which the blur moves almost nothing.
pub const UNDER_PIXEL_PX: f64 = 1.0;

/// Taps whose weight is under this fraction of the pass's total |weight|
/// (in every channel) are ignored by the gap check: a gap in a tail that
/// carries nothing cannot band.
pub const NEGLIGIBLE_WEIGHT: f64 = 1e-3;

/// Fraction of the factor's mass the reported radius holds.
pub const RADIUS_HOLD: f64 = 0.99;

/// A problem of a kernel at a scale, with its numbers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ScaleWarning {
    /// The radius holding [`RADIUS_HOLD`] of the largest factor is under
    /// [`UNDER_PIXEL_PX`] pixels: the filter leaves the image almost as is.
    UnderPixel {
        radius_mm: f64,
        radius_px: f64,
        /// Outermost tap offset in mm and in pixels.
        extent_mm: f64,
        extent_px: f64,
    },
    /// Two weighted neighbouring taps are more than `threshold_px` apart.
    TapGap {
        gap_mm: f64,
        gap_px: f64,
        threshold_px: f64,
        /// Offset of the gap's outer tap.
        at_mm: f64,
    },
}

impl std::fmt::Display for ScaleWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ScaleWarning::UnderPixel {
                radius_mm,
                radius_px,
                extent_mm,
                extent_px,
            } => write!(
                f,
                "{:.0}% of the kernel's weight lies within {radius_px:.2} px of its centre \
                 ({radius_mm:.4} mm), though its taps reach {extent_px:.1} px ({extent_mm:.4} \
                 mm): at this scale the blur moves almost no light to another pixel and leaves \
                 the image almost unchanged",
                RADIUS_HOLD * 100.0
            ),
            ScaleWarning::TapGap {
                gap_mm,
                gap_px,
                threshold_px,
                at_mm,
            } => write!(
                f,
                "tap gaps exceed {threshold_px} px: the largest is {gap_mm:.4} mm = \
                 {gap_px:.1} px (outer tap at {at_mm:.3} mm); pixels between taps are never \
                 read, expect banding: use more taps, a smaller tap extent, or the \
                 full-resolution factors"
            ),
        }
    }
}

/// Radius (mm) from the origin holding `fraction` of sum |w| of one pass
/// (largest over channels).
fn pass_radius_holding(t: &Taps, fraction: f64) -> f64 {
    let mut r: f64 = 0.0;
    for c in 0..3 {
        let total: f64 = t.weights.iter().map(|w| w[c].abs()).sum();
        if !(total > 0.0) {
            continue;
        }
        let mut order: Vec<usize> = (0..t.offsets_mm.len()).collect();
        order.sort_by(|&a, &b| t.offsets_mm[a].abs().total_cmp(&t.offsets_mm[b].abs()));
        let mut acc = 0.0;
        for i in order {
            acc += t.weights[i][c].abs();
            if acc >= fraction * total {
                r = r.max(t.offsets_mm[i].abs());
                break;
            }
        }
    }
    r
}

/// The warnings for `passes` applied at `px_per_mm` pixels per kernel
/// millimetre (the largest step of the image, where gaps are widest and the
/// kernel biggest). `sampled`: the passes are sampled taps (a tap table, or
/// factors used as taps); false for factors resampled to whole pixels,
/// which have no gaps.
pub fn scale_warnings(passes: &[Taps], px_per_mm: f64, sampled: bool) -> Vec<ScaleWarning> {
    let mut out = Vec::new();
    if passes.is_empty() || !(px_per_mm > 0.0 && px_per_mm.is_finite()) {
        return out;
    }
    let radius_mm = passes
        .iter()
        .map(|t| pass_radius_holding(t, RADIUS_HOLD))
        .fold(0.0, f64::max);
    let extent_mm = passes
        .iter()
        .flat_map(|t| t.offsets_mm.iter().map(|o| o.abs()))
        .fold(0.0, f64::max);
    if radius_mm * px_per_mm < UNDER_PIXEL_PX {
        out.push(ScaleWarning::UnderPixel {
            radius_mm,
            radius_px: radius_mm * px_per_mm,
            extent_mm,
            extent_px: extent_mm * px_per_mm,
        });
    }
    if sampled {
        if let Some((gap_mm, at_mm)) = largest_gap(passes) {
            let gap_px = gap_mm * px_per_mm;
            if gap_px > BANDING_GAP_PX {
                out.push(ScaleWarning::TapGap {
                    gap_mm,
                    gap_px,
                    threshold_px: BANDING_GAP_PX,
                    at_mm,
                });
            }
        }
    }
    out
}

/// Largest gap (mm) between neighbouring weighted taps of any pass, and
/// the offset of its outer tap.
pub fn largest_gap(passes: &[Taps]) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    for t in passes {
        let totals: [f64; 3] =
            std::array::from_fn(|c| t.weights.iter().map(|w| w[c].abs()).sum::<f64>());
        let kept: Vec<f64> = t
            .offsets_mm
            .iter()
            .zip(&t.weights)
            .filter(|(_, w)| (0..3).any(|c| w[c].abs() >= NEGLIGIBLE_WEIGHT * totals[c]))
            .map(|(o, _)| *o)
            .collect();
        for w in kept.windows(2) {
            let gap = w[1] - w[0];
            let outer = if w[1].abs() > w[0].abs() { w[1] } else { w[0] };
            if best.is_none_or(|(g, _)| gap > g) {
                best = Some((gap, outer));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn taps(offsets: &[f64], weights: &[f64]) -> Taps {
        Taps {
            offsets_mm: offsets.to_vec(),
            weights: weights.iter().map(|&w| [w, w, w]).collect(),
        }
    }

    #[test]
    fn gaps_and_radius_in_pixels() {
        let t = taps(&[-3.0, -1.0, 0.0, 1.0, 3.0], &[0.1, 0.2, 0.4, 0.2, 0.1]);
        // Gap 2 mm at 0.5 px/mm: 1 px, no banding; radius 3 mm = 1.5 px.
        assert!(scale_warnings(std::slice::from_ref(&t), 0.5, true).is_empty());
        // At 2 px/mm the 2 mm gap is 4 px.
        let w = scale_warnings(std::slice::from_ref(&t), 2.0, true);
        assert_eq!(
            w,
            vec![ScaleWarning::TapGap {
                gap_mm: 2.0,
                gap_px: 4.0,
                threshold_px: BANDING_GAP_PX,
                at_mm: -3.0
            }]
        );
        // Resampled factors have no gaps to report.
        assert!(scale_warnings(std::slice::from_ref(&t), 2.0, false).is_empty());
        // At 0.1 px/mm the whole kernel is 0.3 px wide.
        let w = scale_warnings(std::slice::from_ref(&t), 0.1, true);
        assert!(
            matches!(w[0], ScaleWarning::UnderPixel { radius_px, .. } if (radius_px - 0.3).abs() < 1e-12)
        );
    }

    #[test]
    fn a_gap_in_a_weightless_tail_does_not_band() {
        let t = taps(&[-30.0, -1.0, 0.0, 1.0, 30.0], &[1e-6, 0.3, 0.4, 0.3, 1e-6]);
        assert_eq!(largest_gap(std::slice::from_ref(&t)), Some((1.0, -1.0)));
    }
}
