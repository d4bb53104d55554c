//! Applying kernels to images: image I/O, the exact CPU reference and the
//! wgpu post-process (Freude 2014, sections 4.2-4.4, Jimenez et al. 2015).
//!
//! One algorithm, two implementations: `screen_space::apply_screen_space` (f64) and
//! `gpu::Gpu::apply` (f32, WGSL) run Freude 2014, algorithm 4.1 on the same
//! [`Setup`]: per rank, a horizontal then a vertical 1D pass whose tap
//! offsets are scaled per pixel (Freude 2014, eq. 4.11), with the depth-aware lerp
//! toward the centre colour (Freude 2014, eq. 4.12); ranks are summed and the specular
//! image is added after the blur. Samples between pixels are linearly
//! interpolated along the pass axis; positions outside the image are clamped
//! to the border pixel (clamp-to-edge).
//!
//! The CPU side, one file per job: [`screen_space`] (algorithm 4.1 per
//! pixel), [`separable`] (fixed pixel kernels under a uniform scale, the
//! same result faster), [`exact`] (the full 2D convolution, the ground
//! truth), and [`cpu`], which picks between the first two.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

pub mod accumulate;
pub mod angular;
#[cfg(test)]
pub(crate) mod band_check;
mod bands;
pub mod cpu;
pub mod diff;
pub mod disk;
pub mod disk_error;
pub mod disk_gpu;
mod disk_lanes;
pub mod exact;
pub mod exr_plane;
pub mod gpu;
pub mod image;
pub mod jitter;
pub mod kernel_setup;
pub mod light_space;
pub mod light_space_gpu;
pub mod rows;
pub mod sample;
pub mod screen_space;
pub mod separable;
pub mod signals;
pub mod sweep;
pub mod timing;
mod uniform_pass;
pub mod warnings;
pub(crate) mod which;

use crate::error::{finite_positive, Error, Result};
use crate::kernel::{KernelFile, Pass};
pub use image::{Image, Plane};
pub use jitter::{
    ign_fixed, jitter_unit, rotation_unit, GOLDEN_U32, IGN_FRACTION, IGN_X, IGN_Y, SILVER_U32,
};
pub use which::{taps_for, Which};

/// Clamp-to-edge on whole pixels: index `i` of a row or column of `n`
/// pixels moved to the nearest border pixel.
fn clamp_index(i: i64, n: usize) -> usize {
    i.clamp(0, n as i64 - 1) as usize
}

/// The context of a bad [`Scale`] parameter in errors.
const SCALE: &str = "kernel scale";

/// An orthographic pixel footprint must be a finite positive length.
pub fn check_mm_per_pixel(mm: f64) -> Result<()> {
    finite_positive(SCALE, "mm_per_pixel", mm, "").map(drop)
}

/// How kernel millimetres map to pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// Orthographic: a constant pixel footprint on the surface.
    MmPerPixel(f64),
    /// Perspective (Freude 2014, eq. 4.11): needs a depth image. `sss_width` is scene
    /// units per kernel millimetre (0.001 for a scene in metres).
    Perspective { fov_y_deg: f64, sss_width: f64 },
}

impl Scale {
    /// Checks the scale's parameters (context "kernel scale"; fields named
    /// as the variants' fields).
    pub fn validate(&self) -> Result<()> {
        match *self {
            Scale::MmPerPixel(m) => check_mm_per_pixel(m),
            Scale::Perspective { fov_y_deg, .. } if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) => Err(
                Error::invalid(SCALE, "fov_y_deg", fov_y_deg, "must be in (0, 180) degrees"),
            ),
            Scale::Perspective { sss_width, .. } => {
                finite_positive(SCALE, "sss_width", sss_width, "").map(drop)
            }
        }
    }

    fn tan_half_fov(fov_y_deg: f64) -> f64 {
        (0.5 * fov_y_deg.to_radians()).tan()
    }

    /// Pixels per kernel millimetre before the per-pixel factors: the step is
    /// `step_base * strength` (orthographic) or `step_base * strength / depth`
    /// (perspective). Freude 2014, eq. 4.11: k_sc = 1/(tan(fov_y/2) p_d) maps a scene
    /// length to normalised device units (half the image height is 1), so a
    /// kernel millimetre spans sss_width k_sc height/2 pixels.
    pub fn step_base(&self, height: usize) -> f64 {
        match *self {
            Scale::MmPerPixel(m) => 1.0 / m,
            Scale::Perspective {
                fov_y_deg,
                sss_width,
            } => sss_width * height as f64 / (2.0 * Scale::tan_half_fov(fov_y_deg)),
        }
    }

    fn depth_rate(&self, f: FollowSurface) -> f64 {
        match (*self, f) {
            // Freude 2014, eq. 4.12 as written: in the depth image's units.
            (Scale::MmPerPixel(_), FollowSurface::InSceneUnits(c)) => c,
            (
                Scale::Perspective {
                    fov_y_deg,
                    sss_width,
                },
                FollowSurface::InSceneUnits(c),
            ) => c * sss_width / Scale::tan_half_fov(fov_y_deg),
            // The same with every length in metres of a scene whose kernel
            // millimetre is a millimetre: sss_width 0.001 m, and a depth
            // difference of d scene units is d / sss_width mm.
            (Scale::MmPerPixel(_), FollowSurface::InMetres(c)) => c * MM_IN_M,
            (
                Scale::Perspective {
                    fov_y_deg,
                    sss_width,
                },
                FollowSurface::InMetres(c),
            ) => c * MM_IN_M * MM_IN_M / (sss_width * Scale::tan_half_fov(fov_y_deg)),
        }
    }
}

/// The weight of the centre colour in the depth-aware lerp at a sample of
/// depth `d_sample` (Freude 2014, eq. 4.12), `rate` from
/// [`FollowSurface::rate`]: shared by the separable and the disk pass.
#[inline]
pub(crate) fn follow_t(rate: f64, d_centre: f64, d_sample: f64) -> f64 {
    (rate * (d_centre - d_sample).abs()).clamp(0.0, 1.0)
}

/// Metres per millimetre.
const MM_IN_M: f64 = 0.001;

/// The constant C of the depth-aware lerp toward the centre colour, t =
/// clamp(k |d_centre - d_sample|, 0, 1) (Freude 2014, eq. 4.12: k = C
/// sss_width / tan(fov_y / 2); orthographic k = C), and the unit its
/// lengths are read in. Jimenez's shader (iryoku/separable-sss,
/// SeparableSSS.h, SSSSBlurPS) writes C = 300 for a scene in metres; since k
/// multiplies two lengths (sss_width and the depth difference), the same C
/// in a scene in millimetres lerps a million times faster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FollowSurface {
    /// Unit-safe: C applied to lengths in metres, whatever the scene's unit,
    /// the kernel at its physical size: k = C (0.001)^2 / (sss_width
    /// tan(fov_y / 2)) per scene unit of depth (sss_width = scene units per
    /// kernel mm, so a depth difference d is d / sss_width mm); orthographic
    /// (depth in mm, the unit of the pixel scale) k = 0.001 C per mm. Equal
    /// to `InSceneUnits` for a scene in metres (sss_width 0.001).
    InMetres(f64),
    /// Freude 2014, eq. 4.12 in the depth image's own units: depends on the
    /// scene's length unit (the behaviour before `InMetres`).
    InSceneUnits(f64),
}

impl FollowSurface {
    /// The constant C.
    pub fn constant(self) -> f64 {
        match self {
            FollowSurface::InMetres(c) | FollowSurface::InSceneUnits(c) => c,
        }
    }

    /// The parameter's name in errors.
    pub fn parameter(self) -> &'static str {
        match self {
            FollowSurface::InMetres(_) => "follow_surface",
            FollowSurface::InSceneUnits(_) => "follow_surface_scene_units",
        }
    }

    /// The factor k of t = clamp(k |d_centre - d_sample|, 0, 1) under
    /// `scale`, per unit of the depth image.
    pub fn rate(self, scale: &Scale) -> f64 {
        scale.depth_rate(self)
    }
}

/// One 1D factor as taps: offsets in kernel mm, RGB weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Taps {
    pub offsets_mm: Vec<f64>,
    pub weights: Vec<[f64; 3]>,
}

impl Taps {
    /// The interval of kernel mm each tap stands for, as (start, width): from
    /// the midpoint with the previous tap to the midpoint with the next; the
    /// end taps stop at themselves, the kernel's edge (the footprints the
    /// tap weights were integrated over). A jittered tap samples its own
    /// footprint uniformly, so the expected filter over the jitter is the
    /// kernel box-smoothed over each footprint instead of N spikes.
    pub fn footprints(&self) -> Vec<(f64, f64)> {
        let o = &self.offsets_mm;
        let n = o.len();
        (0..n)
            .map(|i| {
                let lo = if i > 0 { 0.5 * (o[i - 1] + o[i]) } else { o[i] };
                let hi = if i + 1 < n {
                    0.5 * (o[i] + o[i + 1])
                } else {
                    o[i]
                };
                (lo, hi - lo)
            })
            .collect()
    }
}

impl From<&Pass> for Taps {
    fn from(p: &Pass) -> Taps {
        Taps {
            offsets_mm: p.offsets_mm.clone(),
            weights: p.weights.clone(),
        }
    }
}

/// The context of a bad [`Setup`] field in errors.
const SETUP: &str = "filter setup";

/// Everything both backends need besides the image.
#[derive(Clone, Debug)]
pub struct Setup {
    /// One entry per separable term (rank).
    pub passes: Vec<Taps>,
    pub scale: Scale,
    /// Depth per pixel: required for `Scale::Perspective` and for
    /// `follow_surface`.
    pub depth: Option<Plane>,
    /// SSS strength per pixel, multiplies the step (Freude 2014, section 4.4).
    pub strength: Option<Plane>,
    /// The depth-aware lerp of Freude 2014, eq. 4.12; None: no lerp.
    pub follow_surface: Option<FollowSurface>,
    /// Added after the blur.
    pub specular: Option<Image>,
    /// Per-pixel jittered tap offsets against banding ([`jitter_unit`]).
    pub jitter: bool,
}

impl Setup {
    /// Checks sizes and values against the image.
    pub fn validate(&self, image: &Image) -> Result<()> {
        self.validate_view(image)?;
        if self.passes.is_empty() {
            return Err(Error::Unsupported("the kernel has no passes".into()));
        }
        self.check_work(image)
    }

    /// Checks what any kernel shares with `image` (scale, depth, strength,
    /// follow-surface, specular), not the passes: the disk pass
    /// (`disk::DiskSetup`) reuses it.
    pub fn validate_view(&self, image: &Image) -> Result<()> {
        self.scale.validate()?;
        if image.is_empty() {
            return Err(Error::Unsupported("the input image has no pixels".into()));
        }
        if let Some(d) = &self.depth {
            image::check_same_size("the depth image", d.width, d.height, image)?;
            if let Some(i) = d.data.iter().position(|v| !v.is_finite()) {
                return Err(Error::invalid(
                    "depth",
                    format!("pixel ({}, {})", i % d.width, i / d.width),
                    d.data[i],
                    "must be finite",
                ));
            }
            if matches!(self.scale, Scale::Perspective { .. }) {
                if let Some(i) = d.data.iter().position(|v| !(*v > 0.0)) {
                    return Err(Error::invalid(
                        "depth",
                        format!("pixel ({}, {})", i % d.width, i / d.width),
                        d.data[i],
                        "must be > 0 for the perspective kernel scale (Freude 2014, eq. 4.11)",
                    ));
                }
            }
        } else if matches!(self.scale, Scale::Perspective { .. }) {
            return Err(Error::invalid(
                SETUP,
                "depth",
                "none",
                "the perspective kernel scale divides the kernel size by depth (Freude 2014, \
                 eq. 4.11): give a depth image or an input EXR with a depth channel",
            ));
        } else if self.follow_surface.is_some() {
            return Err(Error::invalid(
                SETUP,
                "depth",
                "none",
                "following the surface lerps by depth difference (Freude 2014, eq. 4.12): give \
                 a depth image or an input EXR with a depth channel",
            ));
        }
        if let Some(f) = self.follow_surface {
            let c = f.constant();
            if !(c >= 0.0 && c.is_finite()) {
                return Err(Error::invalid(
                    SETUP,
                    f.parameter(),
                    c,
                    "must be finite and >= 0",
                ));
            }
        }
        if let Some(s) = &self.strength {
            image::check_same_size("the strength image", s.width, s.height, image)?;
            if let Some(i) = s.data.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(Error::invalid(
                    "strength",
                    format!("pixel ({}, {})", i % s.width, i / s.width),
                    s.data[i],
                    "must be finite and >= 0",
                ));
            }
        }
        if let Some(s) = &self.specular {
            image::check_same_size("the specular image", s.width, s.height, image)?;
        }
        Ok(())
    }

    /// The caps of [`crate::limits`] on these passes over `image`: under a
    /// uniform scale each pass becomes a pixel kernel as wide as its span,
    /// otherwise every pixel reads every tap.
    fn check_work(&self, image: &Image) -> Result<()> {
        let uniform = self
            .is_uniform()
            .then(|| self.scale.step_base(image.height));
        if uniform.is_none() {
            // Per-pixel steps (strength, 1/depth) must stay finite: an
            // infinite step times a zero offset is NaN in every pixel.
            let (at, widest) = self
                .steps_iter(image.width, image.height)
                .enumerate()
                .fold((0, 0.0), |a, (i, s)| if !(s <= a.1) { (i, s) } else { a });
            if !widest.is_finite() {
                return Err(Error::Unsupported(
                    "the per-pixel kernel scale overflows (a huge strength, a tiny depth or a \
                     tiny pixel footprint): check the strength and depth images and the scale"
                        .into(),
                ));
            }
            // The rule of the uniform scale at the widest pixel: beyond it
            // every tap but the centre reads the border pixel.
            let span = self
                .passes
                .iter()
                .map(|t| pixel_span(&t.offsets_mm, 1.0 / widest))
                .fold(0.0, f64::max);
            let max = crate::limits::max_kernel_pixels(image.width, image.height);
            if !(span <= max as f64) {
                let (x, y) = (at % image.width, at / image.width);
                let strength = self.strength.as_ref().map(|s| s.data[at]);
                let depth = self.depth.as_ref().map(|d| d.data[at]);
                return Err(Error::Unsupported(format!(
                    "the per-pixel kernel scale reaches {widest:.4e} pixels per kernel mm at \
                     pixel ({x}, {y}){}{}, where the kernel would span {span:.3e} pixels, more \
                     than {max} for a {}x{} image (4 times its longer side, at least 4096; its \
                     taps would all fall outside the image): check the strength and depth \
                     images and the scale",
                    strength.map_or(String::new(), |s| format!(", strength {s}")),
                    depth.map_or(String::new(), |d| format!(", depth {d}")),
                    image.width,
                    image.height
                )));
            }
        }
        let taps: Vec<f64> = self
            .passes
            .iter()
            .map(|t| match uniform {
                Some(step) => pixel_span(&t.offsets_mm, 1.0 / step),
                None => t.offsets_mm.len() as f64,
            })
            .collect();
        if let (Some(step), Some(widest)) = (uniform, taps.iter().copied().reduce(f64::max)) {
            check_span(widest, 1.0 / step, image.width, image.height)?;
        }
        check_filter_work(&taps, image.width, image.height)
    }

    /// True when every pixel uses the same step and no lerp: the passes are
    /// then plain convolutions with fixed integer kernels.
    pub fn is_uniform(&self) -> bool {
        matches!(self.scale, Scale::MmPerPixel(_))
            && self.strength.is_none()
            && self.follow_surface.is_none()
            && !self.jitter
    }

    /// Step in pixels per kernel mm at every pixel.
    pub fn steps(&self, width: usize, height: usize) -> Vec<f64> {
        self.steps_iter(width, height).collect()
    }

    /// The steps of [`Setup::steps`] one by one, without the plane (8
    /// bytes a pixel: 265 MB at 8K).
    pub fn steps_iter(&self, width: usize, height: usize) -> impl Iterator<Item = f64> + '_ {
        let base = self.scale.step_base(height);
        (0..width * height).map(move |i| self.step_at(base, i))
    }

    /// Step in pixels per kernel mm at pixel index `i`, `base` being
    /// [`Scale::step_base`] of the image's height: the base times the
    /// strength (Freude 2014, section 4.4), over the depth under the
    /// perspective scale (Freude 2014, eq. 4.11).
    #[inline]
    pub fn step_at(&self, base: f64, i: usize) -> f64 {
        let s = self.strength.as_ref().map_or(1.0, |p| p.data[i]);
        match self.scale {
            Scale::MmPerPixel(_) => base * s,
            Scale::Perspective { .. } => base * s / self.depth.as_ref().map_or(1.0, |d| d.data[i]),
        }
    }
}

/// Pixels a 1D factor sampled at `offsets_mm` covers at `mm` per pixel,
/// with the half-sample margins that resampling adds at both ends (an upper
/// bound of the pixel kernel's length).
pub fn pixel_span(offsets_mm: &[f64], mm: f64) -> f64 {
    let n = offsets_mm.len();
    if n == 0 {
        return 0.0;
    }
    let margin = if n > 1 {
        0.5 * (offsets_mm[1] - offsets_mm[0]) + 0.5 * (offsets_mm[n - 1] - offsets_mm[n - 2])
    } else {
        mm
    };
    (offsets_mm[n - 1] - offsets_mm[0] + margin) / mm + 3.0
}

fn check_span(span: f64, mm: f64, width: usize, height: usize) -> Result<()> {
    let max = crate::limits::max_kernel_pixels(width, height);
    if !(span <= max as f64) {
        let extent = (span - 3.0) * mm;
        return Err(Error::invalid(
            SCALE,
            "mm_per_pixel",
            mm,
            format!(
                "the kernel ({extent:.4e} mm wide) would span {span:.3e} pixels; at most {max} \
                 for a {width}x{height} image (4 times its longer side, at least 4096): use at \
                 least {:.4e} mm per pixel",
                extent / (max as f64 - 3.0)
            ),
        ));
    }
    Ok(())
}

/// Refuses a filtering of `taps[i]` taps per pass (horizontal and vertical,
/// three channels) over a `width` x `height` image above
/// [`crate::limits::MAX_FILTER_WORK`].
fn check_filter_work(taps: &[f64], width: usize, height: usize) -> Result<()> {
    let work = 6.0 * (width * height) as f64 * taps.iter().sum::<f64>();
    if !(work <= crate::limits::MAX_FILTER_WORK) {
        return Err(Error::Unsupported(format!(
            "applying {} pass(es) of up to {:.0} taps to a {width}x{height} image would take \
             {work:.2e} multiply-adds, above the cap of {:.0e} (about a minute on two cores): \
             use a coarser pixel scale, fewer passes, the real-time tap table or a smaller image",
            taps.len(),
            taps.iter().copied().fold(0.0, f64::max),
            crate::limits::MAX_FILTER_WORK
        )));
    }
    Ok(())
}

/// Checks, before [`taps_for`] builds them, that the taps of `kernel` fit the
/// caps for a `width` x `height` image: resampling to pixels allocates as many
/// taps as the kernel spans at `uniform_mm_per_pixel`.
pub fn check_kernel_fits(
    kernel: &KernelFile,
    which: Which,
    uniform_mm_per_pixel: Option<f64>,
    width: usize,
    height: usize,
) -> Result<()> {
    let passes = match which {
        Which::Taps(_) => &kernel.taps.passes,
        Which::Full => &kernel.passes,
    };
    let taps: Vec<f64> = passes
        .iter()
        .map(|p| match uniform_mm_per_pixel {
            Some(mm) => pixel_span(&p.offsets_mm, mm),
            None => p.offsets_mm.len() as f64,
        })
        .collect();
    if let (Some(mm), Some(widest)) = (uniform_mm_per_pixel, taps.iter().copied().reduce(f64::max))
    {
        check_span(widest, mm, width, height)?;
    }
    check_filter_work(&taps, width, height)
}

/// Box resampling of a sampled 1D factor to pixels of width `mm` centred on
/// the origin: sample k owns the interval between the midpoints to its
/// neighbours; its weight is shared among the pixels that interval overlaps.
pub fn resample_to_pixels(t: &Taps, mm: f64) -> Taps {
    let n = t.offsets_mm.len();
    let edge = |k: usize| -> (f64, f64) {
        let x = t.offsets_mm[k];
        let lo = if k > 0 {
            0.5 * (t.offsets_mm[k - 1] + x)
        } else if n > 1 {
            x - 0.5 * (t.offsets_mm[1] - x)
        } else {
            x - 0.5 * mm
        };
        let hi = if k + 1 < n {
            0.5 * (x + t.offsets_mm[k + 1])
        } else if n > 1 {
            x + 0.5 * (x - t.offsets_mm[n - 2])
        } else {
            x + 0.5 * mm
        };
        (lo, hi)
    };
    let (lo_all, hi_all) = (edge(0).0, edge(n - 1).1);
    let j_lo = (lo_all / mm - 0.5).floor() as i64;
    let j_hi = (hi_all / mm + 0.5).ceil() as i64;
    let mut weights = vec![[0.0; 3]; (j_hi - j_lo + 1) as usize];
    for k in 0..n {
        let (lo, hi) = edge(k);
        let len = hi - lo;
        if !(len > 0.0) {
            continue;
        }
        let first = ((lo / mm) + 0.5).floor() as i64;
        let last = ((hi / mm) + 0.5).floor() as i64;
        for j in first..=last {
            let (plo, phi) = ((j as f64 - 0.5) * mm, (j as f64 + 0.5) * mm);
            let overlap = (hi.min(phi) - lo.max(plo)).max(0.0);
            if overlap > 0.0 {
                let f = overlap / len;
                let w = &mut weights[(j - j_lo) as usize];
                for c in 0..3 {
                    w[c] += f * t.weights[k][c];
                }
            }
        }
    }
    Taps {
        offsets_mm: (j_lo..=j_hi).map(|j| j as f64 * mm).collect(),
        weights,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perspective_step_is_the_projected_size_of_a_kernel_millimetre() {
        // Freude 2014, eq. 4.11: at depth d a vertical field of view F covers
        // 2 d tan(F/2) scene units over the image height H.
        let (fov, w, h, d) = (50.0f64, 0.001, 1080, 0.4);
        let s = Scale::Perspective {
            fov_y_deg: fov,
            sss_width: w,
        };
        let scene_per_pixel = 2.0 * d * (fov.to_radians() / 2.0).tan() / h as f64;
        let expected = w / scene_per_pixel;
        assert!((s.step_base(h) / d - expected).abs() < 1e-12 * expected);
        // Freude 2014, eq. 4.12: t = C sss_width |dd| / tan(F/2).
        let k = FollowSurface::InSceneUnits(300.0).rate(&s);
        assert!((k - 300.0 * w / (fov.to_radians() / 2.0).tan()).abs() < 1e-12);
        assert_eq!(Scale::MmPerPixel(0.25).step_base(h), 4.0);
    }

    #[test]
    fn resampling_preserves_the_sum_and_the_mean() {
        let offsets: Vec<f64> = (-20..=20).map(|i| i as f64 * 0.13).collect();
        let weights: Vec<[f64; 3]> = offsets
            .iter()
            .map(|x| {
                let g = (-(x - 0.2) * (x - 0.2) / 0.5).exp();
                [g, 2.0 * g, 0.5 * g]
            })
            .collect();
        let t = Taps {
            offsets_mm: offsets,
            weights,
        };
        let r = resample_to_pixels(&t, 0.37);
        for c in 0..3 {
            let s0: f64 = t.weights.iter().map(|w| w[c]).sum();
            let s1: f64 = r.weights.iter().map(|w| w[c]).sum();
            assert!((s0 - s1).abs() < 1e-12 * s0);
            let moment = |t: &Taps| -> f64 {
                t.offsets_mm
                    .iter()
                    .zip(&t.weights)
                    .map(|(x, w)| x * w[c])
                    .sum()
            };
            let (m0, m1) = (moment(&t), moment(&r));
            // The first moment moves by less than a pixel's resolution.
            assert!((m0 / s0 - m1 / s1).abs() < 0.01, "{} {}", m0 / s0, m1 / s1);
        }
    }
}
