//! Real-time tap tables (Jimenez et al. 2015; iryoku/separable-sss).
//!
//! Offsets: o_i = -RANGE + i 2 RANGE / (N - 1), offset_i = RANGE sign(o_i)
//! o_i^2 / RANGE^2 (dense near 0), RANGE = 3 if N > 20 else 2. Unit scale:
//! one offset unit is extent / RANGE millimetres, so the outermost taps sit at
//! the kernel's edge (+-extent mm); `offsets_mm` are surface millimetres,
//! which a renderer turns into pixels with its own pixels-per-mm (Jimenez:
//! sssWidth times the depth and field-of-view scale).
//!
//! Weights: the factor integrated over each tap's footprint (from the midpoint
//! with the previous tap to the midpoint with the next; the end taps reach
//! the kernel's edge), not point samples; the factor is a cell-integrated
//! density, so footprints split cells exactly. Per channel, the weights are
//! then scaled so the tap kernel has the model's 1-norm.

use super::factors::Factors;
use super::{Kernel2D, Pass, TapTable};
use crate::error::{finite_positive, Error, Result};

pub const DEFAULT_TAPS: usize = 17;

/// Jimenez's RANGE.
pub fn range(n: usize) -> f64 {
    if n > 20 {
        3.0
    } else {
        2.0
    }
}

/// Unit offsets, increasing, the middle one 0.
pub fn unit_offsets(n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![0.0];
    }
    let r = range(n);
    (0..n)
        .map(|i| {
            let o = -r + i as f64 * 2.0 * r / (n - 1) as f64;
            r * o.signum() * o * o / (r * r)
        })
        .map(|v| if v == 0.0 { 0.0 } else { v })
        .collect()
}

/// Integral of a cell-integrated factor over [x0, x1] (mm), treating each
/// cell as a constant density.
fn integrate(k: &Kernel2D, a: &[f64], x0: f64, x1: f64) -> f64 {
    let e = k.extent_mm();
    let (lo, hi) = (x0.max(-e), x1.min(e));
    if !(hi > lo) {
        return 0.0;
    }
    let first = (((lo + e) / k.cell_mm).floor() as usize).min(k.size - 1);
    let last = (((hi + e) / k.cell_mm).ceil() as usize).clamp(first + 1, k.size);
    let mut s = 0.0;
    for (j, aj) in a.iter().enumerate().take(last).skip(first) {
        let c0 = -e + j as f64 * k.cell_mm;
        let c1 = c0 + k.cell_mm;
        let overlap = (hi.min(c1) - lo.max(c0)).max(0.0);
        s += aj * overlap / k.cell_mm;
    }
    s
}

/// The half-width (mm) of a table of `count` taps: the radius holding
/// `hold_for_taps(count)` of the factors' mass, never beyond the kernel.
pub fn auto_extent(k: &Kernel2D, f: &Factors, count: usize) -> f64 {
    factor_radius_holding(k, f, hold_for_taps(count))
}

/// Fraction of the 1D factors' mass the tap table spans for `count` taps:
/// 1 - 0.7 count^-1.2 (0.90 at 5 taps, 0.977 at 17, 0.990 at 33).
///
/// Why not the whole kernel: with Jimenez's quadratic spacing the outer gap
/// is about a quarter of the extent, so a table spanning the kernel's full
/// extent spends its outer taps on a tail that carries almost nothing while
/// the core is undersampled. Measured on the image-space error (relative RMS
/// against the exact 2D convolution) of the edge and shapes signals at 0.05
/// and 0.2 mm per pixel, for the pre-integrated and renormalised rank-1 SVD
/// kernels of skin1, marble and ketchup, over held fractions 0.9 to 1: the
/// best fraction grows with the tap count (about 0.9 at 5 taps, 0.97 at 9,
/// 0.98 at 17, 0.99 at 25 and 33); this power law follows those optima, and
/// its error is within about 6% of the best fraction of each case on average
/// where the full extent is 17% (33 taps) to 67% (5 taps) above it.
pub fn hold_for_taps(count: usize) -> f64 {
    1.0 - (0.7 * (count.max(1) as f64).powf(-1.2)).min(0.3)
}

/// Radius (mm) holding `fraction` of the factors' mass: per channel, of
/// sum_i |a_i| (cells on both sides counted), the largest over channels,
/// at a cell edge, at most the kernel's extent.
pub fn factor_radius_holding(k: &Kernel2D, f: &Factors, fraction: f64) -> f64 {
    let e = k.extent_mm();
    if !(fraction < 1.0) {
        return e;
    }
    let h = k.half();
    let mut radius: f64 = 0.0;
    for c in 0..3 {
        let mass = |j: usize| f.iter().map(|t| t[c][j].abs()).sum::<f64>();
        let total: f64 = (0..k.size).map(mass).sum();
        if !(total > 0.0) {
            continue;
        }
        // Cells h-m ..= h+m hold the mass within (m + 1/2) cells.
        let mut acc = mass(h);
        let mut m = 0;
        while acc < fraction * total && m < h {
            m += 1;
            acc += mass(h - m) + mass(h + m);
        }
        radius = radius.max((m as f64 + 0.5) * k.cell_mm);
    }
    radius.min(e)
}

/// The table over the automatic extent ([`auto_extent`]).
pub fn tap_table(k: &Kernel2D, f: &Factors, count: usize) -> Result<TapTable> {
    tap_table_with(k, f, count, None)
}

/// A tap count a table can have: odd (a centre tap), at most 255.
pub fn check_count(count: usize) -> Result<()> {
    if count == 0 || count.is_multiple_of(2) || count > 255 {
        return Err(Error::invalid(
            "taps",
            "count",
            count,
            "must be odd, between 1 and 255",
        ));
    }
    Ok(())
}

/// The table of `count` taps over +-`extent_mm` (None: [`auto_extent`]).
/// The factor beyond the extent is dropped and each channel renormalised to
/// the model's 1-norm: folding it into the end taps instead would put a
/// visible copy of the image at the outermost offset.
pub fn tap_table_with(
    k: &Kernel2D,
    f: &Factors,
    count: usize,
    extent_mm: Option<f64>,
) -> Result<TapTable> {
    check_count(count)?;
    let e = match extent_mm {
        Some(x) => finite_positive("taps", "extent_mm", x, " (mm)")?.min(k.extent_mm()),
        None => auto_extent(k, f, count),
    };
    let r = range(count);
    let offsets: Vec<f64> = unit_offsets(count).iter().map(|u| u * e / r).collect();
    let bounds: Vec<f64> = std::iter::once(-e)
        .chain(offsets.windows(2).map(|w| 0.5 * (w[0] + w[1])))
        .chain(std::iter::once(e))
        .collect();
    let mut passes: Vec<Pass> = f
        .iter()
        .map(|term| Pass {
            offsets_mm: offsets.clone(),
            weights: (0..count)
                .map(|i| std::array::from_fn(|c| integrate(k, &term[c], bounds[i], bounds[i + 1])))
                .collect(),
        })
        .collect();
    // Per-channel normalisation to the model's own 2D sum.
    for c in 0..3 {
        let target: f64 = f.iter().map(|t| t[c].iter().sum::<f64>().powi(2)).sum();
        let have: f64 = passes
            .iter()
            .map(|p| p.weights.iter().map(|w| w[c]).sum::<f64>().powi(2))
            .sum();
        if have > 0.0 && target > 0.0 {
            let s = (target / have).sqrt();
            passes
                .iter_mut()
                .for_each(|p| p.weights.iter_mut().for_each(|w| w[c] *= s));
        }
    }
    Ok(TapTable {
        count,
        passes,
        extent_mm: Some(e),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jimenez_offsets() {
        let o = unit_offsets(17);
        assert_eq!(o.len(), 17);
        assert_eq!(o[8], 0.0);
        assert!((o[0] + 2.0).abs() < 1e-15 && (o[16] - 2.0).abs() < 1e-15);
        // o = -2 + 9 (4/16) = 0.25 -> RANGE o^2 / RANGE^2 = 0.25^2 / 2.
        assert!((o[9] - 0.03125).abs() < 1e-15);
        assert_eq!(range(25), 3.0);
    }
}
