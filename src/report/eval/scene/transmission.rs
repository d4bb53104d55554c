//! What a user loses on an object lit from behind without transmission,
//! and what each way back gets: against the path-traced image of a scene
//! whose first directional light shines through its object, the
//! screen-space pass's input alone (front irradiance x R_d / pi: the blur
//! spreads it but adds no light from behind), the same plus each engine's
//! thickness-based transmission with its fitted settings (the thickness as
//! the engine reads it: `scene::thickness`), and the same plus the exact
//! thickness table (T of a slab as thick as the shadow map's or the
//! thickness map's thickness). The transmitted radiance is E / pi x the
//! formula's pi L / E at each pixel, times the pixel's coverage. Scored
//! as `compare --scene` scores its rows (`scene::score`), in a block of its
//! own.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::score::{region_masks, RegionError, Scorer};
use crate::engine::transmission::{ThicknessSource, TransmissionFit};
use crate::error::{Error, Result};
use crate::filter::Image;
use crate::profile::transmission::ThicknessTable;
use crate::scene::thickness::{pixel_thickness, PixelThickness};
use crate::scene::{Render, Scene};
use serde::{Deserialize, Serialize};

/// One way of showing the light from behind, scored.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransmissionRow {
    pub label: String,
    /// Where the thickness came from ("shadow map", "thickness map", or
    /// "-" for the screen-space input alone).
    pub thickness: String,
    pub regions: Vec<RegionError>,
}

/// The block of `compare --scene` for a back-lit scene.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TransmissionComparison {
    pub rows: Vec<TransmissionRow>,
    /// Range of the shadow-map and thickness-map thicknesses over the seen
    /// pixels, mm.
    pub shadow_map_mm: [f64; 2],
    pub thickness_map_mm: [f64; 2],
    /// Share of the path-traced light (its mean over the seen pixels, per
    /// channel) that the screen-space input alone misses.
    pub lost: [f64; 3],
    /// The first lines of `compare --scene`: what is lost without
    /// transmission and which approximation keeps most of it.
    pub headline: String,
    #[serde(skip)]
    pub images: Vec<(String, Image)>,
}

/// Refuses a table of another medium than the scene's first object.
fn check_table(scene: &Scene, table: &ThicknessTable) -> Result<()> {
    let Some(o) = scene.objects.first() else {
        return Err(Error::Unsupported("the scene has no object".into()));
    };
    let (a, b) = (&o.material.layers[0], table.material.layers.last());
    let same = b.is_some_and(|b| {
        a.sigma_a == b.sigma_a
            && a.sigma_s == b.sigma_s
            && a.g == b.g
            && (o.eta() - b.eta / table.material.eta_above).abs() < 1e-12
    });
    if !same || table.material.layers.len() != 1 {
        return Err(Error::invalid(
            "transmission table",
            "material",
            &table.material.name,
            format!(
                "the table is of another medium than the scene's object '{}' ({} at index {}): \
                 make it with `ssskit transmission --material` of that material and --eta {}",
                o.name,
                o.material.name,
                o.eta(),
                o.eta()
            ),
        ));
    }
    Ok(())
}

/// The comparison of `render` (of `scene`) with the engines' `fits` to
/// `table` and the table itself; `ppd` the FLIP viewing condition.
pub fn compare_transmission(
    scene: &Scene,
    render: &Render,
    table: &ThicknessTable,
    fits: &[TransmissionFit],
    ppd: f64,
) -> Result<TransmissionComparison> {
    check_table(scene, table)?;
    let Some((toward, e)) = scene.directional().next() else {
        return Err(Error::Unsupported(
            "transmission rows need a directional light (the scene has none)".into(),
        ));
    };
    let px = pixel_thickness(scene, toward);
    if px.width != render.width || px.height != render.height {
        return Err(Error::Unsupported(
            "the render's size is not the scene's".into(),
        ));
    }
    let (w, h) = (render.width, render.height);
    let truth = Image {
        width: w,
        height: h,
        rgb: render.radiance.clone(),
        alpha: None,
    };
    let g = &render.gbuffer;
    let base = Image {
        width: w,
        height: h,
        rgb: g.irradiance.clone(),
        alpha: None,
    };
    let scorer = Scorer::new(&truth, &render.stderr, region_masks(scene, render), ppd);
    let add = |f: &dyn Fn(usize) -> [f64; 3]| -> Image {
        let mut img = base.clone();
        for i in 0..w * h {
            if px.seen[i] {
                let v = f(i);
                for c in 0..3 {
                    img.rgb[c][i] += e[c] / std::f64::consts::PI * v[c] * g.coverage[i];
                }
            }
        }
        img
    };
    let mut images = vec![("screen-space SSS alone".to_string(), "-", base.clone())];
    for f in fits {
        let Some(m) = &f.model else { continue };
        let src = m.thickness_source();
        let t = thickness(&px, src);
        images.push((
            format!("+ {} transmission", f.engine),
            source_name(src),
            add(&|i| m.eval(t[i], px.n_dot_l[i], px.back_cos[i])),
        ));
    }
    for src in [ThicknessSource::ShadowMap, ThicknessSource::ThicknessMap] {
        let t = thickness(&px, src);
        let idx: Vec<usize> = table.channels.iter().map(|c| c.index()).collect();
        images.push((
            "+ exact table".into(),
            source_name(src),
            add(&|i| {
                let mut v = [0.0; 3];
                for (k, &c) in idx.iter().enumerate() {
                    v[c] = table.interpolate(k, t[i]).unwrap_or(0.0);
                }
                v
            }),
        ));
    }
    let rows: Vec<TransmissionRow> = images
        .iter()
        .map(|(label, src, img)| TransmissionRow {
            label: label.clone(),
            thickness: src.to_string(),
            regions: scorer.score(img),
        })
        .collect();
    let lost = rows[0].regions[0].bias.map(|b| (-b).clamp(0.0, 1.0));
    let range = |v: &[f64]| {
        let seen = v.iter().zip(&px.seen).filter(|(_, s)| **s).map(|(x, _)| *x);
        seen.fold([f64::INFINITY, 0.0f64], |[a, b], x| [a.min(x), b.max(x)])
    };
    let headline = headline(&rows, lost);
    Ok(TransmissionComparison {
        shadow_map_mm: range(&px.shadow_map_mm),
        thickness_map_mm: range(&px.thickness_map_mm),
        rows,
        lost,
        headline,
        images: images
            .into_iter()
            .map(|(l, s, i)| (format!("{l} ({s})"), i))
            .collect(),
    })
}

fn source_name(s: ThicknessSource) -> &'static str {
    match s {
        ThicknessSource::ShadowMap => "shadow map",
        ThicknessSource::ThicknessMap => "thickness map",
    }
}

fn thickness(px: &PixelThickness, s: ThicknessSource) -> &[f64] {
    match s {
        ThicknessSource::ShadowMap => &px.shadow_map_mm,
        ThicknessSource::ThicknessMap => &px.thickness_map_mm,
    }
}

/// The relative RMS over all seen pixels, the mean of the three channels
/// (one channel's can hide another's: the engines' worst differ).
pub fn mean_rms(r: &TransmissionRow) -> f64 {
    r.regions[0].rel_rms.iter().sum::<f64>() / 3.0
}

/// What a user loses without transmission, the engine approximation that
/// keeps most of it (the lowest mean RMS; FLIP beside it), and how far the
/// exact table gets.
fn headline(rows: &[TransmissionRow], lost: [f64; 3]) -> String {
    let pct = |v: [f64; 3]| v.map(|x| format!("{:.0}%", 100.0 * x)).join(", ");
    let best = |exact: bool| {
        rows[1..]
            .iter()
            .filter(|r| r.label.contains("exact table") == exact)
            .min_by(|a, b| mean_rms(a).total_cmp(&mean_rms(b)))
    };
    let mut s = format!(
        "Without transmission, screen-space SSS misses {} (r, g, b) of the light this object \
         sends to the camera from the light behind it (error {:.1}% of the peak, mean of r, g, \
         b; FLIP {:.3}).",
        pct(lost),
        100.0 * mean_rms(&rows[0]),
        rows[0].regions[0].flip
    );
    if let Some(b) = best(false) {
        let bias = b.regions[0]
            .bias
            .map(|x| format!("{:+.0}%", 100.0 * x))
            .join(", ");
        s.push_str(&format!(
            " Of the engines' approximations, {} (thickness from the {}) keeps most: {:.1}% \
             (FLIP {:.3}), bias {bias}.",
            b.label.trim_start_matches("+ "),
            b.thickness,
            100.0 * mean_rms(b),
            b.regions[0].flip
        ));
    }
    if let Some(b) = best(true) {
        s.push_str(&format!(
            " The exact table (thickness from the {}): {:.1}% (FLIP {:.3}).",
            b.thickness,
            100.0 * mean_rms(b),
            b.regions[0].flip
        ));
    }
    s
}
