//! The light-space directional method (Dal Corso et al. 2017;
//! [`crate::filter::light_space`]) on a path-traced scene, beside the
//! screen-space passes at equal samples per pixel, and which of them the
//! scene needs.
//!
//! # Definitions
//!
//! - Per sample count N (per pixel and channel, `--directional-spp`):
//!   the light-space pass (N samples per channel and light, one set per
//!   channel, light maps of `map_side` texels, the render's G-buffer
//!   positions per pixel); the separable pass of the best screen-space
//!   model (lowest RMS over all seen pixels with the depth-aware lerp) at
//!   T taps per pass, T the odd count nearest N / 2 (2 T samples); a disk
//!   kernel of N samples importance-sampled from the profile, accumulated
//!   over `frames` rotations as `advise` scores it. Both screen-space
//!   passes scale by depth with the lerp of `compare --scene`, and run
//!   inside the entry and exit factors where the scene allows them.
//! - Scores: [`super::score`]'s, against the path-traced image.
//! - Cost: samples each pixel reads per frame; the work per pixel (dipole
//!   evaluations of the light-space pass, taps read by the screen-space
//!   ones, over all pixels of the image); and milliseconds per megapixel
//!   of each pass on this machine's CPU (f64; the light maps' ray casting
//!   left out, a rasteriser's shadow pass): loaded-machine noise, to be
//!   read beside the work.
//! - Which method the scene needs: the light-space method when its error
//!   over the seen pixels (worst channel) is at most [`NEEDS_RATIO`] of
//!   the best screen-space pass's (every row of the comparison and the
//!   rows here), else screen-space scattering.

use super::pass::{screen_space_disk_pass, screen_space_pass, SceneRow};
use super::score::{RegionError, Scorer};
use crate::error::{Error, Result};
use crate::filter::light_space::{light_space_cpu, LightSpaceInput, LightSpaceSetup};
use crate::filter::{angular, Image, Plane};
use crate::kernel::angular::AngularFactors;
use crate::kernel::disk::RadiusPdf;
use crate::kernel::disk_fit::fit_disk;
use crate::numerics::Bounded;
use crate::profile::Profile;
use crate::report::eval::disk::DISK_SEED;
use crate::scene::{Render, Scene};
use serde::{Deserialize, Serialize};

/// The light-space method needs to bring the error to at most this share
/// of the best screen-space pass's to be worth its cost: a quarter less
/// error, well beyond the run-to-run spread of a rendered scene's noise
/// floor (a few tenths of a point) and the choice between kernel models.
pub const NEEDS_RATIO: f64 = 0.75;

/// The light-space method with the published dipole, and with the
/// dipole scaled per channel to the profile's total R_d at normal
/// incidence ([`total_ratio`]): a ssskit variant that keeps the model's
/// directional shape and takes the Monte Carlo's total, as the
/// screen-space kernels do.
pub const PUBLISHED: &str = "light-space directional dipole";
pub const CALIBRATED: &str = "light-space, dipole scaled to the profile's R_d";

/// The model's total R_d differing from the profile's by more than this
/// share is said in a warning: the method's error then starts with it.
pub const MODEL_TOTAL_WARNING: f64 = 0.1;

/// Per channel: the profile's total R_d (Monte Carlo) over the
/// directional dipole's at normal incidence on the scene's material (the
/// exact Fresnel moments the method uses, both with the entry
/// transmission).
pub fn total_ratio(scene: &Scene, profile: &Profile) -> Result<[f64; 3]> {
    use crate::profile::analytic::{self, Model, Options};
    use crate::profile::fresnel::FresnelMode;
    let m = &scene.objects[0].material;
    let all = crate::material::Channel::ALL;
    let grid = analytic::default_grid(m, &all)?;
    let opts = Options {
        fresnel: FresnelMode::Exact,
        channels: all.to_vec(),
    };
    let model = analytic::profile(m, Model::DirectionalDipole, &grid, &opts)?;
    Ok(std::array::from_fn(|c| {
        profile.total_rd[c] / model.total_rd[c]
    }))
}

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalConfig {
    /// Samples per pixel and channel of each run.
    pub samples: Vec<usize>,
    /// Light-map texels per side.
    pub map_side: usize,
    pub seed: u64,
    /// Frames the disk kernel accumulates.
    pub frames: u32,
}

/// One method at one sample count.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DirectionalRow {
    pub method: String,
    /// Samples each pixel reads per frame (per channel for the light-space
    /// pass).
    pub samples_per_pixel: usize,
    /// Dipole evaluations (light space) or taps read (screen space) per
    /// pixel of the image.
    pub work_per_pixel: f64,
    /// CPU milliseconds per megapixel on this machine (loaded: see the
    /// module docs).
    pub ms_per_megapixel: f64,
    /// In [`super::score::REGIONS`] order.
    pub regions: Vec<RegionError>,
}

impl DirectionalRow {
    /// The worst channel's relative RMS over all seen pixels.
    pub fn worst(&self) -> f64 {
        self.regions
            .first()
            .map_or(f64::NAN, |a| a.rel_rms.iter().cloned().fold(0.0, f64::max))
    }
}

/// The block of rows, and the verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DirectionalBlock {
    pub map_side: usize,
    pub rows: Vec<DirectionalRow>,
    /// Materials outside the model's comfort (`LightSpaceInput::warnings`).
    pub warnings: Vec<String>,
    /// The light-space method brings the error to NEEDS_RATIO of the best
    /// screen-space pass's or below.
    pub needs_light_space: bool,
    /// The first lines of the output: which method and what it buys.
    pub verdict: String,
}

/// What the block reads from the scene comparison.
pub(in crate::report::eval) struct SceneInputs<'a> {
    pub scene: &'a Scene,
    pub render: &'a Render,
    pub profile: &'a Profile,
    pub scorer: &'a Scorer<'a>,
    pub irradiance: &'a Image,
    pub depth: &'a Plane,
    pub follow_c: f64,
    /// N.L and N.V per pixel, and the factors, where the scene allows them.
    pub angular: Option<(&'a [f64], &'a [f64], &'a AngularFactors)>,
    /// The fitted kernels of the comparison by label.
    pub kernels: Vec<(&'a str, &'a crate::kernel::KernelFile)>,
}

/// The odd tap count nearest n / 2 (at least 3).
fn taps_for_samples(n: usize) -> usize {
    let t = (n / 2).max(3);
    if t % 2 == 1 {
        t
    } else {
        t + 1
    }
}

fn timed<T>(f: impl FnOnce() -> Result<T>) -> Result<(T, f64)> {
    let t0 = std::time::Instant::now();
    let v = f()?;
    Ok((v, t0.elapsed().as_secs_f64()))
}

impl SceneInputs<'_> {
    /// A screen-space pass inside the entry and exit factors where the
    /// scene allows them.
    fn around(&self, blur: &dyn Fn(&Image) -> Result<Image>) -> Result<Image> {
        match self.angular {
            Some((nl, nv, f)) => {
                let lit = angular::entry_weighted(self.irradiance, nl, f)?;
                angular::exit_weighted(&blur(&lit)?, nv, f)
            }
            None => blur(self.irradiance),
        }
    }

    fn row(
        &self,
        method: String,
        n: usize,
        work: f64,
        seconds: f64,
        img: &Image,
    ) -> DirectionalRow {
        let mp = (img.width * img.height) as f64 / 1e6;
        DirectionalRow {
            method,
            samples_per_pixel: n,
            work_per_pixel: work,
            ms_per_megapixel: 1e3 * seconds / mp,
            regions: self.scorer.score(img),
        }
    }

    /// The separable pass of `label` at `taps` taps per pass.
    fn separable(&self, label: &str, taps: usize) -> Result<(Image, f64, f64)> {
        let kernel = self
            .kernels
            .iter()
            .find(|(l, _)| *l == label)
            .map(|(_, k)| *k)
            .ok_or_else(|| Error::Unsupported(format!("no fitted kernel {label}")))?;
        let passes = crate::filter::taps_for(kernel, crate::filter::Which::Taps(taps), None)?;
        // Each rank runs a horizontal and a vertical pass.
        let taps_read: usize = 2 * passes.iter().map(|p| p.offsets_mm.len()).sum::<usize>();
        let (img, s) = timed(|| {
            self.around(&|i: &Image| {
                screen_space_pass(self.scene, self.depth, &passes, i, Some(self.follow_c))
            })
        })?;
        Ok((img, taps_read as f64, s))
    }

    /// The disk kernel of `n` samples, over `frames` rotations.
    fn disk(&self, n: usize, frames: u32) -> Result<(Image, f64)> {
        let k = fit_disk(self.profile, n, RadiusPdf::Widest)?;
        timed(|| {
            self.around(&|i: &Image| {
                screen_space_disk_pass(
                    self.scene,
                    self.depth,
                    &k,
                    (DISK_SEED, frames),
                    i,
                    Some(self.follow_c),
                )
            })
        })
    }
}

/// The rows and images of the light-space method and the screen-space
/// passes beside it at each sample count, and the verdict against
/// `screen` (the comparison's rows).
pub(in crate::report::eval) fn directional_block(
    inp: &SceneInputs,
    cfg: &DirectionalConfig,
    screen: &[SceneRow],
) -> Result<(DirectionalBlock, Vec<(String, Image)>)> {
    let most = cfg.samples.iter().copied().max().unwrap_or(0);
    let side = inp.render.info.config.gbuffer_side;
    let input = LightSpaceInput::new(inp.scene, cfg.map_side, side, most)?;
    let ratio = total_ratio(inp.scene, inp.profile)?;
    let mut warnings = input.warnings.clone();
    if ratio.iter().any(|r| (r - 1.0).abs() > MODEL_TOTAL_WARNING) {
        warnings.push(format!(
            "the directional dipole's total R_d at normal incidence is {:.2} / {:.2} / {:.2} \
             times the profile's (r / g / b): the published model has no albedo factor \
             (docs/analytic.md), and the light-space method inherits its total; the row \
             `{CALIBRATED}` scales it to the profile's",
            1.0 / ratio[0],
            1.0 / ratio[1],
            1.0 / ratio[2]
        ));
    }
    let rms = |r: &SceneRow| {
        r.region("all").map_or(f64::INFINITY, |a| {
            a.rel_rms.iter().cloned().fold(0.0, f64::max)
        })
    };
    let best = screen
        .iter()
        .filter(|r| r.variant.starts_with("depth+follow"))
        .min_by(|a, b| rms(a).total_cmp(&rms(b)))
        .ok_or_else(|| Error::Unsupported("no screen-space row to compare with".into()))?;
    let (mut rows, mut images) = (Vec::new(), Vec::new());
    let pixels = (inp.render.width * inp.render.height) as f64;
    for &n in &cfg.samples {
        let setup = LightSpaceSetup {
            samples: n,
            seed: cfg.seed,
        };
        let (img, s) = timed(|| light_space_cpu(&input, &setup))?;
        let work = input.evaluations(&setup) as f64 / pixels;
        rows.push(inp.row(PUBLISHED.into(), n, work, s, &img));
        let mut cal = img.clone();
        for (plane, k) in cal.rgb.iter_mut().zip(ratio) {
            plane.iter_mut().for_each(|v| *v *= k);
        }
        rows.push(inp.row(CALIBRATED.into(), n, work, s, &cal));
        images.push((format!("light space, {n} spp"), img));
        images.push((format!("light space calibrated, {n} spp"), cal));
        let t = taps_for_samples(n);
        let (img, taps, s) = inp.separable(&best.label, t)?;
        let what = format!("separable {} ({t} taps per pass)", best.label);
        rows.push(inp.row(what, taps as usize, taps, s, &img));
        let (img, s) = inp.disk(n, cfg.frames)?;
        let what = format!("disk ({} frames)", cfg.frames);
        rows.push(inp.row(what, n, n as f64, s, &img));
        images.push((format!("disk, {n} samples"), img));
    }
    let (needs, verdict) = verdict(&rows, (&best.name(), rms(best)), inp.angular.is_some());
    Ok((
        DirectionalBlock {
            map_side: cfg.map_side,
            rows,
            warnings,
            needs_light_space: needs,
            verdict,
        },
        images,
    ))
}

/// Which method the scene needs and what it buys (module docs): the first
/// light-space row against the best screen-space pass of the comparison
/// and of the block.
fn verdict(rows: &[DirectionalRow], best: (&str, f64), angular: bool) -> (bool, String) {
    let pct = |v: f64| Bounded(100.0 * v);
    let Some(ls) = rows
        .iter()
        .take(2)
        .filter(|r| r.method.starts_with("light-space"))
        .min_by(|a, b| a.worst().total_cmp(&b.worst()))
    else {
        return (false, String::new());
    };
    let (name, screen) = rows
        .iter()
        .filter(|r| !r.method.starts_with("light-space"))
        .map(|r| {
            (
                format!("{} at {} samples", r.method, r.samples_per_pixel),
                r.worst(),
            )
        })
        .chain(std::iter::once((best.0.to_string(), best.1)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((best.0.to_string(), best.1));
    let (l, s) = (ls.worst(), screen);
    let (ls_ms, ls_work) = (ls.ms_per_megapixel, ls.work_per_pixel);
    let factors = if angular {
        " (inside the entry and exit factors)"
    } else {
        ""
    };
    let needs = l <= NEEDS_RATIO * s;
    let sentence = if needs {
        format!(
            "This scene needs the light-space directional method (Dal Corso et al. 2017; \
             {}): at {} samples per pixel and channel it brings the worst channel's RMS against \
             the path-traced image from {:.2}% (the best screen-space pass, {name}{factors}) to \
             {:.2}%, {:.1} times less, for {:.0} dipole evaluations per pixel ({:.0} ms per \
             megapixel on this CPU).",
            ls.method,
            ls.samples_per_pixel,
            pct(s),
            pct(l),
            s / l.max(1e-12),
            ls_work,
            ls_ms
        )
    } else {
        format!(
            "Screen-space scattering is enough for this scene: the best screen-space pass \
             ({name}{factors}) is at {:.2}% RMS against the path-traced image, and the \
             light-space directional method (best variant: {}) at {} samples per pixel and \
             channel at {:.2}%, not below {:.0}% of it; it would cost {:.0} dipole evaluations \
             per pixel ({:.0} ms per megapixel on this CPU).",
            pct(s),
            ls.method,
            ls.samples_per_pixel,
            pct(l),
            100.0 * NEEDS_RATIO,
            ls_work,
            ls_ms
        )
    };
    (needs, sentence)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separable_taps_are_odd_and_near_half() {
        assert_eq!(taps_for_samples(34), 17);
        assert_eq!(taps_for_samples(32), 17);
        assert_eq!(taps_for_samples(2), 3);
        assert_eq!(taps_for_samples(100), 51);
    }
}
