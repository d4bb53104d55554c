//! Error tables, plots and comparisons, in two parts: [`eval`] measures and
//! decides (image-space evaluation, model comparisons, the advice, the
//! study, the pipeline), [`present`] shows (tables, plots, report text,
//! recorded measurements, number formats). Callers name a module by its
//! home (`report::eval::advise`, `report::present::table`).

pub mod eval;
pub mod present;
