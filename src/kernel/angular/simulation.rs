//! The angle-resolved Monte Carlo run the angular factor tables come
//! from: its incidences and exit bins, its photons within the main job's
//! work, its radial grid, and the run itself ([`simulate_factors`]).

use super::table::{from_angular, node_mu, AngularFactors, NODES};
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::mc::angular::{AngularOptions, MAX_INCIDENCE_DEG};
use crate::profile::mc::{self, McConfig, McOptions, PhotonBudget};
use crate::profile::RadialGrid;
use crate::progress::Progress;

/// Exit-angle bins of the run the tables come from (1 degree each; the
/// node averages pool them, so finer bins cost no noise).
pub const EXIT_BINS: usize = 90;
/// Photons per channel and incidence of [`simulate_factors`]' default run:
/// standard errors about 0.3-0.7% on the entry nodes and 1-3% on the exit
/// nodes for skin-like media.
pub const DEFAULT_PHOTONS: u64 = 200_000;
/// Events per channel the main job's factor run may spend over all its
/// runs (the normal one and [`NODES`] - 1 oblique ones): half the
/// pipeline's cap on its own profile
/// ([`crate::profile::source::MC_MAX_WORK`]), so that the factors at most
/// add half the Monte Carlo time the profile itself may take.
pub const FACTOR_MAX_WORK: u64 = crate::profile::source::MC_MAX_WORK / 2;
/// Fewest photons per channel and incidence the main job's factor run
/// traces, whatever the work: fewer leave grazing exit nodes without
/// escapes (a factor of 0, refused) in absorbing channels.
pub const MIN_PHOTONS: u64 = 10_000;

/// Photons per channel and incidence of a factor run within
/// [`FACTOR_MAX_WORK`], from the events per photon of the material's normal
/// incidence run (the slowest channel; oblique photons start shallower and
/// take fewer): [`DEFAULT_PHOTONS`] at most, [`MIN_PHOTONS`] at least;
/// [`DEFAULT_PHOTONS`] when the events are unknown.
pub fn photons_within_work(events_per_photon: Option<&[f64]>) -> u64 {
    let worst = events_per_photon
        .unwrap_or(&[])
        .iter()
        .copied()
        .filter(|e| e.is_finite() && *e > 0.0)
        .fold(0.0, f64::max);
    if worst <= 0.0 {
        return DEFAULT_PHOTONS;
    }
    let n = FACTOR_MAX_WORK as f64 / (NODES as f64 * worst);
    (n as u64).clamp(MIN_PHOTONS, DEFAULT_PHOTONS)
}

/// Radial bins of [`simulate_factors`]' run. The factors use the
/// whole-plane tallies only (the exit-angle bins over every radius and the
/// total R_d, beyond r_max included), which do not depend on the radial
/// grid; the radiance table per radial bin, which does, is left unused. A
/// coarse grid keeps that table far under
/// [`crate::profile::mc::angular::MAX_ANGLE_CELLS`] for every material (the
/// material's own grid has up to 5894 bins: 5894 x 90 cells are too many).
pub const FACTOR_RADIAL_BINS: usize = 64;
/// The oblique incidence angles (degrees) whose runs give the entry nodes,
/// grazing first; mu = 0 is run at [`MAX_INCIDENCE_DEG`].
pub fn node_incidences_deg() -> Vec<f64> {
    (0..NODES - 1)
        .map(|k| {
            if k == 0 {
                MAX_INCIDENCE_DEG
            } else {
                node_mu(k).acos().to_degrees()
            }
        })
        .collect()
}

/// The angle-resolved options of a run that yields both tables.
pub fn run_options() -> AngularOptions {
    AngularOptions {
        angle_bins: EXIT_BINS,
        incidence_deg: node_incidences_deg(),
    }
}

/// The radial grid of [`simulate_factors`]' run: [`FACTOR_RADIAL_BINS`]
/// uniform bins out to the material's own r_max.
pub fn factor_grid(material: &Material) -> Result<RadialGrid> {
    let r_max = RadialGrid::for_material(material, &Channel::ALL).r_max();
    RadialGrid::uniform(r_max / FACTOR_RADIAL_BINS as f64, r_max)
}

/// Runs the angle-resolved Monte Carlo for `material` ([`run_options`],
/// `photons` per channel and incidence, on [`factor_grid`]) and builds the
/// tables.
pub fn simulate_factors(
    material: &Material,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    progress: &dyn Progress,
) -> Result<AngularFactors> {
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed,
        threads,
        channels: Channel::ALL.to_vec(),
        grid: Some(factor_grid(material)?),
    };
    let opts = McOptions {
        angular: Some(run_options()),
        ..McOptions::default()
    };
    let p = mc::simulate_with(material, &cfg, &opts, progress)?;
    let a = p.angular()?.ok_or_else(|| {
        Error::Unsupported("angular factors: the run recorded no angular tables".into())
    })?;
    from_angular(&a, photons)
}
