//! Importance-sampled disk kernels: N sample points on the surface whose
//! radii are drawn from R_d(r) by its inverse CDF, on a golden-angle spiral,
//! each weighted by profile / pdf, so that the sum over samples estimates
//! the 2D convolution of Freude 2014, eq. 5.2 without the separable
//! approximation. The radial pdf on the disk is p(r) = 2 pi r q(r) (the
//! annulus measure), q the pdf per unit area; sample i sits at the
//! stratified u_i = (i + 1/2) / N of the CDF (the midpoint rule in u) and
//! at the angle i x the golden angle (Vogel 1979's spiral with radii
//! from the profile in place of sqrt(u)); a per-pixel rotation, changed
//! every frame, turns the fixed pattern into noise that a temporal filter
//! averages out.
//!
//! One set of radii serves the three channels, drawn from the widest
//! channel's kernel ([`RadiusPdf::Widest`], the default, the choice of the
//! engines), the other channels weighted K_c / K_widest. Measured on the
//! edge at 0.1 mm per pixel with 32 samples (docs/kernels.md, record
//! `disk`, table `radii`), it gives the lowest noise in the worst channel
//! of the three choices at equal cost: the noise of an edge comes from the
//! tail of the widest channel, which the mean of the three kernels
//! ([`RadiusPdf::Mean`], a defensive mixture, Hesterberg 1995, whose
//! weights stay below 3) samples three times too thinly (skin 4.7e-2
//! against 2.5e-2 of the peak in red, ketchup 6.2e-2 against 2.7e-2), while
//! the narrow channels' large weights near the centre fall where the image
//! varies least. Per-channel radii ([`RadiusPdf::PerChannel`]) match the
//! widest channel's noise in every channel but cost three fetches per
//! sample a channel uses.

use super::disk::{DiskKernelFile, DiskSample, RadiusPdf, MAX_RADIUS_MM, MAX_SAMPLES, MIN_SAMPLES};
use super::format::DISK_SCHEMA;
use super::kernel2d::{check_profile_values, rgb_indices};
use super::ModelInfo;
use crate::error::{Error, Result};
use crate::material::Channel;
use crate::numerics::{bisect, gauss_legendre};
use crate::profile::{Profile, RadialInterp};
use serde_json::json;
use std::f64::consts::PI;

/// The golden angle pi (3 - sqrt 5) in radians: consecutive samples turn by
/// it, so any run of them covers the circle evenly (Vogel 1979).
pub const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;

/// Bisections per inverted sample: the bracket is one sub-panel of the
/// profile's reconstruction, so 60 halvings reach f64 round-off.
const BISECTIONS: usize = 60;

/// Gauss-Legendre panels per segment of the reconstruction: 8-point rules
/// on quarters of a bin integrate its exponential to round-off.
const SUBPANELS: usize = 4;

/// The profile's three normalised kernels as continuous radial functions
/// with their CDFs over the disk, on panels between the reconstruction's
/// nodes.
pub struct DiskPdf {
    interp: [RadialInterp; 3],
    /// 2 pi int_0^r s R_c(s) ds of the reconstruction, over all r.
    totals: [f64; 3],
    edges: Vec<f64>,
    /// Normalised CDF of each channel at `edges`.
    cum: [Vec<f64>; 3],
}

impl DiskPdf {
    pub fn new(profile: &Profile) -> Result<DiskPdf> {
        let idx = rgb_indices(profile)?;
        check_profile_values(profile, &idx)?;
        let interp = idx.map(|c| RadialInterp::new(profile, c));
        let mut edges = vec![0.0];
        for w in interp[0].nodes().windows(2) {
            for k in 1..=SUBPANELS {
                edges.push(w[0] + (w[1] - w[0]) * k as f64 / SUBPANELS as f64);
            }
        }
        let cum: [Vec<f64>; 3] = std::array::from_fn(|c| {
            let mut acc = 0.0;
            let mut v = vec![0.0];
            for e in edges.windows(2) {
                acc += 2.0 * PI * gauss_legendre(|s| s * interp[c].eval(s), e[0], e[1]);
                v.push(acc);
            }
            v
        });
        let totals = std::array::from_fn(|c| *cum[c].last().unwrap());
        if let Some(c) = (0..3).find(|&c| !(totals[c] > 0.0 && totals[c].is_finite())) {
            return Err(Error::Unsupported(format!(
                "disk kernel: channel {} of the profile integrates to {}: no pdf",
                ["r", "g", "b"][c],
                totals[c]
            )));
        }
        let cum = std::array::from_fn(|c| cum[c].iter().map(|v| v / totals[c]).collect());
        Ok(DiskPdf {
            interp,
            totals,
            edges,
            cum,
        })
    }

    /// The normalised kernel of channel c per unit area at radius r, mm^-2.
    pub fn density(&self, c: usize, r: f64) -> f64 {
        self.interp[c].eval(r) / self.totals[c]
    }

    /// Outer radius of the support.
    pub fn r_max(&self) -> f64 {
        *self.edges.last().unwrap()
    }

    /// The CDF over the disk of the mixture `mix` of the normalised channel
    /// kernels at radius r.
    pub fn cdf(&self, mix: [f64; 3], r: f64) -> f64 {
        if !(r > 0.0) {
            return 0.0;
        }
        if r >= self.r_max() {
            return 1.0;
        }
        let j = self.edges.partition_point(|&e| e <= r) - 1;
        self.cdf_in(mix, j, r)
    }

    fn cdf_in(&self, mix: [f64; 3], j: usize, r: f64) -> f64 {
        let lo = self.edges[j];
        (0..3)
            .filter(|&c| mix[c] != 0.0)
            .map(|c| {
                let part = 2.0 * PI * gauss_legendre(|s| s * self.interp[c].eval(s), lo, r);
                mix[c] * (self.cum[c][j] + part / self.totals[c])
            })
            .sum()
    }

    /// The radius where the mixture's CDF reaches u in (0, 1): its panel
    /// from the tabulated CDF, then bisection inside it.
    pub fn invert(&self, mix: [f64; 3], u: f64) -> f64 {
        let at = |j: usize| (0..3).map(|c| mix[c] * self.cum[c][j]).sum::<f64>();
        let (mut lo, mut hi) = (0, self.edges.len() - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if at(mid) <= u {
                lo = mid
            } else {
                hi = mid
            }
        }
        bisect(
            |r| self.cdf_in(mix, lo, r) - u,
            self.edges[lo],
            self.edges[hi],
            BISECTIONS,
        )
    }

    /// The channel with the largest mean radius (the widest kernel).
    pub fn widest(&self) -> usize {
        let mean_r = |c: usize| -> f64 {
            self.edges
                .windows(2)
                .map(|e| gauss_legendre(|s| 2.0 * PI * s * s * self.density(c, s), e[0], e[1]))
                .sum()
        };
        let m = [mean_r(0), mean_r(1), mean_r(2)];
        (0..3).fold(0, |b, c| if m[c] > m[b] { c } else { b })
    }
}

/// The samples of `n` stratified radii drawn from the mixture `mix` of the
/// channel kernels, weights K_c / (N q), q = sum mix_c K_c; `only`: keep
/// the weight of that channel alone (per-channel radii).
fn sample_set(pdf: &DiskPdf, mix: [f64; 3], n: usize, only: Option<usize>) -> Vec<DiskSample> {
    (0..n)
        .map(|i| {
            // Stratified inversion: the midpoint of stratum i.
            let u = (i as f64 + 0.5) / n as f64;
            let r = pdf.invert(mix, u);
            let q: f64 = (0..3).map(|c| mix[c] * pdf.density(c, r)).sum();
            let weight = std::array::from_fn(|c| match only {
                Some(k) if k != c => 0.0,
                _ if q > 0.0 => pdf.density(c, r) / (q * n as f64),
                _ => 0.0,
            });
            DiskSample {
                radius_mm: r,
                angle: (i as f64 * GOLDEN_ANGLE).rem_euclid(2.0 * PI),
                weight,
            }
        })
        .collect()
}

/// Refuses samples beyond [`MAX_RADIUS_MM`], which no file may hold,
/// saying why they are there: the material scatters over a kilometre.
fn check_reach(profile: &Profile, samples: &[DiskSample]) -> Result<()> {
    let far = samples.iter().map(|s| s.radius_mm).fold(0.0, f64::max);
    if far <= MAX_RADIUS_MM {
        return Ok(());
    }
    let mfp = Channel::ALL
        .iter()
        .map(|&c| 1.0 / profile.material.top(c).sigma_t_reduced())
        .fold(0.0, f64::max);
    Err(Error::Unsupported(format!(
        "disk kernel of {}: its samples reach {far:.3e} mm from the centre, beyond the \
         {MAX_RADIUS_MM:.0e} mm (a kilometre) a disk kernel holds: the material scatters that far \
         (a transport mean free path of {mfp:.3e} mm); check its coefficients and their unit \
         (mm^-1, or `unit = \"cm\"` for cm^-1)",
        profile.material.name
    )))
}

/// Checks a sample count per channel.
pub fn check_samples(n: usize) -> Result<()> {
    if (MIN_SAMPLES..=MAX_SAMPLES).contains(&n) {
        return Ok(());
    }
    Err(Error::invalid(
        "disk kernel",
        "samples",
        n,
        format!("must be in {MIN_SAMPLES}..={MAX_SAMPLES}"),
    ))
}

/// The disk kernel of `profile` with `n` samples per channel whose radii
/// come from `radii`.
pub fn fit_disk(profile: &Profile, n: usize, radii: RadiusPdf) -> Result<DiskKernelFile> {
    check_samples(n)?;
    let t0 = std::time::Instant::now();
    let pdf = DiskPdf::new(profile)?;
    let mut samples = match radii {
        RadiusPdf::Mean => sample_set(&pdf, [1.0 / 3.0; 3], n, None),
        RadiusPdf::Widest => {
            let mut mix = [0.0; 3];
            mix[pdf.widest()] = 1.0;
            sample_set(&pdf, mix, n, None)
        }
        RadiusPdf::PerChannel => (0..3)
            .flat_map(|c| {
                let mut mix = [0.0; 3];
                mix[c] = 1.0;
                sample_set(&pdf, mix, n, Some(c))
            })
            .collect(),
    };
    check_reach(profile, &samples)?;
    let raw_weight_sum: [f64; 3] =
        std::array::from_fn(|c| samples.iter().map(|s| s.weight[c]).sum());
    for s in &mut samples {
        for (w, sum) in s.weight.iter_mut().zip(raw_weight_sum) {
            *w /= sum;
        }
    }
    let idx = rgb_indices(profile)?;
    let file = DiskKernelFile {
        schema: DISK_SCHEMA.into(),
        material: Some(profile.material.clone()),
        profile: json!({
            "source": profile.source,
            "bins": profile.r.len(),
            "r_max_mm": pdf.r_max(),
            "total_rd": profile.total_rd,
        }),
        model: ModelInfo {
            name: "disk".into(),
            params: json!({
                "samples": n,
                "radii": radii.name(),
                "fit_seconds": t0.elapsed().as_secs_f64(),
            }),
        },
        units: "mm".into(),
        total_rd: idx.map(|c| profile.total_rd[c]),
        samples,
        raw_weight_sum,
        usage: None,
        angular: super::angular::AngularFactors::from_profile(profile)?,
        accumulation: None,
    };
    file.validate("fitted disk kernel")?;
    Ok(file)
}
