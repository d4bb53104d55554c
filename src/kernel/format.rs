//! The `ssskit.kernel/1` file: plain data shared by the fitting models (which
//! write it) and the filters (which read it).
//!
//! A kernel is a sum of separable terms ("passes"): the 2D kernel is
//! sum_i a_i(x) a_i(y), applied as a horizontal then a vertical 1D
//! convolution with the same factor a_i, results summed over i. Offsets are in
//! millimetres on the surface; weights are per RGB channel.

use super::factors::Factors;
use crate::error::{check_header, Error, Result};
use crate::material::Material;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const KERNEL_SCHEMA: &str = "ssskit.kernel/1";
/// The schema of a disk kernel file (`kernel::disk`).
pub const DISK_SCHEMA: &str = "ssskit.disk/1";

/// Writes a kernel file (either kind) to `path`, a `.json`, atomically and
/// only after `validate`, the checks a reader makes: ssskit never writes a
/// kernel it would refuse to read. `written` is the file as written (with
/// its usage notes, recomputed).
pub(super) fn write_kernel<T: Serialize>(
    path: &Path,
    validate: impl FnOnce(&str) -> Result<()>,
    written: impl FnOnce() -> T,
) -> Result<()> {
    crate::io::check_extension(path, &["json"], "kernel")?;
    validate(&format!("refusing to write {}", path.display()))?;
    crate::io::write_json_atomic(path, &written())
}

/// Reads a kernel file of `schema`: a file that does not parse as one is
/// first asked for its schema, so that another kind of file (a disk kernel
/// given where a separable one is read, a schema of another version) is
/// named as such rather than by the first field it lacks.
pub(super) fn read_kernel<T: serde::de::DeserializeOwned>(path: &Path, schema: &str) -> Result<T> {
    #[derive(Deserialize)]
    struct Schema {
        schema: serde_json::Value,
    }
    let e = match crate::io::read_json::<T>(path) {
        Ok(k) => return Ok(k),
        Err(e) => e,
    };
    let found = match crate::io::read_json::<Schema>(path) {
        Ok(s) => s.schema,
        Err(_) => return Err(e),
    };
    if found.as_str() == Some(schema) {
        return Err(e);
    }
    let kind = |s: &str| {
        if s == DISK_SCHEMA {
            "a disk kernel"
        } else {
            "a separable kernel"
        }
    };
    Err(Error::format(
        path,
        format!(
            "schema is {found}: this reads {} ('{schema}'){}",
            kind(schema),
            match found.as_str() {
                Some(s) if s == KERNEL_SCHEMA || s == DISK_SCHEMA =>
                    format!(", and the file is {}", kind(s)),
                _ => format!(
                    "; ssskit's kernel files are '{KERNEL_SCHEMA}' (separable) and \
                     '{DISK_SCHEMA}' (disk)"
                ),
            }
        ),
    ))
}

/// One separable term: a 1D factor sampled at `offsets_mm`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pass {
    pub offsets_mm: Vec<f64>,
    /// `weights[k] = [r, g, b]` at `offsets_mm[k]`.
    pub weights: Vec<[f64; 3]>,
}

/// The real-time table: `count` taps per pass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TapTable {
    pub count: usize,
    pub passes: Vec<Pass>,
    /// Half-width in mm the taps span (the outermost offsets); absent in
    /// files written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extent_mm: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    pub name: String,
    #[serde(default)]
    pub params: serde_json::Value,
}

/// Quality measures of a kernel against its ground truth.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    pub kernel_rms: [f64; 3],
    pub norm1_error: [f64; 3],
    pub asymmetry: [f64; 3],
    pub passes: usize,
    pub fit_seconds: f64,
    /// Model-specific extras (singular values, objective, iterations, ...).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub extra: serde_json::Value,
}

/// How an engine runs the kernel, written into every kernel file for the
/// people who integrate it; derived from the rest of the file (readers do
/// not need it, and files without it stay valid).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Usage {
    pub units: String,
    /// Pixels per kernel millimetre from depth and field of view.
    pub pixels_per_mm: String,
    pub depth: String,
    /// How the separable passes combine.
    pub passes: String,
    /// What `total_rd` is and where it multiplies.
    pub total_rd: String,
    /// Per tap-table pass, per channel: the sum of its tap weights.
    pub pass_weight_sums: Vec<[f64; 3]>,
    /// Per channel: the 2D sum of the tap kernel, sum over passes of the
    /// squared pass sums (1 for an energy-conserving kernel).
    pub kernel_sum: [f64; 3],
    /// Whether some tap weight is negative, so that the intermediate
    /// (horizontal) result must be stored in a signed float target.
    pub signed_targets: bool,
}

/// Pixels per kernel millimetre, Freude 2014, eq. 4.11 written out for engines.
pub const PIXELS_PER_MM: &str = "pixels_per_mm = sss_width * viewport_height_px / (2 * tan(fov_y / 2) * depth), where depth is the pixel's linear view depth in scene units, fov_y the vertical field of view and sss_width the scene units per millimetre (0.001 for a scene in metres, 0.1 in centimetres, 1 in millimetres); multiply each tap offset (mm) by it to get a pixel offset along the pass axis (Freude 2014, eq. 4.11)";

pub const DEPTH: &str = "linear view-space depth (distance along the view axis, scene units), not the hardware depth buffer: linearise a perspective z-buffer first; the depth-aware lerp t = clamp(C * sss_width * |d_centre - d_sample| / tan(fov_y / 2), 0, 1) (Freude 2014, eq. 4.12; C = 300 in Jimenez's shader) uses the same depth";

pub const PASSES: &str = "for each pass p: H_p = horizontal 1D filter of the irradiance with pass p's taps, V_p = vertical 1D filter of H_p with the same taps; the result is the sum of V_p over passes. Passes are summed, never chained (pass p + 1 filters the irradiance, not pass p's output). With more than one pass, terms after the first have negative taps: store H_p in a signed float target (RGBA16F/RGBA32F), never R11G11B10F or UNORM, which clamp negative values";

pub const TOTAL_RD: &str = "total diffuse reflectance per channel: the kernel is normalised to a 2D sum of 1 per channel (exact models), so diffuse radiance = total_rd * (sum of the filtered passes) applied to the irradiance (light arriving at the surface, without albedo). Multiply after the blur (or before: the filter is linear). An engine that multiplies by an albedo texture after the blur (post-scatter texturing) uses that texture in place of total_rd, not both";

/// Declares a kernel file's struct (`KernelFile`, the disk kernel's
/// `DiskKernelFile`) with the header fields both files open with, in the
/// order both write them, followed by the kind's own fields. A macro, not
/// a `#[serde(flatten)]` header struct: flatten would read through serde's
/// buffer (parse errors without their line and column) and callers keep
/// naming the fields directly (`k.total_rd`).
macro_rules! kernel_file_struct {
    ($(#[$meta:meta])* pub struct $name:ident { $($fields:tt)* }) => {
        $(#[$meta])*
        pub struct $name {
            pub schema: String,
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub material: Option<Material>,
            /// Summary of the profile the kernel came from.
            #[serde(default)]
            pub profile: serde_json::Value,
            pub model: ModelInfo,
            pub units: String,
            /// Total diffuse reflectance per channel: the colour factor kept
            /// apart from the kernel, whose 2D sum is 1 per channel for an
            /// exact model.
            pub total_rd: [f64; 3],
            $($fields)*
        }
    };
}
pub(super) use kernel_file_struct;

kernel_file_struct! {
    #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
    pub struct KernelFile {
        pub passes: Vec<Pass>,
        pub taps: TapTable,
        pub metrics: Metrics,
        /// Integration notes; recomputed on every write.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub usage: Option<Usage>,
        /// Entry and exit factors to apply around the blur (N.L before, N.V
        /// after), when the profile carried the angle-resolved tables.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub angular: Option<super::angular::AngularFactors>,
        /// The transmittance through a thickness for shaders (`fit
        /// --transmission`), fitted to a thickness table.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pub transmission: Option<super::transmission::ThicknessFit>,
    }
}

impl Pass {
    fn validate(&self, what: &str) -> std::result::Result<(), String> {
        if self.offsets_mm.is_empty() {
            return Err(format!("{what}: no offsets"));
        }
        if self.offsets_mm.len() != self.weights.len() {
            return Err(format!(
                "{what}: {} offsets but {} weights",
                self.offsets_mm.len(),
                self.weights.len()
            ));
        }
        if let Some(x) = self.offsets_mm.iter().find(|x| !x.is_finite()) {
            return Err(format!("{what}: offset {x} is not finite"));
        }
        if self.offsets_mm.windows(2).any(|w| !(w[1] > w[0])) {
            return Err(format!("{what}: offsets must increase strictly"));
        }
        // Filters resample the factor to pixels: a span of more than
        // MAX_STEPS of its finest spacing is no sampled kernel (an offset of
        // -1e12 among steps of 0.1 mm).
        let n = self.offsets_mm.len();
        if n > 1 {
            let span = self.offsets_mm[n - 1] - self.offsets_mm[0];
            let finest = self
                .offsets_mm
                .windows(2)
                .map(|w| w[1] - w[0])
                .fold(f64::INFINITY, f64::min);
            if !(span / finest <= MAX_STEPS) {
                return Err(format!(
                    "{what}: offsets span {span:.4e} mm with steps as fine as {finest:.4e} mm, \
                     more than {MAX_STEPS:.0e} steps: not a sampled kernel"
                ));
            }
        }
        if let Some(w) = self
            .weights
            .iter()
            .find(|w| w.iter().any(|x| !x.is_finite()))
        {
            return Err(format!("{what}: weight {w:?} is not finite"));
        }
        Ok(())
    }
}

/// Relative tolerance of a sum a file states against the one its numbers
/// give: written by ssskit they agree to rounding (about 1e-13 for the
/// largest tables); a file typed by hand with seven significant digits
/// still agrees.
pub const STATED_SUM_TOLERANCE: f64 = 1e-6;

/// Whether a stated sum agrees with the computed one within
/// [`STATED_SUM_TOLERANCE`].
pub(super) fn agrees(stated: f64, computed: f64) -> bool {
    (stated - computed).abs() <= STATED_SUM_TOLERANCE * stated.abs().max(computed.abs()).max(1e-300)
        || stated == computed
}

/// `total_rd` against the summary of the profile the kernel came from
/// (`profile.total_rd`, where it holds three numbers): the colour of the
/// kernel is the profile's total reflectance.
pub(super) fn check_profile_total(
    profile: &serde_json::Value,
    total_rd: &[f64; 3],
) -> std::result::Result<(), String> {
    let Some(p) = profile.get("total_rd").and_then(|v| v.as_array()) else {
        return Ok(());
    };
    let mut p: Vec<f64> = p.iter().filter_map(|v| v.as_f64()).collect();
    if p.len() != 3 {
        return Ok(());
    }
    // The summary lists the profile's channels in its own order.
    let mut k = total_rd.to_vec();
    p.sort_by(f64::total_cmp);
    k.sort_by(f64::total_cmp);
    if let Some(i) = (0..3).find(|&i| !agrees(p[i], k[i])) {
        return Err(format!(
            "total_rd is {total_rd:?} but the profile it came from has {p:?} \
             (profile.total_rd; {} against {}): the kernel's colour is the profile's reflectance",
            k[i], p[i]
        ));
    }
    Ok(())
}

/// Most steps of its finest spacing a factor's offsets may span.
pub const MAX_STEPS: f64 = 1e7;

/// Largest 2D sum of absolute weights per channel: an exact kernel sums to
/// 1 (the colour is in `total_rd`); this leaves room for any fitted model
/// while keeping a filtered image far inside f32.
pub const MAX_KERNEL_SUM: f64 = 1e6;

/// Smallest 2D sum of a kernel per channel: an exact kernel sums to 1 and
/// every fitted one in this repository to more than 0.3 (its tap table
/// keeps what the taps reach); one keeping less than a thousandth of the
/// light turns the image black, whatever its weights' sizes.
pub const MIN_KERNEL_SUM: f64 = 1e-3;

/// The 2D kernel of separable `passes` sums, per channel, to
/// sum_i (sum_k a_ik)^2; refuses a channel whose weights are all zero or
/// whose 2D sum is below [`MIN_KERNEL_SUM`] (a black image: weights that
/// cancel, or that are all tiny), or whose absolute sum is not finite or
/// above [`MAX_KERNEL_SUM`].
fn check_weights(what: &str, passes: &[Pass]) -> std::result::Result<(), String> {
    for (c, name) in ["r", "g", "b"].iter().enumerate() {
        let abs: f64 = passes
            .iter()
            .map(|p| p.weights.iter().map(|w| w[c].abs()).sum::<f64>().powi(2))
            .sum();
        if abs == 0.0 {
            return Err(format!(
                "{what}: every weight of channel {name} is 0: the kernel would turn the image black"
            ));
        }
        let signed: f64 = passes
            .iter()
            .map(|p| p.weights.iter().map(|w| w[c]).sum::<f64>().powi(2))
            .sum();
        if !(signed >= MIN_KERNEL_SUM) && abs.is_finite() {
            return Err(format!(
                "{what}: the 2D kernel of channel {name} sums to {signed:.3e} (an exact kernel \
                 sums to 1), below {MIN_KERNEL_SUM:.0e}: the kernel would turn the image black"
            ));
        }
        if !(abs <= MAX_KERNEL_SUM) {
            return Err(format!(
                "{what}: the 2D kernel of channel {name} has an absolute sum of {abs:.3e}, above \
                 {MAX_KERNEL_SUM:.0e} (an exact kernel sums to 1): the weights are not a kernel"
            ));
        }
    }
    Ok(())
}

impl KernelFile {
    /// The separable factors its passes store: per pass, per channel, the
    /// weights of the pass (the fit's own factors on the pass's offsets).
    pub fn factors(&self) -> Factors {
        self.passes
            .iter()
            .map(|p| std::array::from_fn(|c| p.weights.iter().map(|w| w[c]).collect()))
            .collect()
    }

    pub fn validate(&self, context: &str) -> Result<()> {
        check_header(context, &self.schema, KERNEL_SCHEMA, &self.units)?;
        let bad = |m: String| Err(Error::format(context, m));
        if self.passes.is_empty() {
            return bad("kernel has no passes".into());
        }
        if let Some(t) = &self.transmission {
            let finite = t.terms.iter().flatten().all(|v| v.is_finite() && *v >= 0.0);
            if !(finite && t.range_mm[0] > 0.0 && t.range_mm[1] >= t.range_mm[0]) {
                return bad("transmission: expected terms >= 0 and a range 0 < lo <= hi mm".into());
            }
        }
        if let Some(m) = &self.material {
            m.validate(context)?;
        }
        if let Some(x) = self.total_rd.iter().find(|x| !x.is_finite() || **x < 0.0) {
            return bad(format!("total_rd holds {x}: must be finite and >= 0"));
        }
        for (i, p) in self.passes.iter().enumerate() {
            p.validate(&format!("passes[{i}]")).or_else(bad)?;
        }
        check_weights("passes", &self.passes).or_else(bad)?;
        if self.taps.count == 0 || self.taps.count.is_multiple_of(2) {
            return bad(format!(
                "taps.count is {}: must be odd (a centre tap and pairs around it)",
                self.taps.count
            ));
        }
        if self.model.name.trim().is_empty() {
            return bad("model.name is empty".into());
        }
        check_profile_total(&self.profile, &self.total_rd).or_else(bad)?;
        if let Some(a) = &self.angular {
            a.validate("angular").or_else(bad)?;
            a.check_energy("angular", &self.total_rd).or_else(bad)?;
        }
        let m = &self.metrics;
        if let Some(x) = m
            .kernel_rms
            .iter()
            .chain(&m.norm1_error)
            .chain(&m.asymmetry)
            .chain(std::iter::once(&m.fit_seconds))
            .find(|x| !x.is_finite())
        {
            return bad(format!("metrics hold {x}: must be finite"));
        }
        if self.taps.passes.len() != self.passes.len() {
            return bad(format!(
                "taps has {} passes but the kernel has {}",
                self.taps.passes.len(),
                self.passes.len()
            ));
        }
        for (i, p) in self.taps.passes.iter().enumerate() {
            p.validate(&format!("taps.passes[{i}]")).or_else(bad)?;
            if p.offsets_mm.len() != self.taps.count {
                return bad(format!(
                    "taps.passes[{i}] has {} taps, count says {}",
                    p.offsets_mm.len(),
                    self.taps.count
                ));
            }
        }
        check_weights("taps.passes", &self.taps.passes).or_else(bad)?;
        Ok(())
    }

    /// The sums `usage` states (written with the file) against those of
    /// the taps: a table whose weights were scaled after the file was
    /// written would filter with another brightness than it says.
    fn check_usage(&self, u: &Usage) -> std::result::Result<(), String> {
        let sums = self.pass_weight_sums();
        let kernel: [f64; 3] = std::array::from_fn(|c| sums.iter().map(|s| s[c] * s[c]).sum());
        let stated = u
            .pass_weight_sums
            .iter()
            .enumerate()
            .flat_map(|(i, s)| (0..3).map(move |c| (format!("pass_weight_sums[{i}][{c}]"), s[c])))
            .chain((0..3).map(|c| (format!("kernel_sum[{c}]"), u.kernel_sum[c])));
        let actual = sums.iter().flatten().chain(&kernel);
        if u.pass_weight_sums.len() != sums.len() {
            return Err(format!(
                "usage.pass_weight_sums has {} passes, the tap table {}",
                u.pass_weight_sums.len(),
                sums.len()
            ));
        }
        for ((name, said), &is) in stated.zip(actual) {
            if !agrees(said, is) {
                return Err(format!(
                    "usage.{name} says {said} but the tap weights sum to {is}: the weights were \
                     changed after the file was written (restore them, or remove `usage` to \
                     have it recomputed)"
                ));
            }
        }
        Ok(())
    }

    /// Reads and checks a kernel file; what its `usage` states is checked
    /// against its taps here (a kernel changed in memory states nothing:
    /// `write` recomputes `usage`).
    pub fn read(path: &Path) -> Result<KernelFile> {
        let k: KernelFile = read_kernel(path, KERNEL_SCHEMA)?;
        let context = path.display().to_string();
        k.validate(&context)?;
        if let Some(u) = &k.usage {
            k.check_usage(u).map_err(|m| Error::format(&context, m))?;
        }
        Ok(k)
    }

    /// Writes the file atomically, after the checks a reader makes
    /// ([`write_kernel`]).
    pub fn write(&self, path: &Path) -> Result<()> {
        write_kernel(path, |c| self.validate(c), || self.as_written())
    }

    /// The file as [`write`](Self::write) writes it: with its usage notes.
    pub fn as_written(&self) -> KernelFile {
        KernelFile {
            usage: Some(self.usage()),
            ..self.clone()
        }
    }

    /// Per tap-table pass, per channel: the sum of its weights.
    pub fn pass_weight_sums(&self) -> Vec<[f64; 3]> {
        self.taps
            .passes
            .iter()
            .map(|p| std::array::from_fn(|c| p.weights.iter().map(|w| w[c]).sum()))
            .collect()
    }

    /// The integration notes of this kernel.
    pub fn usage(&self) -> Usage {
        let sums = self.pass_weight_sums();
        Usage {
            units:
                "tap offsets in millimetres on the surface; weights dimensionless, per RGB channel"
                    .into(),
            pixels_per_mm: PIXELS_PER_MM.into(),
            depth: DEPTH.into(),
            passes: PASSES.into(),
            total_rd: TOTAL_RD.into(),
            kernel_sum: std::array::from_fn(|c| sums.iter().map(|s| s[c] * s[c]).sum()),
            pass_weight_sums: sums,
            signed_targets: self
                .taps
                .passes
                .iter()
                .any(|p| p.weights.iter().any(|w| w.iter().any(|v| *v < 0.0))),
        }
    }
}
