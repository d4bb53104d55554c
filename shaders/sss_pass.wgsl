// One 1D pass of the separable screen-space SSS filter (Freude 2014, algorithm 4.1).
// The f64 twin is src/filter/screen_space.rs (apply_screen_space); keep them in step.
// Storage buffers and plain indexing (no samplers): rgba32float is not
// filterable on every adapter (lavapipe), so the linear interpolation along
// the pass axis is done here. Positions are clamped to the image (clamp-to-edge).
// The host prepends the struct Params (src/filter/gpu.rs, where its fields
// are described) and what both screen-space passes share
// (screen_common.wgsl: the image, depth and strength at bindings 1 to 3, the
// noise).

@group(0) @binding(0) var<uniform> params: Params;
// xyz: RGB weight, w: offset in kernel mm.
@group(0) @binding(4) var<storage, read> taps: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> dst: array<vec4<f32>>;
// Per tap: start and width (kernel mm) of the interval the tap stands for.
@group(0) @binding(6) var<storage, read> footprint: array<vec2<f32>>;

// The jitter of tap `tap` in pass `axis`: the noise (screen_common.wgsl) plus golden
// ratio steps, the same bits as the f64 twin (src/filter/jitter.rs,
// jitter_unit). The host prepends the constants GOLDEN_U32 and
// WORKGROUP_SIDE (src/filter/gpu.rs, shared_constants, from
// src/filter/jitter.rs).
fn jitter_unit(x: u32, y: u32, tap: u32, axis: u32) -> f32 {
    return jitter_fraction(ign_fixed(x, y) + (2u * tap + axis) * GOLDEN_U32);
}

@compute @workgroup_size(WORKGROUP_SIDE, WORKGROUP_SIDE, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = params.width;
    if (outside_image(gid, w, params.height)) {
        return;
    }
    let x = gid.x;
    let y = gid.y;
    let centre = y * w + x;
    var coord = x;
    var n = params.width;
    var stride = 1u;
    var base = y * w;
    if (params.axis == 1u) {
        coord = y;
        n = params.height;
        stride = w;
        base = x;
    }
    let d_centre = depth[centre];
    // Freude 2014, eq. 4.11: kernel size per pixel = width * scale * strength.
    var step = params.step_base * strength[centre];
    if (params.perspective == 1u) {
        step = step / d_centre;
    }
    let c_centre = src[centre].xyz;
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < params.ntaps; i = i + 1u) {
        let tap = taps[i];
        var off = tap.w;
        if (params.jitter == 1u) {
            let fp = footprint[i];
            off = fp.x + jitter_unit(x, y, i, params.axis) * fp.y;
        }
        let p = clamp(f32(coord) + off * step, 0.0, f32(n - 1u));
        let fl = floor(p);
        let f = p - fl;
        let i0 = u32(fl);
        let i1 = min(i0 + 1u, n - 1u);
        let a = base + i0 * stride;
        let b = base + i1 * stride;
        var o = src[a].xyz * (1.0 - f) + src[b].xyz * f;
        if (params.follow == 1u) {
            let od = depth[a] * (1.0 - f) + depth[b] * f;
            // Freude 2014, eq. 4.12
            let t = clamp(params.follow_k * abs(d_centre - od), 0.0, 1.0);
            o = o * (1.0 - t) + c_centre * t;
        }
        acc = acc + tap.xyz * o;
    }
    if (params.accumulate == 1u) {
        dst[centre] = vec4<f32>(dst[centre].xyz + acc, 1.0);
    } else {
        dst[centre] = vec4<f32>(acc, 1.0);
    }
}
