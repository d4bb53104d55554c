//! A tap table scored as the kernel it stands for.
//!
//! A renderer that applies a 1D table (offsets x_i, weights w_i)
//! horizontally and then vertically samples the image at (x_i, x_j) with
//! weight w_i w_j. As a kernel on the surface, each tap's weight stands for
//! its footprint: from the midpoints to its neighbours, and half a gap
//! beyond each end tap, the weight spread evenly over it. The separable
//! product K(x) K(y) is then a sum of uniform rectangles, and its radial
//! profile on a grid of annuli is exact: the area of a rectangle inside a
//! disc has a closed form. Bins hold the annulus average of K(x) K(y)
//! (mass in the annulus over its area), as a tallied R_d(r) does.

use super::Pass;
use crate::error::{Error, Result};
use std::f64::consts::PI;

/// Most (tap pair, bin) entries a table's geometry may hold (8 bytes each).
pub const MAX_ENTRIES: usize = 1 << 25;

/// Footprint bounds of increasing `offsets` (n + 1 values): midpoints
/// between neighbours, and half a gap beyond each end tap.
pub fn footprints(offsets: &[f64]) -> Result<Vec<f64>> {
    let n = offsets.len();
    if n < 2 {
        return Err(Error::invalid(
            "tap table",
            "count",
            n,
            "a footprint needs a neighbour: at least 2 taps",
        ));
    }
    if let Some(x) = offsets.iter().find(|x| !x.is_finite()) {
        return Err(Error::invalid(
            "tap table",
            "offsets_mm",
            x,
            "must be finite",
        ));
    }
    if let Some(w) = offsets.windows(2).find(|w| !(w[1] > w[0])) {
        return Err(Error::invalid(
            "tap table",
            "offsets_mm",
            format!("{} then {}", w[0], w[1]),
            "must increase strictly",
        ));
    }
    let mut b = Vec::with_capacity(n + 1);
    b.push(offsets[0] - 0.5 * (offsets[1] - offsets[0]));
    b.extend(offsets.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    b.push(offsets[n - 1] + 0.5 * (offsets[n - 1] - offsets[n - 2]));
    Ok(b)
}

/// Area of [0, x] x [0, y] inside the disc of radius `r` about the origin,
/// x, y >= 0: the integral of min(y, sqrt(r^2 - u^2)) over u in [0, x].
fn quadrant_area(x: f64, y: f64, r: f64) -> f64 {
    if !(r > 0.0 && x > 0.0 && y > 0.0) {
        return 0.0;
    }
    let (x, y, r2) = (x.min(r), y.min(r), r * r);
    if x * x + y * y <= r2 {
        return x * y;
    }
    // The circle's height passes y at u = ux < x; beyond, the arc: the
    // antiderivative of sqrt(r^2 - u^2) is (u sqrt(r^2 - u^2) + r^2 asin(u / r)) / 2.
    let ux = (r2 - y * y).max(0.0).sqrt();
    let arc = |u: f64| 0.5 * (u * (r2 - u * u).max(0.0).sqrt() + r2 * (u / r).min(1.0).asin());
    y * ux + arc(x) - arc(ux)
}

/// `quadrant_area` extended oddly in x and y: the signed area of the
/// rectangle between the origin and (x, y) inside the disc.
fn corner_area(x: f64, y: f64, r: f64) -> f64 {
    let s = if (x < 0.0) == (y < 0.0) { 1.0 } else { -1.0 };
    s * quadrant_area(x.abs(), y.abs(), r)
}

/// Area of [x0, x1] x [y0, y1] inside the disc of radius `r` about the
/// origin.
pub fn rect_disc_area(x0: f64, x1: f64, y0: f64, y1: f64, r: f64) -> f64 {
    corner_area(x1, y1, r) - corner_area(x0, y1, r) - corner_area(x1, y0, r)
        + corner_area(x0, y0, r)
}

/// Nearest and farthest distance from the origin to points of [lo, hi].
fn axis_range(lo: f64, hi: f64) -> (f64, f64) {
    let near = if lo <= 0.0 && hi >= 0.0 {
        0.0
    } else {
        lo.abs().min(hi.abs())
    };
    (near, lo.abs().max(hi.abs()))
}

/// One rectangle's share of the bins: `values[k]` is the average density
/// in bin `first + k` of a unit density on the rectangle.
struct Rect {
    a: usize,
    b: usize,
    first: usize,
    start: usize,
    len: usize,
}

/// The radial bins of the separable product of tables with the given
/// offsets, as a bilinear form in their weights: `bilinear(u, v)[b]` is
/// the average over annulus b of K_u(x) K_v(y) + K_v(x) K_u(y), halved.
/// Build once per set of offsets and grid, evaluate for many weights.
///
/// A table whose offsets are symmetric about 0 (every table ssskit and the
/// engines write) is folded onto the quadrant x, y >= 0: the annuli are
/// symmetric, so a footprint and its mirror image meet them alike and four
/// times fewer rectangles are needed.
pub struct SeparableBins {
    /// Axis intervals, the same on both axes.
    intervals: Vec<(f64, f64)>,
    /// For each tap, the interval its weight goes to (folded: the mirror's).
    interval_of: Vec<usize>,
    /// Interval widths a tap's weight spreads over (full footprints; the
    /// folded centre interval takes the whole centre tap on half its width).
    spread: Vec<f64>,
    rects: Vec<Rect>,
    values: Vec<f64>,
    bins: usize,
}

/// The intervals of taps at `offsets` with footprints `bounds`, the
/// interval of each tap and its width: a symmetric table folds onto x >= 0
/// (the centre tap's interval is its half footprint, each other tap shares
/// the interval of its mirror).
fn fold_intervals(offsets: &[f64], bounds: &[f64]) -> (Vec<(f64, f64)>, Vec<usize>, Vec<f64>) {
    let n = offsets.len();
    let scale = offsets.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let symmetric = n % 2 == 1
        && offsets[n / 2] == 0.0
        && (0..n / 2).all(|i| (offsets[i] + offsets[n - 1 - i]).abs() <= 1e-12 * scale);
    if symmetric {
        let c = n / 2;
        let half = bounds[c + 1];
        let mut iv = vec![(0.0, half)];
        iv.extend((c + 1..n).map(|i| (bounds[i], bounds[i + 1])));
        let of: Vec<usize> = (0..n).map(|i| i.abs_diff(c)).collect();
        let sp: Vec<f64> = (0..n)
            .map(|i| {
                if i == c {
                    half
                } else {
                    bounds[i + 1] - bounds[i]
                }
            })
            .collect();
        (iv, of, sp)
    } else {
        let iv: Vec<(f64, f64)> = (0..n).map(|i| (bounds[i], bounds[i + 1])).collect();
        let sp = iv.iter().map(|(a, b)| b - a).collect();
        (iv, (0..n).collect(), sp)
    }
}

impl SeparableBins {
    /// The geometry of tables with `offsets` (mm, increasing) on the radial
    /// grid with `edges` (mm, increasing from 0).
    pub fn new(offsets: &[f64], edges: &[f64]) -> Result<SeparableBins> {
        let bounds = footprints(offsets)?;
        if edges.len() < 2
            || edges[0] != 0.0
            || edges.windows(2).any(|w| !(w[1] > w[0]))
            || !edges[edges.len() - 1].is_finite()
        {
            return Err(Error::invalid(
                "tap table",
                "radial grid",
                format!("{} edges", edges.len()),
                "edges must start at 0 and increase strictly to a finite radius",
            ));
        }
        let n = offsets.len();
        let (intervals, interval_of, spread) = fold_intervals(offsets, &bounds);
        let bins = edges.len() - 1;
        let r_max = edges[bins];
        let bin_of = |r: f64| edges.partition_point(|e| *e <= r).saturating_sub(1);
        // Rectangles a <= b (the mirror b, a meets every annulus alike):
        // their bin ranges, counted before anything is allocated.
        let mut rects = Vec::new();
        let mut total = 0usize;
        for a in 0..intervals.len() {
            for b in a..intervals.len() {
                let (xn, xf) = axis_range(intervals[a].0, intervals[a].1);
                let (yn, yf) = axis_range(intervals[b].0, intervals[b].1);
                let (near, far) = (xn.hypot(yn), xf.hypot(yf));
                if near >= r_max {
                    continue;
                }
                let (first, last) = (bin_of(near), bin_of(far).min(bins - 1));
                let len = last - first + 1;
                rects.push(Rect {
                    a,
                    b,
                    first,
                    start: total,
                    len,
                });
                total += len;
                if total > MAX_ENTRIES {
                    return Err(Error::invalid(
                        "tap table",
                        "taps x bins",
                        total,
                        format!(
                            "a table of {n} taps on {bins} radial bins needs more than \
                             {MAX_ENTRIES} entries: use fewer taps or a coarser grid"
                        ),
                    ));
                }
            }
        }
        let mut values = vec![0.0; total];
        for r in &rects {
            let (x0, x1) = intervals[r.a];
            let (y0, y1) = intervals[r.b];
            let inside = |rad: f64| rect_disc_area(x0, x1, y0, y1, rad);
            let mut below = inside(edges[r.first]);
            for k in 0..r.len {
                let bin = r.first + k;
                let above = inside(edges[bin + 1]);
                let ring = PI * (edges[bin + 1] - edges[bin]) * (edges[bin + 1] + edges[bin]);
                values[r.start + k] = (above - below) / ring;
                below = above;
            }
        }
        Ok(SeparableBins {
            intervals,
            interval_of,
            spread,
            rects,
            values,
            bins,
        })
    }

    pub fn bins(&self) -> usize {
        self.bins
    }

    /// Bins past this one hold nothing of the kernel.
    pub fn support(&self) -> usize {
        self.rects
            .iter()
            .map(|r| r.first + r.len)
            .max()
            .unwrap_or(0)
    }

    /// Density on each interval from tap weights.
    fn densities(&self, w: &[f64]) -> Vec<f64> {
        let mut d = vec![0.0; self.intervals.len()];
        for (i, wi) in w.iter().enumerate() {
            d[self.interval_of[i]] += wi / self.spread[i];
        }
        d
    }

    /// Annulus averages of the symmetrised product of tables with weights
    /// `u` and `v` (one per offset); `bilinear(w, w)` is the kernel of `w`.
    pub fn bilinear(&self, u: &[f64], v: &[f64]) -> Vec<f64> {
        let (du, dv) = (self.densities(u), self.densities(v));
        let mut out = vec![0.0; self.bins];
        for r in &self.rects {
            let c = if r.a == r.b {
                du[r.a] * dv[r.a]
            } else {
                du[r.a] * dv[r.b] + du[r.b] * dv[r.a]
            };
            if c == 0.0 {
                continue;
            }
            let vals = &self.values[r.start..r.start + r.len];
            for (o, m) in out[r.first..r.first + r.len].iter_mut().zip(vals) {
                *o += c * m;
            }
        }
        out
    }
}

/// The radial profile (annulus averages on `edges`) of the kernel a tap
/// table stands for, per channel: K(x) K(y) of each pass, summed over
/// passes.
pub fn radial_bins(passes: &[Pass], edges: &[f64]) -> Result<[Vec<f64>; 3]> {
    let mut out: [Vec<f64>; 3] = Default::default();
    for o in out.iter_mut() {
        *o = vec![0.0; edges.len().saturating_sub(1)];
    }
    for p in passes {
        let g = SeparableBins::new(&p.offsets_mm, edges)?;
        for (c, o) in out.iter_mut().enumerate() {
            let w: Vec<f64> = p.weights.iter().map(|w| w[c]).collect();
            for (a, b) in o.iter_mut().zip(g.bilinear(&w, &w)) {
                *a += b;
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_areas_in_a_disc() {
        let r = 1.0;
        // Whole disc inside a big square; whole square inside a big disc.
        assert!((rect_disc_area(-2.0, 2.0, -2.0, 2.0, r) - PI).abs() < 1e-14);
        assert!((rect_disc_area(-0.5, 0.5, -0.2, 0.3, 10.0) - 0.5).abs() < 1e-15);
        // The quarter disc, and a half disc from a strip across it.
        assert!((rect_disc_area(0.0, 3.0, 0.0, 3.0, r) - PI / 4.0).abs() < 1e-14);
        assert!((rect_disc_area(-3.0, 3.0, 0.0, 3.0, r) - PI / 2.0).abs() < 1e-14);
        // A strip |y| < 1/2 through the unit disc: 2 (asin(1/2) + (1/2) sqrt(3)/2).
        let strip = 2.0 * ((0.5f64).asin() + 0.5 * 0.75f64.sqrt());
        assert!((rect_disc_area(-5.0, 5.0, -0.5, 0.5, r) - strip).abs() < 1e-14);
    }

    /// The folded (symmetric) geometry gives what the unfolded one gives
    /// for the same taps: offsets nudged off symmetry take the general path.
    #[test]
    fn folding_matches_the_general_rectangles() {
        let edges: Vec<f64> = (0..=80).map(|i| 0.05 * i as f64).collect();
        let offs = super::super::jimenez::offsets_mm(17, 2.0);
        let w: Vec<f64> = (0..17).map(|i| 1.0 + (i as f64 * 0.7).sin()).collect();
        let folded = SeparableBins::new(&offs, &edges).unwrap();
        let mut skew = offs.clone();
        skew[0] -= 1e-9;
        let general = SeparableBins::new(&skew, &edges).unwrap();
        assert!(folded.intervals.len() < general.intervals.len());
        let (a, b) = (folded.bilinear(&w, &w), general.bilinear(&w, &w));
        let peak = a.iter().fold(0.0f64, |m, v| m.max(*v));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-7 * peak, "{x} {y}");
        }
        // All the mass lands on the grid when the grid covers the kernel.
        let total: f64 = (0..80)
            .map(|k| a[k] * crate::numerics::annulus_area(edges[k], edges[k + 1]))
            .sum();
        let sum: f64 = w.iter().sum();
        assert!((total - sum * sum).abs() < 1e-12 * sum * sum);
    }
}
