//! The advice job (`ssskit advise`, and the main job's recommendation):
//! the cheapest configuration whose image-space error meets a target at a
//! pixel scale. Results type: [`Advice`].

pub mod advice;
pub mod decide;
pub mod directional;
pub mod disk;
pub mod noise;
pub mod run;
pub mod scene;
pub mod search;
pub mod types;

pub use advice::Advice;
pub use decide::{Budget, Verdict, DEFAULT_MAX_PASSES, NOISE_K};
pub use run::{advise, advise_on_scene, advise_prepared, candidate_models, Prepared};
pub use types::{
    Candidate, CoarserScale, Config, ExtentRule, Remedy, ViewScale, ADVISED_FAMILIES, CHECKER_PX,
    COARSER_SCALES, DEFAULT_TARGET, FULL_MAX_PIXELS, TAP_COUNTS,
};
