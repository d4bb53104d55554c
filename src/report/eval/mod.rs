//! Evaluation and decision, one folder per job: [`compare`] (kernel and
//! profile models across materials, the thesis's claims checked on them,
//! separable against disk kernels), [`scene`] (screen-space and
//! light-space passes against a path-traced scene, transmission),
//! [`advise`] (the configuration to ship at a pixel scale), [`study`] (the
//! speed/accuracy trade of every knob) and [`ship`] (what the main job adds
//! around the advice: the shipped configuration on the test images, the
//! preview, the engine step, stage times). Shared by all:
//! [`evaluate`] (how far a kernel lands from the exact convolution) and
//! [`colour_shift`], [`disk`] (the disk kernels as every job builds
//! them) and [`radial`] (the radial ranges of the profile figures). Each job hands [`super::present`] a results type of
//! plain data.

pub mod advise;
pub mod colour_shift;
pub mod compare;
pub mod disk;
pub mod evaluate;
pub mod radial;
pub mod scene;
pub mod ship;
pub mod study;
