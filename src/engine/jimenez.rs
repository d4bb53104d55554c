//! The separable screen-space kernels iryoku and Godot render, and their
//! fit (Jimenez et al. 2015).
//!
//! Both engines filter the lit image with one 1D tap table, horizontally
//! then vertically: the kernel on the surface is the separable product
//! K(x) K(y) of a truncated table, not the radial skin profile the table
//! was sampled from. ssskit scores it as the kernel the table stands for
//! (`kernel::tap_kernel`): each tap's weight spread evenly over its
//! footprint, the product binned on the profile's annuli, at the step of
//! the pass whose length in the scene does not depend on the screen's
//! aspect ratio (iryoku's vertical pass, Godot's horizontal one). The fit
//! minimises that error: per channel the squared relative L2 error of
//! r R_d(r) over r < r99 (the shape error `profiles compare` reports),
//! summed over the channels.

use super::model::{error, modelled, Target};
use super::FitError;
use crate::error::{Error, Result};
use crate::kernel::jimenez::{offsets_mm, scattered_weights};
use crate::kernel::tap_kernel::{radial_bins, SeparableBins};
use crate::kernel::{taps, Pass};
use crate::numerics::minimise_log;
use crate::profile::Profile;
use rayon::prelude::*;

/// The tap counts of the tables iryoku prints and Godot ships.
pub const TAP_COUNTS: [usize; 3] = [11, 17, 25];

/// What a separable engine renders: one 1D table (offsets in mm on the
/// surface at the scored pass's step, weights per channel) applied along
/// both axes, times the albedo.
#[derive(Clone, Debug, PartialEq)]
pub struct Separable {
    pub albedo: [f64; 3],
    pub taps: Pass,
}

/// A [`Separable`] kernel on a radial grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Binned {
    /// Annulus averages of albedo K(x) K(y), per channel.
    pub rd: [Vec<f64>; 3],
    /// albedo (sum of the weights)^2: the 2D kernel's total.
    pub total: [f64; 3],
}

impl Separable {
    pub fn on_grid(&self, edges: &[f64]) -> Result<Binned> {
        let k = radial_bins(std::slice::from_ref(&self.taps), edges)?;
        let a = self.albedo;
        Ok(Binned {
            rd: std::array::from_fn(|c| k[c].iter().map(|v| a[c] * v).collect()),
            total: std::array::from_fn(|c| {
                a[c] * self.taps.weights.iter().map(|w| w[c]).sum::<f64>().powi(2)
            }),
        })
    }
}

impl Binned {
    /// This kernel as a profile on `like`'s grid (the grid it was binned
    /// on), as engine `engine` renders it.
    pub fn profile(&self, like: &Profile, engine: &str) -> Profile {
        let (rd, total) = (self.rd.to_vec(), self.total.to_vec());
        modelled(like, engine, "separable taps", rd, total)
    }
}

/// The best of the fits with each of [`TAP_COUNTS`] taps: the first of
/// the smallest cost, the same answer whatever the threads.
pub(crate) fn best_count<K: Send>(fit: impl Fn(usize) -> Result<(K, f64)> + Sync) -> Result<K> {
    let fits: Vec<(K, f64)> = TAP_COUNTS
        .par_iter()
        .map(|&n| fit(n))
        .collect::<Result<_>>()?;
    fits.into_iter()
        .reduce(|a, b| if b.1 < a.1 { b } else { a })
        .map(|k| k.0)
        .ok_or_else(|| Error::Unsupported("no tap count to fit".into()))
}

/// What `kernel` renders, on `like`'s grid, and its error against `like`.
pub(crate) fn rendered(
    kernel: &Separable,
    like: &Profile,
    engine: &str,
) -> Result<(Profile, FitError)> {
    let model_profile = kernel.on_grid(&like.r_edges)?.profile(like, engine);
    let error = error(&model_profile, like)?;
    Ok((model_profile, error))
}

/// The profile's least-squares targets on the grid up to the widest r99.
pub(crate) struct FitData {
    pub targets: Vec<Target>,
    pub edges: Vec<f64>,
    pub r99: f64,
}

impl FitData {
    pub fn new(p: &Profile) -> Result<FitData> {
        let targets: Vec<Target> = (0..3).map(|c| Target::new(p, c)).collect();
        let bins = targets.iter().map(|t| t.bins).max().unwrap_or(0);
        if bins == 0 {
            return Err(Error::Unsupported("no profile bins to fit".into()));
        }
        let edges = p.r_edges[..=bins].to_vec();
        Ok(FitData {
            r99: edges[bins],
            targets,
            edges,
        })
    }

    /// The geometry of a table of `count` taps, `mm_per_unit` mm per offset
    /// unit (iryoku's span: RANGE units), and its centre tap.
    pub fn geometry(&self, count: usize, mm_per_unit: f64) -> Result<(Vec<f64>, SeparableBins)> {
        let offsets = offsets_mm(count, taps::range(count) * mm_per_unit);
        let g = SeparableBins::new(&offsets, &self.edges)?;
        Ok((offsets, g))
    }

    /// Range of mm per offset unit the fits search: from a kernel far
    /// narrower than the profile to one whose taps reach past r99.
    pub fn unit_range(&self) -> (f64, f64) {
        (1e-3 * self.r99, 2.0 * self.r99)
    }
}

/// w-weighted dot product over the target's bins.
fn dot(t: &Target, a: &[f64], b: &[f64]) -> f64 {
    (0..t.bins).map(|i| t.weight[i] * a[i] * b[i]).sum()
}

/// The squared relative error of amplitude x `shape` against the target.
pub(crate) fn relative_residual(t: &Target, shape: &[f64], amplitude: f64) -> f64 {
    let yy = dot(t, &t.value, &t.value);
    if yy > 0.0 {
        t.residual_at(shape, amplitude) / yy
    } else {
        0.0
    }
}

/// One channel of iryoku's kernel fitted at a given geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ChannelFit {
    pub falloff: f64,
    pub strength: f64,
    pub albedo: f64,
    /// Squared relative error of the fit.
    pub residual: f64,
}

/// The kernel of strength t is t^2 P + 2 t (1 - t) X + (1 - t)^2 E, with P
/// the product of the scattered table, E of the centre tap alone and X the
/// cross term (`SeparableBins::bilinear`); with the best amplitude its
/// residual is 1 - (y.s)^2 / ((s.s)(y.y)) for s(t) the shape, a quartic over
/// a quadratic in t from nine dot products.
struct StrengthFit {
    y: [f64; 3],
    gram: [[f64; 3]; 3],
    yy: f64,
}

impl StrengthFit {
    /// From the parts, which vanish past bin `support`, and the target's
    /// y.y.
    fn new(t: &Target, parts: [&[f64]; 3], support: usize, yy: f64) -> StrengthFit {
        let n = t.bins.min(support);
        let (mut y, mut gram) = ([0.0; 3], [[0.0; 3]; 3]);
        for (i, (w, v)) in t.weight[..n].iter().zip(&t.value[..n]).enumerate() {
            let p = parts.map(|q| q[i]);
            for (a, pa) in p.iter().enumerate() {
                y[a] += w * v * pa;
                for (g, pb) in gram[a].iter_mut().zip(&p) {
                    *g += w * pa * pb;
                }
            }
        }
        StrengthFit { y, gram, yy }
    }

    /// (amplitude, squared relative residual) at strength `s`: the best
    /// amplitude, or `fixed` where given.
    fn at(&self, s: f64, fixed: Option<f64>) -> (f64, f64) {
        let c = [s * s, 2.0 * s * (1.0 - s), (1.0 - s) * (1.0 - s)];
        let ys: f64 = (0..3).map(|i| c[i] * self.y[i]).sum();
        let ss: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| c[i] * c[j] * self.gram[i][j])
            .sum();
        if !(self.yy > 0.0) {
            return (fixed.unwrap_or(0.0), 0.0);
        }
        if let Some(a) = fixed {
            // |a s - y|^2 / |y|^2.
            return (
                a,
                ((self.yy - 2.0 * a * ys + a * a * ss) / self.yy).max(0.0),
            );
        }
        if !(ys > 0.0 && ss > 0.0) {
            return (0.0, 1.0);
        }
        (ys / ss, (1.0 - ys * ys / (ss * self.yy)).max(0.0))
    }

    fn best(&self, fixed: Option<f64>) -> (f64, f64, f64) {
        let s = minimise_log(|s| self.at(s, fixed).1, 1e-3, 1.0, 21);
        let (a, r) = self.at(s, fixed);
        (s, a, r)
    }
}

/// iryoku's channel `t` at a geometry: falloff in [0, 1] (the demo's
/// slider), strength in [0, 1] and amplitude (the albedo) by least squares,
/// or the albedo `fixed` where given (the table sums to 1, so the albedo is
/// the kernel's total: the colour kept).
pub(crate) fn fit_channel(
    t: &Target,
    offsets: &[f64],
    g: &SeparableBins,
    mm_per_unit: f64,
    fixed: Option<f64>,
) -> ChannelFit {
    let centre = offsets.len() / 2;
    let mut e0 = vec![0.0; offsets.len()];
    e0[centre] = 1.0;
    let ee = g.bilinear(&e0, &e0);
    let (support, yy) = (g.support(), dot(t, &t.value, &t.value));
    let at = |rho: f64| {
        let p = scattered_weights(offsets, mm_per_unit, rho - 0.001);
        let (pp, pe) = (g.bilinear(&p, &p), g.bilinear(&p, &e0));
        StrengthFit::new(t, [&pp, &pe, &ee], support, yy).best(fixed)
    };
    // rho = 0.001 + falloff, searched in log space.
    let rho = minimise_log(|rho| at(rho).2, 0.001, 1.001, 21);
    let (strength, albedo, residual) = at(rho);
    ChannelFit {
        falloff: (rho - 0.001).clamp(0.0, 1.0),
        strength,
        albedo,
        residual,
    }
}

/// One fit per channel at `mm_per_unit`, and their summed residual; the
/// albedo per channel `fixed` where given.
pub(crate) fn fit_channels(
    d: &FitData,
    count: usize,
    mm_per_unit: f64,
    fixed: Option<[f64; 3]>,
) -> Result<([ChannelFit; 3], f64)> {
    let (offsets, g) = d.geometry(count, mm_per_unit)?;
    let fits: [ChannelFit; 3] = std::array::from_fn(|c| {
        fit_channel(
            &d.targets[c],
            &offsets,
            &g,
            mm_per_unit,
            fixed.map(|f| f[c]),
        )
    });
    let total = fits.iter().map(|f| f.residual).sum();
    Ok((fits, total))
}

/// The mm per offset unit minimising `cost` over the fits' range; a
/// geometry the cost cannot build (too many entries) counts as no fit.
pub(crate) fn best_unit(d: &FitData, cost: impl Fn(f64) -> Result<f64>) -> Result<f64> {
    let (lo, hi) = d.unit_range();
    // Check once that the geometry builds at all, so that a refusal is an
    // error, not a silently skipped range.
    cost(lo)?;
    Ok(minimise_log(
        |l| cost(l).unwrap_or(f64::INFINITY),
        lo,
        hi,
        25,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::jimenez::apply_strength;

    /// The strength search's closed form agrees with the kernel built at
    /// that strength.
    #[test]
    fn strength_residual_matches_the_kernel_it_stands_for() {
        let edges: Vec<f64> = (0..=100).map(|i| 0.04 * i as f64).collect();
        let offsets = offsets_mm(17, 2.0);
        let g = SeparableBins::new(&offsets, &edges).unwrap();
        let r: Vec<f64> = edges.windows(2).map(|e| 0.5 * (e[0] + e[1])).collect();
        let t = Target {
            bins: 80,
            weight: (0..80).map(|i| 0.04 * r[i] * r[i]).collect(),
            value: (0..80).map(|i| (-r[i]).exp()).collect(),
        };
        let p = scattered_weights(&offsets, 1.0, 0.6);
        let mut e0 = vec![0.0; 17];
        e0[8] = 1.0;
        let (pp, pe, ee) = (
            g.bilinear(&p, &p),
            g.bilinear(&p, &e0),
            g.bilinear(&e0, &e0),
        );
        let yy = dot(&t, &t.value, &t.value);
        let f = StrengthFit::new(&t, [&pp, &pe, &ee], g.support(), yy);
        for s in [0.2, 0.5, 0.9] {
            let mut w = p.clone();
            apply_strength(&mut w, 8, s);
            let k = g.bilinear(&w, &w);
            let (a, _) = t.scale_of(&k);
            let (a2, rel) = f.at(s, None);
            assert!((a - a2).abs() < 1e-9 * a);
            assert!((relative_residual(&t, &k, a) - rel).abs() < 1e-9);
        }
    }
}
