//! Philox4x32-10 (Salmon et al. 2011) on the CPU: the reference the
//! shader's generator (shaders/mc_philox.wgsl) is checked against, and the
//! constants both use.

/// The round multipliers of Philox4x32 (Salmon et al. 2011; Random123's
/// PHILOX_M4x32_0 and _1), for the CPU twin and the shader.
pub(super) const PHILOX_M: [u32; 2] = [0xD251_1F53, 0xCD9E_8D57];
/// The key increments (Weyl sequence) of Philox4x32: 2^32 / golden ratio
/// and 2^32 (sqrt(3) - 1) (Random123's PHILOX_W32_0 and _1).
pub(super) const PHILOX_W: [u32; 2] = [0x9E37_79B9, 0xBB67_AE85];

/// shaders/mc_philox.wgsl: the generator, for every shader that draws
/// from it (the tracer, the light-space pass); the host prepends
/// `WGSL_WIDE_MUL` and [`philox_wgsl_constants`].
pub const PHILOX_WGSL: &str = include_str!("../../../../shaders/mc_philox.wgsl");

/// The constants mc_philox.wgsl reads, as `wgsl_u32_consts` takes them.
pub fn philox_wgsl_constants() -> [(&'static str, u32); 4] {
    [
        ("PHILOX_M0", PHILOX_M[0]),
        ("PHILOX_M1", PHILOX_M[1]),
        ("PHILOX_W0", PHILOX_W[0]),
        ("PHILOX_W1", PHILOX_W[1]),
    ]
}

/// Philox4x32-10 on the CPU (Salmon et al. 2011, Random123's
/// `philox4x32_R` with R = 10): the reference for the shader's generator.
pub fn philox4x32_10(ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let (mut c, mut k) = (ctr, key);
    for _ in 0..10 {
        let p0 = PHILOX_M[0] as u64 * c[0] as u64;
        let p1 = PHILOX_M[1] as u64 * c[2] as u64;
        c = [
            (p1 >> 32) as u32 ^ c[1] ^ k[0],
            p1 as u32,
            (p0 >> 32) as u32 ^ c[3] ^ k[1],
            p0 as u32,
        ];
        k = [
            k[0].wrapping_add(PHILOX_W[0]),
            k[1].wrapping_add(PHILOX_W[1]),
        ];
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn philox_matches_random123_known_answers() {
        // Random123 tests/kat_vectors, the three "philox4x32 10" lines.
        let kat = [
            (
                [0u32; 4],
                [0u32; 2],
                [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8],
            ),
            (
                [u32::MAX; 4],
                [u32::MAX; 2],
                [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd],
            ),
            (
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0],
                [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1],
            ),
        ];
        for (c, k, want) in kat {
            assert_eq!(philox4x32_10(c, k), want);
        }
    }
}
