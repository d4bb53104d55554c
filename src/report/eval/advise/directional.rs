//! `advise --scene` with the light-space directional method: the method
//! ([`crate::report::eval::scene::directional`]'s two variants, published and scaled to
//! the profile's R_d) scored on the pixels and with the peak the advice
//! scores its kernels on ([`super::scene`]), beside what the advice
//! ships and the best within its budget, and which the scene needs
//! ([`crate::report::eval::scene::directional::NEEDS_RATIO`]).

use super::scene::{scored_pixels, SceneCheck};
use crate::error::Result;
use crate::filter::light_space::{light_space_cpu, LightSpaceInput, LightSpaceSetup};
use crate::filter::Image;
use crate::profile::Profile;
use crate::report::eval::scene::directional::{total_ratio, DirectionalConfig, NEEDS_RATIO};
use crate::report::eval::scene::score::percentile99;
use crate::scene::{Render, Scene};
use serde::{Deserialize, Serialize};

/// The method at one sample count on the advice's pixels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdviseDirectionalRow {
    /// Samples per pixel and channel.
    pub samples: usize,
    /// Relative RMS per channel, the published dipole and the dipole
    /// scaled to the profile's total R_d.
    pub rel_rms: [f64; 3],
    pub rel_rms_scaled: [f64; 3],
    /// Dipole evaluations per pixel and CPU ms per megapixel (this
    /// machine, loaded).
    pub evaluations_per_pixel: f64,
    pub ms_per_megapixel: f64,
}

/// The method on the advice's scene, and the verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdviseDirectional {
    pub rows: Vec<AdviseDirectionalRow>,
    /// The worst channel's error of what the advice ships on the scene,
    /// and of the best configuration within its budget.
    pub shipped: f64,
    pub best: f64,
    pub needs_light_space: bool,
    pub sentence: String,
}

fn worst(v: [f64; 3]) -> f64 {
    v.iter().cloned().fold(0.0, f64::max)
}

/// Runs the method on the scene of `check` (the advice's result there).
pub fn directional_on_advice(
    scene: &Scene,
    render: &Render,
    profile: &Profile,
    check: &SceneCheck,
    cfg: &DirectionalConfig,
) -> Result<AdviseDirectional> {
    let pixels = scored_pixels(scene, render, profile)?;
    let mut mask = vec![false; render.width * render.height];
    pixels.iter().for_each(|&i| mask[i] = true);
    let peak: [f64; 3] = std::array::from_fn(|c| percentile99(&render.radiance[c], &mask));
    let rms = |img: &Image| -> [f64; 3] {
        std::array::from_fn(|c| {
            let sq: f64 = pixels
                .iter()
                .map(|&i| (img.rgb[c][i] - render.radiance[c][i]).powi(2))
                .sum();
            (sq / pixels.len() as f64).sqrt() / peak[c]
        })
    };
    let most = cfg.samples.iter().copied().max().unwrap_or(1);
    let side = render.info.config.gbuffer_side;
    let input = LightSpaceInput::new(scene, cfg.map_side, side, most)?;
    let ratio = total_ratio(scene, profile)?;
    let mut rows = Vec::new();
    for &n in &cfg.samples {
        let setup = LightSpaceSetup {
            samples: n,
            seed: cfg.seed,
        };
        let t0 = std::time::Instant::now();
        let img = light_space_cpu(&input, &setup)?;
        let seconds = t0.elapsed().as_secs_f64();
        let mut scaled = img.clone();
        for (plane, k) in scaled.rgb.iter_mut().zip(ratio) {
            plane.iter_mut().for_each(|v| *v *= k);
        }
        let mp = (img.width * img.height) as f64 / 1e6;
        rows.push(AdviseDirectionalRow {
            samples: n,
            rel_rms: rms(&img),
            rel_rms_scaled: rms(&scaled),
            evaluations_per_pixel: input.evaluations(&setup) as f64 / (mp * 1e6),
            ms_per_megapixel: 1e3 * seconds / mp,
        });
    }
    let shipped = check.rows[check.chosen].worst;
    let best = check.rows[check.best].worst;
    let first = rows.first();
    let ls = first.map_or(f64::INFINITY, |r| {
        worst(r.rel_rms).min(worst(r.rel_rms_scaled))
    });
    let needs = ls <= NEEDS_RATIO * shipped.min(best);
    let sentence = match first {
        None => String::new(),
        Some(r) => format!(
            "Light-space directional method (Dal Corso et al. 2017) on the scene at {} samples \
             per pixel and channel: {:.2}% (published dipole) and {:.2}% (scaled to the \
             profile's R_d) against {:.2}% for what ships and {:.2}% for the best within the \
             budget, worst channel; {:.0} dipole evaluations per pixel. {}",
            r.samples,
            100.0 * worst(r.rel_rms),
            100.0 * worst(r.rel_rms_scaled),
            100.0 * shipped,
            100.0 * best,
            r.evaluations_per_pixel,
            if needs {
                "This scene needs the light-space method: a screen-space kernel leaves more \
                 than a third more error."
            } else {
                "Screen-space scattering is enough for this scene."
            }
        ),
    };
    Ok(AdviseDirectional {
        rows,
        shipped,
        best,
        needs_light_space: needs,
        sentence,
    })
}
