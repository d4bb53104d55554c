//! Oracle for `engine::sampling`: the sample positions and weights of
//! Unreal's and HDRP's Burley passes for given pixels, frames and seeds,
//! computed here from the shader formulas written out again, with their
//! constants as the sources state them (Unreal 5: SubsurfaceBurleyNormalized.ush
//! `GenerateSampleInfo`, `RadiusRootFindByApproximation`, `GetPdf`,
//! `UpdateSeed`; BurleyNormalizedSSSCommon.ush; Random.ush `Rand3DPCG16`;
//! MonteCarlo.ush `R2Sequence`. HDRP 17: SubsurfaceScattering.compute
//! `EvaluateSss`, `EvaluateSample`; DiffusionProfile.hlsl
//! `SampleBurleyDiffusionProfile`, `EvalBurleyDiffusionProfile`;
//! Fibonacci.hlsl `SampleDiskGolden`; Random.hlsl `JenkinsHash`,
//! `ConstructFloat`), not from ssskit's code.

use ssskit::engine::sampling::{burley_cdf, EngineSample, HdrpProfile, UnrealProfile};
use std::f64::consts::PI;

/// Agreement of two f64 evaluations of the same formula in a different
/// order: a few hundred ulps of the largest term.
const SAME_FORMULA: f64 = 1e-12;
/// `LOG2_E` of the HLSL sources.
const LOG2_E: f64 = std::f64::consts::LOG2_E;

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= SAME_FORMULA * a.abs().max(b.abs()).max(1.0),
        "{what}: {a} vs {b}"
    );
}

fn same(got: &[EngineSample], want: &[([f64; 2], [f64; 3])]) {
    assert_eq!(got.len(), want.len());
    for (i, (g, (xy, w))) in got.iter().zip(want).enumerate() {
        close(g.x_mm, xy[0], &format!("sample {i} x"));
        close(g.y_mm, xy[1], &format!("sample {i} y"));
        for (c, (gw, ww)) in g.weight.iter().zip(w).enumerate() {
            close(*gw, *ww, &format!("sample {i} weight {c}"));
        }
    }
}

/// Rand3DPCG16 as Random.ush writes it.
fn pcg16(p: [i32; 3]) -> [u32; 3] {
    let mut v = [p[0] as u32, p[1] as u32, p[2] as u32];
    for x in v.iter_mut() {
        *x = x.wrapping_mul(1664525u32).wrapping_add(1013904223u32);
    }
    let round = |v: &mut [u32; 3]| {
        v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[2]));
        v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
        v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    };
    round(&mut v);
    round(&mut v);
    round(&mut v);
    [v[0] >> 16u32, v[1] >> 16u32, v[2] >> 16u32]
}

/// R2Sequence: frac(float2(1 / Phi, 1 / Pow2(Phi)) * Index), in float.
fn r2(index: u32) -> (f64, f64) {
    // As the source types it (its nearest float).
    #[allow(clippy::excessive_precision)]
    let phi: f32 = 1.324717957244746;
    let a: (f32, f32) = (1.0 / phi, 1.0 / (phi * phi));
    let (x, y) = (a.0 * index as f32, a.1 * index as f32);
    ((x - x.floor()) as f64, (y - y.floor()) as f64)
}

#[test]
fn unreal_samples_follow_the_shader() {
    let albedo = [0.43, 0.2, 0.1];
    let dmfp = [2.5, 1.2, 0.6];
    let p = UnrealProfile {
        surface_albedo: albedo,
        dmfp_mm: dmfp,
    };
    let (x, y, frame, n, pixel_mm) = (17u32, 5u32, 3u32, 8usize, 0.1);
    // GetSearchLightDiffuseScalingFactor3D: 3.5 + 100 (A - 0.33)^4.
    let s3d = albedo.map(|a: f64| 3.5 + 100.0 * (a - 0.33).powi(4));
    // The texture's alpha: the largest DMFP (red here) and its albedo.
    let d_sampling = dmfp[0] / s3d[0];
    // GetCDF(D, X, 0) = 1 - 0.25 exp(-X / D) - 0.75 exp(-X / (3 D)).
    let cdf = |d: f64, x: f64| 1.0 - 0.25 * (-x / d).exp() - 0.75 * (-x / (3.0 * d)).exp();
    let centre_cdf = cdf(d_sampling, pixel_mm);
    let mut seed = pcg16([x as i32, y as i32, frame as i32])[0];
    let want: Vec<([f64; 2], [f64; 3])> = (0..n)
        .map(|_| {
            let (u0, v) = r2(seed);
            seed += 1;
            let u = centre_cdf + u0 * (1.0 - centre_cdf);
            let root = d_sampling * ((2.0 - 2.6) * u - 2.0) * (1.0 - u).ln();
            let r = root.max(0.00001);
            let theta = v * 2.0 * PI;
            // GetPdf = max(GetCDFDeriv1(L / S, r), CLAMP_PDF).
            let deriv =
                0.25 / d_sampling * ((-r / d_sampling).exp() + (-r / (3.0 * d_sampling)).exp());
            let pdf = deriv.max(0.00001);
            let w = std::array::from_fn(|c| {
                // GetDiffuseReflectProfileWithDiffuseMeanFreePath.
                let big_d = 1.0 / s3d[c];
                let rr = r / dmfp[c];
                let neg = -rr / big_d;
                let inv8pi = 1.0 / (8.0 * PI);
                ((neg.exp() + (neg / 3.0).exp()) / (big_d * dmfp[c]) * inv8pi).max(0.0) / pdf
            });
            ([r * theta.cos(), r * theta.sin()], w)
        })
        .collect();
    same(&p.samples(x, y, frame, n, pixel_mm), &want);
    // CalculateCenterSampleWeight: D = DMFP.a / GetDiffuseSurfaceScalingFactor3D(A).
    let cw = p.centre_weight(pixel_mm);
    for c in 0..3 {
        let s = 1.9 - albedo[c] + 3.5 * (albedo[c] - 0.8) * (albedo[c] - 0.8);
        close(cw[c], cdf(dmfp[0] / s, pixel_mm), "centre weight");
    }
}

/// JenkinsHash(uint) as Random.hlsl writes it.
fn jenkins(mut x: u32) -> u32 {
    x = x.wrapping_add(x << 10u32);
    x ^= x >> 6u32;
    x = x.wrapping_add(x << 3u32);
    x ^= x >> 11u32;
    x = x.wrapping_add(x << 15u32);
    x
}

/// SampleBurleyDiffusionProfile in the shader's log2 / exp2 form.
fn sample_burley(u: f64, rcp_s: f64) -> (f64, f64) {
    let u = 1.0 - u;
    let g = 1.0 + (4.0 * u) * (2.0 * u + (1.0 + (4.0 * u) * u).sqrt());
    let n = (g.log2() * (-1.0 / 3.0)).exp2();
    let p = (g * n) * n;
    let c = 1.0 + p + n;
    let d = (3.0 / LOG2_E * 2.0) + (3.0 / LOG2_E) * u.log2();
    let x = (3.0 / LOG2_E) * c.log2() - d;
    let rcp_exp = ((c * c) * c) * (1.0 / ((4.0 * u) * ((c * c) + (4.0 * u) * (4.0 * u))));
    (x * rcp_s, (8.0 * PI * rcp_s) * rcp_exp)
}

#[test]
fn hdrp_samples_follow_the_shader() {
    let d = [1.1, 0.7, 0.45];
    let p = HdrpProfile { d_mm: d };
    let (x, y, depth_bits, pixel_mm, budget) = (17u32, 5u32, 12345u32, 0.1, 40usize);
    // GenerateHashedRandomFloat(uint3): ConstructFloat(JenkinsHash(x ^ JenkinsHash(y ^ JenkinsHash(z)))).
    let h = jenkins(x ^ jenkins(y ^ jenkins(depth_bits)));
    let f = f32::from_bits((h & 0x007FFFFF) | 0x3F800000) - 1.0;
    let phase = 2.0 * PI * f as f64;
    close(HdrpProfile::phase(x, y, depth_bits), phase, "phase");
    // filterRadius at CDF 0.997 of the largest d; SSS_PIXELS_PER_SAMPLE 4.
    let d_max = 1.1;
    let radius = sample_burley(0.997, d_max).0;
    let count = (PI * (radius / pixel_mm).powi(2) * (1.0 / 4.0)) as usize;
    let n = count.min(budget);
    assert_eq!(p.sample_count(pixel_mm, budget), n);
    let want: Vec<([f64; 2], [f64; 3])> = (0..n as u32)
        .map(|i| {
            let scale = 1.0 / n as f64;
            let (r, rcp_pdf) = sample_burley(i as f64 * scale + scale * 0.5, d_max);
            #[allow(clippy::excessive_precision)]
            let gold: f32 = 1.618033988749895;
            let t = i as f32 * (1.0 / gold);
            let phi = 2.0 * PI * (t - t.floor()) as f64;
            let (sin_phase, cos_phase) = phase.sin_cos();
            let (sin_phi, cos_phi) = phi.sin_cos();
            let sin_psi = cos_phase * sin_phi + sin_phase * cos_phi;
            let cos_psi = cos_phase * cos_phi - sin_phase * sin_phi;
            let w = d.map(|dc| {
                let s = 1.0 / dc;
                let exp_13 = ((LOG2_E * (-1.0 / 3.0)) * r * s).exp2();
                (s / (8.0 * PI)) * (exp_13 * (1.0 + exp_13 * exp_13)) * rcp_pdf
            });
            ([r * cos_psi, r * sin_psi], w)
        })
        .collect();
    same(&p.samples(phase, n), &want);
}

/// HDRP's inverse is exact: the closed-form CDF of DiffusionProfileSettings.cs
/// (`DisneyProfileCdf`) at the sampled radius gives back u; Unreal's
/// approximate root does not (it is what makes its sampling biased).
#[test]
fn the_inverse_cdfs_against_the_closed_form() {
    /// f64 round-off through a cube root and two logarithms.
    const EXACT: f64 = 1e-12;
    let d = 0.8;
    for k in 1..100 {
        let u = k as f64 / 100.0;
        let r = ssskit::engine::sampling::hdrp_sample_burley(u, d).0;
        assert!((burley_cdf(d, r) - u).abs() < EXACT, "u {u}");
    }
    /// Unreal's approximate root misses the CDF by more than this
    /// somewhere in u (0.0086 at D = 0.8): its samples do not follow the
    /// pdf their weights divide by.
    const APPROX_OFF: f64 = 0.005;
    let worst = (1..100)
        .map(|k| {
            let u = k as f64 / 100.0;
            (burley_cdf(d, ssskit::engine::sampling::unreal_radius(d, u)) - u).abs()
        })
        .fold(0.0, f64::max);
    assert!(
        worst > APPROX_OFF,
        "Unreal's root is closer than stated: {worst}"
    );
}
