//! Error tables, plots and comparisons (issues 3 and 4).

pub mod compare;
pub mod evaluate;
pub mod plot;
pub mod table;
