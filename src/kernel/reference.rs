//! Stand-in reference profiles from the standard dipole, on the radial grid
//! of 002 table 6.1, for tests and for `scripts/regen-kernels` while the
//! Monte Carlo simulator (`ssskit simulate`) is not available.

use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::analytic::{bin_averages, dipole};
use crate::profile::{fresnel, Profile, RadialGrid, Source, PROFILE_SCHEMA};
use serde_json::json;

/// 002 table 6.1: dr = min(MFP_rgb)/20, r_max = 32 max(MFP_rgb) (here at
/// least `min_mfps` max MFPs, for materials whose falloff is longer).
pub fn thesis_grid(m: &Material, min_mfps: f64) -> Result<RadialGrid> {
    let mfps: Vec<f64> = Channel::ALL.iter().map(|&c| m.top(c).mfp()).collect();
    let lo = mfps.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = mfps.iter().cloned().fold(0.0, f64::max);
    RadialGrid::uniform(lo / 20.0, min_mfps.max(32.0) * hi)
}

/// Bin-averaged dipole R_d of each channel of the top layer.
pub fn dipole_profile(m: &Material, grid: &RadialGrid) -> Result<Profile> {
    m.validate(&m.name)?;
    let t0 = std::time::Instant::now();
    let media: Vec<_> = Channel::ALL.iter().map(|&c| m.top(c)).collect();
    for (c, md) in Channel::ALL.iter().zip(&media) {
        if !(md.sigma_t_reduced() > 0.0) {
            return Err(Error::invalid(
                &m.name,
                format!("sigma_t' [{}]", c.name()),
                md.sigma_t_reduced(),
                "the dipole needs sigma_t' > 0",
            ));
        }
    }
    let rd: Vec<Vec<f64>> = media
        .iter()
        .map(|md| bin_averages(|r| dipole::dipole_rd(md, r), grid))
        .collect();
    let total_rd = media.iter().map(dipole::dipole_total).collect();
    let eta = m.layers[0].eta;
    Ok(Profile {
        schema: PROFILE_SCHEMA.into(),
        material: m.clone(),
        units: "mm".into(),
        source: Source {
            kind: "analytic".into(),
            photons: None,
            seed: None,
            model: Some("dipole".into()),
            params: json!({"grid": "002 table 6.1", "stand_in_for": "monte-carlo"}),
        },
        channels: Channel::ALL.to_vec(),
        r: grid.centres(),
        r_edges: grid.edges.clone(),
        rd,
        rd_stderr: None,
        total_rd,
        total_rd_stderr: None,
        specular: vec![fresnel::specular_normal(m.eta_above, eta); 3],
        transmittance: None,
        transmittance_stderr: None,
        absorbed: None,
        extra: serde_json::Value::Null,
        elapsed_s: t0.elapsed().as_secs_f64(),
    })
}

/// The dipole profile of a preset on the thesis grid.
pub fn dipole_preset(name: &str) -> Result<Profile> {
    let m = Material::load(name)?;
    dipole_profile(&m, &thesis_grid(&m, 32.0)?)
}
