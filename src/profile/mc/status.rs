//! How far each channel of a run is from its budget's rule: the relative
//! errors of total R_d, of the profile and of the kernel factor, the
//! transmitted light's alike, the absolute floor, and the ratio that sizes
//! the next round.

use super::consumer::provisional_geometry;
use super::tally::{convergence_of, densities};
use super::transmit::{tr_statuses, LightStatus};
use super::*;

/// How a channel's run ended.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Status {
    /// The reflected light: total R_d, its profile inside r99 (the
    /// R_d-weighted mean relative error, `convergence`) and the kernel
    /// factor (`consumer`).
    pub(super) rd: LightStatus,
    /// Radius holding 99% of R_d.
    pub(super) r99: f64,
    /// The transmitted light's errors (finite stacks only).
    pub(super) tr: Option<LightStatus>,
}

/// How far a channel's reflected light is from the absolute floor of the
/// kernel-factor rule (`LightStatus::floor_ratio`) after `photons`;
/// infinite for other rules or with the floor off.
pub(super) fn floor_ratio(budget: &PhotonBudget, floor: f64, s: &Status, photons: u64) -> f64 {
    if !matches!(budget, PhotonBudget::KernelFactor { .. }) || !(floor > 0.0) {
        return f64::INFINITY;
    }
    s.rd.floor_ratio(floor, photons)
}

/// The error a target-error rule compares with its target.
pub(super) fn rule_error(budget: &PhotonBudget, s: &Status) -> f64 {
    s.rd.rule_error(budget)
}

/// The status of every channel and the default kernel grid they imply
/// (all channels together, as `Kernel2D::from_profile` sees them).
pub(super) fn statuses(
    material: &Material,
    channels: &[Channel],
    grid: &RadialGrid,
    tallies: &[ExactTally],
) -> (Vec<Status>, Option<KernelGeometry>) {
    let t: Vec<ChunkTally> = tallies.iter().map(ExactTally::to_f64).collect();
    let areas = grid.areas();
    let geometry = provisional_geometry(
        material,
        channels,
        grid,
        t.iter()
            .map(|t| densities(&t.rd_bins.sum, t.photons, &areas))
            .collect(),
        t.iter().map(|t| t.rd.mean(t.photons)).collect(),
    );
    let projection = geometry.map(|g| Projection::new(&grid.edges, &g));
    let tr = tr_statuses(material, channels, grid, &t);
    let s = t
        .iter()
        .zip(tr)
        .map(|(t, tr)| {
            let (rel_total, rel_profile, r99) = convergence(t, grid);
            let rel_factor = projection.as_ref().map_or(0.0, |p| {
                p.factor_rel_error(&t.rd_bins.sum, &t.rd_bins.sum_sq, t.photons)
            });
            Status {
                rd: LightStatus {
                    rel_total,
                    rel_profile,
                    rel_factor,
                    total: t.rd.mean(t.photons),
                    stderr: t.rd.stderr(t.photons),
                },
                r99,
                tr,
            }
        })
        .collect();
    (s, geometry)
}

/// (relative stderr of total R_d, relative stderr of the profile, r99).
///
/// The profile error is the R_d-weighted mean relative error of the bins
/// up to r99, the radius within which the tally holds 99% of the total R_d
/// (all bins when r_max holds less):
/// sum_i w_i (s_i / W_i) / sum_i w_i with weights w_i = W_i, i.e.
/// sum_i s_i / sum_i W_i, where W_i is the reflectance scored in bin i and
/// s_i its standard error. A zero R_d (nothing comes back) counts as exact.
pub(super) fn convergence(t: &ChunkTally, grid: &RadialGrid) -> (f64, f64, f64) {
    convergence_of(&t.rd, &t.rd_bins, t.photons, grid)
}

/// The larger of how far the reflected and the transmitted light are from
/// the target (`err / rel`) and from the floor, each part met either way:
/// a channel stops when both its reflected and its transmitted light meet
/// the target or the floor.
pub(super) fn channel_ratio(
    budget: &PhotonBudget,
    floor: f64,
    rel: f64,
    s: &Status,
    rd_err: f64,
    photons: u64,
) -> (f64, bool) {
    let r = (rd_err / rel).min(floor_ratio(budget, floor, s, photons));
    let mut by_floor = rd_err > rel;
    let t = match &s.tr {
        Some(t) => {
            // No light through yet is not an exact zero (the slab is
            // finite): only the floor's photon minimum may stop it.
            let e = if t.total > 0.0 {
                t.rule_error(budget) / rel
            } else {
                f64::INFINITY
            };
            let f = if matches!(budget, PhotonBudget::KernelFactor { .. }) && floor > 0.0 {
                t.floor_ratio(floor, photons)
            } else {
                f64::INFINITY
            };
            by_floor |= e > 1.0 && f <= 1.0;
            e.min(f)
        }
        None => 0.0,
    };
    (r.max(t), by_floor)
}
