// The light-space directional method (Dal Corso et al. 2017): one
// invocation per pixel and channel estimates the scattered radiosity of
// each of the pixel's surface positions from the lights' G-buffers with
// the full directional dipole (Frisvad et al. 2014) and shows it as
// L_o = F_t(w_o) B / pi (eq. 5). The f64 twin is src/filter/light_space.rs
// (LightSpaceInput::sample, ::exit, ::pixel); keep them in step: the
// module docs there state the estimator. The host prepends the constants
// (PHILOX_*, UNIFORM_BITS, WORKGROUP), the structs LsParams, LsMap and
// LsMedium (src/filter/light_space_gpu.rs, where their fields are
// described), mul_wide (wide_mul.wgsl), fresnel (fresnel.wgsl) and
// philox4x32_10 (mc_philox.wgsl). Positions are relative to the scene's centre (the
// host subtracts it in f64), which keeps their f32 rounding small.

@group(0) @binding(0) var<uniform> params: LsParams;
@group(0) @binding(1) var<storage, read> maps: array<LsMap>;
// Per texel three vec4: position and object (as f32, -1 none), normal,
// transmitted irradiance (rgb).
@group(0) @binding(2) var<storage, read> texels: array<vec4<f32>>;
// Per surface position three vec4: position and object, normal, the unit
// direction towards the camera.
@group(0) @binding(3) var<storage, read> surface: array<vec4<f32>>;
// Per object and channel (object * 3 + channel).
@group(0) @binding(4) var<storage, read> media: array<LsMedium>;
// Channel-major: channel * pixels + pixel.
@group(0) @binding(5) var<storage, read_write> dst: array<f32>;

const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;

// xi in (0, 1): the top UNIFORM_BITS bits plus one half (unit() in the twin).
fn unit(x: u32) -> f32 {
    return (f32(x >> (32u - UNIFORM_BITS)) + 0.5) / f32(1u << UNIFORM_BITS);
}

// The orthonormal pair completing w (Duff et al. 2017; frame() in
// src/scene/frame.rs).
fn frame_a(w: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, w.z >= 0.0);
    let a = -1.0 / (s + w.z);
    let b = w.x * w.y * a;
    return vec3<f32>(1.0 + s * w.x * w.x * a, s * b, -s * w.x);
}

fn frame_b(w: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, w.z >= 0.0);
    let a = -1.0 / (s + w.z);
    let b = w.x * w.y * a;
    return vec3<f32>(b, s + w.y * w.y * a, -w.y);
}

// S'_d of Dal Corso 2014, eq. 3.13 without 1 / (4 C_phi(1/eta)).
fn s_prime(m: LsMedium, x_w: f32, w_n: f32, x_n: f32, dist: f32) -> f32 {
    let one = 1.0 + m.sigma_tr * dist;
    let r2 = dist * dist;
    let t0 = exp(-m.sigma_tr * dist) / (4.0 * PI * PI * r2 * dist);
    let t1 = r2 / m.d + 3.0 * one * x_w;
    let t2 = 3.0 * m.d * one * w_n;
    let trd = m.sigma_tr * dist;
    let t3 = (one + 3.0 * m.d * (3.0 * one + trd * trd) / r2 * x_w) * x_n;
    return t0 * (m.c_phi * t1 - m.c_e * (t2 - t3));
}

// S_d(x_i, w_i; x_o) (Frisvad et al. 2014), clamped at 0.
fn s_d(m: LsMedium, x_i: vec3<f32>, n_i: vec3<f32>, w_i: vec3<f32>, x_o: vec3<f32>,
       n_o: vec3<f32>) -> f32 {
    let x = x_o - x_i;
    let r2 = dot(x, x);
    let c = dot(w_i, n_i);
    let w12 = (c * n_i - w_i) / m.eta
        - n_i * sqrt(max(1.0 - (1.0 - c * c) / (m.eta * m.eta), 0.0));
    let x_w = dot(x, w12);
    let mu0 = -dot(n_o, w12);
    var z_r2: f32;
    if (mu0 > 0.0) {
        let s = sqrt(max(r2 - x_w * x_w, 0.0));
        let q = sqrt(r2) / m.d_e;
        let de_cos_beta = s / sqrt(q * q + 1.0);
        let dm = m.d * mu0;
        z_r2 = dm * (dm + 2.0 * de_cos_beta);
    } else {
        z_r2 = 1.0 / ((3.0 * m.sigma_t) * (3.0 * m.sigma_t));
    }
    let real = s_prime(m, x_w, dot(w12, n_o), dot(x, n_o), sqrt(r2 + z_r2));
    let z_v = 2.0 * m.a * m.d_e;
    var n_star = n_i;
    let v = cross(n_i, x);
    let r = sqrt(r2);
    let nv = length(v);
    if (r > 0.0 && nv > 0.0) {
        n_star = cross(x / r, v / nv);
    }
    let xv = x - z_v * n_star;
    let w_v = w12 - 2.0 * dot(w12, n_star) * n_star;
    let virt = s_prime(m, dot(xv, w_v), dot(w_v, n_o), dot(xv, n_o), length(xv));
    return max((real - virt) / (4.0 * m.c_phi_exit), 0.0);
}

fn vec_of(a: f32, b: f32, c: f32) -> vec3<f32> {
    return vec3<f32>(a, b, c);
}

// One sample of light k at surface position q in channel c (sample() in
// the twin): S_d E_t (dA_i / dA_j) / p.
fn sample(q: u32, c: u32, k: u32, xi1: f32, xi2: f32) -> f32 {
    let sp = surface[3u * q];
    let obj = i32(sp.w);
    let x_o = sp.xyz;
    let n_o = surface[3u * q + 1u].xyz;
    let m = media[u32(obj) * 3u + c];
    let map = maps[k];
    let r = -log(xi1) / m.sigma;
    let alpha = TAU * xi2;
    let light = vec_of(map.lx, map.ly, map.lz);
    var a = vec_of(map.ux, map.uy, map.uz);
    var b = vec_of(map.vx, map.vy, map.vz);
    if (map.kind == 1u) {
        let w = normalize(light - x_o);
        a = frame_a(w);
        b = frame_b(w);
    }
    let x_j = x_o + r * (cos(alpha) * a + sin(alpha) * b);
    // The texel holding x_j (LightMap::coordinates and ::texel).
    let qc = x_j - vec_of(map.cx, map.cy, map.cz);
    let fwd = vec_of(map.fx, map.fy, map.fz);
    var scale = 2.0 * map.half;
    var rel = qc;
    if (map.kind == 1u) {
        rel = x_j - light;
        let z = dot(rel, fwd);
        if (!(z > 0.0)) {
            return 0.0;
        }
        scale = 2.0 * z * map.half;
    }
    let side = f32(map.side);
    let tx = (0.5 + dot(rel, a_axis(map)) / scale) * side;
    let ty = (0.5 - dot(rel, b_axis(map)) / scale) * side;
    if (!(tx >= 0.0 && tx < side && ty >= 0.0 && ty < side)) {
        return 0.0;
    }
    let t = map.offset + u32(ty) * map.side + u32(tx);
    let tp = texels[3u * t];
    if (i32(tp.w) != obj) {
        return 0.0;
    }
    let e = texels[3u * t + 2u][c];
    if (!(e > 0.0)) {
        return 0.0;
    }
    let x_i = tp.xyz;
    let n_i = texels[3u * t + 1u].xyz;
    var w_i = -fwd;
    var area: f32;
    if (map.kind == 1u) {
        let to_i = light - x_i;
        let to_j = x_j - light;
        let d_i2 = dot(to_i, to_i);
        let d_j2 = dot(to_j, to_j);
        w_i = to_i / sqrt(d_i2);
        let cos_j = abs(dot(to_j, normalize(light - x_o)) / sqrt(d_j2));
        area = cos_j * d_i2 / (dot(n_i, w_i) * d_j2);
    } else {
        area = 1.0 / dot(n_i, w_i);
    }
    // 1 / p = 2 pi r / (sigma e^{-sigma r}), e^{-sigma r} = xi_1.
    return s_d(m, x_i, n_i, w_i, x_o, n_o) * e * area * TAU * r / (m.sigma * xi1);
}

// The map's image-plane axes (the sampling plane of a directional light).
fn a_axis(map: LsMap) -> vec3<f32> {
    return vec_of(map.ux, map.uy, map.uz);
}

fn b_axis(map: LsMap) -> vec3<f32> {
    return vec_of(map.vx, map.vy, map.vz);
}

// F_t(w_o) for radiance, 4 C_phi(1/eta) for the exitance sensor (exit()).
fn exit_factor(q: u32, c: u32) -> f32 {
    let obj = u32(i32(surface[3u * q].w));
    let m = media[obj * 3u + c];
    if (params.exitance == 1u) {
        return 4.0 * m.c_phi_exit;
    }
    let cos_o = dot(surface[3u * q + 1u].xyz, surface[3u * q + 2u].xyz);
    return 1.0 - fresnel(cos_o, m.eta);
}

@compute @workgroup_size(WORKGROUP, 1, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pixels = params.width * params.height;
    let p = gid.x;
    let c = gid.y;
    if (p >= pixels || c >= 3u) {
        return;
    }
    let per = params.per;
    let used = min(per, params.samples);
    let key = vec2<u32>(params.seed_lo, params.seed_hi);
    var sum = 0.0;
    for (var s = 0u; s < used; s = s + 1u) {
        let q = p * per + s;
        if (surface[3u * q].w < 0.0) {
            continue;
        }
        var acc = 0.0;
        var n = 0u;
        for (var j = s; j < params.samples; j = j + per) {
            for (var k = 0u; k < params.maps; k = k + 1u) {
                let r = philox4x32_10(vec4<u32>(p, c + 4u * k, j, 0u), key);
                acc = acc + sample(q, c, k, unit(r.x), unit(r.y));
            }
            n = n + 1u;
        }
        sum = sum + exit_factor(q, c) * acc / f32(n);
    }
    dst[c * pixels + p] = sum / f32(used);
}
