//! Screen-space kernels: the discretised 2D ground truth (`Kernel2D`), the
//! separable models fitted to it, and the kernel file format with real-time
//! tap tables.

pub mod format;
pub mod kernel2d;

pub use format::{KernelFile, Metrics, ModelInfo, Pass, TapTable, KERNEL_SCHEMA};
pub use kernel2d::{Kernel2D, Kernel2DSpec};
