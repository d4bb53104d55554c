//! Error tables, plots and comparisons (issues 3 and 4).
