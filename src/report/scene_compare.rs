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
//!   [`super::evaluate`] with the exposure taken from the path-traced
//!   image.
//! - Flat-plane errors beside them: the same kernels on the edge and
//!   shapes signals at the object's footprint ([`super::kernel_compare`]),
//!   tap table, largest relative RMS over the channels.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::evaluate::{exposure_of, flip_map, tone_map, ImageCase, Options};
use super::kernel_compare::{self, Comparison, Config, Factor, MaterialInput};
use super::table::Table;
use crate::error::{Error, Result};
use crate::filter::signals::Signal;
use crate::filter::{cpu, taps_for, Factors, FollowSurface, Image, Plane, Scale, Setup};
use crate::profile::Profile;
use crate::progress::Progress;
use crate::scene::{Projection, Render, Scene};
use serde::{Deserialize, Serialize};

/// Half-width of the terminator band in N.L.
pub const TERMINATOR_BAND: f64 = 0.2;
/// N.V below which a pixel is seen at a grazing angle.
pub const GRAZING_VIEW: f64 = 0.3;
/// The regions, in table order.
pub const REGIONS: [&str; 5] = ["all", "lit", "unlit", "terminator", "grazing"];

/// What to compare.
#[derive(Clone, Debug)]
pub struct SceneConfig {
    /// Kernel model families (see [`kernel_compare::FAMILIES`]).
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
}

/// One region's errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionError {
    pub region: String,
    pub pixels: usize,
    pub rel_rms: [f64; 3],
    pub bias: [f64; 3],
    pub noise: [f64; 3],
    pub flip: f64,
}

/// One variant of one model on the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneRow {
    /// The model's label in the flat-plane comparison ("svd1", ...), or the
    /// baseline's name.
    pub label: String,
    /// "depth", "depth+follow", or "baseline".
    pub variant: String,
    /// Flat-plane relative RMS (largest over channels) on the edge and
    /// shapes signals with the same tap table; None for the baselines.
    pub flat_edge: Option<f64>,
    pub flat_shapes: Option<f64>,
    /// In [`REGIONS`] order.
    pub regions: Vec<RegionError>,
}

impl SceneRow {
    pub fn region(&self, name: &str) -> Option<&RegionError> {
        self.regions.iter().find(|r| r.region == name)
    }

    /// "label" or "label, variant".
    pub fn name(&self) -> String {
        if self.variant == "baseline" {
            self.label.clone()
        } else {
            format!("{} ({})", self.label, self.variant)
        }
    }
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
    pub rows: Vec<SceneRow>,
    /// The flat-plane comparison of the same kernels.
    pub flat: Comparison,
    /// The path-traced image, and each row's image when kept.
    pub truth: Image,
    pub images: Vec<(String, Image)>,
}

/// The screen-space pass's scale for the scene's camera: perspective with
/// `sss_width` = scene units per millimetre, or the orthographic footprint.
pub fn scale_of(scene: &Scene) -> Scale {
    match scene.camera.projection {
        Projection::Perspective { fov_y_deg } => Scale::Perspective {
            fov_y_deg,
            sss_width: 1.0 / scene.unit.mm(),
        },
        Projection::Orthographic { mm_per_pixel } => Scale::MmPerPixel(mm_per_pixel),
    }
}

/// The constant C of the depth-aware lerp that completes it at a depth
/// difference of `follow_mm` millimetres: the lerp factor is linear in C
/// (`FollowSurface::rate`) and compares depths in scene units.
pub fn follow_constant(scene: &Scene, follow_mm: f64) -> f64 {
    let per_scene_unit = scene.unit.mm() / follow_mm;
    per_scene_unit / FollowSurface::InSceneUnits(1.0).rate(&scale_of(scene))
}

/// Masks of the regions (see the module's definitions), in [`REGIONS`]
/// order.
pub fn region_masks(scene: &Scene, render: &Render) -> Vec<Vec<bool>> {
    let (w, h) = (render.width, render.height);
    let g = &render.gbuffer;
    let light = scene.directional().next().map(|(d, _)| d);
    let mut masks = vec![vec![false; w * h]; REGIONS.len()];
    for i in 0..w * h {
        if !(g.coverage[i] > 0.0) {
            continue;
        }
        let n = crate::scene::V3::new(g.normal[0][i], g.normal[1][i], g.normal[2][i]);
        let v = -scene
            .camera
            .ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5)
            .d;
        masks[0][i] = true;
        if let Some(l) = light {
            let nl = n.dot(&l);
            masks[1][i] = nl >= TERMINATOR_BAND;
            masks[2][i] = nl <= -TERMINATOR_BAND;
            masks[3][i] = nl.abs() < TERMINATOR_BAND;
        }
        masks[4][i] = n.dot(&v) < GRAZING_VIEW;
    }
    masks
}

/// The 99th percentile of `v` over `mask` (0 when empty).
fn percentile99(v: &[f64], mask: &[bool]) -> f64 {
    let mut x: Vec<f64> = v
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|(&a, _)| a)
        .collect();
    if x.is_empty() {
        return 0.0;
    }
    x.sort_by(f64::total_cmp);
    x[((0.99 * x.len() as f64).ceil() as usize).clamp(1, x.len()) - 1]
}

/// Scores images against one path-traced truth.
struct Scorer<'a> {
    truth: &'a Image,
    stderr: &'a [Vec<f64>; 3],
    masks: Vec<Vec<bool>>,
    peak: [f64; 3],
    exposure: f64,
    truth_ldr: Vec<u8>,
    ppd: f32,
}

impl Scorer<'_> {
    fn score(&self, img: &Image) -> Vec<RegionError> {
        let ldr = tone_map(img, |i| {
            std::array::from_fn(|c| img.rgb[c][i] * self.exposure)
        });
        let map = flip_map(&self.truth_ldr, &ldr, img.width, img.height, self.ppd);
        REGIONS
            .iter()
            .zip(&self.masks)
            .map(|(name, mask)| {
                let idx: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
                let n = idx.len().max(1) as f64;
                let per = |f: &dyn Fn(usize, usize) -> f64| -> [f64; 3] {
                    std::array::from_fn(|c| idx.iter().map(|&i| f(c, i)).sum::<f64>() / n)
                };
                let sq = per(&|c, i| (img.rgb[c][i] - self.truth.rgb[c][i]).powi(2));
                let diff = per(&|c, i| img.rgb[c][i] - self.truth.rgb[c][i]);
                let mean = per(&|c, i| self.truth.rgb[c][i]);
                let var = per(&|c, i| self.stderr[c][i].powi(2));
                let empty = idx.is_empty();
                let nan_if = |v: f64| if empty { f64::NAN } else { v };
                RegionError {
                    region: name.to_string(),
                    pixels: idx.len(),
                    rel_rms: std::array::from_fn(|c| nan_if(sq[c].sqrt() / self.peak[c])),
                    bias: std::array::from_fn(|c| nan_if(diff[c] / mean[c])),
                    noise: std::array::from_fn(|c| nan_if(var[c].sqrt() / self.peak[c])),
                    flip: nan_if(idx.iter().map(|&i| map[i] as f64).sum::<f64>() / n),
                }
            })
            .collect()
    }
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
    let g = &render.gbuffer;
    let seen: Vec<usize> = (0..w * h).filter(|&i| g.coverage[i] > 0.0).collect();
    if seen.is_empty() {
        return Err(Error::Unsupported(format!(
            "{}: the camera sees no object",
            scene.origin
        )));
    }
    let mut depths: Vec<f64> = seen.iter().map(|&i| g.depth[i]).collect();
    depths.sort_by(f64::total_cmp);
    let median_mm = depths[depths.len() / 2] * scene.unit.mm();
    let mm_per_pixel = scene.camera.mm_per_pixel_at(median_mm);
    let follow_mm = match cfg.follow_mm {
        Some(f) if f > 0.0 && f.is_finite() => f,
        Some(f) => {
            return Err(Error::invalid(
                "scene comparison",
                "follow_mm",
                f,
                "must be finite and > 0",
            ))
        }
        None => (0..profile.channels.len())
            .map(|c| crate::profile::radius_holding(profile, c, 0.99))
            .fold(0.0, f64::max),
    };
    let follow_c = follow_constant(scene, follow_mm);
    // The flat-plane comparison fits the kernels.
    let cases = [Signal::Edge, Signal::Shapes]
        .into_iter()
        .map(|s| ImageCase::signal(s, cfg.signal_size, mm_per_pixel))
        .collect::<Result<Vec<_>>>()?;
    let flat = kernel_compare::run(
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
    )?;
    let truth = Image {
        width: w,
        height: h,
        rgb: render.radiance.clone(),
        alpha: None,
    };
    let irradiance = Image {
        width: w,
        height: h,
        rgb: g.irradiance.clone(),
        alpha: None,
    };
    let masks = region_masks(scene, render);
    let peak = std::array::from_fn(|c| percentile99(&truth.rgb[c], &masks[0]));
    let max_rgb: Vec<f64> = (0..w * h)
        .map(|i| (0..3).fold(0.0f64, |m, c| m.max(truth.rgb[c][i])))
        .collect();
    let exposure = exposure_of(&max_rgb);
    let truth_ldr = tone_map(&truth, |i| {
        std::array::from_fn(|c| truth.rgb[c][i] * exposure)
    });
    let scorer = Scorer {
        truth: &truth,
        stderr: &render.stderr,
        masks,
        peak,
        exposure,
        truth_ldr,
        ppd: cfg.options.pixels_per_degree as f32,
    };
    let scale = scale_of(scene);
    let depth = Plane {
        width: w,
        height: h,
        data: g.depth.clone(),
    };
    let mut rows = Vec::new();
    let mut images = Vec::new();
    let mut keep = |label: &str, img: Image| {
        if cfg.keep_images {
            images.push((label.to_string(), img));
        }
    };
    rows.push(SceneRow {
        label: "no-blur".into(),
        variant: "baseline".into(),
        flat_edge: None,
        flat_shapes: None,
        regions: scorer.score(&irradiance),
    });
    keep("no-blur", irradiance.clone());
    let k = cpu::reference_kernel(profile, mm_per_pixel)?;
    cpu::check_reference_fits(w, h, k.size)?;
    let exact = cpu::convolve_2d(&irradiance, &k);
    rows.push(SceneRow {
        label: "exact-2d".into(),
        variant: "baseline".into(),
        flat_edge: None,
        flat_shapes: None,
        regions: scorer.score(&exact),
    });
    keep("exact-2d", exact);
    let stored = cfg.taps.first().copied().unwrap_or(17);
    for f in &flat.fitted {
        let label = &f.spec.label;
        let row = flat
            .rows
            .iter()
            .find(|r| &r.label == label)
            .ok_or_else(|| Error::Unsupported(format!("no flat-plane row for {label}")))?;
        let flat_err = |signal: &str| -> Option<f64> {
            let three: Vec<f64> = flat
                .rows
                .iter()
                .filter(|r| r.label == row.label)
                .filter_map(|r| r.image_error(signal, Factor::Taps(stored)))
                .map(|e| e.rel_rms)
                .collect();
            (three.len() == 3).then(|| three.into_iter().fold(0.0, f64::max))
        };
        for (variant, follow) in [("depth", None), ("depth+follow", Some(follow_c))] {
            let setup = Setup {
                passes: taps_for(&f.kernel, Factors::Taps, None),
                scale,
                depth: Some(depth.clone()),
                strength: None,
                follow_surface: follow.map(FollowSurface::InSceneUnits),
                specular: None,
                jitter: false,
            };
            let img = cpu::apply_with(&irradiance, &setup, cpu::Precision::F64)
                .map_err(|e| Error::Unsupported(format!("{label} ({variant}): {e}")))?;
            rows.push(SceneRow {
                label: label.clone(),
                variant: variant.into(),
                flat_edge: flat_err("edge"),
                flat_shapes: flat_err("shapes"),
                regions: scorer.score(&img),
            });
            keep(&format!("{label} ({variant})"), img);
        }
    }
    Ok(SceneComparison {
        mm_per_pixel,
        follow_mm,
        follow_constant: follow_c,
        noise: render.info.noise,
        rows,
        flat,
        truth,
        images,
    })
}

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:.2}", 100.0 * v)
    } else {
        "-".into()
    }
}

fn rgb_pct(v: [f64; 3]) -> String {
    format!("{} / {} / {}", pct(v[0]), pct(v[1]), pct(v[2]))
}

/// Per row: flat-plane errors beside the scene's, over all seen pixels.
pub fn summary_table(cmp: &SceneComparison) -> Table {
    let mut t = Table::new(&[
        "model",
        "flat edge %",
        "flat shapes %",
        "scene RMS % (r / g / b)",
        "scene bias % (r / g / b)",
        "FLIP",
    ]);
    for r in &cmp.rows {
        let all = r.region("all");
        t.push(vec![
            r.name(),
            r.flat_edge.map_or("-".into(), pct),
            r.flat_shapes.map_or("-".into(), pct),
            all.map_or("-".into(), |a| rgb_pct(a.rel_rms)),
            all.map_or("-".into(), |a| rgb_pct(a.bias)),
            all.map_or("-".into(), |a| format!("{:.3}", a.flip)),
        ]);
    }
    t
}

/// Per row and region: the largest relative RMS over the channels and the
/// region's FLIP.
pub fn region_table(cmp: &SceneComparison) -> Table {
    let mut head = vec!["model".to_string()];
    for r in REGIONS {
        head.push(format!("{r} RMS %"));
        head.push(format!("{r} FLIP"));
    }
    let mut t = Table {
        header: head,
        rows: Vec::new(),
    };
    for r in &cmp.rows {
        let mut row = vec![r.name()];
        for name in REGIONS {
            match r.region(name) {
                Some(e) if e.pixels > 0 => {
                    row.push(pct(e.rel_rms.iter().cloned().fold(0.0, f64::max)));
                    row.push(format!("{:.3}", e.flip));
                }
                _ => {
                    row.push("-".into());
                    row.push("-".into());
                }
            }
        }
        t.push(row);
    }
    t
}

/// The path-traced image's noise per region (the floor under the RMS).
pub fn noise_table(cmp: &SceneComparison) -> Table {
    let mut t = Table::new(&["region", "pixels", "noise % (r / g / b)"]);
    if let Some(r) = cmp.rows.first() {
        for e in &r.regions {
            t.push(vec![
                e.region.clone(),
                e.pixels.to_string(),
                if e.pixels > 0 {
                    rgb_pct(e.noise)
                } else {
                    "-".into()
                },
            ]);
        }
    }
    t
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
}

impl Dominance {
    pub fn sentence(&self) -> String {
        format!(
            "Best kernel model on the scene: {} at {:.2}% RMS of the peak against the path-traced \
             image, where its flat-plane error at {:.3} mm per pixel is {:.2}%; the exact flat \
             kernel: {:.2}%. {}",
            self.best_label,
            100.0 * self.best_scene_rms,
            self.mm_per_pixel,
            100.0 * self.best_flat_rms,
            100.0 * self.exact_scene_rms,
            if self.best_scene_rms > self.best_flat_rms {
                format!(
                    "The screen-space model's own error dominates, {:.1} times the kernel's.",
                    self.best_scene_rms / self.best_flat_rms.max(1e-12)
                )
            } else {
                "The kernel's error dominates.".to_string()
            }
        )
    }
}

/// [`Dominance`] of a comparison (None without kernel rows).
pub fn dominance(cmp: &SceneComparison) -> Option<Dominance> {
    let rms = |r: &SceneRow| {
        r.region("all")
            .map(|a| a.rel_rms.iter().cloned().fold(0.0, f64::max))
    };
    let best = cmp
        .rows
        .iter()
        .filter(|r| r.variant == "depth+follow")
        .filter_map(|r| Some((r, rms(r)?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let exact = cmp
        .rows
        .iter()
        .find(|r| r.label == "exact-2d")
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
    })
}

/// Fraction of the path-traced peak shown as white in difference tiles.
pub const SCENE_DIFF_SCALE: f64 = 0.1;

/// A contact sheet: the path-traced image, then the baselines and each
/// model with the lerp (its image above |image - path traced|, white =
/// [`SCENE_DIFF_SCALE`] of the peak), one exposure for all.
pub fn contact_sheet(cmp: &SceneComparison, title: &str, out: &std::path::Path) -> Result<()> {
    use super::kernel_plots::{draw_sheet, to_rgb8, SheetTile};
    let truth = &cmp.truth;
    let max_rgb: Vec<f64> = (0..truth.len())
        .map(|i| (0..3).fold(0.0f64, |m, c| m.max(truth.rgb[c][i])))
        .collect();
    let exposure = exposure_of(&max_rgb);
    let peak = truth.peak().iter().cloned().fold(0.0f64, f64::max);
    let mut tiles = vec![SheetTile {
        label: "path traced".into(),
        top: to_rgb8(truth, exposure),
        bottom: None,
    }];
    for (label, img) in cmp
        .images
        .iter()
        .filter(|(l, _)| !l.contains('(') || l.ends_with("(depth+follow)"))
    {
        let d = crate::filter::diff::false_colour(truth, img, Some(SCENE_DIFF_SCALE * peak));
        tiles.push(SheetTile {
            label: label.replace(" (depth+follow)", ""),
            top: to_rgb8(img, exposure),
            bottom: Some(("difference".into(), to_rgb8(&d, 1.0))),
        });
    }
    let title = format!(
        "{title}: screen-space pass (depth + follow) above |pass - path traced| (white = {}% of \
         the peak)",
        100.0 * SCENE_DIFF_SCALE
    );
    draw_sheet(&tiles, (truth.width, truth.height), &title, out)
}
