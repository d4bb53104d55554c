//! Evaluation and decision: how far a kernel lands from the exact
//! convolution, model comparisons in kernel and image space, the thesis's
//! claims checked on them, the configuration to ship, the speed/accuracy
//! study and the one-call pipeline.

pub mod advise;
pub mod advise_decide;
pub mod advise_disk;
pub mod advise_noise;
pub mod advise_scene;
pub mod advise_search;
pub mod advise_types;
pub mod claims;
pub mod colour_shift;
pub mod directional_advise;
pub mod directional_scene;
pub mod disk_compare;
pub mod engine_step;
pub mod engine_tables;
pub mod evaluate;
pub mod kernel_compare;
pub mod pipeline;
pub mod preview;
pub mod profile_compare;
pub mod scene_compare;
pub mod scene_pass;
pub mod scene_score;
pub mod scene_transmission;
pub mod shipped;
pub mod stage_times;
pub mod study;
