//! Christensen and Burley 2015 normalized diffusion with its two
//! parameters free per channel: R(r) = A (e^{-r/d} + e^{-r/(3d)}) /
//! (8 pi d r), which integrates to A for any shape distance d (the paper's
//! eq. 2 with s = 1/d). The forward model (`profile::analytic::burley`)
//! takes A from the dipole and d from the searchlight fit; here both come
//! from the profile itself.

use super::{minimise_log, Target};
use crate::error::{Error, Result};
use crate::numerics::bin_averages_resolved;
use crate::profile::{Profile, RadialGrid};
use std::f64::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Burley {
    /// Surface albedo A per channel (= the total reflectance).
    pub albedo: [f64; 3],
    /// Shape distance d per channel, mm.
    pub d_mm: [f64; 3],
}

/// R(r) in mm^-2; singular like 1/r at 0 (bins integrate it).
pub fn rd(a: f64, d: f64, r: f64) -> f64 {
    let r = r.max(1e-12 * d);
    a * ((-r / d).exp() + (-r / (3.0 * d)).exp()) / (8.0 * PI * d * r)
}

impl Burley {
    /// Bin averages of channel `c` on `grid`.
    pub fn bins(&self, c: usize, grid: &RadialGrid) -> Vec<f64> {
        let (a, d) = (self.albedo[c], self.d_mm[c]);
        bin_averages_resolved(|r| rd(a, d, r), grid)
    }
}

/// Least squares on r R_d(r) (the shape norm) per channel: for each d the
/// best A is linear; d by a log-space search from 1e-4 to 10 times the
/// radius holding 99% of the channel.
pub fn fit(p: &Profile) -> Result<Burley> {
    let mut albedo = [0.0; 3];
    let mut d_mm = [0.0; 3];
    for c in 0..3 {
        let t = Target::new(p, c);
        if t.bins == 0 {
            return Err(Error::Unsupported(format!(
                "channel {c}: no profile bins to fit"
            )));
        }
        let grid = RadialGrid {
            edges: p.r_edges[..=t.bins].to_vec(),
        };
        let shape = |d: f64| bin_averages_resolved(|r| rd(1.0, d, r), &grid);
        let r99 = p.r_edges[t.bins];
        let d = minimise_log(|d| t.scale_of(&shape(d)).1, 1e-4 * r99, 10.0 * r99, 41);
        albedo[c] = t.scale_of(&shape(d)).0;
        d_mm[c] = d;
    }
    Ok(Burley { albedo, d_mm })
}

/// The error of the forward model (A from the dipole, d from the
/// searchlight fit and the optical coefficients; `profile --model burley`)
/// against `p`, on `p`'s grid: the baseline the fit must beat.
pub fn forward_error(p: &Profile) -> Result<super::FitError> {
    use crate::profile::analytic::{self, Options};
    let grid = RadialGrid {
        edges: p.r_edges.clone(),
    };
    let options = Options {
        channels: p.channels.clone(),
        ..Options::default()
    };
    let forward = analytic::profile(&p.material, analytic::Model::Burley, &grid, &options)?;
    super::error(&forward, p)
}
