//! A packet at a boundary of its layer (MCML's CrossUpOrNot and
//! CrossDnOrNot; Wang et al. 1995): which medium lies beyond, Fresnel
//! reflection, escape into the ambient medium (scored) or refraction into
//! the next layer by Snell's law.

use super::sampling::uniform;
use super::{BoundaryMode, Packet, PacketScores, Stack, Walk};
use crate::profile::fresnel::fresnel_dielectric;
use crate::profile::mc::tally::PhotonScratch;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Where a packet goes at a boundary.
pub(super) enum Neighbour {
    Ambient { n: f64, top: bool },
    Layer(usize),
}

impl Stack {
    /// Where a packet in layer `layer` goes through the boundary ahead
    /// (`down`: the bottom one).
    #[inline(always)]
    pub(super) fn neighbour(&self, layer: usize, down: bool) -> Neighbour {
        if down {
            if layer + 1 < self.layers.len() {
                Neighbour::Layer(layer + 1)
            } else {
                Neighbour::Ambient {
                    n: self.n_below,
                    top: false,
                }
            }
        } else if layer > 0 {
            Neighbour::Layer(layer - 1)
        } else {
            Neighbour::Ambient {
                n: self.n_above,
                top: true,
            }
        }
    }
}

/// A packet at the surface to the ambient medium of index `n` (from a
/// layer of index `n_i`): the escaping weight is scored (split: (1 - R) w;
/// classic: all of w with probability 1 - R) and the rest reflected.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn meet_ambient<const ANGULAR: bool>(
    walk: &Walk,
    p: &mut Packet,
    n_i: f64,
    n: f64,
    top: bool,
    rng: &mut Xoshiro256PlusPlus,
    scores: &mut PacketScores,
    scratch: &mut PhotonScratch,
) {
    let cos_i = p.uz.abs();
    let r = fresnel_dielectric(cos_i, n / n_i);
    let escaping = match walk.set.mode {
        BoundaryMode::Split => (1.0 - r) * p.w,
        BoundaryMode::Classic => {
            if r > 0.0 && uniform(rng) < r {
                0.0
            } else {
                p.w
            }
        }
    };
    if escaping > 0.0 {
        let radius = (p.x * p.x + p.y * p.y).sqrt();
        if top {
            scores.rd += escaping;
            if p.x > 0.0 {
                scores.rd_ahead += escaping;
            }
            scratch.score_reflectance(walk.bins, radius, escaping, p.scatters);
        } else {
            scores.tr += escaping;
            scratch.score_transmittance(walk.bins, radius, escaping, p.scatters);
        }
        if ANGULAR {
            // Snell's law gives the exit direction in the ambient medium,
            // which MCML bins (RecordR; RecordT the same way).
            let k = n_i / n;
            let cos_out = (1.0 - (1.0 - cos_i * cos_i) * k * k).max(0.0).sqrt();
            let ir = walk.bins.bin(radius).unwrap_or(walk.bins.len());
            let ia = walk.angles.angle_bin(cos_out);
            let exit = if top {
                &mut scratch.exit
            } else {
                &mut scratch.tr_exit
            };
            exit.score(walk.angles, ir, ia, escaping);
        }
        // Leaves R w (split) or 0 (classic; split with R = 0).
        p.w -= escaping;
    }
    p.uz = -p.uz;
}

/// A packet at the interface to layer `j` (from a layer of index `n_i`):
/// Fresnel reflection with probability R, else refraction into `j`.
#[inline(always)]
pub(super) fn meet_layer(
    stack: &Stack,
    p: &mut Packet,
    n_i: f64,
    j: usize,
    rng: &mut Xoshiro256PlusPlus,
) {
    let cos_i = p.uz.abs();
    let n_t = stack.layers[j].n;
    let eta = n_t / n_i;
    let r = fresnel_dielectric(cos_i, eta);
    if r > 0.0 && (r >= 1.0 || uniform(rng) < r) {
        p.uz = -p.uz;
    } else {
        // Snell: the tangential component scales by n_i / n_t.
        let k = n_i / n_t;
        let sin2_t = (1.0 - cos_i * cos_i) * k * k;
        let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
        p.ux *= k;
        p.uy *= k;
        p.uz = cos_t * p.uz.signum();
        p.layer = j;
    }
}
