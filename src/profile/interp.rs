//! A continuous reconstruction R_d(r) of a binned radial profile, for
//! whatever integrates the profile over shapes other than its annuli (the 2D
//! kernel's cells, the Abel projection).

use super::Profile;
use crate::numerics::gauss_legendre;

/// A continuous reconstruction of a binned radial profile: geometric
/// (log-linear) between bin centres, fading linearly to zero over the last
/// half bin, and, inside the first
/// bin, a value at r = 0 chosen so that the area average over the first
/// annulus equals the tabulated bin average (a constant there would bias the
/// peak low; plain extrapolation would not conserve the bin's energy).
#[derive(Clone, Debug)]
pub struct RadialInterp {
    /// Nodes: 0, bin centres, last edge.
    r: Vec<f64>,
    v: Vec<f64>,
    /// Whether node 0 is the added r = 0 (the first bin's inner half).
    origin: bool,
    /// Per segment: d ln v / dr where the segment is geometric (both ends
    /// positive, not the origin segment), NaN where it is linear.
    log_slope: Vec<f64>,
    /// (first node, spacing) when the bin centres are evenly spaced.
    uniform: Option<(f64, f64)>,
}

impl RadialInterp {
    pub fn new(p: &Profile, c: usize) -> RadialInterp {
        let n = p.r.len();
        let rd = &p.rd[c];
        let mut r = Vec::with_capacity(n + 2);
        let mut v = Vec::with_capacity(n + 2);
        let origin = p.r[0] > 0.0;
        if origin {
            r.push(0.0);
            v.push(rd[0]);
        }
        r.extend_from_slice(&p.r);
        v.extend_from_slice(rd);
        let last = p.r_edges[n];
        if last > p.r[n - 1] {
            r.push(last);
            v.push(0.0);
        }
        let uniform = uniform_spacing(&p.r);
        let mut f = RadialInterp {
            r,
            v,
            origin,
            log_slope: Vec::new(),
            uniform: None,
        };
        f.set_slopes();
        if origin {
            f.v[0] = f.centre_value_preserving_first_bin(p.r[0], p.r_edges[1], rd[0]);
        }
        f.uniform = uniform;
        f
    }

    // Geometric between positive bin centres: exact for the exponential
    // falloff of R_d, where linear interpolation overestimates a convex
    // profile bin after bin. Linear on the origin segment and where a value
    // is zero.
    fn set_slopes(&mut self) {
        self.log_slope = self
            .r
            .windows(2)
            .zip(self.v.windows(2))
            .enumerate()
            .map(|(i, (r, v))| {
                if v[0] > 0.0 && v[1] > 0.0 && !(self.origin && i == 0) {
                    (v[1] / v[0]).ln() / (r[1] - r[0])
                } else {
                    f64::NAN
                }
            })
            .collect();
    }

    /// v0 such that the area average over the first annulus [0, e1] of the
    /// reconstruction (linear from v0 at 0 to rd0 at the centre c0, then as
    /// interpolated) equals the tabulated rd0; clamped to [0, 4 rd0] so a
    /// noisy second bin cannot produce a spike.
    fn centre_value_preserving_first_bin(&self, c0: f64, e1: f64, rd0: f64) -> f64 {
        // int_0^c0 [v0 + (rd0 - v0) r/c0] r dr = v0 c0^2/6 + rd0 c0^2/3
        let outer = gauss_legendre(|r| self.eval(r) * r, c0, e1);
        let v0 = (rd0 * e1 * e1 / 2.0 - outer - rd0 * c0 * c0 / 3.0) / (c0 * c0 / 6.0);
        if v0.is_finite() {
            v0.clamp(0.0, 4.0 * rd0)
        } else {
            rd0
        }
    }

    /// Largest radius with a non-zero value.
    pub fn r_max(&self) -> f64 {
        *self.r.last().unwrap()
    }

    /// Node radii (where the reconstruction has kinks).
    pub fn nodes(&self) -> &[f64] {
        &self.r
    }

    /// The segment [r_i, r_i+1] holding `r` (r inside the node range).
    fn segment(&self, r: f64) -> usize {
        let n = self.r.len();
        if let Some((r0, step)) = self.uniform {
            // Bin centres start at node `base`.
            let base = usize::from(self.origin);
            if r < r0 {
                return 0;
            }
            let i = (base + ((r - r0) / step) as usize).min(n - 2);
            // Guard rounding and the last (edge) node, off the even spacing.
            if self.r[i] <= r && r <= self.r[i + 1] {
                return i;
            }
        }
        (self.r.partition_point(|&x| x <= r)).clamp(1, n - 1) - 1
    }

    /// The segment holding `r`, or None where the reconstruction is
    /// constant (below the first node) or zero (beyond the last).
    pub fn segment_of(&self, r: f64) -> Option<usize> {
        let n = self.r.len();
        if n < 2 || !(r > self.r[0]) || r > self.r[n - 1] {
            return None;
        }
        Some(self.segment(r))
    }

    /// `eval` with the segment already known (from `segment_of` at a point
    /// of the same panel).
    #[inline]
    pub fn eval_in(&self, seg: Option<usize>, r: f64) -> f64 {
        match seg {
            Some(i) => self.eval_segment(i, r),
            None => self.eval(r),
        }
    }

    /// Value on segment `i` (no range checks).
    #[inline]
    pub fn eval_segment(&self, i: usize, r: f64) -> f64 {
        let k = self.log_slope[i];
        if k.is_finite() {
            self.v[i] * (k * (r - self.r[i])).exp()
        } else {
            let t = (r - self.r[i]) / (self.r[i + 1] - self.r[i]);
            self.v[i] * (1.0 - t) + self.v[i + 1] * t
        }
    }

    pub fn eval(&self, r: f64) -> f64 {
        self.eval_at(self.place(r), r)
    }

    /// Where `r` lies among the nodes: what [`Self::eval`] decides before
    /// it evaluates, the same for every reconstruction on these nodes
    /// ([`Self::same_nodes`]).
    #[inline]
    pub fn place(&self, r: f64) -> Place {
        let n = self.r.len();
        if !(r >= 0.0) || r > self.r[n - 1] {
            return Place::Outside;
        }
        if n == 1 || r <= self.r[0] {
            return Place::First;
        }
        Place::Segment(self.segment(r))
    }

    /// The value at `r`, placed by [`Self::place`] of this reconstruction
    /// or of one on the same nodes.
    #[inline]
    pub fn eval_at(&self, place: Place, r: f64) -> f64 {
        match place {
            Place::Outside => 0.0,
            Place::First => self.v[0],
            Place::Segment(i) => self.eval_segment(i, r),
        }
    }

    /// Whether `other` has these nodes, so that a [`Place`] found by one
    /// holds for the other (profiles on one radial grid: the channels of a
    /// profile, the bootstrap replicates of one).
    pub fn same_nodes(&self, other: &RadialInterp) -> bool {
        self.r == other.r && self.origin == other.origin && self.uniform == other.uniform
    }
}

/// Where a radius lies for a reconstruction ([`RadialInterp::place`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Place {
    /// Below 0, beyond the last node or NaN: the value is 0.
    Outside,
    /// At or below the first node: its value.
    First,
    /// On segment i between nodes i and i + 1.
    Segment(usize),
}

/// (first, spacing) if `r` is evenly spaced to 1e-9 relative.
fn uniform_spacing(r: &[f64]) -> Option<(f64, f64)> {
    if r.len() < 2 {
        return None;
    }
    let step = (r[r.len() - 1] - r[0]) / (r.len() - 1) as f64;
    let even = r
        .iter()
        .enumerate()
        .all(|(i, x)| (x - (r[0] + i as f64 * step)).abs() <= 1e-9 * step);
    (even && step > 0.0).then_some((r[0], step))
}
