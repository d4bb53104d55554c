//! Error tables, plots and comparisons, in two parts: [`eval`] measures and
//! decides (image-space evaluation, model comparisons, the advice, the
//! study, the pipeline), [`present`] shows (tables, plots, report text,
//! recorded measurements, number formats). The modules' old paths
//! (`report::advise`, `report::table`, ...) are re-exported here.

pub mod eval;
pub mod present;

pub use eval::{
    advise, advise_disk, disk_compare, evaluate, kernel_compare, pipeline, scene_compare, study,
};
pub use present::{kernel_plots, kernel_report, pareto, plot, record, scene_tables, table};

/// Analytic profile models against a Monte Carlo reference: the
/// measurement ([`eval::profile_compare`]) and its tables and plots
/// ([`present::profile_tables`]).
pub mod compare {
    pub use super::eval::profile_compare::*;
    pub use super::present::number::{short, time};
    pub use super::present::profile_tables::*;
}
