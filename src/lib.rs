//! ssskit: from a material's optical coefficients to subsurface-scattering
//! kernels for real-time renderers, and proof of how good each kernel is.
//!
//! The modules follow the data flow: `material` -> `profile` -> `kernel` ->
//! `filter` -> `report`. Each stage's output is a file a user can keep.

// `!(x > 0.0)` is how this crate rejects NaN along with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod engine;
pub mod error;
pub mod filter;
pub mod gpu;
pub mod io;
pub mod kernel;
pub mod limits;
pub mod material;
pub mod numerics;
pub mod profile;
pub mod progress;
pub mod report;
pub mod scene;

pub use error::{Error, Result};
