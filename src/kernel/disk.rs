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

use super::format::{agrees, check_profile_total, STATED_SUM_TOLERANCE};
use super::kernel2d::{check_profile_values, rgb_indices};
use super::ModelInfo;
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::numerics::{bisect, gauss_legendre};
use crate::profile::{Profile, RadialInterp};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::f64::consts::PI;
use std::path::Path;

pub use super::format::DISK_SCHEMA;

/// Fewest samples per channel a disk kernel may have: below 4 the spiral
/// covers no angle twice and the estimate is a handful of spikes.
pub const MIN_SAMPLES: usize = 4;
/// Samples per channel of `ssskit fit --model disk` unless told: 32
/// fetches, the cost of a 17-tap separable pair (34 samples per pixel).
pub const DEFAULT_SAMPLES: usize = 32;
/// Most samples per channel: 1024 reaches the exact convolution within the
/// bias the oracles state; more costs fetches no renderer spends.
pub const MAX_SAMPLES: usize = 1024;

/// The golden angle pi (3 - sqrt 5) in radians: consecutive samples turn by
/// it, so any run of them covers the circle evenly (Vogel 1979).
pub const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;

/// Largest sample radius a file may hold, in mm: far beyond any profile
/// (metres of scattering), small enough that radius x pixels-per-mm stays
/// finite in f32.
pub const MAX_RADIUS_MM: f64 = 1e6;

/// Bisections per inverted sample: the bracket is one sub-panel of the
/// profile's reconstruction, so 60 halvings reach f64 round-off.
const BISECTIONS: usize = 60;

/// Gauss-Legendre panels per segment of the reconstruction: 8-point rules
/// on quarters of a bin integrate its exponential to round-off.
const SUBPANELS: usize = 4;

/// Which density the radii are drawn from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RadiusPdf {
    /// One set from the widest channel's kernel (largest mean radius), the
    /// engines' choice and the default; the other channels weighted
    /// K_c / K_widest.
    Widest,
    /// One set of N radii from the mean of the three normalised channel
    /// kernels; per-channel weights K_c / q (each below 3).
    Mean,
    /// N radii per channel from its own kernel, weight 1 / N in that channel
    /// and 0 in the others: 3 N samples in the file.
    PerChannel,
}

impl RadiusPdf {
    pub fn name(self) -> &'static str {
        match self {
            RadiusPdf::Mean => "mean",
            RadiusPdf::Widest => "widest",
            RadiusPdf::PerChannel => "per-channel",
        }
    }
}

/// One sample: polar position in mm on the surface, RGB weight.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskSample {
    pub radius_mm: f64,
    /// Radians in [0, 2 pi), before the per-pixel rotation.
    pub angle: f64,
    pub weight: [f64; 3],
}

/// How an engine runs a disk kernel, recomputed on every write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskUsage {
    pub pixels_per_mm: String,
    pub rotation: String,
    pub weights: String,
    pub depth: String,
    pub total_rd: String,
}

/// How to rotate, fetch and weigh (the header of the emitted tables too).
pub const ROTATION: &str = "rotate every sample by the pixel's angle phi = 2 pi fract(ign(x, y) + (seed + frame) x 0.41421356 (sqrt 2 - 1)), with interleaved gradient noise ign(x, y) = fract(52.9829189 fract(0.06711056 x + 0.00583715 y)) (Jimenez 2014; ssskit evaluates it in 32-bit fixed point and keeps 24 bits); the sample's pixel offset is pixels_per_mm x radius_mm x (cos(angle + phi), sin(angle + phi)), x right and y down; fetch the irradiance bilinearly, clamped to the image";

pub const WEIGHTS: &str = "result = sum over samples of weight x colour, per channel; the weights are R_d / pdf and already sum to 1 per channel (no division: a constant image stays constant), so only total_rd multiplies afterwards; accumulate frames with a changing `frame` (ssskit's apply --frames takes the plain mean, static camera)";

pub const DEPTH_DISK: &str = "as the separable pass: pixels_per_mm divides by the pixel's linear view depth, and with follow-surface each sample's colour is lerped toward the centre colour by t = clamp(C x sss_width x |d_centre - d_sample| / tan(fov_y / 2), 0, 1) (Freude 2014, eq. 4.12)";

/// A disk kernel file (`ssskit.disk/1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskKernelFile {
    pub schema: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub material: Option<Material>,
    #[serde(default)]
    pub profile: serde_json::Value,
    pub model: ModelInfo,
    pub units: String,
    pub total_rd: [f64; 3],
    pub samples: Vec<DiskSample>,
    /// Per channel: the weights' sum before they were scaled to 1 (the
    /// stratified estimate of the kernel's integral, exactly 1 for
    /// per-channel radii); its distance from 1 is what the normalisation
    /// moved.
    pub raw_weight_sum: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub usage: Option<DiskUsage>,
    /// The profile's angular entry and exit factors, when it has them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular: Option<super::angular::AngularFactors>,
}

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
    };
    file.validate("fitted disk kernel")?;
    Ok(file)
}

impl DiskKernelFile {
    /// Fetches per pixel and frame.
    pub fn samples_per_pixel(&self) -> usize {
        self.samples.len()
    }

    pub fn validate(&self, context: &str) -> Result<()> {
        let bad = |m: String| Err(Error::format(context, m));
        if self.schema != DISK_SCHEMA {
            return bad(format!(
                "schema is '{}', expected '{DISK_SCHEMA}'",
                self.schema
            ));
        }
        if self.units != "mm" {
            return bad(format!("units is '{}', expected 'mm'", self.units));
        }
        let n = self.samples.len();
        if !(MIN_SAMPLES..=3 * MAX_SAMPLES).contains(&n) {
            return bad(format!(
                "{n} samples: a disk kernel has {MIN_SAMPLES} to {} (3 x {MAX_SAMPLES} with \
                 per-channel radii)",
                3 * MAX_SAMPLES
            ));
        }
        if let Some(m) = &self.material {
            m.validate(context)?;
        }
        if let Some(x) = self.total_rd.iter().find(|x| !x.is_finite() || **x < 0.0) {
            return bad(format!("total_rd holds {x}: must be finite and >= 0"));
        }
        for (i, s) in self.samples.iter().enumerate() {
            if !(s.radius_mm >= 0.0 && s.radius_mm <= MAX_RADIUS_MM) {
                return bad(format!(
                    "samples[{i}].radius_mm is {}: must be in [0, {MAX_RADIUS_MM:e}] mm",
                    s.radius_mm
                ));
            }
            if !(s.angle >= 0.0 && s.angle < 2.0 * PI) {
                return bad(format!(
                    "samples[{i}].angle is {}: must be in [0, 2 pi)",
                    s.angle
                ));
            }
            if let Some(w) = s.weight.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
                return bad(format!(
                    "samples[{i}].weight holds {w}: must be finite and >= 0 (profile / pdf)"
                ));
            }
        }
        for (c, name) in ["r", "g", "b"].iter().enumerate() {
            let sum: f64 = self.samples.iter().map(|s| s.weight[c]).sum();
            if !agrees(1.0, sum) {
                return bad(format!(
                    "samples[*].weight: channel {name} sums to {sum:.9}; a disk kernel's weights \
                     sum to 1 per channel (they are normalised: a constant image stays constant; \
                     tolerance {STATED_SUM_TOLERANCE:.0e})"
                ));
            }
        }
        self.check_raw_sums().or_else(bad)?;
        check_profile_total(&self.profile, &self.total_rd).or_else(bad)?;
        if let Some(a) = &self.angular {
            a.validate("angular").or_else(bad)?;
            a.check_energy("angular", &self.total_rd).or_else(bad)?;
        }
        Ok(())
    }

    /// `raw_weight_sum` against the radii the file names: the raw weights
    /// K_c / (N q) of the mixture q = sum mix_c K_c sum, over the channels
    /// mixed, to sum_c mix_c raw_c = 1 exactly (each sample adds 1 / N):
    /// every channel's sum is 1 with per-channel radii, the widest
    /// channel's with the widest, their mean with the mean.
    fn check_raw_sums(&self) -> std::result::Result<(), String> {
        let raw = self.raw_weight_sum;
        if let Some(x) = raw.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
            return Err(format!(
                "raw_weight_sum holds {x}: the weights' sums before normalising are finite and > 0"
            ));
        }
        let radii = self.model.params.get("radii").and_then(|v| v.as_str());
        let (ok, rule) = match radii {
            Some("per-channel") => (raw.iter().all(|&x| agrees(1.0, x)), "each channel's is 1"),
            Some("widest") => (
                raw.iter().any(|&x| agrees(1.0, x)),
                "the widest channel's is 1",
            ),
            Some("mean") => (
                agrees(1.0, raw.iter().sum::<f64>() / 3.0),
                "their mean is 1",
            ),
            _ => return Ok(()),
        };
        if !ok {
            return Err(format!(
                "raw_weight_sum is {raw:?}: with radii '{}' {rule} (each sample adds 1 / N to the \
                 density it was drawn from)",
                radii.unwrap_or_default()
            ));
        }
        Ok(())
    }

    pub fn usage(&self) -> DiskUsage {
        DiskUsage {
            pixels_per_mm: super::format::PIXELS_PER_MM.into(),
            rotation: ROTATION.into(),
            weights: WEIGHTS.into(),
            depth: DEPTH_DISK.into(),
            total_rd: super::format::TOTAL_RD.into(),
        }
    }

    pub fn read(path: &Path) -> Result<DiskKernelFile> {
        let k: DiskKernelFile = super::format::read_kernel(path, DISK_SCHEMA)?;
        k.validate(&path.display().to_string())?;
        Ok(k)
    }

    /// Writes atomically, after the reader's checks.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::io::check_extension(path, &["json"], "kernel")?;
        self.validate(&format!("refusing to write {}", path.display()))?;
        let mut k = self.clone();
        k.usage = Some(self.usage());
        crate::io::write_json_atomic(path, &k)
    }
}

/// Whether the JSON file at `path` holds a disk kernel (its `schema`), for
/// readers that take either kind; false when it cannot be read as JSON
/// (the kernel reader then says why).
pub fn is_disk_file(path: &Path) -> bool {
    #[derive(Deserialize)]
    struct Schema {
        schema: String,
    }
    crate::io::read_json::<Schema>(path).is_ok_and(|s| s.schema == DISK_SCHEMA)
}
