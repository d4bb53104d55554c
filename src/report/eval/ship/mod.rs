//! What the main job (`ssskit kernels`, [`crate::report::pipeline`]) measures
//! around the comparison and the advice: the shipped configuration on the
//! test images ([`shipped`]), the material's preview ([`preview`]), the
//! engine step ([`engine_step`]) and the stage times ([`stage_times`]).

pub mod engine_step;
pub mod preview;
pub mod shipped;
pub mod stage_times;
