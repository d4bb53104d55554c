// Known-answer check of the generator in mc_philox.wgsl (prepended by the
// host): out[4 i ..] = philox(ctr_i, key_i) for 6-word (counter, key) inputs.

@group(0) @binding(0) var<storage, read> kat_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> kat_out: array<u32>;

@compute @workgroup_size(1)
fn kat(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    let b = 6u * i;
    let r = philox4x32_10(
        vec4<u32>(kat_in[b], kat_in[b + 1u], kat_in[b + 2u], kat_in[b + 3u]),
        vec2<u32>(kat_in[b + 4u], kat_in[b + 5u]),
    );
    kat_out[4u * i] = r.x;
    kat_out[4u * i + 1u] = r.y;
    kat_out[4u * i + 2u] = r.z;
    kat_out[4u * i + 3u] = r.w;
}
