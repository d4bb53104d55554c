//! The asymmetry of R_d along the plane of incidence: of the diffuse
//! reflectance of a pencil beam arriving at `theta_in` in the x-z plane
//! (MCML's launch at that angle, the oblique runs of the entry table), the
//! share that leaves ahead of the entry point (x > 0, the side the
//! refracted beam runs to). 1/2 at normal incidence by symmetry; the
//! directional dipole (Frisvad et al. 2014) predicts more ahead as the
//! beam tilts, which is what this run measures.
//!
//! Chunks of `CHUNK` photons on streams of their own, keyed by (seed,
//! channel, chunk, angle); their f64 sums are added in chunk order, so the
//! result does not depend on the thread count.

use super::super::tally::{BinIndex, ChunkTally, Moments, PhotonScratch};
use super::super::tracer::{self, Stack, WalkSettings};
use super::super::{chunk_key, splitmix64, McOptions, CHUNK, CONTEXT};
use super::MAX_INCIDENCE_DEG;
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::RadialGrid;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// Most photons of one run: bounds its work (an albedo-1 medium spends
/// thousands of events per photon).
pub const MAX_AHEAD_PHOTONS: u64 = 100_000_000;

/// What one oblique run measured, per incident photon.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AheadShare {
    pub incidence_deg: f64,
    pub photons: u64,
    /// Total diffuse reflectance and its standard error.
    pub rd: f64,
    pub rd_stderr: f64,
    /// R_d(x > 0) / R_d and its standard error (delta method over the
    /// per-photon sums, which are correlated).
    pub ahead: f64,
    pub ahead_stderr: f64,
}

/// The share of `material`'s R_d in channel `ch` that leaves ahead of a
/// pencil beam at `incidence_deg`, from `photons` photons.
pub fn ahead_share(
    material: &Material,
    ch: Channel,
    incidence_deg: f64,
    photons: u64,
    seed: u64,
) -> Result<AheadShare> {
    material.validate_named()?;
    if !material.is_half_space() {
        return Err(Error::Unsupported(format!(
            "material '{}': the ahead share is measured on a half-space (one semi-infinite layer)",
            material.name
        )));
    }
    if !(incidence_deg.is_finite() && (0.0..=MAX_INCIDENCE_DEG).contains(&incidence_deg)) {
        return Err(Error::invalid(
            CONTEXT,
            "incidence_deg",
            incidence_deg,
            format!("must be in [0, {MAX_INCIDENCE_DEG}] degrees"),
        ));
    }
    if !(2..=MAX_AHEAD_PHOTONS).contains(&photons) {
        return Err(Error::invalid(
            CONTEXT,
            "photons",
            photons,
            format!("must be in [2, {MAX_AHEAD_PHOTONS}] (a standard error needs two)"),
        ));
    }
    let stack = Stack::oblique(material, ch, incidence_deg.to_radians());
    // The radial tally is not read: one bin keeps it cheap.
    let bins = BinIndex::new(&RadialGrid::uniform(1.0, 1.0)?);
    let o = McOptions::default();
    let set = WalkSettings {
        mode: o.boundary,
        event_roulette: o.event_roulette,
        max_events: o.max_events,
        single_scatter: false,
        roulette_threshold: o.roulette_threshold,
        chunk_events: u64::MAX,
        angular: None,
    };
    let angle_key = splitmix64(incidence_deg.to_bits());
    let chunks: Vec<ChunkTally> = (0..photons.div_ceil(CHUNK))
        .into_par_iter()
        .map(|k| {
            let key = splitmix64(chunk_key(seed, ch, k) ^ angle_key);
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(key);
            let mut t = ChunkTally::new(bins.len(), false);
            let mut sc = PhotonScratch::new(bins.len(), false);
            let n = CHUNK.min(photons - k * CHUNK);
            tracer::trace_photons(&stack, &bins, &set, &mut rng, n, &mut t, &mut sc);
            t
        })
        .collect();
    let (mut rd, mut ahead, mut cross) = (Moments::default(), Moments::default(), 0.0);
    for t in &chunks {
        rd.merge(&t.rd);
        ahead.merge(&t.rd_ahead);
        cross += t.rd_ahead_cross;
    }
    Ok(share_of(incidence_deg, photons, rd, ahead, cross))
}

/// The ratio A / R of per-photon means with its delta-method standard
/// error: var(A/R) = (var A - 2 q cov(A, R) + q^2 var R) / (n R^2), q = A / R.
fn share_of(incidence_deg: f64, n: u64, rd: Moments, ahead: Moments, cross: f64) -> AheadShare {
    let nf = n as f64;
    let (r, a) = (rd.sum / nf, ahead.sum / nf);
    let q = if r > 0.0 { a / r } else { 0.0 };
    let var = |m: &Moments, mean: f64| (m.sum_sq / nf - mean * mean).max(0.0);
    let cov = cross / nf - a * r;
    let v = (var(&ahead, a) - 2.0 * q * cov + q * q * var(&rd, r)).max(0.0);
    AheadShare {
        incidence_deg,
        photons: n,
        rd: r,
        rd_stderr: rd.stderr(n),
        ahead: q,
        ahead_stderr: if r > 0.0 {
            (v / (nf - 1.0)).sqrt() / r
        } else {
            0.0
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The delta method against a case with a known answer: every photon
    /// returns R = 1 and half of them leave ahead, a coin: share 1/2 with
    /// the coin's standard error sqrt(1/4 / (n - 1)).
    #[test]
    fn the_share_of_a_coin_has_the_coin_s_standard_error() {
        let n = 1000u64;
        let rd = Moments {
            sum: n as f64,
            sum_sq: n as f64,
        };
        let ahead = Moments {
            sum: 0.5 * n as f64,
            sum_sq: 0.5 * n as f64,
        };
        let s = share_of(0.0, n, rd, ahead, 0.5 * n as f64);
        assert!((s.ahead - 0.5).abs() < 1e-15);
        let want = (0.25 / (n as f64 - 1.0)).sqrt();
        assert!(
            (s.ahead_stderr - want).abs() < 1e-12 * want,
            "{}",
            s.ahead_stderr
        );
    }

    /// At normal incidence the half-space is symmetric: the share is 1/2
    /// within 4 standard errors.
    #[test]
    fn normal_incidence_is_symmetric() {
        let m = Material::load("skin1").unwrap();
        let s = ahead_share(&m, Channel::G, 0.0, 20_000, 3).unwrap();
        assert!(s.ahead_stderr > 0.0);
        assert!(
            (s.ahead - 0.5).abs() < 4.0 * s.ahead_stderr,
            "{} +- {}",
            s.ahead,
            s.ahead_stderr
        );
    }
}
