//! The comparison job (`ssskit compare`, `ssskit profiles`, and the main
//! job's model table): kernel models across materials in kernel and image
//! space ([`kernel`], results type [`kernel::Comparison`]), the thesis's
//! claims counted on its rows ([`claims`]), separable against disk kernels
//! ([`disk`], [`disk::DiskRows`]), the engine tables of the comparison
//! report ([`engine_tables`]), analytic profiles against Monte Carlo
//! ([`profile`], [`profile::Row`]) and what the comparison's figures show
//! ([`sheets`]: the contact sheets' tiles, the slices' rebuilt kernels).

pub mod claims;
pub mod disk;
pub mod engine_tables;
pub mod kernel;
pub mod profile;
pub mod sheets;
