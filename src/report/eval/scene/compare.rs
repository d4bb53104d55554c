//! The error of screen-space subsurface scattering itself: every kernel
//! model run through the screen-space pass on a path-traced scene's
//! G-buffer, against the path-traced image (the evaluation layer; tables
//! and the contact sheet at the end).
//!
//! # Definitions
//!
//! - Input of the pass: the G-buffer's irradiance / pi x R_d (the
//!   convention of `ssskit apply`), its linear depth, the scene's camera:
//!   perspective scale per pixel (Freude 2014, eq. 4.11, with `sss_width`
//!   = scene units per millimetre) or the orthographic footprint.
//! - Variants per kernel model, each with the model's real-time tap table
//!   (the first tap count): `depth` (scaled by depth, no lerp) and
//!   `depth+follow` (with the depth-aware lerp of Freude 2014, eq. 4.12,
//!   complete at a depth difference of `follow_mm`). Baselines: `no-blur`
//!   (the irradiance itself: a Lambertian surface with albedo R_d) and
//!   `exact-2d` (the exact 2D convolution with the profile at the
//!   footprint of the object's median depth, one scale for the image:
//!   what `apply --reference` gives).
//! - Regions, over the pixels that see an object (coverage > 0), from the
//!   G-buffer's normal N, the first directional light's direction L and
//!   the direction V to the camera: lit (N.L >= [`TERMINATOR_BAND`]),
//!   unlit (N.L <= -[`TERMINATOR_BAND`]), terminator (|N.L| below it),
//!   grazing view (N.V < [`GRAZING_VIEW`]), and all. Without a directional
//!   light only `all` and `grazing` are filled.
//! - Errors per region and channel: relative RMS = RMS of (pass - path
//!   traced) over the region / the peak, the peak being the 99th
//!   percentile of the path-traced radiance over the seen pixels (robust
//!   to its noise); bias = mean(pass - path traced) / mean(path traced)
//!   over the region; noise = RMS of the path-traced image's standard
//!   error over the region / the peak (the floor under the RMS: the
//!   expected RMS is the root of the sum of squares of the true error and
//!   the noise); FLIP = the mean over the region of the per-pixel
//!   LDR-FLIP map of the colour images, tone-mapped as in
//!   [`crate::report::eval::evaluate`] with the exposure taken from the path-traced
//!   image.
//! - Flat-plane errors beside them: the same kernels on the edge and
//!   shapes signals at the object's footprint ([`crate::report::eval::compare::kernel`]),
//!   tap table, largest relative RMS over the channels.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::pass::{scale_of, screen_space_pass, SceneRow};
use super::score::{cosines, masks_of, ranking, Cosines, Scorer};
use crate::error::{finite_positive, Error, Result};
use crate::filter::signals::Signal;
use crate::filter::{angular, exact, taps_for, FollowSurface, Image, Plane, Which};
use crate::kernel::angular::AngularFactors;
use crate::numerics::Bounded;
use crate::profile::Profile;
use crate::progress::Progress;
use crate::report::eval::compare;
use crate::report::eval::compare::kernel::{Comparison, Config, Fitted, MaterialInput};
use crate::report::eval::evaluate::{ImageCase, Options};
use crate::scene::{Render, Scene};
use serde::{Deserialize, Serialize};

/// What to compare.
#[derive(Clone, Debug)]
pub struct SceneConfig {
    /// Kernel model families (see [`compare::kernel::FAMILIES`]).
    pub families: Vec<String>,
    /// SVD ranks and Gaussian counts.
    pub ranks: Vec<usize>,
    /// Tap counts; the first is the table the pass runs.
    pub taps: Vec<usize>,
    pub options: Options,
    /// Depth difference (mm) at which the depth-aware lerp reaches the
    /// centre colour; None: the radius holding 99% of the profile's R_d
    /// (the largest over the channels), the kernel's reach.
    pub follow_mm: Option<f64>,
    /// Side of the flat-plane test signals, pixels.
    pub signal_size: usize,
    /// Keep every variant's image (contact sheet).
    pub keep_images: bool,
    /// Entry and exit factors to apply around the pass (extra rows), when
    /// the scene allows them ([`angular_obstacle`]).
    pub angular: Option<AngularFactors>,
    /// The light-space directional method's block (None: not run).
    pub directional: Option<super::directional::DirectionalConfig>,
}

/// Everything a scene comparison produced.
#[derive(Clone, Debug)]
pub struct SceneComparison {
    /// Millimetres per pixel at the object's median depth (the flat-plane
    /// signals' scale and the exact baseline's).
    pub mm_per_pixel: f64,
    /// The lerp's depth difference, mm, and the constant C of the
    /// screen-space pass that gives it.
    pub follow_mm: f64,
    pub follow_constant: f64,
    /// The path-traced image's noise (as the render measured it).
    pub noise: [f64; 3],
    /// The angular factors the rows used, and why the scene allows none
    /// ([`angular_obstacle`]).
    pub angular: Option<AngularFactors>,
    pub angular_note: Option<String>,
    pub rows: Vec<SceneRow>,
    /// The flat-plane comparison of the same kernels.
    pub flat: Comparison,
    /// The path-traced image, and each row's image when kept.
    pub truth: Image,
    pub images: Vec<(String, Image)>,
    /// The exposure the images are shown at (the scoring's tone mapping)
    /// and the path-traced image's peak, its largest channel.
    pub exposure: f64,
    pub peak: f64,
    /// Which error dominates ([`dominance`]).
    pub dominance: Option<Dominance>,
    /// The light-space directional method beside the screen-space passes,
    /// or why the scene allows it none.
    pub directional: Option<std::result::Result<super::directional::DirectionalBlock, String>>,
}

/// The constant C of the depth-aware lerp that completes it at a depth
/// difference of `follow_mm` millimetres: the lerp factor is linear in C
/// (`FollowSurface::rate`) and compares depths in scene units.
pub fn follow_constant(scene: &Scene, follow_mm: f64) -> f64 {
    let per_scene_unit = scene.unit.mm() / follow_mm;
    per_scene_unit / FollowSurface::InSceneUnits(1.0).rate(&scale_of(scene))
}

/// Refuses a render that is not of `scene`'s camera, a scene of several
/// materials (one kernel for the image) and a camera that sees nothing.
fn check_scene(scene: &Scene, render: &Render) -> Result<()> {
    let (w, h) = (render.width, render.height);
    if (w, h) != (scene.camera.width, scene.camera.height) {
        return Err(Error::Unsupported(format!(
            "the render is {w}x{h} but the scene's camera is {}x{}",
            scene.camera.width, scene.camera.height
        )));
    }
    if let Some(o) = scene
        .objects
        .iter()
        .find(|o| o.material != scene.objects[0].material)
    {
        return Err(Error::Unsupported(format!(
            "{}: the screen-space comparison applies one kernel: every object must be of one \
             material ({} is {}, {} is {})",
            scene.origin,
            scene.objects[0].name,
            scene.objects[0].material.name,
            o.name,
            o.material.name
        )));
    }
    if !render.gbuffer.coverage.iter().any(|&c| c > 0.0) {
        return Err(Error::Unsupported(format!(
            "{}: the camera sees no object",
            scene.origin
        )));
    }
    Ok(())
}

/// Millimetres per pixel at the seen objects' median depth.
pub fn median_mm_per_pixel(scene: &Scene, render: &Render) -> f64 {
    let g = &render.gbuffer;
    let mut depths: Vec<f64> = (0..g.depth.len())
        .filter(|&i| g.coverage[i] > 0.0)
        .map(|i| g.depth[i])
        .collect();
    depths.sort_by(f64::total_cmp);
    scene
        .camera
        .mm_per_pixel_at(depths[depths.len() / 2] * scene.unit.mm())
}

/// The lerp's depth difference: the configured one, or the radius holding
/// 99% of R_d (largest over the channels).
fn follow_mm_of(cfg: &SceneConfig, profile: &Profile) -> Result<f64> {
    match cfg.follow_mm {
        Some(f) => finite_positive("scene comparison", "follow_mm", f, ""),
        None => Ok(kernel_reach_mm(profile)),
    }
}

/// The radius holding 99% of the profile's R_d, the largest over the
/// channels: the kernel's reach, where the depth-aware lerp completes by
/// default.
pub fn kernel_reach_mm(profile: &Profile) -> f64 {
    (0..profile.channels.len())
        .map(|c| crate::profile::radius_holding(profile, c, 0.99))
        .fold(0.0, f64::max)
}

/// Why the angular factors cannot be applied to `scene` (None: they can):
/// the entry factor weighs one collimated light's N.L, so the G-buffer's
/// irradiance must come from exactly one directional light.
pub fn angular_obstacle(scene: &Scene) -> Option<String> {
    let directional = scene.directional().count();
    (directional != 1 || scene.lights.len() != 1).then(|| {
        format!(
            "{}: the angular factors need one directional light and no other (the scene has {} \
             light(s), {} directional)",
            scene.origin,
            scene.lights.len(),
            directional
        )
    })
}

/// The path-traced image, the irradiance input and what every variant is
/// scored with.
struct Stage<'a> {
    scene: &'a Scene,
    cfg: &'a SceneConfig,
    scorer: Scorer<'a>,
    irradiance: Image,
    depth: Plane,
    cosines: Cosines,
    /// The factors when the scene allows them.
    angular: Option<&'a AngularFactors>,
    rows: Vec<SceneRow>,
    images: Vec<(String, Image)>,
}

impl Stage<'_> {
    fn push(&mut self, label: &str, variant: &str, flat: [Option<f64>; 2], img: Image) {
        let row = SceneRow {
            label: label.into(),
            variant: variant.into(),
            flat_edge: flat[0],
            flat_shapes: flat[1],
            regions: self.scorer.score(&img),
        };
        if self.cfg.keep_images {
            self.images.push((row.name(), img));
        }
        self.rows.push(row);
    }

    /// `blur` of the irradiance, and with an angular factor table: the
    /// blur of the entry-weighted irradiance, weighted by the exit factor.
    fn around(&self, f: &AngularFactors, blur: &dyn Fn(&Image) -> Result<Image>) -> Result<Image> {
        let nl = self.cosines.n_dot_l.as_deref().unwrap_or(&[]);
        let lit = angular::entry_weighted(&self.irradiance, nl, f)?;
        angular::exit_weighted(&blur(&lit)?, &self.cosines.n_dot_v, f)
    }

    /// The baselines: no blur, the exact flat 2D convolution and, with the
    /// angular factors, the exact convolution with each of them and both.
    fn baselines(&mut self, profile: &Profile, mm_per_pixel: f64) -> Result<()> {
        let irr = self.irradiance.clone();
        self.push("no-blur", "baseline", [None, None], irr);
        let k = exact::reference_kernel(profile, mm_per_pixel)?;
        exact::check_reference_fits(self.irradiance.width, self.irradiance.height, k.size)?;
        let exact = |img: &Image| Ok(exact::convolve_2d(img, &k));
        let plain = exact(&self.irradiance)?;
        self.push("exact-2d", "baseline", [None, None], plain.clone());
        if let Some(f) = self.angular {
            // `around` with the entry blur kept: one convolution each.
            let nl = self.cosines.n_dot_l.as_deref().unwrap_or(&[]);
            let entry = exact(&angular::entry_weighted(&self.irradiance, nl, f)?)?;
            let both = angular::exit_weighted(&entry, &self.cosines.n_dot_v, f)?;
            self.push("exact-2d", "entry", [None, None], entry);
            let exit = angular::exit_weighted(&plain, &self.cosines.n_dot_v, f)?;
            self.push("exact-2d", "exit", [None, None], exit);
            self.push("exact-2d", "entry+exit", [None, None], both);
        }
        Ok(())
    }

    /// One fitted model's variants: depth scale, with the lerp, and with
    /// the lerp inside the angular factors.
    fn model(&mut self, f: &Fitted, flat: [Option<f64>; 2], follow_c: f64) -> Result<()> {
        let label = &f.spec.label;
        let passes = taps_for(&f.kernel, Which::stored(&f.kernel), None)?;
        let (scene, depth) = (self.scene, self.depth.clone());
        let pass = move |img: &Image, follow: Option<f64>, variant: &str| {
            screen_space_pass(scene, &depth, &passes, img, follow)
                .map_err(|e| Error::Unsupported(format!("{label} ({variant}): {e}")))
        };
        for (variant, follow) in [("depth", None), ("depth+follow", Some(follow_c))] {
            let img = pass(&self.irradiance, follow, variant)?;
            self.push(label, variant, flat, img);
        }
        if let Some(a) = self.angular {
            const VARIANT: &str = "depth+follow+angular";
            let img = self.around(a, &|i: &Image| pass(i, Some(follow_c), VARIANT))?;
            self.push(label, VARIANT, flat, img);
        }
        Ok(())
    }
}

impl Stage<'_> {
    /// The light-space directional block (its own module); its images join
    /// the contact sheet. A scene the method refuses (an environment
    /// light, a material outside the dipole) gets the reason instead.
    fn directional(
        &mut self,
        profile: &Profile,
        render: &Render,
        flat: &Comparison,
        follow_c: f64,
        cfg: &super::directional::DirectionalConfig,
    ) -> std::result::Result<super::directional::DirectionalBlock, String> {
        let nl = self.cosines.n_dot_l.as_deref().unwrap_or(&[]);
        let inputs = super::directional::SceneInputs {
            scene: self.scene,
            render,
            profile,
            scorer: &self.scorer,
            irradiance: &self.irradiance,
            depth: &self.depth,
            follow_c,
            angular: self
                .angular
                .map(|f| (nl, self.cosines.n_dot_v.as_slice(), f)),
            kernels: flat
                .fitted
                .iter()
                .map(|f| (f.spec.label.as_str(), &f.kernel))
                .collect(),
        };
        let (block, images) = super::directional::directional_block(&inputs, cfg, &self.rows)
            .map_err(|e| e.to_string())?;
        if self.cfg.keep_images {
            self.images.extend(images);
        }
        Ok(block)
    }
}

/// The largest flat-plane relative RMS over the channels of `label`'s tap
/// table (`taps` taps) on `signal`, None unless all three channels have one.
fn flat_error(flat: &Comparison, label: &str, signal: &str, taps: usize) -> Option<f64> {
    let three: Vec<f64> = flat
        .rows
        .iter()
        .filter(|r| r.label == label)
        .filter_map(|r| r.image_error(signal, Which::Taps(taps)))
        .map(|e| e.rel_rms)
        .collect();
    (three.len() == 3).then(|| three.into_iter().fold(0.0, f64::max))
}

/// The flat-plane comparison that fits the kernels, on the edge and shapes
/// signals at the scene's footprint.
fn flat_comparison(
    scene: &Scene,
    profile: &Profile,
    cfg: &SceneConfig,
    mm_per_pixel: f64,
    progress: &dyn Progress,
) -> Result<Comparison> {
    let cases = [Signal::Edge, Signal::Shapes]
        .into_iter()
        .map(|s| ImageCase::signal(s, cfg.signal_size, mm_per_pixel))
        .collect::<Result<Vec<_>>>()?;
    compare::kernel::run(
        &[MaterialInput {
            name: scene.objects[0].material.name.clone(),
            profile: profile.clone(),
        }],
        &Config {
            families: cfg.families.clone(),
            ranks: cfg.ranks.clone(),
            cases,
            taps: cfg.taps.clone(),
            options: cfg.options,
            keep: None,
            extent_mm: None,
        },
        progress,
    )
}

/// Runs the comparison on a rendered scene whose objects share the
/// material of `profile`.
pub fn compare_scene(
    scene: &Scene,
    render: &Render,
    profile: &Profile,
    cfg: &SceneConfig,
    progress: &dyn Progress,
) -> Result<SceneComparison> {
    check_scene(scene, render)?;
    let (w, h) = (render.width, render.height);
    let g = &render.gbuffer;
    let mm_per_pixel = median_mm_per_pixel(scene, render);
    let follow_mm = follow_mm_of(cfg, profile)?;
    let follow_c = follow_constant(scene, follow_mm);
    let flat = flat_comparison(scene, profile, cfg, mm_per_pixel, progress)?;
    let truth = Image {
        width: w,
        height: h,
        rgb: render.radiance.clone(),
        alpha: None,
    };
    let cos = cosines(scene, render);
    let masks = masks_of(&cos, &g.coverage);
    let angular_note = angular_obstacle(scene);
    let mut stage = Stage {
        scene,
        cfg,
        scorer: Scorer::new(&truth, &render.stderr, masks, cfg.options.pixels_per_degree),
        irradiance: Image {
            width: w,
            height: h,
            rgb: g.irradiance.clone(),
            alpha: None,
        },
        depth: Plane {
            width: w,
            height: h,
            data: g.depth.clone(),
        },
        cosines: cos,
        angular: cfg.angular.as_ref().filter(|_| angular_note.is_none()),
        rows: Vec::new(),
        images: Vec::new(),
    };
    stage.baselines(profile, mm_per_pixel)?;
    let stored = cfg.taps.first().copied().unwrap_or(17);
    for f in &flat.fitted {
        let label = &f.spec.label;
        if !flat.rows.iter().any(|r| &r.label == label) {
            return Err(Error::Unsupported(format!("no flat-plane row for {label}")));
        }
        let errs = ["edge", "shapes"].map(|s| flat_error(&flat, label, s, stored));
        stage.model(f, errs, follow_c)?;
    }
    let directional = cfg
        .directional
        .as_ref()
        .map(|d| stage.directional(profile, render, &flat, follow_c, d));
    let exposure = stage.scorer.exposure();
    let (rows, images) = (stage.rows, stage.images);
    let peak = truth.peak().iter().cloned().fold(0.0f64, f64::max);
    let mut cmp = SceneComparison {
        mm_per_pixel,
        follow_mm,
        follow_constant: follow_c,
        noise: render.info.noise,
        angular: stage.angular.cloned(),
        angular_note,
        rows,
        flat,
        truth,
        images,
        exposure,
        peak,
        dominance: None,
        directional,
    };
    cmp.dominance = dominance(&cmp);
    Ok(cmp)
}

/// Which error dominates on the scene: the best kernel model's (with the
/// lerp) screen-space error against the path-traced image, beside its
/// error on the flat plane at the same footprint (the error `advise`
/// minimises), and the exact flat kernel's screen-space error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dominance {
    pub best_label: String,
    /// Largest relative RMS over the channels, all seen pixels.
    pub best_scene_rms: f64,
    /// Largest of its edge and shapes flat-plane errors.
    pub best_flat_rms: f64,
    pub exact_scene_rms: f64,
    pub mm_per_pixel: f64,
    /// The best model with the angular factors around the pass, and its
    /// relative RMS (None without angular rows).
    #[serde(default)]
    pub angular_label: Option<String>,
    #[serde(default)]
    pub angular_scene_rms: Option<f64>,
    /// The unblurred irradiance's relative RMS (worst channel).
    #[serde(default)]
    pub no_blur_scene_rms: Option<f64>,
    /// Why there are no angular rows, where there are none.
    #[serde(default)]
    pub angular_note: Option<String>,
}

impl Dominance {
    /// The ranking first ([`ranking`]): no blur, the best screen-space pass
    /// (depth+follow) without the factors, the best with them.
    pub fn headline(&self) -> Option<String> {
        Some(ranking(
            self.no_blur_scene_rms?,
            (
                &format!("{} (depth+follow)", self.best_label),
                self.best_scene_rms,
            ),
            self.angular_label.as_deref().zip(self.angular_scene_rms),
            self.angular_note
                .as_deref()
                .unwrap_or("the comparison ran without them"),
        ))
    }

    pub fn sentence(&self) -> String {
        format!(
            "Best kernel model on the scene: {} at {:.2}% RMS of the peak against the path-traced \
             image, where its flat-plane error at {:.3} mm per pixel is {:.2}%; the exact flat \
             kernel: {:.2}%. {}",
            self.best_label,
            Bounded(100.0 * self.best_scene_rms),
            self.mm_per_pixel,
            Bounded(100.0 * self.best_flat_rms),
            Bounded(100.0 * self.exact_scene_rms),
            if self.best_scene_rms > self.best_flat_rms {
                format!(
                    "The screen-space model's own error dominates, {:.1} times the kernel's.",
                    self.best_scene_rms / self.best_flat_rms.max(1e-12)
                )
            } else {
                "The kernel's error dominates.".to_string()
            }
        ) + &match (&self.angular_label, self.angular_scene_rms) {
            (Some(l), Some(a)) => format!(
                " With the angular entry and exit factors around the pass: {l} at {:.2}%, {:.2} \
                 times less than the best without.",
                Bounded(100.0 * a),
                self.best_scene_rms / a.max(1e-12)
            ),
            _ => String::new(),
        }
    }
}

/// [`Dominance`] of a comparison (None without kernel rows).
pub fn dominance(cmp: &SceneComparison) -> Option<Dominance> {
    let rms = |r: &SceneRow| {
        r.region("all")
            .map(|a| a.rel_rms.iter().cloned().fold(0.0, f64::max))
    };
    let best_of = |variant: &str| {
        cmp.rows
            .iter()
            .filter(|r| r.variant == variant)
            .filter_map(|r| Some((r, rms(r)?)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let best = best_of("depth+follow")?;
    let angular = best_of("depth+follow+angular");
    let exact = cmp
        .rows
        .iter()
        .find(|r| r.label == "exact-2d" && r.variant == "baseline")
        .and_then(rms)?;
    Some(Dominance {
        best_label: best.0.label.clone(),
        best_scene_rms: best.1,
        best_flat_rms: best
            .0
            .flat_edge
            .unwrap_or(0.0)
            .max(best.0.flat_shapes.unwrap_or(0.0)),
        exact_scene_rms: exact,
        mm_per_pixel: cmp.mm_per_pixel,
        angular_label: angular.map(|a| format!("{} (depth+follow)", a.0.label)),
        angular_scene_rms: angular.map(|a| a.1),
        no_blur_scene_rms: cmp
            .rows
            .iter()
            .find(|r| r.label == "no-blur" && r.variant == "baseline")
            .and_then(rms),
        angular_note: cmp.angular_note.clone(),
    })
}
