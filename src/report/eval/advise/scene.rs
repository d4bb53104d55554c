//! The advice checked beyond the flat plane: each kernel model's answer
//! within the budget run through the screen-space pass on a path-traced
//! scene's G-buffer, against the path-traced image, so the user sees what
//! the chosen kernel gives on a scene next to the best the budget allows.
//!
//! # Definitions
//!
//! - Pixels scored: those whose centre ray meets an object of the advised
//!   material and that the G-buffer covers (occluders of another material
//!   may cast shadows into the image but not be seen in it).
//! - The pass: each configuration's own taps (as `advise` scored them),
//!   scaled per pixel by the depth (Freude 2014, eq. 4.11), with the
//!   depth-aware lerp (Freude 2014, eq. 4.12) completing at the kernel's
//!   reach ([`kernel_reach_mm`]): the `depth+follow` variant of
//!   `compare --scene`.
//! - Error per channel: RMS of (pass - path traced) over the scored pixels
//!   divided by the 99th percentile of the path-traced radiance there
//!   (`compare --scene`'s relative RMS); a configuration's scene error is
//!   its worst channel.
//! - With the entry and exit factors (Freude's blur assumes light that
//!   enters along the normal and leaves Lambertian; [`crate::kernel::angular`]):
//!   where the scene has one directional light and nothing else, each
//!   configuration is also run with the irradiance weighted by the entry
//!   factor at N.L before the pass and the result by the exit factor at
//!   N.V after it (`compare --scene`'s `depth+follow+angular`). The
//!   factors are the profile's own when it carries an angle-resolved
//!   record, else [`simulate_factors`] of its material
//!   ([`ANGULAR_PHOTONS`] photons per channel and incidence).
//! - Uncertainty of a difference: the path-traced image t carries a
//!   per-pixel standard error s; the standard deviation of RMS_a - RMS_b
//!   from it is [`rms_difference_sigma`]'s. The noise common to both
//!   scores cancels, so two kernels are told apart far below the render's
//!   own noise.
//! - Ranking: by the worst channel of what ships, the pass with the
//!   factors around it where the scene allows them (the kernel files carry
//!   them), else the bare pass.
//! - Verdicts: the gap (the chosen configuration's scene error less the
//!   best one's) is `significant` beyond [`NOISE_K`] of those standard
//!   deviations (the margin of the flat-plane decision,
//!   [`super::decide`]); it is `within_accepted` when it is at most
//!   the error the advice accepted on the flat plane (the target, or the
//!   chosen worst case where nothing within the budget meets it) plus that
//!   margin: a cheaper kernel is worth what it loses only up to the error
//!   the user asked for.

use super::decide::NOISE_K;
use crate::error::{Error, Result};
use crate::filter::{angular, Image, Plane, Taps};
use crate::kernel::angular::{simulate_factors, AngularFactors};
use crate::kernel::disk::DiskKernelFile;
use crate::profile::source::MC_SEED;
use crate::profile::Profile;
use crate::report::eval::disk::first_and_frames;
use crate::report::eval::scene::compare::angular_obstacle;
use crate::report::eval::scene::compare::{follow_constant, kernel_reach_mm, median_mm_per_pixel};
use crate::report::eval::scene::pass::{screen_space_disk_pass, screen_space_pass};
use crate::report::eval::scene::score::cosines;
use crate::report::eval::scene::score::{percentile99, ranking, rms_difference_sigma};
use crate::scene::{Render, Scene};
use serde::{Deserialize, Serialize};

/// One configuration run on the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneRow {
    /// The configuration (`Candidate::describe`).
    pub configuration: String,
    pub passes: usize,
    pub samples_per_pixel: usize,
    /// Relative RMS per channel against the path-traced image.
    pub rel_rms: [f64; 3],
    /// The worst channel's of what ships: with the factors where the
    /// scene allows them, else the bare pass (the ranking's score).
    pub worst: f64,
    /// Relative RMS per channel with the entry and exit factors around the
    /// pass (None: the scene's lights leave them nothing to weigh).
    pub rel_rms_with_factors: Option<[f64; 3]>,
}

/// The advice on a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneCheck {
    /// The scene's origin (its file).
    pub scene: String,
    /// Millimetres per pixel at the seen object's median depth.
    pub mm_per_pixel: f64,
    pub pixels: usize,
    /// The render's noise per channel (RMS standard error over its peak).
    pub noise: [f64; 3],
    /// Where the depth-aware lerp completes, mm, and the pass's constant C
    /// for it in scene units (`apply --follow-surface-scene-units C`).
    pub follow_mm: f64,
    pub follow_constant: f64,
    /// The unblurred irradiance's errors, for scale.
    pub no_blur: [f64; 3],
    /// The chosen configuration's errors without and with the entry and
    /// exit factors (the latter None where the scene allows none, with
    /// why), and where the factors came from.
    pub rms_without_factors: [f64; 3],
    pub rms_with_factors: Option<[f64; 3]>,
    pub factors: String,
    /// Each model's answer within the budget, and the chosen one.
    pub rows: Vec<SceneRow>,
    pub chosen: usize,
    /// The row with the lowest scene error.
    pub best: usize,
    /// Chosen's scene error less the best's.
    pub gap: f64,
    /// The standard deviation of that gap from the render's noise.
    pub gap_sigma: f64,
    /// gap > NOISE_K x gap_sigma: the best is really better.
    pub significant: bool,
    /// The flat-plane error the advice accepted: the target, or the chosen
    /// worst case where nothing within the budget meets it.
    pub accepted: f64,
    /// gap <= accepted + NOISE_K x gap_sigma.
    pub within_accepted: bool,
}

impl SceneCheck {
    /// The ranking of [`ranking`] over the rows: the unblurred irradiance,
    /// the best row without the factors and the best with them.
    pub fn headline(&self) -> String {
        let best_of = |f: &dyn Fn(&SceneRow) -> Option<[f64; 3]>| {
            self.rows
                .iter()
                .filter_map(|r| Some((r.configuration.as_str(), worst(f(r)?).1)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        let without = best_of(&|r| Some(r.rel_rms)).unwrap_or(("no row", f64::NAN));
        format!(
            "On the scene {} at {:.3} mm per pixel:\n{}",
            self.scene,
            self.mm_per_pixel,
            ranking(
                worst(self.no_blur).1,
                without,
                best_of(&|r| r.rel_rms_with_factors),
                &self.factors
            )
        )
    }

    /// One line: the chosen configuration's scene error, the best's, the
    /// gap with its uncertainty.
    pub fn sentence(&self) -> String {
        let (c, b) = (&self.rows[self.chosen], &self.rows[self.best]);
        let pct = |v: [f64; 3]| v.map(|x| format!("{:.2}", 100.0 * x)).join(" / ");
        let shipped = |r: &SceneRow| pct(r.rel_rms_with_factors.unwrap_or(r.rel_rms));
        let verdict = if self.chosen == self.best {
            "the best within the budget".to_string()
        } else {
            format!(
                "{:.3} +- {:.3} points behind the best within the budget ({}; {} at {}%), {} the \
                 {:.2}% the advice accepts{}",
                100.0 * self.gap,
                100.0 * self.gap_sigma,
                if self.significant {
                    "beyond the render's noise"
                } else {
                    "within the render's noise"
                },
                b.configuration,
                shipped(b),
                if self.within_accepted {
                    "within"
                } else {
                    "MORE than"
                },
                100.0 * self.accepted,
                if self.within_accepted {
                    ""
                } else {
                    ": the flat-plane signals do not rank these kernels as the scene does"
                }
            )
        };
        let factors = match self.rms_with_factors {
            Some(v) => format!(
                "; with the entry and exit factors ({}) {}%",
                self.factors,
                pct(v)
            ),
            None => format!("; no entry and exit factors: {}", self.factors),
        };
        format!(
            "on the scene {} ({:.3} mm per pixel, {} pixels, render noise {}%), RMS of the peak \
             (r / g / b): no blur {}%; {} without the entry and exit factors {}%{factors}; {verdict}",
            self.scene,
            self.mm_per_pixel,
            self.pixels,
            pct(self.noise),
            pct(self.no_blur),
            c.configuration,
            pct(c.rel_rms),
        )
    }
}

/// A configuration to run: its description, cost and pass.
pub struct SceneCandidate {
    pub configuration: String,
    pub passes: usize,
    pub samples_per_pixel: usize,
    pub pass: ScenePass,
}

/// What a configuration runs: separable taps as `advise` scored them, or
/// a disk kernel accumulated over the frames it records (those `advise`
/// scored it after, [`with_frames`](crate::report::eval::disk::with_frames)), as `apply` runs it by default.
pub enum ScenePass {
    Separable(Vec<Taps>),
    Disk(Box<DiskKernelFile>),
}

/// Photons per channel and incidence of the factors' run when the profile
/// has none: [`crate::kernel::angular::DEFAULT_PHOTONS`], standard errors
/// of 0.3-0.7% on the entry nodes and 1-3% on the exit nodes for skin.
pub const ANGULAR_PHOTONS: u64 = crate::kernel::angular::DEFAULT_PHOTONS;

/// The entry and exit factors for the scene and where they came from, or
/// None with why the scene allows none.
fn factors_for(scene: &Scene, profile: &Profile) -> Result<(Option<AngularFactors>, String)> {
    if let Some(why) = angular_obstacle(scene) {
        return Ok((None, why));
    }
    if crate::kernel::angular::left_out(profile) {
        return Ok((None, "left out by the caller: no factor run".into()));
    }
    if let Some(f) = AngularFactors::from_profile(profile)? {
        return Ok((Some(f), "the profile's own".into()));
    }
    // A run the Monte Carlo refuses (a material whose radial grid is too
    // fine for the angle-resolved tables) leaves the scene check without
    // the factors, said in the output, rather than without an answer.
    match simulate_factors(
        &profile.material,
        ANGULAR_PHOTONS,
        MC_SEED,
        None,
        &crate::progress::NoProgress,
    ) {
        Ok(f) => Ok((
            Some(f),
            format!("Monte Carlo, {ANGULAR_PHOTONS} photons per channel and incidence"),
        )),
        Err(e) => Ok((None, format!("their Monte Carlo run was refused: {e}"))),
    }
}

/// Which object each pixel's centre ray meets first (None: nothing).
fn seen_objects(scene: &Scene) -> Vec<Option<usize>> {
    let cam = &scene.camera;
    let mut seen = Vec::with_capacity(cam.width * cam.height);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let ray = cam.ray(x as f64 + 0.5, y as f64 + 0.5);
            seen.push(scene.nearest(&ray, f64::INFINITY).map(|(i, _)| i));
        }
    }
    seen
}

/// The pixels to score: covered, and their centre ray meets an object of
/// `profile`'s material; refuses a scene whose seen objects are of another
/// material, or whose render is not of its camera.
pub fn scored_pixels(scene: &Scene, render: &Render, profile: &Profile) -> Result<Vec<usize>> {
    if (render.width, render.height) != (scene.camera.width, scene.camera.height) {
        return Err(Error::Unsupported(format!(
            "the render is {}x{} but the scene's camera is {}x{}",
            render.width, render.height, scene.camera.width, scene.camera.height
        )));
    }
    let mut pixels = Vec::new();
    for (i, o) in seen_objects(scene).into_iter().enumerate() {
        let Some(o) = o else { continue };
        let object = &scene.objects[o];
        if object.material.name != profile.material.name {
            return Err(Error::Unsupported(format!(
                "{}: the camera sees {} ({}), but the advice is for {}: one kernel for the \
                 image, so every seen object must be of the advised material (occluders of \
                 another material may stay out of view)",
                scene.origin, object.name, object.material.name, profile.material.name
            )));
        }
        if render.gbuffer.coverage[i] > 0.0 {
            pixels.push(i);
        }
    }
    if pixels.is_empty() {
        return Err(Error::Unsupported(format!(
            "{}: the camera sees no object of {}",
            scene.origin, profile.material.name
        )));
    }
    Ok(pixels)
}

/// What each pass is scored against.
struct Truth<'a> {
    radiance: &'a [Vec<f64>; 3],
    stderr: &'a [Vec<f64>; 3],
    pixels: Vec<usize>,
    peak: [f64; 3],
}

impl<'a> Truth<'a> {
    /// The path-traced image on the pixels where `profile`'s object is
    /// seen, refused where it is black there.
    fn on(scene: &Scene, render: &'a Render, profile: &Profile) -> Result<Truth<'a>> {
        let pixels = scored_pixels(scene, render, profile)?;
        let truth = Truth {
            radiance: &render.radiance,
            stderr: &render.stderr,
            // The peak of `compare --scene`'s scores, over the scored pixels.
            peak: {
                let mut mask = vec![false; render.radiance[0].len()];
                pixels.iter().for_each(|&i| mask[i] = true);
                std::array::from_fn(|c| percentile99(&render.radiance[c], &mask))
            },
            pixels,
        };
        if truth.peak.iter().any(|&p| !(p > 0.0)) {
            return Err(Error::Unsupported(format!(
                "{}: the path-traced image is black where the object is seen",
                scene.origin
            )));
        }
        Ok(truth)
    }

    /// The best row (smallest worst channel), how far the chosen row lies
    /// above it and that gap's standard deviation: the gap's channel is
    /// the chosen one's worst, its uncertainty that of the difference on
    /// that channel.
    fn gap_to_best(&self, rows: &[SceneRow], images: &[Image], chosen: usize) -> (usize, f64, f64) {
        let best = (0..rows.len())
            .min_by(|&a, &b| rows[a].worst.total_cmp(&rows[b].worst))
            .unwrap_or(chosen);
        let gap = rows[chosen].worst - rows[best].worst;
        let ranked = |r: &SceneRow| r.rel_rms_with_factors.unwrap_or(r.rel_rms);
        let (wc, _) = worst(ranked(&rows[chosen]));
        let rms = [ranked(&rows[chosen])[wc], ranked(&rows[best])[wc]];
        let gap_sigma = self.gap_sigma(&images[chosen], &images[best], rms, wc);
        (best, gap, gap_sigma)
    }
    fn rel_rms(&self, img: &Image) -> [f64; 3] {
        let n = self.pixels.len() as f64;
        std::array::from_fn(|c| {
            let sq: f64 = self
                .pixels
                .iter()
                .map(|&i| (img.rgb[c][i] - self.radiance[c][i]).powi(2))
                .sum();
            (sq / n).sqrt() / self.peak[c]
        })
    }

    /// The standard deviation of RMS_a - RMS_b on channel `c` from the
    /// truth's noise (module docs).
    fn gap_sigma(&self, a: &Image, b: &Image, rms: [f64; 2], c: usize) -> f64 {
        let planes = [a.rgb[c].as_slice(), b.rgb[c].as_slice(), &self.stderr[c]];
        rms_difference_sigma(
            planes,
            self.pixels.iter().copied(),
            self.peak[c],
            rms[0] + rms[1],
        )
    }
}

fn worst(v: [f64; 3]) -> (usize, f64) {
    (0..3).fold((0, f64::NEG_INFINITY), |(bi, b), c| {
        if v[c] > b {
            (c, v[c])
        } else {
            (bi, b)
        }
    })
}

/// Runs `candidates` on the scene (`chosen` indexes them) and compares the
/// chosen one with the best.
pub fn check_on_scene(
    scene: &Scene,
    render: &Render,
    profile: &Profile,
    candidates: &[SceneCandidate],
    chosen: usize,
    accepted: f64,
) -> Result<SceneCheck> {
    if chosen >= candidates.len() {
        return Err(Error::Unsupported(
            "scene check: no chosen configuration".into(),
        ));
    }
    let truth = Truth::on(scene, render, profile)?;
    let (w, h) = (render.width, render.height);
    let irradiance = Image {
        width: w,
        height: h,
        rgb: render.gbuffer.irradiance.clone(),
        alpha: None,
    };
    let depth = Plane {
        width: w,
        height: h,
        data: render.gbuffer.depth.clone(),
    };
    let follow_mm = kernel_reach_mm(profile);
    let follow_c = follow_constant(scene, follow_mm);
    let (factors, factors_note) = factors_for(scene, profile)?;
    let cos = cosines(scene, render);
    let mut images = Vec::with_capacity(candidates.len());
    let mut rows = Vec::with_capacity(candidates.len());
    for c in candidates {
        let pass = |img: &Image| {
            match &c.pass {
                ScenePass::Separable(taps) => {
                    screen_space_pass(scene, &depth, taps, img, Some(follow_c))
                }
                ScenePass::Disk(kernel) => screen_space_disk_pass(
                    scene,
                    &depth,
                    kernel,
                    first_and_frames(kernel),
                    img,
                    Some(follow_c),
                ),
            }
            .map_err(|e| Error::Unsupported(format!("{} on the scene: {e}", c.configuration)))
        };
        let img = pass(&irradiance)?;
        let rel_rms = truth.rel_rms(&img);
        let factored = match &factors {
            Some(f) => {
                let nl = cos.n_dot_l.as_deref().unwrap_or(&[]);
                let lit = angular::entry_weighted(&irradiance, nl, f)?;
                Some(angular::exit_weighted(&pass(&lit)?, &cos.n_dot_v, f)?)
            }
            None => None,
        };
        let rel_rms_with_factors = factored.as_ref().map(|out| truth.rel_rms(out));
        rows.push(SceneRow {
            configuration: c.configuration.clone(),
            passes: c.passes,
            samples_per_pixel: c.samples_per_pixel,
            rel_rms,
            worst: worst(rel_rms_with_factors.unwrap_or(rel_rms)).1,
            rel_rms_with_factors,
        });
        // What ships is ranked: the pass with the factors where the scene
        // allows them (the kernel files carry them), else the bare pass.
        images.push(factored.unwrap_or(img));
    }
    let (best, gap, gap_sigma) = truth.gap_to_best(&rows, &images, chosen);
    Ok(SceneCheck {
        scene: scene.origin.clone(),
        mm_per_pixel: median_mm_per_pixel(scene, render),
        pixels: truth.pixels.len(),
        noise: render.info.noise,
        follow_mm,
        follow_constant: follow_c,
        no_blur: truth.rel_rms(&irradiance),
        rms_without_factors: rows[chosen].rel_rms,
        rms_with_factors: rows[chosen].rel_rms_with_factors,
        factors: factors_note,
        rows,
        chosen,
        best,
        gap,
        gap_sigma,
        significant: gap > NOISE_K * gap_sigma,
        accepted,
        within_accepted: gap <= accepted + NOISE_K * gap_sigma,
    })
}
