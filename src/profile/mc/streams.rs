//! Per-chunk random streams: each chunk of each channel draws from a
//! stream that is a function of (seed, channel, chunk) only, so a run is
//! the same whatever the thread count and its shards merge bit for bit.

use crate::material::Channel;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): decorrelates stream keys.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The RNG of chunk `chunk` of channel `ch`: a function of (seed, ch, chunk)
/// only.
pub(super) fn chunk_rng(seed: u64, ch: Channel, chunk: u64) -> Xoshiro256PlusPlus {
    Xoshiro256PlusPlus::seed_from_u64(chunk_key(seed, ch, chunk))
}

/// The stream key of chunk `chunk` of channel `ch`, hashed from (seed, ch,
/// chunk) (also the root of the oblique runs' keys).
pub(super) fn chunk_key(seed: u64, ch: Channel, chunk: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(seed) ^ (ch.index() as u64 + 1)) ^ chunk)
}
