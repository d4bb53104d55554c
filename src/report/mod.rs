//! Error tables, plots and comparisons, in three parts: [`eval`] measures
//! and decides, one folder per job (comparison, scene, advice, study, and
//! what the main job ships), [`present`] shows (tables, plots, report text,
//! recorded measurements, number formats) what eval handed it as plain
//! data, and [`pipeline`] runs the main job, eval then present. Callers name
//! a module by its home (`report::eval::advise`, `report::present::table`).

pub mod eval;
pub mod kernel_files;
pub mod pipeline;
pub mod present;
