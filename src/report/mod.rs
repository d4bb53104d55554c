//! Error tables, plots and comparisons.

pub mod advise;
pub mod compare;
pub mod evaluate;
pub mod kernel_compare;
pub mod kernel_plots;
pub mod kernel_report;
pub mod pareto;
pub mod pipeline;
pub mod plot;
pub mod record;
pub mod scene_compare;
pub mod scene_tables;
pub mod study;
pub mod table;
