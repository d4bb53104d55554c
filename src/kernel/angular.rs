//! Angular entry and exit factors: the two small tables a screen-space pass
//! applies around its blur, so that light arriving obliquely and light
//! seen obliquely are weighted as the medium weights them.
//!
//! The blur assumes light that enters along the normal and leaves
//! Lambertian. A semi-infinite medium does neither: oblique light scatters
//! nearer the surface and more of it comes back (for isotropic scattering
//! without a boundary the plane albedo is 1 - sqrt(1 - a) H(mu0),
//! Chandrasekhar 1960, ch. V), and the light leaving has the angular
//! distribution H(mu) H(mu0) / (mu + mu0) rather than a constant radiance.
//! Separably, per channel:
//!
//! - **Entry** E(mu_l) = R_d(theta_in) / R_d(0) with mu_l = N.L: the
//!   irradiance buffer is multiplied by it before the blur (the kernel keeps
//!   R_d(0) as its colour).
//! - **Exit** X(mu_v) = pi L(theta_out) / M with mu_v = N.V, for light
//!   entering along the normal: the blurred exitance is multiplied by it
//!   after the blur, turning the Lambertian radiance M / pi into what the
//!   camera sees.
//!
//! Both are tabulated at [`NODES`] cosines mu_k = k / (NODES - 1) and read
//! back by linear interpolation ([`lookup`]), the rule the shader header
//! implements. The tables come from one angle-resolved Monte Carlo run
//! (`extra.angular` of a profile, Wang et al. 1995's Rd_a and oblique
//! launch): the entry node values interpolate the oblique runs linearly in
//! mu (the run at [`crate::profile::mc::angular::MAX_INCIDENCE_DEG`] stands
//! for mu = 0, where the irradiance vanishes), the exit node values average
//! the exit-angle bins over mu_k +- 1 / (2 (NODES - 1)) with the Lambertian
//! weight 2 mu dmu (a bin straddling an interval counts by the share of its
//! Lambertian weight inside it). Standard errors follow, the bins and runs
//! taken as independent.
//!
//! Two jobs, one file each: `table` (the tables, their checks and where
//! a profile keeps them) and `simulation` (the run that makes them),
//! which imports the tables.

mod simulation;
mod table;

pub use simulation::{
    factor_grid, node_incidences_deg, photons_within_work, run_options, simulate_factors,
    DEFAULT_PHOTONS, EXIT_BINS, FACTOR_MAX_WORK, FACTOR_RADIAL_BINS, MIN_PHOTONS,
};
pub use table::{
    attach, from_angular, leave_out, left_out, lookup, missing_note, node_mu, AngularFactors,
    ENTRY_ENERGY_SLACK, EXIT_MEAN_TOLERANCE, LEFT_OUT_KEY, MAX_NODES, NODES, PROFILE_KEY,
    UNIT_ENTRY_TOLERANCE,
};
