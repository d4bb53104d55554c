// Philox4x32-10 (Salmon, Moraes, Dror & Shaw 2011, "Parallel random
// numbers: as easy as 1, 2, 3"). Shared by mc_trace.wgsl and its
// known-answer check mc_kat.wgsl. The host prepends mul_wide
// (wide_mul.wgsl) and the constants PHILOX_M0, PHILOX_M1 (round
// multipliers) and PHILOX_W0, PHILOX_W1 (key increments) from the CPU twin
// in src/profile/mc/gpu/philox.rs, so both use one definition.

fn philox_round(c: vec4<u32>, k: vec2<u32>) -> vec4<u32> {
    let p0 = mul_wide(PHILOX_M0, c.x);
    let p1 = mul_wide(PHILOX_M1, c.z);
    return vec4<u32>(p1.y ^ c.y ^ k.x, p1.x, p0.y ^ c.w ^ k.y, p0.x);
}

// Ten rounds written out, not looped: llvmpipe (lavapipe) allows 65535 loop
// iterations per shader invocation across all loops, and the walk needs
// them.
fn philox4x32_10(ctr: vec4<u32>, key: vec2<u32>) -> vec4<u32> {
    let w = vec2<u32>(PHILOX_W0, PHILOX_W1);
    var c = philox_round(ctr, key);
    c = philox_round(c, key + w);
    c = philox_round(c, key + 2u * w);
    c = philox_round(c, key + 3u * w);
    c = philox_round(c, key + 4u * w);
    c = philox_round(c, key + 5u * w);
    c = philox_round(c, key + 6u * w);
    c = philox_round(c, key + 7u * w);
    c = philox_round(c, key + 8u * w);
    return philox_round(c, key + 9u * w);
}
