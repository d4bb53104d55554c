//! Error tables, plots and comparisons (issues 3 and 4).

pub mod compare;
pub mod evaluate;
pub mod kernel_compare;
pub mod kernel_plots;
pub mod kernel_report;
pub mod plot;
pub mod table;
