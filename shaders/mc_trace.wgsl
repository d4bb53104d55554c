// MCML photon transport (Wang, Jacques & Zheng 1995) in f32, one packet at
// a time per invocation, the same walk as src/profile/mc/tracer.rs with its
// classic (all-or-none) boundaries.
//
// Reproducibility: packet i draws from Philox4x32-10 (Salmon et al. 2011,
// "Parallel random numbers: as easy as 1, 2, 3") with key = seed and counter
// (draw, channel, i_lo, i_hi), and every tally is an integer sum of per-packet
// values in fixed point (2^-24), so the totals do not depend on which
// invocation traced which packet nor in what order they were added.

// The host prepends the structs Params and Layer and a header of constants
// whose one definition is in Rust, with their descriptions
// (src/profile/mc/gpu/shader.rs): the tally layout (T_RD .. BINS,
// SUM_WORDS, MOMENT_WORDS), WORKGROUP, FIX (the fixed point 2^24 of the
// tallies and of the 24-bit uniforms), ROULETTE_CHANCE (Russian roulette's
// survival chance), PI2 (2 pi) and HG_ISOTROPIC (the |g| below which the
// phase function is sampled isotropically). This file declares no constant
// of its own.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> layers: array<Layer>;
@group(0) @binding(2) var<storage, read> edges: array<f32>;
// Tally words (see src/profile/mc/gpu/sums.rs for the layout).
@group(0) @binding(3) var<storage, read_write> acc: array<atomic<u32>>;

// mul_wide (wide_mul.wgsl), fresnel (fresnel.wgsl) and philox4x32_10
// (mc_philox.wgsl) are prepended by the host.

var<private> rng_buf: vec4<u32>;
var<private> rng_used: u32;
var<private> rng_draw: u32;
var<private> rng_lo: u32;
var<private> rng_hi: u32;

fn rng_start(lo: u32, hi: u32) {
    rng_lo = lo;
    rng_hi = hi;
    rng_draw = 0u;
    rng_used = 4u;
}

fn next_u32() -> u32 {
    if (rng_used == 4u) {
        rng_buf = philox4x32_10(
            vec4<u32>(rng_draw, params.channel, rng_lo, rng_hi),
            vec2<u32>(params.seed_lo, params.seed_hi),
        );
        rng_draw += 1u;
        rng_used = 0u;
    }
    // Explicit selects rather than a dynamic index into a private vector,
    // which lavapipe (Mesa 22.3) miscompiles under divergent control flow.
    let u = rng_used;
    let v = select(select(select(rng_buf.w, rng_buf.z, u == 2u), rng_buf.y, u == 1u), rng_buf.x, u == 0u);
    rng_used += 1u;
    return v;
}

// Uniform in [0, 1) on a 2^-24 lattice (exact in f32).
fn rand01() -> f32 {
    return f32(next_u32() >> 8u) * (1.0 / FIX);
}

// Uniform in (0, 1): midpoints of the 2^-24 lattice, so -ln() is finite.
fn rand_open() -> f32 {
    return (f32(next_u32() >> 8u) + 0.5) * (1.0 / FIX);
}

// ---------------------------------------------------------------- tallies

// Per-invocation sums (64-bit as vec2, 96-bit as vec3, least significant
// first), flushed once to `acc` when the invocation ends. Separate variables,
// not one private array: lavapipe (Mesa 22.3) loses updates to dynamically
// indexed private arrays when lanes diverge.
var<private> a_rd: vec2<u32>;
var<private> a_rd_sq: vec3<u32>;
var<private> a_tr: vec2<u32>;
var<private> a_tr_sq: vec3<u32>;
var<private> a_abs: vec2<u32>;
var<private> a_abs_sq: vec3<u32>;
var<private> a_beyond: vec2<u32>;
var<private> a_loss: vec2<u32>;
var<private> a_gain: vec2<u32>;
var<private> a_trunc: vec2<u32>;
var<private> a_trunc_n: vec2<u32>;
var<private> a_events: vec2<u32>;
var<private> saturated: bool;
var<private> incomplete: u32;
var<private> traced: u32;

fn carry(old: u32, added: u32) -> u32 {
    return select(0u, 1u, old + added < added);
}

fn add64(a: vec2<u32>, v: u32) -> vec2<u32> {
    return vec2<u32>(a.x + v, a.y + carry(a.x, v));
}

// Adds q^2 (64 bits) to a 96-bit sum.
fn add_sq(a: vec3<u32>, q: u32) -> vec3<u32> {
    let p = mul_wide(q, q);
    let s0 = a.x + p.x;
    let c0 = carry(a.x, p.x);
    let s1 = a.y + p.y;
    let s1c = s1 + c0;
    let c1 = carry(a.y, p.y) + carry(s1, c0);
    return vec3<u32>(s0, s1c, a.z + c1);
}

fn acc_add64(i: u32, lo: u32, hi: u32) {
    if (lo != 0u) {
        let o = atomicAdd(&acc[i], lo);
        if (carry(o, lo) != 0u) {
            atomicAdd(&acc[i + 1u], 1u);
        }
    }
    if (hi != 0u) {
        atomicAdd(&acc[i + 1u], hi);
    }
}

fn acc_add96(i: u32, w0: u32, w1: u32, w2: u32) {
    var c1 = 0u;
    if (w0 != 0u) {
        let o = atomicAdd(&acc[i], w0);
        if (carry(o, w0) != 0u) {
            let o1 = atomicAdd(&acc[i + 1u], 1u);
            c1 += carry(o1, 1u);
        }
    }
    if (w1 != 0u) {
        let o1 = atomicAdd(&acc[i + 1u], w1);
        c1 += carry(o1, w1);
    }
    if (w2 + c1 != 0u) {
        atomicAdd(&acc[i + 2u], w2 + c1);
    }
}

// Per-packet value to fixed point, rounded to nearest; flags values the
// 32-bit range cannot hold (256 and above).
fn fixed(x: f32) -> u32 {
    let v = round(x * FIX);
    if (v >= 4294967040.0) {
        saturated = true;
        return 0xffffffffu;
    }
    return u32(max(v, 0.0));
}

fn bin_of(r: f32) -> u32 {
    if (params.uniform_bins != 0u) {
        return min(u32(r * params.inv_dr), params.n_bins - 1u);
    }
    // Largest i with edges[i] <= r (edges[0] = 0 <= r < edges[n]).
    var lo = 0u;
    var hi = params.n_bins;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (edges[mid] <= r) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// ---------------------------------------------------------------- physics

// Henyey-Greenstein cos(theta) by inversion (MCML SpinTheta).
fn sample_hg_cos(g: f32, xi: f32) -> f32 {
    let t = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
    return clamp((1.0 + g * g - t * t) / (2.0 * g), -1.0, 1.0);
}

// MCML Spin (MCML manual eq. 3.24-3.26), renormalised: f32 rounding would
// otherwise let |u| drift over thousands of scatterings.
fn spin(u: vec3<f32>, cos_t: f32, phi: f32) -> vec3<f32> {
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    let cp = cos(phi);
    let sp = sin(phi);
    var v: vec3<f32>;
    if (abs(u.z) > 0.99999) {
        v = vec3<f32>(sin_t * cp, sin_t * sp, cos_t * sign(u.z));
    } else {
        let tmp = sqrt(1.0 - u.z * u.z);
        let k = sin_t / tmp;
        v = vec3<f32>(
            k * (u.x * u.z * cp - u.y * sp) + u.x * cos_t,
            k * (u.y * u.z * cp + u.x * sp) + u.y * cos_t,
            -sin_t * cp * tmp + u.z * cos_t,
        );
    }
    return v * inverseSqrt(dot(v, v));
}

fn trace_one(lo: u32, hi: u32) {
    rng_start(lo, hi);
    var p = vec3<f32>(0.0, 0.0, 0.0);
    var u = vec3<f32>(0.0, 0.0, 1.0);
    var w = params.w0;
    var layer = 0u;
    var rd = 0.0;
    var tr = 0.0;
    var absorbed = 0.0;
    var loss = 0.0;
    var gain = 0.0;
    var truncated = 0.0;
    var escape_r = -1.0;
    // Remaining optical depth of the free flight, carried across interfaces
    // (MCML's sleft).
    var tau = 0.0;
    var need_step = true;
    var events = 0u;
    while (w > 0.0) {
        if (need_step) {
            tau = -log(rand_open());
            need_step = false;
        }
        let l = layers[layer];
        let s = tau * l.inv_sigma_t;
        let z_new = p.z + s * u.z;
        var crossing = false;
        var z_b = 0.0;
        if (u.z > 0.0) {
            crossing = z_new >= l.z_bottom;
            z_b = l.z_bottom;
        } else if (u.z < 0.0) {
            crossing = z_new <= l.z_top;
            z_b = l.z_top;
        }
        if (crossing) {
            let d_b = min((z_b - p.z) / u.z, s);
            p = vec3<f32>(p.x + d_b * u.x, p.y + d_b * u.y, z_b);
            tau = max(tau - d_b * l.sigma_t, 0.0);
            if (tau == 0.0) {
                need_step = true;
            }
            var ambient = false;
            var top = false;
            var next = layer;
            var n_t = 0.0;
            if (u.z > 0.0) {
                if (layer + 1u < params.n_layers) {
                    next = layer + 1u;
                    n_t = layers[next].n;
                } else {
                    ambient = true;
                    n_t = params.n_below;
                }
            } else if (layer > 0u) {
                next = layer - 1u;
                n_t = layers[next].n;
            } else {
                ambient = true;
                top = true;
                n_t = params.n_above;
            }
            let cos_i = abs(u.z);
            let r = fresnel(cos_i, n_t / l.n);
            if (ambient) {
                // Classic boundary: reflect with probability R, else leave
                // with the whole weight.
                if (!(r > 0.0 && rand01() < r)) {
                    if (top) {
                        rd = w;
                        escape_r = sqrt(p.x * p.x + p.y * p.y);
                    } else {
                        tr = w;
                    }
                    w = 0.0;
                }
                u.z = -u.z;
            } else if (r > 0.0 && (r >= 1.0 || rand01() < r)) {
                u.z = -u.z;
            } else {
                // Snell: the tangential component scales by n_i / n_t.
                let k = l.n / n_t;
                let sin2_t = (1.0 - cos_i * cos_i) * k * k;
                let cos_t = sqrt(max(1.0 - sin2_t, 0.0));
                u = vec3<f32>(u.x * k, u.y * k, cos_t * sign(u.z));
                layer = next;
            }
        } else {
            p = vec3<f32>(p.x + s * u.x, p.y + s * u.y, z_new);
            need_step = true;
            // Implicit absorption: deposit w sigma_a / sigma_t.
            let kept = w * l.albedo;
            absorbed += w - kept;
            w = kept;
            if (abs(l.g) < HG_ISOTROPIC) {
                let c = 2.0 * rand01() - 1.0;
                let sn = sqrt(max(1.0 - c * c, 0.0));
                let phi = PI2 * rand01();
                u = vec3<f32>(sn * cos(phi), sn * sin(phi), c);
            } else {
                let c = sample_hg_cos(l.g, rand01());
                u = spin(u, c, PI2 * rand01());
            }
        }
        events += 1u;
        if (w < params.roulette && w > 0.0) {
            if (rand01() < ROULETTE_CHANCE) {
                gain += w * (1.0 / ROULETTE_CHANCE - 1.0);
                w *= 1.0 / ROULETTE_CHANCE;
            } else {
                loss += w;
                w = 0.0;
            }
        }
        if (events >= params.max_events && w > 0.0) {
            truncated = w;
            a_trunc_n = add64(a_trunc_n, 1u);
            w = 0.0;
        }
    }
    traced += 1u;
    if (w > 0.0) {
        // The loop above ends only at w = 0 unless the driver cut it
        // (llvmpipe stops any invocation's loops after 65535 iterations).
        incomplete += 1u;
    }
    // A classic boundary lets a packet leave at most once, so its score per
    // bin is its whole R_d: one value, squared as the per-packet second
    // moment requires.
    let q_rd = fixed(rd);
    if (q_rd != 0u) {
        a_rd = add64(a_rd, q_rd);
        a_rd_sq = add_sq(a_rd_sq, q_rd);
        if (escape_r < params.r_max) {
            let b = BINS + MOMENT_WORDS * bin_of(escape_r);
            let sq = mul_wide(q_rd, q_rd);
            acc_add64(b, q_rd, 0u);
            acc_add96(b + SUM_WORDS, sq.x, sq.y, 0u);
        } else {
            a_beyond = add64(a_beyond, q_rd);
        }
    }
    let q_tr = fixed(tr);
    a_tr = add64(a_tr, q_tr);
    a_tr_sq = add_sq(a_tr_sq, q_tr);
    let q_abs = fixed(absorbed);
    a_abs = add64(a_abs, q_abs);
    a_abs_sq = add_sq(a_abs_sq, q_abs);
    a_loss = add64(a_loss, fixed(loss));
    a_gain = add64(a_gain, fixed(gain));
    a_trunc = add64(a_trunc, fixed(truncated));
    a_events = add64(a_events, events);
}

@compute @workgroup_size(WORKGROUP)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    // Dynamic: an invocation whose packet ended early takes the next one
    // (load balance on GPUs). Static: on llvmpipe, where the lanes of one
    // workgroup run one after another and share a budget of 65535 loop
    // iterations, the first lanes would otherwise take every packet. Which
    // invocation traces a packet changes nothing in the result.
    var next = gid.x;
    loop {
        var i = next;
        if (params.dynamic != 0u) {
            i = atomicAdd(&acc[WORK], 1u);
        }
        if (i >= params.count) {
            break;
        }
        next = i + params.stride;
        let lo = params.base_lo + i;
        trace_one(lo, params.base_hi + select(0u, 1u, lo < i));
    }
    acc_add64(T_RD, a_rd.x, a_rd.y);
    acc_add96(T_RD + SUM_WORDS, a_rd_sq.x, a_rd_sq.y, a_rd_sq.z);
    acc_add64(T_TR, a_tr.x, a_tr.y);
    acc_add96(T_TR + SUM_WORDS, a_tr_sq.x, a_tr_sq.y, a_tr_sq.z);
    acc_add64(T_ABS, a_abs.x, a_abs.y);
    acc_add96(T_ABS + SUM_WORDS, a_abs_sq.x, a_abs_sq.y, a_abs_sq.z);
    acc_add64(T_BEYOND, a_beyond.x, a_beyond.y);
    acc_add64(T_LOSS, a_loss.x, a_loss.y);
    acc_add64(T_GAIN, a_gain.x, a_gain.y);
    acc_add64(T_TRUNC, a_trunc.x, a_trunc.y);
    acc_add64(T_TRUNC_N, a_trunc_n.x, a_trunc_n.y);
    acc_add64(T_EVENTS, a_events.x, a_events.y);
    atomicAdd(&acc[TRACED], traced);
    if (incomplete != 0u) {
        atomicAdd(&acc[INCOMPLETE], incomplete);
    }
    if (saturated) {
        atomicOr(&acc[T_SATURATED], 1u);
    }
}
