//! Scoring an image against the path-traced truth of a scene, by region:
//! the pixels' cosines with the light and the view, the regions they
//! define (see [`super::compare`]'s definitions) and the per-region
//! relative RMS, bias, noise floor and FLIP.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use crate::filter::Image;
use crate::report::eval::evaluate::{exposure_of, flip_map, tone_map};
use crate::scene::{Render, Scene};
use serde::{Deserialize, Serialize};

/// Half-width of the terminator band in N.L.
pub const TERMINATOR_BAND: f64 = 0.2;
/// N.V below which a pixel is seen at a grazing angle.
pub const GRAZING_VIEW: f64 = 0.3;
/// The regions, in table order.
pub const REGIONS: [&str; 5] = ["all", "lit", "unlit", "terminator", "grazing"];

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

/// The cosines of each pixel: N.L with the scene's first directional
/// light (None without one) and N.V with the direction to the camera; 0
/// where no object is seen.
pub struct Cosines {
    pub n_dot_l: Option<Vec<f64>>,
    pub n_dot_v: Vec<f64>,
}

/// [`Cosines`] of a render from its G-buffer normals and the scene's
/// camera and light.
pub fn cosines(scene: &Scene, render: &Render) -> Cosines {
    let (w, h) = (render.width, render.height);
    let g = &render.gbuffer;
    let light = scene.directional().next().map(|(d, _)| d);
    let normal = |i: usize| crate::scene::V3::new(g.normal[0][i], g.normal[1][i], g.normal[2][i]);
    let seen = |i: usize| g.coverage[i] > 0.0;
    let n_dot_v = (0..w * h)
        .map(|i| {
            if !seen(i) {
                return 0.0;
            }
            let v = -scene
                .camera
                .ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5)
                .d;
            normal(i).dot(&v)
        })
        .collect();
    let n_dot_l = light.map(|l| {
        (0..w * h)
            .map(|i| if seen(i) { normal(i).dot(&l) } else { 0.0 })
            .collect()
    });
    Cosines { n_dot_l, n_dot_v }
}

/// Masks of the regions (see the module's definitions), in [`REGIONS`]
/// order.
pub fn region_masks(scene: &Scene, render: &Render) -> Vec<Vec<bool>> {
    masks_of(&cosines(scene, render), &render.gbuffer.coverage)
}

pub(in crate::report::eval) fn masks_of(cos: &Cosines, coverage: &[f64]) -> Vec<Vec<bool>> {
    let n = coverage.len();
    let mut masks = vec![vec![false; n]; REGIONS.len()];
    for i in 0..n {
        if !(coverage[i] > 0.0) {
            continue;
        }
        masks[0][i] = true;
        if let Some(nl) = cos.n_dot_l.as_ref().map(|v| v[i]) {
            masks[1][i] = nl >= TERMINATOR_BAND;
            masks[2][i] = nl <= -TERMINATOR_BAND;
            masks[3][i] = nl.abs() < TERMINATOR_BAND;
        }
        masks[4][i] = cos.n_dot_v[i] < GRAZING_VIEW;
    }
    masks
}

/// The 99th percentile of `v` over `mask` (0 when empty).
pub(in crate::report::eval) fn percentile99(v: &[f64], mask: &[bool]) -> f64 {
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
    crate::numerics::nearest_rank(&x, 0.99)
}

/// The standard deviation of RMS_a - RMS_b, both relative to `peak`
/// over `pixels`, from the noise of the truth t they are scored against
/// (`[a, b, stderr of t]`, `rms_sum` = RMS_a + RMS_b): RMS_a^2 - RMS_b^2 =
/// mean((a - b)(a + b - 2t)), whose standard deviation from t's noise is
/// 2 sqrt(sum (a - b)^2 s^2) / N; divided by RMS_a + RMS_b it is that of
/// RMS_a - RMS_b. The noise common to both scores cancels, so two passes
/// are told apart far below the render's own noise.
pub(in crate::report::eval) fn rms_difference_sigma(
    [a, b, stderr]: [&[f64]; 3],
    pixels: impl Iterator<Item = usize>,
    peak: f64,
    rms_sum: f64,
) -> f64 {
    let (mut n, mut var) = (0usize, 0.0f64);
    for i in pixels {
        n += 1;
        var += ((a[i] - b[i]) * stderr[i]).powi(2);
    }
    if rms_sum > 0.0 && n > 0 {
        2.0 * var.sqrt() / n as f64 / peak.powi(2) / rms_sum
    } else {
        0.0
    }
}

/// Scores images against one path-traced truth.
pub(in crate::report::eval) struct Scorer<'a> {
    truth: &'a Image,
    stderr: &'a [Vec<f64>; 3],
    masks: Vec<Vec<bool>>,
    peak: [f64; 3],
    exposure: f64,
    truth_ldr: Vec<u8>,
    ppd: f32,
}

/// The exposure of a scene's tone mapping, FLIP's and the contact
/// sheets': [`exposure_of`] the path-traced image's brightest channel.
pub(in crate::report::eval) fn truth_exposure(truth: &Image) -> f64 {
    let max_rgb: Vec<f64> = (0..truth.len())
        .map(|i| (0..3).fold(0.0f64, |m, c| m.max(truth.rgb[c][i])))
        .collect();
    exposure_of(&max_rgb)
}

impl<'a> Scorer<'a> {
    pub(in crate::report::eval) fn new(
        truth: &'a Image,
        stderr: &'a [Vec<f64>; 3],
        masks: Vec<Vec<bool>>,
        ppd: f64,
    ) -> Self {
        let peak = std::array::from_fn(|c| percentile99(&truth.rgb[c], &masks[0]));
        let exposure = truth_exposure(truth);
        let truth_ldr = tone_map(truth, |i| {
            std::array::from_fn(|c| truth.rgb[c][i] * exposure)
        });
        Scorer {
            truth,
            stderr,
            masks,
            peak,
            exposure,
            truth_ldr,
            ppd: ppd as f32,
        }
    }

    /// The exposure of the tone mapping FLIP sees (the path-traced image's).
    pub(in crate::report::eval) fn exposure(&self) -> f64 {
        self.exposure
    }

    /// Per channel, the standard deviation from the truth's noise of
    /// RMS_a - RMS_b over the region `all` ([`rms_difference_sigma`]);
    /// `rms` holds both images' relative RMS there.
    pub(in crate::report::eval) fn difference_sigma(
        &self,
        a: &Image,
        b: &Image,
        rms: [[f64; 3]; 2],
    ) -> [f64; 3] {
        std::array::from_fn(|c| {
            let pixels = (0..self.masks[0].len()).filter(|&i| self.masks[0][i]);
            let planes = [a.rgb[c].as_slice(), b.rgb[c].as_slice(), &self.stderr[c]];
            rms_difference_sigma(planes, pixels, self.peak[c], rms[0][c] + rms[1][c])
        })
    }

    pub(in crate::report::eval) fn score(&self, img: &Image) -> Vec<RegionError> {
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

/// The ranking a user needs first on a scene: the unblurred irradiance,
/// the best pass without the entry and exit factors and the best with them
/// (None: the scene allows none, `why_none` says why), each as its worst
/// channel's relative RMS, lowest first, and what that means for what to
/// ship. `passes` are (configuration, error) pairs.
pub fn ranking(
    no_blur: f64,
    without: (&str, f64),
    with: Option<(&str, f64)>,
    why_none: &str,
) -> String {
    let mut rows: Vec<(f64, String)> = vec![
        (no_blur, "no blur (the irradiance as lit)".to_string()),
        (
            without.1,
            format!("{} without the entry and exit factors", without.0),
        ),
    ];
    if let Some((l, e)) = with {
        rows.push((
            e,
            format!("{l} with the entry and exit factors around the pass"),
        ));
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut s = String::from(
        "Ranking (worst channel's RMS of the peak against the path-traced image, lowest first):\n",
    );
    for (i, (e, what)) in rows.iter().enumerate() {
        s.push_str(&format!("  {}. {:>6.2}%  {what}\n", i + 1, 100.0 * e));
    }
    let blur = if without.1 < no_blur {
        format!(
            "the blur alone takes the error from {:.2}% to {:.2}%",
            100.0 * no_blur,
            100.0 * without.1
        )
    } else {
        format!(
            "the blur alone does not beat the unblurred irradiance ({:.2}% against {:.2}%): on \
             this scene the light's entry and exit, not the blur, is what the kernel misses",
            100.0 * without.1,
            100.0 * no_blur
        )
    };
    let factors = match with {
        Some((_, e)) if e < without.1 => format!(
            "; with the entry and exit factors it falls to {:.2}% ({:.2} times less): ship them \
             (sss_entry_factor(N.L) per light before the blur, sss_exit_factor(N.V) after it)",
            100.0 * e,
            without.1 / e.max(1e-12)
        ),
        Some((_, e)) => format!(
            "; the entry and exit factors do not help here ({:.2}% with them)",
            100.0 * e
        ),
        None => format!("; no entry and exit factors: {why_none}"),
    };
    s.push_str(&format!("What it means: {blur}{factors}.\n"));
    s
}
