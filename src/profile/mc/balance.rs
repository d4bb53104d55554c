//! Where the weight launched into one channel went: the energy balance a
//! Monte Carlo profile records per channel under `extra.energy_balance`.
//! The field names are the JSON keys of the profile file.

use crate::error::{Error, Result};
use crate::material::Channel;
use crate::profile::Profile;
use serde::{Deserialize, Serialize};

/// Fractions of the launched weight, per photon. Specular, R_d,
/// transmittance and absorption, plus what Russian roulette and the event
/// cap moved (the residual), add up to `sum`, which is 1 up to rounding
/// when the tracer loses nothing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EnergyBalance {
    /// Reflected at the first surface, never entering.
    pub specular: f64,
    /// Diffuse reflectance, within and beyond the grid.
    pub rd: f64,
    pub transmittance: f64,
    pub absorbed: f64,
    /// Weight of the packets that lost the roulette.
    pub roulette_loss: f64,
    /// Weight added to the packets that won it.
    pub roulette_gain: f64,
    /// Weight of packets abandoned at the event cap.
    pub truncated: f64,
    pub sum: f64,
    pub sum_minus_1: f64,
}

impl EnergyBalance {
    /// The balance `p` records for channel `ch`; `None` when it records
    /// none (an analytic profile, say). A record that is there but not a
    /// balance is an error naming the profile's material and the channel.
    pub fn of(p: &Profile, ch: Channel) -> Result<Option<EnergyBalance>> {
        let v = &p.extra["energy_balance"][ch.name()];
        if v.is_null() {
            return Ok(None);
        }
        serde_json::from_value(v.clone()).map(Some).map_err(|e| {
            Error::invalid(
                format!("profile of '{}'", p.material.name),
                format!("extra.energy_balance.{}", ch.name()),
                v,
                e.to_string(),
            )
        })
    }
}
