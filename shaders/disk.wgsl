// The disk pass of an importance-sampled disk kernel, every frame of the
// accumulation in one dispatch. The f64 twin is src/filter/disk.rs
// (Pass::pixel); keep them in step. Storage buffers and plain indexing (no
// samplers): rgba32float is not filterable on every adapter (lavapipe), so
// the bilinear fetch is done here, positions clamped to the image. The host
// prepends the struct DiskParams (src/filter/disk_gpu.rs, where its fields
// are described), what both screen-space passes share (screen_common.wgsl:
// the image, depth and strength at bindings 1 to 3, the noise) and the
// constants SILVER_U32 and WORKGROUP_SIDE (from src/filter/jitter.rs).

@group(0) @binding(0) var<uniform> params: DiskParams;
// Per sample: its unrotated position in kernel mm.
@group(0) @binding(4) var<storage, read> points: array<vec2<f32>>;
// Per sample: xyz the RGB weight.
@group(0) @binding(5) var<storage, read> weights: array<vec4<f32>>;
// Starts as the specular image; the blur is added to it.
@group(0) @binding(6) var<storage, read_write> dst: array<vec4<f32>>;

// The pixel's rotation in turns: interleaved gradient noise (Jimenez 2014)
// in 32-bit fixed point plus `frame` steps of sqrt 2 - 1, the same bits as
// rotation_unit in src/filter/jitter.rs.
fn rotation_unit(x: u32, y: u32, frame: u32) -> f32 {
    return jitter_fraction(ign_fixed(x, y) + frame * SILVER_U32);
}

// The bilinear fetch at (px, py), clamped: colour in xyz, depth in w.
fn fetch(px: f32, py: f32) -> vec4<f32> {
    let w = params.width;
    let h = params.height;
    let x0 = u32(px);
    let y0 = u32(py);
    let fx = px - f32(x0);
    let fy = py - f32(y0);
    let x1 = min(x0 + 1u, w - 1u);
    let y1 = min(y0 + 1u, h - 1u);
    var i = array<u32, 4>(y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1);
    var k = array<f32, 4>((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    var o = vec4<f32>(0.0);
    for (var j = 0u; j < 4u; j = j + 1u) {
        o = o + vec4<f32>(src[i[j]].xyz, depth[i[j]]) * k[j];
    }
    return o;
}

@compute @workgroup_size(WORKGROUP_SIDE, WORKGROUP_SIDE, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (outside_image(gid, params.width, params.height)) {
        return;
    }
    let x = gid.x;
    let y = gid.y;
    let centre = y * params.width + x;
    let d_centre = depth[centre];
    // Freude 2014, eq. 4.11: kernel size per pixel = width * scale * strength.
    var step = params.step_base * strength[centre];
    if (params.perspective == 1u) {
        step = step / d_centre;
    }
    let c_centre = src[centre].xyz;
    let hi = vec2<f32>(f32(params.width - 1u), f32(params.height - 1u));
    var acc = vec3<f32>(0.0);
    for (var f = 0u; f < params.frames; f = f + 1u) {
        let a = 6.283185307 * rotation_unit(x, y, params.first_frame + f);
        let s = sin(a);
        let c = cos(a);
        for (var i = 0u; i < params.nsamples; i = i + 1u) {
            let q = points[i];
            let d = step * vec2<f32>(q.x * c - q.y * s, q.x * s + q.y * c);
            let p = clamp(vec2<f32>(f32(x), f32(y)) + d, vec2<f32>(0.0), hi);
            let v = fetch(p.x, p.y);
            var o = v.xyz;
            if (params.follow == 1u) {
                // Freude 2014, eq. 4.12
                let t = clamp(params.follow_k * abs(d_centre - v.w), 0.0, 1.0);
                o = o * (1.0 - t) + c_centre * t;
            }
            acc = acc + weights[i].xyz * o;
        }
    }
    dst[centre] = vec4<f32>(dst[centre].xyz + acc / f32(params.frames), 1.0);
}
