// What the two screen-space passes (sss_pass.wgsl, disk.wgsl) share; the
// host prepends it to both, after mul_wide (wide_mul.wgsl) and the
// constants IGN_X, IGN_Y, IGN_WHOLE, IGN_FRACTION and JITTER_BITS
// (src/filter/gpu.rs, ign_constants).

// The image and the per-pixel linear depth and strength (ones where none is
// given), bound alike by both hosts (src/filter/gpu.rs, disk_gpu.rs).
@group(0) @binding(1) var<storage, read> src: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> depth: array<f32>;
@group(0) @binding(3) var<storage, read> strength: array<f32>;

// Interleaved gradient noise (Jimenez 2014) at pixel (x, y) in 32-bit fixed
// point, fract(52.9829189 fract(0.06711056 x + 0.00583715 y)): the same bits
// as ign_fixed in src/filter/jitter.rs, for the separable pass's jitter and
// the disk pass's rotation.
fn ign_fixed(x: u32, y: u32) -> u32 {
    let inner = IGN_X * x + IGN_Y * y;
    return IGN_WHOLE * inner + mul_wide(IGN_FRACTION, inner).y;
}

// The top JITTER_BITS of `n` as a fraction in [0, 1), exact in f32.
fn jitter_fraction(n: u32) -> f32 {
    return f32(n >> (32u - JITTER_BITS)) / f32(1u << JITTER_BITS);
}

// Whether invocation `gid` lies outside the width x height image: the
// dispatch rounds the image up to whole workgroups.
fn outside_image(gid: vec3<u32>, width: u32, height: u32) -> bool {
    return gid.x >= width || gid.y >= height;
}
