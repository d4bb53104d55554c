//! How many samples a pixel gets and which random stream each draws: a
//! leaf that the render, its rounds and the G-buffer share.

use crate::profile::mc::splitmix64;
use serde::{Deserialize, Serialize};

/// Context of the render settings' errors.
pub(super) const CONTEXT: &str = "scene render";

/// Samples per pixel of the first round.
pub const FIRST_ROUND_SPP: u64 = 16;

/// How many samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleBudget {
    /// Exactly this many per pixel and channel.
    Fixed(u64),
    /// Until the image's noise is below `rel` in every channel, or
    /// `max_spp`: noise = RMS over the pixels that see an object of the
    /// radiance's standard error, divided by the 99th percentile of their
    /// radiance (a robust peak).
    TargetError { rel: f64, max_spp: u64 },
}

/// The key of the stream of sample `s` of pixel `p` in stream family `c`
/// (0-2 the channels, 3 the G-buffer): a function of these only.
pub(crate) fn sample_key(seed: u64, c: u64, p: u64, s: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(splitmix64(seed) ^ (c + 1)) ^ p) ^ s)
}
