//! Presentation: markdown/CSV tables, PNG plots, the written reports of the
//! comparisons and the advice, recorded measurements and number formats.
//! Nothing here measures; it shows what [`super::eval`] measured.

pub mod advice_text;
pub mod axes;
pub mod colour_bar;
pub mod diff_png;
pub mod directional_tables;
pub mod disk_table;
pub mod engine_section;
pub mod figures;
pub mod kernel_plots;
pub mod kernel_report;
pub mod layout;
pub mod number;
pub mod pareto;
pub mod plot;
pub mod preview_panel;
pub mod profile_tables;
pub mod record;
pub mod scene_tables;
pub mod sheet;
pub mod ship_report;
pub mod study_report;
pub mod table;
pub mod transmission_plots;
