// One 1D pass of term 0 of an ssskit kernel in an engine (WGSL compute).
// Paste the output of `ssskit fit ... --emit wgsl` above this code; run it
// horizontally (dir = (1, 0)) from the irradiance into a signed float
// target, then vertically (dir = (0, 1)) from that target, for each term
// sss_kernel_p, and add the terms' vertical results (see docs/engines.md).
// Multiply by total_rd (or the albedo texture) afterwards.

struct View {
    // Vertical field of view, radians.
    fov_y: f32,
    // Scene units per kernel millimetre (0.001 for metres).
    sss_width: f32,
    // Viewport height in pixels.
    height_px: f32,
    // Depth-aware lerp constant C (300 in Jimenez's shader); 0 turns it off.
    follow_c: f32,
    // (1, 0) horizontal, (0, 1) vertical.
    dir: vec2<f32>,
    size: vec2<u32>,
}

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var src_tex: texture_2d<f32>;
// Linear view depth in scene units, not the hardware z-buffer.
@group(0) @binding(2) var depth_tex: texture_2d<f32>;
// Signed float: the taps of terms after the first are negative.
@group(0) @binding(3) var dst_tex: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8, 1)
fn sss_pass(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= view.size.x || id.y >= view.size.y) {
        return;
    }
    let p = vec2<i32>(id.xy);
    let last = vec2<i32>(view.size) - vec2<i32>(1, 1);
    let depth = textureLoad(depth_tex, p, 0).r;
    let tan_half = tan(0.5 * view.fov_y);
    // Freude 2014, eq. 4.11: pixels per kernel millimetre at this depth.
    let px_per_mm = view.sss_width * view.height_px / (2.0 * tan_half * depth);
    let centre = textureLoad(src_tex, p, 0).rgb;
    var kernel = sss_kernel_0;
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < sss_taps; i = i + 1u) {
        let tap = kernel[i];
        let q = clamp(p + vec2<i32>(round(view.dir * tap.w * px_per_mm)), vec2<i32>(0, 0), last);
        var c = textureLoad(src_tex, q, 0).rgb;
        // Freude 2014, eq. 4.12: toward the centre colour across depth edges.
        let d = textureLoad(depth_tex, q, 0).r;
        let t = clamp(view.follow_c * view.sss_width * abs(depth - d) / tan_half, 0.0, 1.0);
        c = mix(c, centre, t);
        acc = acc + tap.xyz * c;
    }
    textureStore(dst_tex, p, vec4<f32>(acc, 1.0));
}
