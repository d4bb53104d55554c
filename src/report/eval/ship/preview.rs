//! A preview of the material: the lit sphere of docs/scenes/sphere.toml
//! ([`crate::scene::lit_sphere`], filled with the profile's material)
//! path-traced at a small size with few samples per pixel, and on the
//! render's G-buffer the screen-space pass of what ships and the unblurred
//! irradiance, each scored against the path trace, with the render's noise
//! beside the scores.
//!
//! # Definitions
//!
//! - Scores: those of the `all` region of [`crate::report::eval::scene::compare`] (the
//!   pixels that see the sphere; relative RMS per channel over the 99th
//!   percentile of the path-traced radiance there; mean bias; FLIP with
//!   the path-traced image's exposure) and its noise floor, the RMS of the
//!   path trace's per-pixel standard error over that peak.
//! - Beyond the noise: sqrt(max(0, RMS^2 - noise^2)), an estimate of the
//!   RMS against a noiseless path trace (the expected RMS^2 is the true
//!   error^2 plus the noise^2; each pixel's squared standard error is its
//!   samples' variance over their count, an unbiased estimate).
//! - The pass: what `advise --scene` runs for the chosen configuration
//!   ([`crate::report::eval::advise::scene`]): its taps as scored, or its disk kernel over
//!   the frames the kernel file records (as `apply` runs it), scaled per pixel by the depth
//!   (Freude 2014, eq. 4.11), the depth-aware lerp (Freude 2014, eq. 4.12)
//!   completing at the kernel's reach; with the kernel file's entry and
//!   exit factors around it where the file carries them (the sphere has
//!   one directional light, which they need).
//! - The difference: no blur's RMS less the shipped pass's, per channel,
//!   with its standard deviation from the render's noise
//!   ([`rms_difference_sigma`](crate::report::eval::scene::score::rms_difference_sigma)):
//!   the noise common to both scores cancels.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use crate::error::Result;
use crate::filter::{angular, Image, Plane};
use crate::kernel::angular::AngularFactors;
use crate::profile::source::MC_SEED;
use crate::profile::Profile;
use crate::report::eval::advise::scene::ScenePass;
use crate::report::eval::advise::search::scored_passes;
use crate::report::eval::advise::Advice;
use crate::report::eval::disk::first_and_frames;
use crate::report::eval::evaluate::Options;
use crate::report::eval::scene::compare::{follow_constant, kernel_reach_mm, median_mm_per_pixel};
use crate::report::eval::scene::pass::{screen_space_disk_pass, screen_space_pass};
use crate::report::eval::scene::score::{cosines, region_masks, RegionError, Scorer};
use crate::scene::{lit_sphere, render, RenderConfig, SampleBudget, SPHERE_RADIUS_MM};
use serde::Serialize;

/// Pixels per side of the preview: the 30 mm sphere spans about 39 of
/// them (0.7 mm per pixel at its median depth), enough to see the light
/// bleed past the terminator, and the render stays a fraction of a second
/// on two cores.
pub const PREVIEW_SIDE: usize = 48;
/// Samples per pixel and channel of the preview's path trace: its noise is
/// about 8% of the peak per pixel for skin, stated beside every score.
pub const PREVIEW_SPP: u64 = 16;

/// What runs on the preview's G-buffer: a label, the pass and the entry and
/// exit factors around it (None: without them).
pub struct PreviewKernel {
    pub label: String,
    pub pass: ScenePass,
    pub factors: Option<AngularFactors>,
}

impl PreviewKernel {
    /// The advice's chosen configuration as it ships: the kernel file's
    /// passes as scored (a disk kernel over the frames it records) and the
    /// factors the file carries.
    pub fn shipped(advice: &Advice) -> PreviewKernel {
        let c = advice.chosen();
        let (pass, factors) = match &advice.disk_kernel {
            Some(k) => (ScenePass::Disk(Box::new(k.clone())), k.angular.clone()),
            None => (
                ScenePass::Separable(scored_passes(
                    &advice.kernel,
                    c.taps.is_none(),
                    advice.mm_per_pixel,
                )),
                advice.kernel.angular.clone(),
            ),
        };
        PreviewKernel {
            label: c.describe(),
            pass,
            factors,
        }
    }
}

/// One image of the preview scored against the path trace.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PreviewRow {
    pub label: String,
    /// Relative RMS per channel (with the render's noise in it).
    pub rel_rms: [f64; 3],
    /// sqrt(max(0, rel_rms^2 - noise^2)) per channel.
    pub beyond_noise: [f64; 3],
    /// Mean bias per channel, relative to the path trace's mean.
    pub bias: [f64; 3],
    pub flip: f64,
}

/// The preview: the path trace, the two passes, their scores and what the
/// render cost.
#[derive(Clone, Debug, Serialize)]
pub struct Preview {
    pub material: String,
    pub side: usize,
    pub samples_per_pixel: u64,
    pub seed: u64,
    pub radius_mm: f64,
    /// Millimetres per pixel at the sphere's median depth.
    pub mm_per_pixel: f64,
    /// Pixels scored (those that see the sphere).
    pub pixels: usize,
    /// The path trace's noise floor per channel.
    pub noise: [f64; 3],
    /// Whether the shipped pass has the entry and exit factors around it.
    pub with_factors: bool,
    pub shipped: PreviewRow,
    pub no_blur: PreviewRow,
    /// no_blur.rel_rms - shipped.rel_rms per channel, and its standard
    /// deviation from the render's noise.
    pub gap: [f64; 3],
    pub gap_sigma: [f64; 3],
    /// Scattering events and boundary crossings of the render per channel.
    pub events: [u64; 3],
    pub render_seconds: f64,
    /// The tone mapping's exposure (the path trace's, as FLIP sees it).
    pub exposure: f64,
    #[serde(skip)]
    pub images: PreviewImages,
}

/// The preview's images, linear radiance, `side` x `side`.
#[derive(Clone, Debug)]
pub struct PreviewImages {
    pub path_traced: Image,
    pub shipped: Image,
    pub no_blur: Image,
    /// |mean of (shipped - path traced)| over the [`WINDOW`] x [`WINDOW`]
    /// pixels around each pixel (clipped to the image): the error the
    /// render's noise would hide pixel by pixel.
    pub shipped_diff: Image,
    pub no_blur_diff: Image,
    /// The standard error of those window means from the render's noise.
    pub window_noise: Image,
}

/// Pixels per side of the window the difference images average over: 5 x
/// 5 pixels divide the render's noise by 5.
pub const WINDOW: usize = 5;

/// |window mean of (a - t)| per pixel and channel ([`PreviewImages`]).
fn window_diff(a: &Image, t: &Image) -> Image {
    let d: [Vec<f64>; 3] =
        std::array::from_fn(|c| a.rgb[c].iter().zip(&t.rgb[c]).map(|(x, y)| x - y).collect());
    let m = window_mean(&d, a.width, a.height, false);
    image(a.width, m.map(|v| v.into_iter().map(f64::abs).collect()))
}

/// Per pixel the mean of `planes` (or, with `errors`, the standard error of
/// that mean from per-pixel standard errors: sqrt(sum s^2) / n) over the
/// [`WINDOW`] x [`WINDOW`] pixels around it, clipped to the image.
fn window_mean(planes: &[Vec<f64>; 3], w: usize, h: usize, errors: bool) -> [Vec<f64>; 3] {
    let half = (WINDOW / 2) as isize;
    std::array::from_fn(|c| {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as isize, (i / w) as isize);
                let (mut sum, mut n) = (0.0, 0usize);
                for yy in (y - half).max(0)..=(y + half).min(h as isize - 1) {
                    for xx in (x - half).max(0)..=(x + half).min(w as isize - 1) {
                        let v = planes[c][yy as usize * w + xx as usize];
                        sum += if errors { v * v } else { v };
                        n += 1;
                    }
                }
                if errors {
                    sum.sqrt() / n as f64
                } else {
                    sum / n as f64
                }
            })
            .collect()
    })
}

fn row(label: &str, e: &RegionError) -> PreviewRow {
    PreviewRow {
        label: label.to_string(),
        rel_rms: e.rel_rms,
        beyond_noise: std::array::from_fn(|c| {
            (e.rel_rms[c].powi(2) - e.noise[c].powi(2)).max(0.0).sqrt()
        }),
        bias: e.bias,
        flip: e.flip,
    }
}

fn image(w: usize, rgb: [Vec<f64>; 3]) -> Image {
    Image {
        width: w,
        height: w,
        rgb,
        alpha: None,
    }
}

/// Why the scene tracer cannot render `profile`'s material on the
/// preview's sphere (None: it can).
pub fn obstacle(profile: &Profile) -> Option<String> {
    lit_sphere(&profile.material, PREVIEW_SIDE)
        .err()
        .map(|e| e.to_string())
}

/// Renders the preview of `profile`'s material ([`PREVIEW_SIDE`] pixels,
/// [`PREVIEW_SPP`] samples per pixel, seed [`MC_SEED`]: the same image at
/// any thread count) and scores `kernel`'s pass and no blur on it.
pub fn preview(profile: &Profile, kernel: &PreviewKernel) -> Result<Preview> {
    preview_sized(profile, kernel, (PREVIEW_SIDE, PREVIEW_SPP), MC_SEED)
}

/// [`preview`] at `side` pixels and `spp` samples per pixel, traced from
/// `seed`.
pub fn preview_sized(
    profile: &Profile,
    kernel: &PreviewKernel,
    (side, spp): (usize, u64),
    seed: u64,
) -> Result<Preview> {
    let scene = lit_sphere(&profile.material, side)?;
    let idx = crate::kernel::kernel2d::rgb_indices(profile)?;
    let rd = idx.map(|i| profile.total_rd[i]);
    let cfg = RenderConfig {
        budget: SampleBudget::Fixed(spp),
        seed,
        ..RenderConfig::default()
    };
    let r = render(&scene, &[rd], &cfg, &crate::progress::NoProgress)?;
    let w = side;
    let path_traced = image(w, r.radiance.clone());
    let irradiance = image(w, r.gbuffer.irradiance.clone());
    let depth = Plane {
        width: w,
        height: w,
        data: r.gbuffer.depth.clone(),
    };
    let follow = Some(follow_constant(&scene, kernel_reach_mm(profile)));
    let pass = |img: &Image| match &kernel.pass {
        ScenePass::Separable(taps) => screen_space_pass(&scene, &depth, taps, img, follow),
        ScenePass::Disk(kernel) => screen_space_disk_pass(
            &scene,
            &depth,
            kernel,
            first_and_frames(kernel),
            img,
            follow,
        ),
    };
    let shipped = match &kernel.factors {
        Some(f) => {
            let cos = cosines(&scene, &r);
            let nl = cos.n_dot_l.as_deref().unwrap_or(&[]);
            let lit = angular::entry_weighted(&irradiance, nl, f)?;
            angular::exit_weighted(&pass(&lit)?, &cos.n_dot_v, f)?
        }
        None => pass(&irradiance)?,
    };
    let masks = region_masks(&scene, &r);
    let pixels = masks[0].iter().filter(|&&m| m).count();
    let scorer = Scorer::new(
        &path_traced,
        &r.stderr,
        masks,
        Options::default().pixels_per_degree,
    );
    // Region 0 is `all`.
    let (s, n) = (&scorer.score(&shipped)[0], &scorer.score(&irradiance)[0]);
    let gap_sigma = scorer.difference_sigma(&irradiance, &shipped, [n.rel_rms, s.rel_rms]);
    Ok(Preview {
        material: profile.material.name.clone(),
        side: w,
        samples_per_pixel: spp,
        seed,
        radius_mm: SPHERE_RADIUS_MM,
        mm_per_pixel: median_mm_per_pixel(&scene, &r),
        pixels,
        noise: s.noise,
        with_factors: kernel.factors.is_some(),
        shipped: row(&kernel.label, s),
        no_blur: row("no blur", n),
        gap: std::array::from_fn(|c| n.rel_rms[c] - s.rel_rms[c]),
        gap_sigma,
        events: r.info.events,
        render_seconds: r.info.seconds,
        exposure: scorer.exposure(),
        images: PreviewImages {
            shipped_diff: window_diff(&shipped, &path_traced),
            no_blur_diff: window_diff(&irradiance, &path_traced),
            window_noise: image(w, window_mean(&r.stderr, w, w, true)),
            path_traced,
            shipped,
            no_blur: irradiance,
        },
    })
}
