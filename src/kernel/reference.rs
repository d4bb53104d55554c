//! Quick reference profiles from the standard dipole on the radial grid of
//! Freude 2014, table 6.1, for tests and benchmarks that need a realistic profile
//! without a simulation.

use crate::error::Result;
use crate::material::{Channel, Material};
use crate::profile::analytic;
use crate::profile::grid::{thesis_dr, THESIS_RADIUS_MFPS};
use crate::profile::{Profile, RadialGrid};

/// Freude 2014, table 6.1: dr = min(MFP_rgb)/20, r_max = 32 max(MFP_rgb) (here at
/// least `min_mfps` max MFPs, for materials whose falloff is longer).
pub fn thesis_grid(m: &Material, min_mfps: f64) -> Result<RadialGrid> {
    let mfps: Vec<f64> = Channel::ALL.iter().map(|&c| m.top(c).mfp()).collect();
    let lo = mfps.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = mfps.iter().cloned().fold(0.0, f64::max);
    RadialGrid::uniform(thesis_dr(lo), min_mfps.max(THESIS_RADIUS_MFPS) * hi)
}

/// The dipole profile (`ssskit profile --model dipole`) on `grid`.
pub fn dipole_profile(m: &Material, grid: &RadialGrid) -> Result<Profile> {
    analytic::profile(
        m,
        analytic::Model::Dipole,
        grid,
        &analytic::Options::default(),
    )
}

/// The dipole profile of a preset on the thesis grid.
pub fn dipole_preset(name: &str) -> Result<Profile> {
    let m = Material::load(name)?;
    dipole_profile(&m, &thesis_grid(&m, 32.0)?)
}

/// The dipole profile of preset `name` on a uniform grid of `dr_mm` out to
/// `r_max_mm`: the small profile unit tests fit their kernels to.
#[cfg(test)]
pub(crate) fn dipole_uniform(name: &str, dr_mm: f64, r_max_mm: f64) -> Profile {
    let m = crate::material::preset(name).unwrap();
    dipole_profile(&m, &RadialGrid::uniform(dr_mm, r_max_mm).unwrap()).unwrap()
}
