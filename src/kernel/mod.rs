//! Screen-space kernels: the discretised 2D ground truth (`Kernel2D`), the
//! separable models fitted to it (Freude 2014, ch. 5 and the baselines of ch. 4), the
//! kernel file format with real-time tap tables, metrics and shader export.

pub mod angular;
pub mod cell_integrals;
pub mod disk;
pub mod disk_emit;
pub mod disk_fit;
pub mod emit;
pub mod factors;
pub mod format;
pub mod gaussians;
pub mod guided;
pub mod jimenez;
pub mod kernel2d;
pub mod manual;
pub mod metrics;
pub mod model;
pub mod preintegrate;
pub mod reference;
pub mod svd;
pub mod tap_kernel;
pub mod taps;
pub mod transmission;

pub use factors::Factors;
pub use format::{KernelFile, Metrics, ModelInfo, Pass, TapTable, Usage, KERNEL_SCHEMA};
pub use kernel2d::{Kernel2D, Kernel2DSpec};
pub use model::{fit_kernel_file, fit_kernel_file_with, fit_model, Model};
