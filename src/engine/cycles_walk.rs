//! Cycles' Random Walk subsurface as it renders a flat, thick slab seen
//! and lit at normal incidence: the medium Cycles builds from the
//! Principled BSDF's values and the walk's exit profile by Monte Carlo.
//! Read in the blender/cycles repository at v5.0.0 (the same computation
//! at v4.0.0, refactored since):
//!
//! - kernel/svm/closure.h (principled BSDF): the closure's albedo is
//!   min(Base Color, 1), its radius Subsurface Radius x Subsurface Scale,
//!   its weight the albedo x Subsurface Weight x the layers' weight, its
//!   roughness Roughness^2 and its IOR the node's IOR (Subsurface IOR for
//!   Random Walk (Skin) only).
//! - kernel/closure/bssrdf.h `bssrdf_setup`, `bssrdf_setup_radius`:
//!   anisotropy clamped to [0, 0.9]; radius x 1 / (4 pi) for Random Walk.
//! - kernel/integrator/subsurface.h `subsurface_entry_bounce`: the walk
//!   starts along the view ray refracted through a GGX microfacet of that
//!   roughness (Random Walk (Skin): half of the walks start cosine-weighted
//!   instead); at Roughness 0 and normal view that is straight down, the
//!   same whatever the IOR. `subsurface_shader_data_setup`: at the exit a
//!   Lambertian BSDF of weight 1 takes the light; no Fresnel, no internal
//!   reflection at either crossing.
//! - kernel/integrator/subsurface_random_walk.h
//!   `subsurface_random_walk_remap`: sigma_t = 1 / (d (1 - g)) and the
//!   single-scattering albedo alpha from the albedo (Chiang et al. 2016's
//!   fit, refitted by Cycles for anisotropy);
//!   `subsurface_random_walk_coefficients`: the throughput is divided by
//!   the albedo (the closure weight's colour leaves), and alpha below
//!   MIN_ALPHA is raised to it with the throughput scaled by alpha /
//!   MIN_ALPHA; `subsurface_random_walk`: the walk ends at the first
//!   surface crossing, at most BSSRDF_MAX_BOUNCES flights (kernel/types.h;
//!   a walk still inside is lost), and after SIMILARITY_LEVEL scatterings
//!   it walks the similarity medium (sigma_s (1 - g), isotropic). Its
//!   guided and spectral MIS sampling estimates, per channel, this analog
//!   walk.
//!
//! So the render, divided by a white Lambertian render (E / pi), is per
//! channel k x the exit density of a walk entering straight down, each
//! exit weighted by the product of the alphas of its scatterings.

use crate::error::{Error, Result};
use crate::progress::{Progress, INTERRUPTED};
use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// `subsurface_random_walk_coefficients`: the smallest alpha walked.
pub const MIN_ALPHA: f64 = 0.2;
/// `BSSRDF_MAX_BOUNCES` (kernel/types.h): flights per walk.
pub const MAX_BOUNCES: usize = 256;
/// `SUBSURFACE_RANDOM_WALK_SIMILARITY_LEVEL`: the last bounce walked with
/// the node's anisotropy.
pub const SIMILARITY_LEVEL: usize = 9;
/// `bssrdf_setup`: the anisotropy's clamp.
pub const ANISOTROPY_RANGE: (f64, f64) = (0.0, 0.9);
/// `subsurface_random_walk_remap`: alpha's upper clamp.
const ALPHA_MAX: f64 = 0.999999;
/// Walks per chunk: each chunk has its own seed, so the walks and their
/// order are the same whatever the thread count.
const CHUNK: usize = 1 << 15;

/// `subsurface_random_walk_remap`: the single-scattering albedo alpha for
/// a surface albedo and an anisotropy (Cycles' coefficients, v5.0.0).
pub fn remap_alpha(albedo: f64, g: f64) -> f64 {
    let p = |c: [f64; 8]| c.iter().rev().fold(0.0, |acc, &k| acc * g + k);
    let a = p([
        1.8260523782,
        -1.28451056436,
        -1.79904629312,
        9.19393289202,
        -22.8215585862,
        32.0234874259,
        -23.6264803333,
        7.21067002658,
    ]);
    let b = 4.98511194385
        + 0.127355959438
            * p([
                0.0,
                31.1491581433,
                -201.847017512,
                841.576016723,
                -2018.09288505,
                2731.71560286,
                -1935.41424244,
                559.009054474,
            ])
            .exp();
    let c = p([
        1.09686102424,
        -0.394704063468,
        1.05258115941,
        -8.83963712726,
        28.8643230661,
        -46.8802913581,
        38.5402837518,
        -12.7181042538,
    ]);
    let d = p([
        0.496310210422,
        0.360146581622,
        -2.15139309747,
        17.8896899217,
        -55.2984010333,
        82.065982243,
        -58.5106008578,
        15.8478295021,
    ]);
    let e = 4.23190299701
        + 0.00310603949088
            * p([
                0.0,
                76.7316253952,
                -594.356773233,
                2448.8834203,
                -5576.68528998,
                7116.60171912,
                -4763.54467887,
                1303.5318055,
            ])
            .exp();
    let f = p([
        2.40602999408,
        -2.51814844609,
        9.18494908356,
        -79.2191708682,
        259.082868209,
        -403.613804597,
        302.85712436,
        -87.4370473567,
    ]);
    let blend = albedo.powf(0.25);
    let alpha =
        (1.0 - blend) * a * (b * albedo).atan().powf(c) + blend * d * (e * albedo).atan().powf(f);
    alpha.clamp(0.0, ALPHA_MAX)
}

/// The walk of one channel: extinction in 1/mm, the alpha walked and the
/// throughput factor of the MIN_ALPHA clamp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    pub sigma_t: f64,
    pub alpha: f64,
    pub throughput: f64,
}

/// `subsurface_random_walk_coefficients` for one channel: albedo =
/// min(Base Color, 1), radius in mm (Subsurface Radius x Scale over the
/// scene's units per mm), g the clamped anisotropy.
pub fn channel(albedo: f64, radius_mm: f64, g: f64) -> Channel {
    let d = radius_mm * 0.25 / std::f64::consts::PI;
    let sigma_t = 1.0 / (d.max(1e-16) * (1.0 - g));
    let alpha = remap_alpha(albedo.clamp(0.0, 1.0), g);
    if alpha < MIN_ALPHA {
        Channel {
            sigma_t,
            alpha: MIN_ALPHA,
            throughput: alpha / MIN_ALPHA,
        }
    } else {
        Channel {
            sigma_t,
            alpha,
            throughput: 1.0,
        }
    }
}

/// The alpha of the scattering that ends flight `bounce`: the node's up
/// to SIMILARITY_LEVEL, then the similarity medium's sigma_s* / sigma_t*
/// with sigma_s* = sigma_s (1 - g), sigma_t* = sigma_t - sigma_s g.
fn alpha_at(bounce: usize, alpha: f64, g: f64) -> f64 {
    if bounce <= SIMILARITY_LEVEL {
        alpha
    } else {
        alpha * (1.0 - g) / (1.0 - alpha * g)
    }
}

/// The exits of walks in a medium of sigma_t = 1 (lengths in mean free
/// paths): the radius from the entry point and the number of scatterings
/// before the exit. With g = 0 the paths do not depend on alpha, so one
/// run serves every alpha by its weight alpha^n.
#[derive(Clone, Debug)]
pub struct UnitWalk {
    pub walks: usize,
    pub alpha: f64,
    pub g: f64,
    pub exits: Vec<(f64, u16)>,
    /// Where the exits of the first half of the chunks end.
    pub first_half: usize,
}

fn uniform(rng: &mut Xoshiro256PlusPlus) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A direction scattered from `d` by Henyey-Greenstein with parameter g.
fn scatter(d: [f64; 3], g: f64, rng: &mut Xoshiro256PlusPlus) -> [f64; 3] {
    let u = uniform(rng);
    let cos_t = if g.abs() < 1e-6 {
        2.0 * u - 1.0
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * uniform(rng);
    let (sp, cp) = phi.sin_cos();
    let [x, y, z] = d;
    if z.abs() > 0.99999 {
        return [sin_t * cp, sin_t * sp, cos_t * z.signum()];
    }
    let t = (1.0 - z * z).sqrt();
    [
        sin_t * (x * z * cp - y * sp) / t + x * cos_t,
        sin_t * (y * z * cp + x * sp) / t + y * cos_t,
        -sin_t * cp * t + z * cos_t,
    ]
}

/// One walk from the surface z = 0 straight down into z < 0: the exit's
/// radius and scatterings, or None when MAX_BOUNCES flights end inside.
fn walk_one(alpha: f64, g: f64, rng: &mut Xoshiro256PlusPlus) -> Option<(f64, u16)> {
    let (mut p, mut d) = ([0.0f64; 3], [0.0, 0.0, -1.0]);
    let sigma_t_star = 1.0 - alpha * g;
    for bounce in 0..MAX_BOUNCES {
        let (sigma_t, g_here) = if bounce <= SIMILARITY_LEVEL {
            (1.0, g)
        } else {
            (sigma_t_star, 0.0)
        };
        if bounce > 0 {
            d = scatter(d, g_here, rng);
        }
        let t = -(1.0 - uniform(rng)).ln() / sigma_t;
        if d[2] > 0.0 && p[2] + t * d[2] >= 0.0 {
            let s = -p[2] / d[2];
            let (x, y) = (p[0] + s * d[0], p[1] + s * d[1]);
            return Some((x.hypot(y), bounce as u16));
        }
        for k in 0..3 {
            p[k] += t * d[k];
        }
    }
    None
}

/// The work cap of one run: walks times flights.
pub const MAX_WALKS: usize = 1 << 24;

impl UnitWalk {
    /// `walks` walks with seed `seed`, for alpha (used only where g > 0:
    /// the similarity medium's extinction) and anisotropy g; each chunk's
    /// walks reported to `progress` as done, and none started once it
    /// asks to stop.
    pub fn run(
        walks: usize,
        alpha: f64,
        g: f64,
        seed: u64,
        progress: &dyn Progress,
    ) -> Result<UnitWalk> {
        if walks == 0 || walks > MAX_WALKS {
            return Err(Error::invalid(
                "engine",
                "walks",
                walks,
                format!("must be in 1..={MAX_WALKS}"),
            ));
        }
        let chunks = walks.div_ceil(CHUNK);
        let parts: Vec<Vec<(f64, u16)>> = (0..chunks)
            .into_par_iter()
            .map(|i| {
                if progress.cancelled() {
                    return Err(Error::Unsupported(INTERRUPTED.into()));
                }
                let n = CHUNK.min(walks - i * CHUNK);
                let mut rng = Xoshiro256PlusPlus::seed_from_u64(
                    seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                );
                let exits = (0..n)
                    .filter_map(|_| walk_one(alpha, g, &mut rng))
                    .collect();
                progress.advance(n as u64);
                Ok(exits)
            })
            .collect::<Result<_>>()?;
        let half = chunks.div_ceil(2);
        let first_half = parts[..half].iter().map(Vec::len).sum();
        Ok(UnitWalk {
            walks,
            alpha,
            g,
            exits: parts.concat(),
            first_half,
        })
    }

    /// The exits of the first and of the second half of the chunks, with
    /// the walks of each: two independent estimates.
    pub fn halves(&self) -> [(std::ops::Range<usize>, usize); 2] {
        let first = self.walks.div_ceil(CHUNK).div_ceil(2) * CHUNK;
        let first = first.min(self.walks);
        [
            (0..self.first_half, first),
            (self.first_half..self.exits.len(), self.walks - first),
        ]
    }

    /// The weight of an exit after `n` scatterings in a channel walking
    /// `alpha`: the product of the alphas of its scatterings.
    pub fn weight(&self, n: u16, alpha: f64) -> f64 {
        let n = n as usize;
        let head = n.min(SIMILARITY_LEVEL + 1);
        alpha.powi(head as i32)
            * alpha_at(SIMILARITY_LEVEL + 1, alpha, self.g).powi((n - head) as i32)
    }

    /// The channel's R_d (per mm^2) averaged over the annuli `edges` (mm)
    /// and its total, from the exits in `range` (all, or one half).
    pub fn bins(
        &self,
        ch: Channel,
        edges: &[f64],
        range: std::ops::Range<usize>,
        walks: usize,
    ) -> (Vec<f64>, f64) {
        let mut mass = vec![0.0; edges.len().saturating_sub(1)];
        let mut total = 0.0;
        let last = *edges.last().unwrap_or(&0.0);
        for &(r, n) in &self.exits[range] {
            let w = self.weight(n, ch.alpha);
            total += w;
            let r = r / ch.sigma_t;
            if r < last {
                let i = edges.partition_point(|e| *e <= r).saturating_sub(1);
                mass[i] += w;
            }
        }
        let k = ch.throughput / walks as f64;
        let rd = mass
            .iter()
            .zip(edges.windows(2))
            .map(|(m, e)| k * m / (crate::numerics::annulus_area(e[0], e[1])))
            .collect();
        (rd, k * total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;

    /// `subsurface_random_walk_remap` (Cycles v5.0.0,
    /// kernel/integrator/subsurface_random_walk.h) as the source writes
    /// it, in f32: powers g2..g7, powf, atanf, expf, the clamp.
    #[allow(clippy::excessive_precision)] // the source's digits, as written there
    fn cycles_remap(albedo: f32, g: f32) -> f32 {
        let (g2, g3) = (g * g, g * g * g);
        let (g4, g5, g6, g7) = (g3 * g, g3 * g2, g3 * g3, g3 * g3 * g);
        let a = 1.8260523782
            + -1.28451056436 * g
            + -1.79904629312 * g2
            + 9.19393289202 * g3
            + -22.8215585862 * g4
            + 32.0234874259 * g5
            + -23.6264803333 * g6
            + 7.21067002658 * g7;
        let b = 4.98511194385
            + 0.127355959438
                * (31.1491581433 * g
                    + -201.847017512 * g2
                    + 841.576016723 * g3
                    + -2018.09288505 * g4
                    + 2731.71560286 * g5
                    + -1935.41424244 * g6
                    + 559.009054474 * g7)
                    .exp();
        let c = 1.09686102424
            + -0.394704063468 * g
            + 1.05258115941 * g2
            + -8.83963712726 * g3
            + 28.8643230661 * g4
            + -46.8802913581 * g5
            + 38.5402837518 * g6
            + -12.7181042538 * g7;
        let d = 0.496310210422
            + 0.360146581622 * g
            + -2.15139309747 * g2
            + 17.8896899217 * g3
            + -55.2984010333 * g4
            + 82.065982243 * g5
            + -58.5106008578 * g6
            + 15.8478295021 * g7;
        let e = 4.23190299701
            + 0.00310603949088
                * (76.7316253952 * g
                    + -594.356773233 * g2
                    + 2448.8834203 * g3
                    + -5576.68528998 * g4
                    + 7116.60171912 * g5
                    + -4763.54467887 * g6
                    + 1303.5318055 * g7)
                    .exp();
        let f = 2.40602999408
            + -2.51814844609 * g
            + 9.18494908356 * g2
            + -79.2191708682 * g3
            + 259.082868209 * g4
            + -403.613804597 * g5
            + 302.85712436 * g6
            + -87.4370473567 * g7;
        let blend = albedo.powf(0.25);
        let alpha = (1.0 - blend) * a * (b * albedo).atan().powf(c)
            + blend * d * (e * albedo).atan().powf(f);
        alpha.clamp(0.0, 0.999999)
    }

    /// f32 against f64: the exponents' terms reach about 3e3 at g = 0.9,
    /// so f32's 6e-8 rounding moves the exponentials by a few 1e-4 of
    /// themselves; alpha moves by less than this.
    const REMAP_F32_TOL: f64 = 5e-4;

    #[test]
    fn the_remap_is_cycles_formula() {
        for g in [0.0, 0.3, 0.6, 0.9] {
            for albedo in [0.0, 0.01, 0.05, 0.1, 0.3, 0.5, 0.8, 0.95, 1.0] {
                let ours = remap_alpha(albedo, g);
                let theirs = cycles_remap(albedo as f32, g as f32) as f64;
                assert!(
                    (ours - theirs).abs() < REMAP_F32_TOL,
                    "albedo {albedo} g {g}: {ours} vs Cycles' {theirs}"
                );
            }
        }
    }

    /// The rest of the chain from Principled BSDF values to the walked
    /// medium, ported from the blender/cycles repository at v5.0.0 as the
    /// source writes it (f32, its names and `#define`s), so that ssskit's
    /// `channel`, `ANISOTROPY_RANGE`, `MAX_BOUNCES`, `SIMILARITY_LEVEL`
    /// and `UnitWalk::weight` are held to Cycles, not to themselves.
    mod cycles {
        /// kernel/types.h `BSSRDF_MAX_BOUNCES`.
        pub const BSSRDF_MAX_BOUNCES: usize = 256;
        /// kernel/integrator/subsurface_random_walk.h
        /// `SUBSURFACE_RANDOM_WALK_SIMILARITY_LEVEL`.
        pub const SIMILARITY_LEVEL: usize = 9;
        const M_1_PI_F: f32 = std::f32::consts::FRAC_1_PI;

        /// kernel/closure/bssrdf.h `bssrdf_setup`: "Clamps protecting
        /// against bad/extreme and non physical values".
        pub fn bssrdf_setup_anisotropy(anisotropy: f32) -> f32 {
            anisotropy.clamp(0.0, 0.9)
        }

        /// kernel/closure/bssrdf.h `bssrdf_setup_radius`, the
        /// `CLOSURE_BSSRDF_RANDOM_WALK_ID` branch.
        pub fn bssrdf_setup_radius(radius: f32) -> f32 {
            radius * (0.25 * M_1_PI_F)
        }

        /// subsurface_random_walk.h `subsurface_random_walk_remap` (sigma_t;
        /// alpha is `super::cycles_remap`) and
        /// `subsurface_random_walk_coefficients` for one channel whose
        /// throughput holds the closure weight `weight` (the albedo at
        /// Subsurface Weight 1): (sigma_t, alpha, throughput).
        pub fn coefficients(albedo: f32, weight: f32, radius: f32, g: f32) -> (f32, f32, f32) {
            let alpha = super::cycles_remap(albedo, g);
            let sigma_t_prime = 1.0 / radius.max(1e-16);
            let sigma_t = sigma_t_prime / (1.0 - g);
            // safe_divide_color(throughput, albedo)
            let mut throughput = if albedo != 0.0 { weight / albedo } else { 0.0 };
            let min_alpha = 0.2f32;
            let mut alpha = alpha;
            if alpha < min_alpha {
                throughput *= alpha / min_alpha;
                alpha = min_alpha;
            }
            (sigma_t, alpha, throughput)
        }

        /// `subsurface_random_walk`'s throughput after `n` scatterings
        /// in one channel (channel_pdf 1, classic sampling): each flight
        /// that ends inside multiplies it by sigma_s T / (sigma_t T), with
        /// sigma_s = sigma_t alpha, and the medium of flights past
        /// SIMILARITY_LEVEL is sigma_s* = sigma_s (1 - g), sigma_t* =
        /// sigma_t - sigma_s + sigma_s*.
        /// The factors are f32 as in Cycles, their product is taken in f64
        /// (Cycles' f32 throughput underflows past 1e-38 and stops the
        /// walk at VOLUME_THROUGHPUT_EPSILON; ssskit keeps every exit).
        pub fn scattering_weight(n: usize, sigma_t: f32, alpha: f32, g: f32) -> f64 {
            let sigma_s = sigma_t * alpha;
            let sigma_s_star = sigma_s * (1.0 - g);
            let sigma_t_star = sigma_t - sigma_s + sigma_s_star;
            (0..n)
                .map(|bounce| {
                    if bounce <= SIMILARITY_LEVEL {
                        (sigma_s / sigma_t) as f64
                    } else {
                        (sigma_s_star / sigma_t_star) as f64
                    }
                })
                .product()
        }
    }

    /// f32 against f64 for a chain of a few operations (a division, a
    /// product of a few factors): a few f32 roundings of 6e-8 each.
    const CHAIN_F32_TOL: f64 = 1e-6;

    /// A product of up to 255 factors, each made in f32 by up to 4
    /// roundings of 6e-8 relative (alpha, sigma_s*, sigma_t*, the
    /// quotient), repeated: at most 255 x 4 x 6e-8 = 6e-5 of the whole.
    const PRODUCT_F32_TOL: f64 = 1e-4;

    fn close(ours: f64, theirs: impl Into<f64>, tol: f64) -> bool {
        let theirs = theirs.into();
        (ours - theirs).abs() <= tol * theirs.abs()
    }

    #[test]
    fn coefficients_follow_cycles_chain() {
        // Node values (albedo, Subsurface Radius x Scale, anisotropy)
        // through bssrdf_setup, bssrdf_setup_radius and
        // subsurface_random_walk_coefficients, against ssskit's channel
        // with the anisotropy clamped to ANISOTROPY_RANGE.
        let mut raised = 0;
        for g_node in [-0.5f64, 0.0, 0.4, 0.8, 0.9, 0.95] {
            let g = g_node.clamp(ANISOTROPY_RANGE.0, ANISOTROPY_RANGE.1);
            assert_eq!(
                g as f32,
                cycles::bssrdf_setup_anisotropy(g_node as f32),
                "anisotropy {g_node}"
            );
            for albedo in [0.0, 0.02, 0.1, 0.5, 0.8, 1.0] {
                for radius in [0.01, 0.5, 3.0] {
                    let ch = channel(albedo, radius, g);
                    let d = cycles::bssrdf_setup_radius(radius as f32);
                    let (sigma_t, alpha, throughput) =
                        cycles::coefficients(albedo as f32, albedo as f32, d, g as f32);
                    let what = format!("albedo {albedo} radius {radius} g {g}");
                    assert!(close(ch.sigma_t, sigma_t, CHAIN_F32_TOL), "{what}: {ch:?}");
                    assert!(close(ch.alpha, alpha, REMAP_F32_TOL), "{what}: {ch:?}");
                    // Cycles' throughput is 0 for a black albedo; ssskit
                    // keeps the remap's alpha / MIN_ALPHA (0 there too).
                    assert!(
                        (ch.throughput - throughput as f64).abs() < REMAP_F32_TOL,
                        "{what}: {ch:?} vs {throughput}"
                    );
                    raised += (alpha == 0.2) as usize;
                }
            }
        }
        // Both sides of the MIN_ALPHA clamp were taken.
        assert!(raised > 0 && raised < 6 * 6 * 3, "{raised}");
        // The constants, as Cycles' loops use them.
        assert_eq!(
            (MAX_BOUNCES, SIMILARITY_LEVEL),
            (cycles::BSSRDF_MAX_BOUNCES, cycles::SIMILARITY_LEVEL)
        );
    }

    /// Monte Carlo checks hold to this many standard errors.
    const SIGMAS: f64 = 4.0;

    /// The share of walks leaving after exactly one scattering: entering
    /// straight down, scattering at depth z (density e^-z) into direction
    /// cosine mu upwards and leaving unscattered (e^(-z / mu)), it is
    /// int_0^1 p(mu) mu / (1 + mu) dmu with p the phase function's
    /// density of the upward cosine mu for a downward direction: (1 -
    /// ln 2) / 2 when isotropic.
    fn single_scatter_share(g: f64) -> f64 {
        let hg = |mu: f64| 0.5 * (1.0 - g * g) / (1.0 + g * g + 2.0 * g * mu).powf(1.5);
        crate::numerics::gauss_legendre(|mu| hg(mu) * mu / (1.0 + mu), 0.0, 1.0)
    }

    #[test]
    fn one_scattering_leaves_as_the_closed_form_says() {
        let exact = (1.0 - 2f64.ln()) / 2.0;
        assert!((single_scatter_share(0.0) - exact).abs() < 1e-12);
        let walks = 1 << 18;
        for g in [0.0, 0.5] {
            let w = UnitWalk::run(walks, 1.0, g, 7, &NoProgress).unwrap();
            let once = w.exits.iter().filter(|e| e.1 == 1).count() as f64 / walks as f64;
            let p = single_scatter_share(g);
            let se = (p * (1.0 - p) / walks as f64).sqrt();
            assert!(
                (once - p).abs() < SIGMAS * se,
                "g {g}: {once} leave after one scattering, exactly {p} (se {se})"
            );
        }
    }

    #[test]
    fn the_walk_stops_at_the_flight_cap() {
        // Without absorption a walk in a half-space comes back: what does
        // not within MAX_BOUNCES flights is lost, and the longest exits
        // come after MAX_BOUNCES - 1 scatterings.
        let w = UnitWalk::run(1 << 17, 1.0, 0.0, 3, &NoProgress).unwrap();
        let longest = w.exits.iter().map(|e| e.1).max().unwrap();
        assert_eq!(longest as usize, cycles::BSSRDF_MAX_BOUNCES - 1);
        assert!(w.exits.len() < w.walks);
    }

    #[test]
    fn the_similarity_medium_weights_scatterings_after_level_9() {
        // UnitWalk::weight for every scattering count a walk can have,
        // against the throughput Cycles' walk loop builds.
        for (alpha, g) in [(0.8, 0.5), (0.2, 0.9), (0.99, 0.3), (0.5, 0.0)] {
            let w = UnitWalk {
                walks: 1,
                alpha,
                g,
                exits: Vec::new(),
                first_half: 0,
            };
            for n in 0..cycles::BSSRDF_MAX_BOUNCES {
                let theirs = cycles::scattering_weight(n, 1.0, alpha as f32, g as f32);
                let ours = w.weight(n as u16, alpha);
                assert!(
                    close(ours, theirs, PRODUCT_F32_TOL),
                    "alpha {alpha} g {g} n {n}: {ours} vs Cycles' {theirs}"
                );
            }
        }
    }

    #[test]
    fn same_seed_same_walks_whatever_the_threads() {
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| UnitWalk::run(3 * CHUNK + 5, 0.9, 0.3, 11, &NoProgress).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(a.exits, b.exits);
        assert_eq!(a.first_half, b.first_half);
    }
}
