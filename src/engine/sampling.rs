//! The per-pixel sample patterns of the two engines that render Burley
//! diffusion by importance-sampled disk samples, re-implemented from their
//! shader sources (formulas and constants as the sources write them; the
//! sources are cited per function, the repositories in docs/engines.md):
//!
//! - Unreal Engine 5 (Epic's UnrealEngine repository, read in a mirror of
//!   the 5.2.0 source, Build.version 5.2.0):
//!   Engine/Shaders/Private/SubsurfaceBurleyNormalized.ush,
//!   `BurleyNormalizedSS` with `GenerateSampleInfo`,
//!   `RadiusRootFindByApproximation`, `GetPdf`, `UpdateSeed`,
//!   `CalculateCenterSampleCdf`, `CalculateCenterSampleWeight`;
//!   BurleyNormalizedSSSCommon.ush, `GetDiffuseReflectProfileWithDiffuseMeanFreePath`
//!   and the three scaling factors; Random.ush, `Rand3DPCG16`;
//!   MonteCarlo.ush, `R2Sequence`. The default options of the file: the
//!   approximate root (`ROOT_APROXIMATE`), radius and angle from the R2
//!   sequence (`SAMPLE_ROOT_ANGLE_R2SEQUENCE`), the centre sample
//!   reweighted (`REWEIGHT_CENTER_SAMPLE`), bilateral normalisation.
//! - Unity HDRP 17 (Unity-Technologies/Graphics, Packages/com.unity.
//!   render-pipelines.high-definition): Runtime/Material/SubsurfaceScattering/
//!   SubsurfaceScattering.compute, `EvaluateSss` and `EvaluateSample`;
//!   `SampleBurleyDiffusionProfile` and `EvalBurleyDiffusionProfile`
//!   (DiffusionProfile.hlsl); DiffusionProfileSettings.cs, `UpdateKernel`
//!   (filter radius at the CDF's 0.997) and `DefaultSssSampleBudgetForQualityLevel`;
//!   render-pipelines.core ShaderLibrary/Sampling/Fibonacci.hlsl,
//!   `SampleDiskGolden`; ShaderLibrary/Random.hlsl, `JenkinsHash`,
//!   `ConstructFloat`, `GenerateHashedRandomFloat`.
//!
//! Lengths here are mm on the surface; a sample is an offset in mm and a
//! weight per channel, the pass (`super::sampled`) turns the offset into
//! the texel the engine fetches.

use std::f64::consts::PI;

/// `BURLEY_NUM_SAMPLES`: the most samples Unreal's pass takes per pixel.
pub const UNREAL_MAX_SAMPLES: usize = 64;
/// `BETA_LIMIT`: the fewest samples its adaptive count
/// (`GetNumOfSamplesBasedOnQuality`) takes.
pub const UNREAL_MIN_SAMPLES: usize = 8;
/// `CLAMP_PDF`: the least pdf `GetPdf` returns.
const UNREAL_CLAMP_PDF: f64 = 0.00001;
/// The least radius `GenerateSampleInfo` keeps, mm.
const UNREAL_MIN_RADIUS_MM: f64 = 0.00001;
/// `EnergyNormalization = 1 / 0.99995` of `BurleyNormalizedSS`.
const UNREAL_ENERGY_NORMALIZATION: f64 = 1.0 / 0.99995;
/// The plastic number `R2Sequence` steps by, as the source types it (its
/// nearest float, which the sequence's fractions depend on).
#[allow(clippy::excessive_precision)]
const R2_PHI: f32 = 1.324_717_957_244_746;

/// `DefaultSssSampleBudgetForQualityLevel`: Low, Medium, High.
pub const HDRP_BUDGETS: [usize; 3] = [20, 40, 80];
/// `SSS_PIXELS_PER_SAMPLE`: HDRP takes one sample per 4 pixels of the
/// filter's disk, up to the budget.
const HDRP_PIXELS_PER_SAMPLE: f64 = 4.0;
/// The CDF value whose radius is HDRP's filter radius (`UpdateKernel`).
const HDRP_FILTER_CDF: f64 = 0.997;
/// `GOLDEN_RATIO` of Fibonacci.hlsl, as the source types it.
#[allow(clippy::excessive_precision)]
const GOLDEN_RATIO: f32 = 1.618_033_988_749_895;
/// `DiffusionProfile.UpdateKernel`'s bound on S = 1 / d.
const HDRP_MAX_SHAPE: f64 = 16_777_216.0;

/// One sample of a pixel: offset in mm on the surface (x right, y down)
/// and weight per channel before the pass divides by the weights' sum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineSample {
    pub x_mm: f64,
    pub y_mm: f64,
    pub weight: [f64; 3],
}

/// The Burley profile CDF over the disk, 1 - e^{-x/D}/4 - 3 e^{-x/(3D)}/4
/// (Unreal's `GetCDF` with XI = 0).
pub fn burley_cdf(d: f64, x: f64) -> f64 {
    1.0 - 0.25 * (-x / d).exp() - 0.75 * (-x / (3.0 * d)).exp()
}

// ---------------------------------------------------------------- Unreal

/// `Rand3DPCG16`: an LCG step then three rounds of a MAD Feistel network on
/// the three words; 16 bits of each.
pub fn rand3d_pcg16(p: [i32; 3]) -> [u32; 3] {
    let mut v = p.map(|x| {
        (x as u32)
            .wrapping_mul(1_664_525)
            .wrapping_add(1_013_904_223)
    });
    for _ in 0..3 {
        v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[2]));
        v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
        v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    }
    v.map(|x| x >> 16)
}

/// `R2Sequence`: frac(index x (1 / phi, 1 / phi^2)), phi the plastic
/// number (Roberts 2018), in the shader's 32-bit floats: at the indices
/// the pass reaches (a 16-bit start plus up to 64) the product keeps
/// about 8 bits of fraction, which is what the engine renders with.
pub fn r2_sequence(index: u32) -> [f64; 2] {
    let a = [1.0f32 / R2_PHI, 1.0f32 / (R2_PHI * R2_PHI)];
    let i = index as f32;
    a.map(|a| {
        let x = a * i;
        (x - x.floor()) as f64
    })
}

/// `RadiusRootFindByApproximation`: D ((2 - 2.6) u - 2) ln(1 - u), the
/// approximate inverse of [`burley_cdf`] the pass uses by default.
pub fn unreal_radius(d: f64, u: f64) -> f64 {
    d * ((2.0 - 2.6) * u - 2.0) * (1.0 - u).ln()
}

/// `GetPdf`: the radial density of the Burley profile,
/// (e^{-r/D} + e^{-r/(3D)}) / (4 D), at least `CLAMP_PDF`.
pub fn unreal_pdf(r: f64, d: f64) -> f64 {
    (0.25 / d * ((-r / d).exp() + (-r / (3.0 * d)).exp())).max(UNREAL_CLAMP_PDF)
}

/// The profile values `BurleyNormalizedSS` reads, in profile mm: surface
/// albedo A and diffuse mean free path L per channel, after
/// `SetupSurfaceAlbedoAndDiffuseMeanFreePath`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnrealProfile {
    pub surface_albedo: [f64; 3],
    pub dmfp_mm: [f64; 3],
}

impl UnrealProfile {
    /// The channel of the largest L: its L and A are the texture's alpha
    /// (`GetDiffuseMeanFreePathForSampling`, `GetComponentForScalingFactorEstimation`).
    fn sampling_channel(&self) -> usize {
        (0..3).fold(0, |b, c| {
            if self.dmfp_mm[c] > self.dmfp_mm[b] {
                c
            } else {
                b
            }
        })
    }

    /// D = L / S(A) of the sampling channel, S the searchlight-diffuse
    /// factor 3.5 + 100 (A - 0.33)^4 (`GetScalingFactor`).
    pub fn sampling_d(&self) -> f64 {
        let j = self.sampling_channel();
        self.dmfp_mm[j] / crate::profile::analytic::burley::dmfp_scale(self.surface_albedo[j])
    }

    /// `GetDiffuseReflectProfileWithDiffuseMeanFreePath`: r R(r) of channel
    /// c, (e^{-r S/L} + e^{-r S/(3L)}) / (8 pi L / S).
    pub fn profile(&self, c: usize, r: f64) -> f64 {
        let s = crate::profile::analytic::burley::dmfp_scale(self.surface_albedo[c]);
        let d = self.dmfp_mm[c] / s;
        (((-r / d).exp() + (-r / (3.0 * d)).exp()) / (8.0 * PI * d)).max(0.0)
    }

    /// `CalculateCenterSampleCdf`: the sampling CDF at the centre pixel's
    /// radius (one pixel, `CalculateCenterSampleRadiusInMM`).
    pub fn centre_cdf(&self, pixel_mm: f64) -> f64 {
        burley_cdf(self.sampling_d(), pixel_mm)
    }

    /// `CalculateCenterSampleWeight`: per channel the CDF at the centre
    /// radius of D = L_max / S_surface(A_c), S_surface = 1.9 - A + 3.5
    /// (A - 0.8)^2 (`GetDiffuseSurfaceScalingFactor3D`), as the source writes
    /// it (a different factor from the samples').
    pub fn centre_weight(&self, pixel_mm: f64) -> [f64; 3] {
        let l = self.dmfp_mm[self.sampling_channel()];
        std::array::from_fn(|c| {
            let s = crate::profile::analytic::burley::diffuse_surface_scale(self.surface_albedo[c]);
            burley_cdf(l / s, pixel_mm)
        })
    }

    /// The `n` samples of pixel (x, y) in frame `frame` (`View.FrameNumber`)
    /// at `pixel_mm` mm per pixel: start index `Rand3DPCG16(x, y, frame).x`
    /// (`UpdateSeed`), then consecutive R2 points; u remapped to
    /// [centre CDF, 1), radius by the approximate root, angle 2 pi v,
    /// weight r R_c(r) / pdf(r).
    pub fn samples(
        &self,
        x: u32,
        y: u32,
        frame: u32,
        n: usize,
        pixel_mm: f64,
    ) -> Vec<EngineSample> {
        let d = self.sampling_d();
        let cdf0 = self.centre_cdf(pixel_mm);
        let start = rand3d_pcg16([x as i32, y as i32, frame as i32])[0];
        (0..n as u32)
            .map(|i| {
                let [u, v] = r2_sequence(start.wrapping_add(i));
                let u = cdf0 + u * (1.0 - cdf0);
                let r = unreal_radius(d, u).max(UNREAL_MIN_RADIUS_MM);
                let theta = v * 2.0 * PI;
                let pdf = unreal_pdf(r, d);
                EngineSample {
                    x_mm: r * theta.cos(),
                    y_mm: r * theta.sin(),
                    weight: std::array::from_fn(|c| self.profile(c, r) / pdf),
                }
            })
            .collect()
    }

    /// The pixel's result from its samples' colours and its own colour:
    /// sum w I / sum w x EnergyNormalization, then lerped toward the centre
    /// colour by the centre weight.
    pub fn resolve(
        &self,
        acc: [f64; 3],
        wsum: [f64; 3],
        centre: [f64; 3],
        cw: [f64; 3],
    ) -> [f64; 3] {
        std::array::from_fn(|c| {
            let blurred = if wsum[c] == 0.0 {
                0.0
            } else {
                acc[c] / wsum[c] * UNREAL_ENERGY_NORMALIZATION
            };
            blurred + (centre[c] - blurred) * cw[c]
        })
    }
}

// ------------------------------------------------------------------ HDRP

/// `JenkinsHash(uint)`: one round of Jenkins's one-at-a-time hash.
pub fn jenkins_hash(mut x: u32) -> u32 {
    x = x.wrapping_add(x << 10);
    x ^= x >> 6;
    x = x.wrapping_add(x << 3);
    x ^= x >> 11;
    x = x.wrapping_add(x << 15);
    x
}

/// `GenerateHashedRandomFloat(uint3)`: JenkinsHash(x ^ JenkinsHash(y ^
/// JenkinsHash(z))), its low 23 bits as the mantissa of a float in [1, 2),
/// less 1 (`ConstructFloat`).
pub fn hashed_random_float(v: [u32; 3]) -> f64 {
    let h = jenkins_hash(v[0] ^ jenkins_hash(v[1] ^ jenkins_hash(v[2])));
    (h & 0x007F_FFFF) as f64 / (1u32 << 23) as f64
}

/// `SampleBurleyDiffusionProfile`: the exact inverse of [`burley_cdf`]
/// with D = `rcp_s` (Golubev 2018): radius and 1 / pdf, pdf the radial
/// density r R(r) of the normalised profile over 2 pi.
pub fn hdrp_sample_burley(u: f64, rcp_s: f64) -> (f64, f64) {
    let u = 1.0 - u;
    let g = 1.0 + 4.0 * u * (2.0 * u + (1.0 + 4.0 * u * u).sqrt());
    let n = g.powf(-1.0 / 3.0);
    let p = g * n * n;
    let c = 1.0 + p + n;
    let x = 3.0 * (c / (4.0 * u)).ln();
    let rcp_exp = c * c * c / (4.0 * u * (c * c + 4.0 * u * (4.0 * u)));
    (x * rcp_s, 8.0 * PI * rcp_s * rcp_exp)
}

/// `EvalBurleyDiffusionProfile`: S / (8 pi) (e^{-S r / 3} + e^{-S r}).
pub fn hdrp_eval_burley(r: f64, s: f64) -> f64 {
    s / (8.0 * PI) * ((-s * r / 3.0).exp() + (-s * r).exp())
}

/// `SampleDiskGolden(i, n).y`: 2 pi frac(i / GOLDEN_RATIO), in 32-bit floats.
pub fn hdrp_golden_angle(i: u32) -> f64 {
    let f = i as f32 * (1.0f32 / GOLDEN_RATIO);
    2.0 * PI * (f - f.floor()) as f64
}

/// A diffusion profile as `EvaluateSss` reads it: the shape distance d per
/// channel in mm (Multiplier x linear Scattering Color, scaled by World
/// Scale and the Subsurface Mask).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HdrpProfile {
    pub d_mm: [f64; 3],
}

impl HdrpProfile {
    /// S = 1 / d per channel (at most 2^24).
    fn shape(&self) -> [f64; 3] {
        self.d_mm.map(|d| (1.0 / d).min(HDRP_MAX_SHAPE))
    }

    /// The widest channel's d (`maxScatteringDistance`).
    pub fn max_d(&self) -> f64 {
        self.d_mm.iter().copied().fold(0.0, f64::max)
    }

    /// `filterRadius`: the radius of the CDF's 0.997 for the widest d.
    pub fn filter_radius(&self) -> f64 {
        hdrp_sample_burley(HDRP_FILTER_CDF, self.max_d()).0
    }

    /// Samples per pixel at `pixel_mm` mm per pixel and `budget`:
    /// min(floor(pi (filterRadius / pixel_mm)^2 / 4), budget); 0 means
    /// the pass copies the pixel (its filter is under a sample).
    pub fn sample_count(&self, pixel_mm: f64, budget: usize) -> usize {
        let area = PI * (self.filter_radius() / pixel_mm).powi(2);
        let count = (area / HDRP_PIXELS_PER_SAMPLE).floor();
        if count >= budget as f64 {
            budget
        } else {
            count as usize
        }
    }

    /// The pixel's rotation: 2 pi x the hash of (x, y, the depth buffer's
    /// value x 2^24); it changes only with the depth, not with the frame.
    pub fn phase(x: u32, y: u32, depth_bits: u32) -> f64 {
        2.0 * PI * hashed_random_float([x, y, depth_bits])
    }

    /// The `n` samples of a pixel with rotation `phase`: u_i = (i + 1/2) / n
    /// through the exact inverse CDF of the widest channel, angle
    /// phase + the golden angle's i-th turn, weight EvalBurley(r, S_c) /
    /// pdf.
    pub fn samples(&self, phase: f64, n: usize) -> Vec<EngineSample> {
        let s = self.shape();
        let d = self.max_d();
        (0..n as u32)
            .map(|i| {
                let u = i as f64 / n as f64 + 0.5 / n as f64;
                let (r, rcp_pdf) = hdrp_sample_burley(u, d);
                let psi = phase + hdrp_golden_angle(i);
                EngineSample {
                    x_mm: r * psi.cos(),
                    y_mm: r * psi.sin(),
                    weight: s.map(|s| hdrp_eval_burley(r, s) * rcp_pdf),
                }
            })
            .collect()
    }
}
