//! The per-tap jitter of the screen-space pass: interleaved gradient noise
//! in 32-bit fixed point, spread over the taps by an additive recurrence.
//! The WGSL twin (shaders/sss_pass.wgsl) gets these constants from
//! [`super::gpu`], so both sides compute the same bits.

/// Interleaved gradient noise (Jimenez 2014, "Next Generation Post
/// Processing in Call of Duty: Advanced Warfare"): fract(52.9829189
/// fract(0.06711056 x + 0.00583715 y)), evaluated in 32-bit fixed point
/// (the constants times 2^32) so that the WGSL twin gets the same bits as
/// this f64 path: float fract of a value near 100 would differ by 1e-3
/// between f32 and f64.
pub const IGN_X: u32 = 288_237_660;
pub const IGN_Y: u32 = 25_070_368;
/// The whole part of 52.9829189.
pub const IGN_WHOLE: u32 = 52;
/// The fractional part 0.9829189 of 52.9829189, times 2^32.
pub const IGN_FRACTION: u32 = 4_221_604_530;
/// 2^32 / golden ratio: consecutive taps get well-spread noise values
/// (additive recurrence), not one shift shared by every tap.
pub const GOLDEN_U32: u32 = 2_654_435_769;

/// The high 32 bits of a 32 x 32 bit product.
fn mul_high(a: u32, b: u32) -> u32 {
    ((a as u64 * b as u64) >> 32) as u32
}

/// Interleaved gradient noise at pixel (x, y) in 32-bit fixed point.
pub fn ign_fixed(x: u32, y: u32) -> u32 {
    let inner = IGN_X.wrapping_mul(x).wrapping_add(IGN_Y.wrapping_mul(y));
    IGN_WHOLE
        .wrapping_mul(inner)
        .wrapping_add(mul_high(IGN_FRACTION, inner))
}

/// Bits of the jitter: the top 24 of the noise, exact in f32 and f64.
pub const JITTER_BITS: u32 = 24;

/// The jitter in [0, 1) of tap `tap` in pass `axis` (0 horizontal, 1
/// vertical) at pixel (x, y): [`JITTER_BITS`] bits, exact in f32 and f64.
pub fn jitter_unit(x: u32, y: u32, tap: u32, axis: u32) -> f64 {
    let n = ign_fixed(x, y).wrapping_add((2 * tap + axis).wrapping_mul(GOLDEN_U32));
    (n >> (32 - JITTER_BITS)) as f64 / (1u32 << JITTER_BITS) as f64
}

/// 2^32 (sqrt 2 - 1): the per-frame step of a disk kernel's rotation. Not
/// the golden ratio: a step of 1 / golden ratio turn is minus the golden
/// angle of the spiral the samples sit on, so it carries sample i onto the
/// angle of sample i - 1 and consecutive frames repeat nearly the same
/// estimate; sqrt 2 - 1 (continued fraction [0; 2, 2, 2, ...]) spreads the
/// frames as evenly without that coincidence.
pub const SILVER_U32: u32 = 1_779_033_704;

/// The per-pixel rotation of a disk kernel in turns, [0, 1): interleaved
/// gradient noise at (x, y) plus `frame` steps of [`SILVER_U32`],
/// [`JITTER_BITS`] bits, exact in f32 and f64. `frame` already holds the
/// seed (seed + frame index, wrapping).
pub fn rotation_unit(x: u32, y: u32, frame: u32) -> f64 {
    let n = ign_fixed(x, y).wrapping_add(frame.wrapping_mul(SILVER_U32));
    (n >> (32 - JITTER_BITS)) as f64 / (1u32 << JITTER_BITS) as f64
}
