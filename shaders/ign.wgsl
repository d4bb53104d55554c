// Interleaved gradient noise (Jimenez 2014) at pixel (x, y) in 32-bit fixed
// point, fract(52.9829189 fract(0.06711056 x + 0.00583715 y)): the same bits
// as ign_fixed in src/filter/jitter.rs. Shared by the separable pass's
// jitter (sss_pass.wgsl) and the disk pass's rotation (disk.wgsl); the host
// prepends it after mul_wide (wide_mul.wgsl) and the constants IGN_X, IGN_Y,
// IGN_WHOLE, IGN_FRACTION and JITTER_BITS (src/filter/gpu.rs, ign_constants).
fn ign_fixed(x: u32, y: u32) -> u32 {
    let inner = IGN_X * x + IGN_Y * y;
    return IGN_WHOLE * inner + mul_wide(IGN_FRACTION, inner).y;
}

// The top JITTER_BITS of `n` as a fraction in [0, 1), exact in f32.
fn jitter_fraction(n: u32) -> f32 {
    return f32(n >> (32u - JITTER_BITS)) / f32(1u << JITTER_BITS);
}
