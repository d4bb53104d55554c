//! The order of the kernel models' errors: rank-1 SVD is the best rank-1
//! separable fit in the least-squares sense (Eckart-Young), so no other
//! rank-1 model may beat it.

/// Relative slack of "rank-1 SVD is lowest": a model that reaches the same
/// optimum differs from it only by rounding.
pub const ROUNDING: f64 = 1e-9;

/// Asserts, channel by channel, that `svd1` (rank-1 SVD's error) is at
/// most `other` within [`ROUNDING`]; `say(c)` is the message for channel c.
pub fn assert_svd1_lowest(svd1: &[f64], other: &[f64], say: impl Fn(usize) -> String) {
    for c in 0..3 {
        assert!(svd1[c] <= other[c] * (1.0 + ROUNDING), "{}", say(c));
    }
}
