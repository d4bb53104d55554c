//! Monte Carlo photon transport (the MCML scheme; REFERENCE.md section 3).
//! FOUNDATION STUB: the tracer is being written (issue 2). The public
//! signature below is the contract other modules rely on.

use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::{Profile, RadialGrid};
use crate::progress::Progress;

/// How many photons to trace.
#[derive(Clone, Debug, PartialEq)]
pub enum PhotonBudget {
    /// Exactly this many per channel.
    Fixed(u64),
    /// Until the relative standard error of the total R_d and of the profile
    /// inside the radius holding 99% of R_d is below `rel` in every channel,
    /// or `max_photons` per channel are spent.
    TargetError { rel: f64, max_photons: u64 },
}

#[derive(Clone, Debug)]
pub struct McConfig {
    pub budget: PhotonBudget,
    pub seed: u64,
    /// Worker threads; None = rayon's default. Results do not depend on it.
    pub threads: Option<usize>,
    pub channels: Vec<Channel>,
    /// Radial tally bins; None = sized from the material.
    pub grid: Option<RadialGrid>,
}

/// Simulates the diffuse reflectance profile of `material`.
pub fn simulate(material: &Material, cfg: &McConfig, progress: &dyn Progress) -> Result<Profile> {
    let _ = (material, cfg, progress);
    Err(Error::Unsupported(
        "Monte Carlo simulation is not built yet".into(),
    ))
}
