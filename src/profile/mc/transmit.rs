//! The light a finite stack transmits, as a profile: T_d(r) at the bottom
//! surface per radial bin (MCML's Tt_r; Wang et al. 1995) with standard
//! errors from the per-photon second moments, its exit angles when the run
//! resolves them (Tt_a, Tt_ra), and its part in the stopping rule: a run of
//! a finite stack stops when the transmitted light meets the same rule as
//! the reflected light (relative errors of the total and of the
//! pre-integrated 1D factor, or the absolute floor).

use super::consumer::{provisional_geometry, Projection};
use super::tally::{convergence_of, densities, BinSums, ChunkTally, ExitSums, Moments};
use super::{PhotonBudget, CONTEXT};
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::RadialGrid;
use serde::{Deserialize, Serialize};

/// How far one light of a channel (the reflected or the transmitted) is
/// from the budget's rule.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct LightStatus {
    /// Relative standard error of the total (R_d or T).
    pub(super) rel_total: f64,
    /// Mean relative error of the bins inside the radius holding 99% of
    /// the total, weighted by their light (the `total-and-profile` rule).
    pub(super) rel_profile: f64,
    /// Relative L2 standard error of the pre-integrated 1D factor on its
    /// own default kernel grid (the `kernel-factor` rule).
    pub(super) rel_factor: f64,
    /// The total per incident photon and its standard error.
    pub(super) total: f64,
    pub(super) stderr: f64,
}

impl LightStatus {
    /// The error a budget's rule compares with its target, from the
    /// relative errors of the total, the profile and the 1D factor (0 for
    /// a fixed budget).
    pub(super) fn rule_error(&self, budget: &PhotonBudget) -> f64 {
        match budget {
            PhotonBudget::Fixed(_) => 0.0,
            PhotonBudget::TargetError { .. } => self.rel_total.max(self.rel_profile),
            PhotonBudget::KernelFactor { .. } => self.rel_total.max(self.rel_factor),
        }
    }

    /// How far this light is from the absolute floor of the kernel-factor
    /// rule (<= 1: reached; see `DEFAULT_ABS_FLOOR`) after `photons`.
    pub(super) fn floor_ratio(&self, floor: f64, photons: u64) -> f64 {
        // Noise in the un-normalised kernel: the total times the factor's
        // relative error (nothing back counts as 0 here: the photon
        // minimum covers it).
        let shape = if self.total > 0.0 {
            self.total * self.rel_factor
        } else {
            0.0
        };
        let noise = self.stderr.max(shape) / floor;
        // Written as an error ~ N^-1/2 so that round_len aims at it too.
        let minimum = (3.0 / floor / photons.max(1) as f64).sqrt();
        noise.max(minimum)
    }
}

/// The transmittance status of each channel (None for a channel whose
/// tally holds no transmittance: a semi-infinite stack).
pub(super) fn tr_statuses(
    material: &Material,
    channels: &[Channel],
    grid: &RadialGrid,
    t: &[ChunkTally],
) -> Vec<Option<LightStatus>> {
    if t.iter().all(|t| t.tr_bins.sum.is_empty()) {
        return vec![None; t.len()];
    }
    let n = grid.len();
    let areas = grid.areas();
    let rd = t
        .iter()
        .map(|t| match t.tr_bins.sum.get(..n) {
            Some(s) => densities(s, t.photons, &areas),
            None => vec![0.0; n],
        })
        .collect();
    let total = t.iter().map(|t| t.transmittance.mean(t.photons)).collect();
    let projection = provisional_geometry(material, channels, grid, rd, total)
        .map(|g| Projection::new(&grid.edges, &g));
    t.iter()
        .map(|t| {
            if t.tr_bins.sum.len() != n + 2 {
                return None;
            }
            let inside = BinSums {
                sum: t.tr_bins.sum[..n].to_vec(),
                sum_sq: t.tr_bins.sum_sq[..n].to_vec(),
            };
            let (rel_total, rel_profile, _) =
                convergence_of(&t.transmittance, &inside, t.photons, grid);
            let total = t.transmittance.mean(t.photons);
            let rel_factor = match &projection {
                Some(p) if total > 0.0 => {
                    p.factor_rel_error(&inside.sum, &inside.sum_sq, t.photons)
                }
                _ => 0.0,
            };
            Some(LightStatus {
                rel_total,
                rel_profile,
                rel_factor,
                total,
                stderr: t.transmittance.stderr(t.photons),
            })
        })
        .collect()
}

/// The transmitted light of one run as a profile records it
/// (`extra.transmittance_profile`): T_d(r) in mm^-2 per channel and bin with
/// standard errors, what left beyond r_max, and the exit angles when
/// tallied (`Profile::transmittance_profile` reads it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransmittanceProfile {
    /// T_d per bin of the profile's radial grid, `[channel][bin]`, mm^-2.
    pub td: Vec<Vec<f64>>,
    pub td_stderr: Vec<Vec<f64>>,
    /// Part of the incident light transmitted beyond r_max (in the total).
    pub beyond_rmax: Vec<f64>,
    /// The part of total T that scattered at least once on its way (what
    /// leaves the unlit face spread out; the rest left unscattered, on the
    /// beam's axis), per channel, and its standard error.
    #[serde(default)]
    pub diffuse: Vec<f64>,
    #[serde(default)]
    pub diffuse_stderr: Vec<f64>,
    /// Achieved relative errors of total T and of T_d's 1D factor.
    pub rel_error_total: Vec<f64>,
    pub rel_error_kernel_factor: Vec<f64>,
    /// Exit angles of the transmitted light (angle-resolved runs only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular: Option<TransmittedAngles>,
}

/// The transmitted light by exit angle (bins of `Angular::theta_edges_deg`
/// in the ambient medium below), MCML's Tt_a and Tt_ra.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransmittedAngles {
    pub angle_bins: usize,
    /// Part of the incident light through each angle bin: `[channel][bin]`.
    pub fraction: Vec<Vec<f64>>,
    pub fraction_stderr: Vec<Vec<f64>>,
    /// Part of the incident light per radial row (the last beyond r_max)
    /// and angle bin: `[channel][row][bin]`.
    pub cell: Vec<Vec<Vec<f64>>>,
    pub cell_stderr: Vec<Vec<Vec<f64>>>,
}

/// The record of the transmitted light of `t` (one tally per channel), None
/// when no channel tallied it.
pub(super) fn record(
    t: &[ChunkTally],
    status: &[Option<LightStatus>],
    areas: &[f64],
) -> Option<TransmittanceProfile> {
    if t.iter().any(|t| t.tr_bins.sum.len() != areas.len() + 2) {
        return None;
    }
    let n = areas.len();
    let bin = |t: &ChunkTally, i: usize| Moments {
        sum: t.tr_bins.sum[i],
        sum_sq: t.tr_bins.sum_sq[i],
    };
    // Per channel and bin, a statistic of the bin's weight per unit area.
    let per_area = |f: fn(&Moments, u64) -> f64| -> Vec<Vec<f64>> {
        t.iter()
            .map(|t| {
                (0..n)
                    .map(|i| f(&bin(t, i), t.photons) / areas[i])
                    .collect()
            })
            .collect()
    };
    let (td, td_stderr) = (per_area(Moments::mean), per_area(Moments::stderr));
    let angular = t.iter().all(|t| !t.tr_exit.is_empty()).then(|| angles(t));
    let st = |f: &dyn Fn(&LightStatus) -> f64| -> Vec<f64> {
        status.iter().map(|s| s.as_ref().map_or(0.0, f)).collect()
    };
    Some(TransmittanceProfile {
        td,
        td_stderr,
        beyond_rmax: t.iter().map(|t| bin(t, n).mean(t.photons)).collect(),
        diffuse: t.iter().map(|t| bin(t, n + 1).mean(t.photons)).collect(),
        diffuse_stderr: t.iter().map(|t| bin(t, n + 1).stderr(t.photons)).collect(),
        rel_error_total: st(&|s| s.rel_total),
        rel_error_kernel_factor: st(&|s| s.rel_factor),
        angular,
    })
}

fn angles(t: &[ChunkTally]) -> TransmittedAngles {
    let per_bin = |e: &ExitSums, n: u64| -> (Vec<f64>, Vec<f64>) {
        (0..e.a.sum.len())
            .map(|i| {
                let m = Moments {
                    sum: e.a.sum[i],
                    sum_sq: e.a.sum_sq[i],
                };
                (m.mean(n), m.stderr(n))
            })
            .unzip()
    };
    let cells = |e: &ExitSums, n: u64, se: bool| -> Vec<Vec<f64>> {
        let na = e.a.sum.len();
        e.ra.sum
            .chunks(na)
            .zip(e.ra.sum_sq.chunks(na))
            .map(|(s, q)| {
                s.iter()
                    .zip(q)
                    .map(|(s, q)| {
                        let m = Moments {
                            sum: *s,
                            sum_sq: *q,
                        };
                        if se {
                            m.stderr(n)
                        } else {
                            m.mean(n)
                        }
                    })
                    .collect()
            })
            .collect()
    };
    let (fraction, fraction_stderr) = t.iter().map(|t| per_bin(&t.tr_exit, t.photons)).unzip();
    TransmittedAngles {
        angle_bins: t[0].tr_exit.a.sum.len(),
        fraction,
        fraction_stderr,
        cell: t
            .iter()
            .map(|t| cells(&t.tr_exit, t.photons, false))
            .collect(),
        cell_stderr: t
            .iter()
            .map(|t| cells(&t.tr_exit, t.photons, true))
            .collect(),
    }
}

/// Refuses a transmittance request on a stack without a finite bottom:
/// nothing is transmitted there, and no thickness was given to make it so.
pub fn require_finite(material: &Material, what: &str) -> Result<()> {
    let finite = material
        .layers
        .last()
        .is_some_and(|l| l.thickness.is_some());
    if finite {
        return Ok(());
    }
    Err(Error::invalid(
        CONTEXT,
        "thickness",
        "none",
        format!(
            "{what} needs light to leave through the bottom, but the last layer of '{}' is \
             semi-infinite: give it a finite thickness",
            material.name
        ),
    ))
}
