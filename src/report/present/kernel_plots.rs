//! Plots of a kernel comparison: kernel slices along the axis and the
//! diagonal with the ground truth dashed (Freude 2014, fig. 6.2 and the
//! appendix kernel plots), singular value spectra, and a contact sheet per
//! material and signal with each model's filtered image and its difference
//! from the exact convolution.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::colour_bar::{self, ColourBar};
use super::plot::{self, Curve, Panel, PALETTE};
use crate::error::{Error, Result};
use crate::filter::diff::false_colour;
use crate::filter::image::linear_to_srgb;
use crate::filter::Image;
use crate::kernel::metrics::reconstruct;
use crate::kernel::{Factors, Kernel2D, KernelFile};
use crate::report::eval::claims::RANK1;
use crate::report::eval::kernel_compare::{Comparison, Fitted};
use plotters::prelude::*;
use std::path::Path;

const CH: [&str; 3] = ["red", "green", "blue"];

fn factors_of(k: &KernelFile) -> Factors {
    k.passes
        .iter()
        .map(|p| std::array::from_fn(|c| p.weights.iter().map(|w| w[c]).collect()))
        .collect()
}

/// Points (distance mm, density 1/mm^2).
type Slice = Vec<(f64, f64)>;

/// Slices along the axis and the diagonal of a row-major n x n kernel with
/// cells of `cell` mm.
fn slices(a: &[f64], n: usize, cell: f64) -> (Slice, Slice) {
    let h = n / 2;
    let area = cell * cell;
    let axis = (0..=h)
        .map(|j| (j as f64 * cell, a[h * n + h + j] / area))
        .collect();
    let diag = (0..=h)
        .map(|m| {
            (
                m as f64 * cell * std::f64::consts::SQRT_2,
                a[(h + m) * n + h + m] / area,
            )
        })
        .collect();
    (axis, diag)
}

fn colour(i: usize) -> RGBColor {
    const EXTRA: [RGBColor; 2] = [RGBColor(170, 0, 60), RGBColor(90, 60, 20)];
    if i < PALETTE.len() - 1 {
        PALETTE[i + 1]
    } else {
        EXTRA[(i - PALETTE.len() + 1) % EXTRA.len()]
    }
}

/// Axis and diagonal slices of the rank-1 models of `material` (and the
/// highest-rank renormalised SVD) against the ground truth, log scale.
pub fn kernel_slices(cmp: &Comparison, material: &str, out: &Path) -> Result<()> {
    let Some(mi) = cmp.materials.iter().position(|m| m == material) else {
        return Err(Error::Unsupported(format!("no material {material}")));
    };
    let truth: &Kernel2D = &cmp.truths[mi];
    let n = truth.size;
    let models: Vec<&Fitted> = cmp
        .fitted
        .iter()
        .filter(|f| f.material == material && RANK1.contains(&f.spec.label.as_str()))
        .collect();
    let x_max = truth.extent_mm() / 2.0;
    let mut panels = Vec::new();
    for (which, name) in [(0, "axis"), (1, "diagonal")] {
        for c in 0..3 {
            let (ta, td) = slices(&truth.data[c], n, truth.cell_mm);
            let mut curves = vec![Curve {
                label: "ground truth".into(),
                color: BLACK,
                points: if which == 0 { ta } else { td },
                band: None,
                dashed: true,
            }];
            for (i, f) in models.iter().enumerate() {
                let a = reconstruct(&factors_of(&f.kernel), n, c);
                let (sa, sd) = slices(&a, n, truth.cell_mm);
                curves.push(Curve {
                    label: f.spec.label.clone(),
                    color: colour(i),
                    points: if which == 0 { sa } else { sd },
                    band: None,
                    dashed: false,
                });
            }
            panels.push(Panel {
                title: format!("{material}, {}, {name}", CH[c]),
                x_label: format!("distance from the centre along the {name} (mm)"),
                y_label: "kernel density (1/mm², sum 1)".into(),
                x_max,
                log_y: true,
                curves,
            });
        }
    }
    plot::render(
        &panels,
        3,
        &format!("{material}: kernel slices, ground truth dashed"),
        out,
    )
}

/// Singular values sigma_i / sigma_1 of each material's ground truth per
/// channel (from the SVD fits' stored spectra).
pub fn spectra(cmp: &Comparison, out: &Path) -> Result<()> {
    let mut panels = Vec::new();
    for m in &cmp.materials {
        let Some(f) = cmp
            .fitted
            .iter()
            .find(|f| f.material == *m && f.kernel.model.name == "svd")
        else {
            continue;
        };
        let sv = &f.kernel.metrics.extra["singular_values"];
        let mut curves = Vec::new();
        let mut n_max = 1usize;
        for c in 0..3 {
            let v: Vec<f64> = sv[c]
                .as_array()
                .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
                .unwrap_or_default();
            let Some(&s1) = v.first() else { continue };
            n_max = n_max.max(v.len());
            curves.push(Curve {
                label: CH[c].into(),
                color: [
                    RGBColor(213, 94, 0),
                    RGBColor(0, 158, 115),
                    RGBColor(0, 114, 178),
                ][c],
                points: v
                    .iter()
                    .enumerate()
                    .map(|(i, s)| ((i + 1) as f64, s / s1))
                    .collect(),
                band: None,
                dashed: false,
            });
        }
        if curves.is_empty() {
            continue;
        }
        panels.push(Panel {
            title: format!("{m}: singular values of the 2D kernel"),
            x_label: "index i".into(),
            y_label: "σ_i / σ_1".into(),
            x_max: n_max as f64,
            log_y: true,
            curves,
        });
    }
    if panels.is_empty() {
        return Err(Error::Unsupported(
            "no SVD fit in the comparison: no spectrum to plot".into(),
        ));
    }
    plot::render(&panels, 3, "Singular value spectra", out)
}

/// Tone mapping of the report (see [`crate::report::eval::evaluate`]): exposure, clamp,
/// sRGB 8-bit, interleaved.
pub(crate) fn to_rgb8(img: &Image, exposure: f64) -> Vec<u8> {
    let mut v = Vec::with_capacity(3 * img.len());
    for i in 0..img.len() {
        for c in 0..3 {
            let x = (img.rgb[c][i] * exposure).clamp(0.0, 1.0);
            v.push((linear_to_srgb(if x.is_nan() { 0.0 } else { x }) * 255.0).round() as u8);
        }
    }
    v
}

/// Fraction of the exact image's peak shown as white in difference tiles.
pub const DIFF_SCALE: f64 = 0.05;

/// A contact sheet for `material` and case `ci`: the input and the exact
/// convolution, then per model its filtered image (`factor` names which
/// factors) above its difference from the exact image (false colour, white
/// = [`DIFF_SCALE`] of the exact peak).
pub fn contact_sheet(
    cmp: &Comparison,
    material: &str,
    ci: usize,
    factor: &str,
    out: &Path,
) -> Result<()> {
    plot::register_fonts();
    let Some(mi) = cmp.materials.iter().position(|m| m == material) else {
        return Err(Error::Unsupported(format!("no material {material}")));
    };
    let exact = &cmp.exact[mi][ci];
    let models: Vec<(&str, &Image)> = cmp
        .fitted
        .iter()
        .filter(|f| f.material == material)
        .filter_map(|f| f.kept.get(ci)?.as_ref().map(|i| (f.spec.label.as_str(), i)))
        .collect();
    let (w, h) = (exact.image.width, exact.image.height);
    let peak = exact.image.peak().iter().cloned().fold(0.0f64, f64::max);
    let exposure = exact.exposure_rgb;
    let mut tiles = vec![SheetTile {
        label: "input".into(),
        top: to_rgb8(&exact.case.image, exposure),
        bottom: Some(("exact 2D".into(), to_rgb8(&exact.image, exposure))),
    }];
    for (label, img) in &models {
        let d = false_colour(&exact.image, img, Some(DIFF_SCALE * peak));
        tiles.push(SheetTile {
            label: label.to_string(),
            top: to_rgb8(img, exposure),
            bottom: Some(("difference".into(), to_rgb8(&d, 1.0))),
        });
    }
    let title = format!(
        "{material}, {} at {} mm/px, {factor}: result (tone mapped) above |result - exact|",
        exact.case.name, exact.case.mm_per_pixel,
    );
    let bar = ColourBar {
        white: 100.0 * DIFF_SCALE,
        unit: "% of the exact peak".into(),
        quantity: "difference tiles: |result - exact|, largest channel".into(),
    };
    draw_sheet(&tiles, (w, h), &title, Some(&bar), out)
}

/// One cell of a contact sheet: an 8-bit RGB image of the sheet's tile
/// size with its label, and optionally a second one below it.
pub(crate) struct SheetTile {
    pub label: String,
    pub top: Vec<u8>,
    pub bottom: Option<(String, Vec<u8>)>,
}

/// Draws `tiles` of `w` x `h` pixels six to a row under `title`, with the
/// colour bar of its difference tiles below them, and writes the PNG
/// atomically.
pub(crate) fn draw_sheet(
    tiles: &[SheetTile],
    (w, h): (usize, usize),
    title: &str,
    bar: Option<&ColourBar>,
    out: &Path,
) -> Result<()> {
    plot::register_fonts();
    let cols = 6usize;
    let label_h = 22usize;
    let cell_w = w + 8;
    let cell_h = 2 * (h + label_h) + 8;
    let rows = tiles.len().div_ceil(cols);
    let head = 34usize;
    let bar_h = if bar.is_some() { colour_bar::HEIGHT } else { 0 };
    let sw = cols * cell_w;
    let sh = head + rows * cell_h + bar_h;
    crate::limits::check_image_size(&out.display().to_string(), sw, sh)?;
    let mut buf = vec![255u8; sw * sh * 3];
    let blit = |buf: &mut [u8], rgb: &[u8], x0: usize, y0: usize| {
        for y in 0..h {
            let dst = ((y0 + y) * sw + x0) * 3;
            buf[dst..dst + 3 * w].copy_from_slice(&rgb[y * w * 3..(y + 1) * w * 3]);
        }
    };
    let mut labels: Vec<(&str, usize, usize)> = Vec::new();
    for (t, tile) in tiles.iter().enumerate() {
        let (x0, y0) = ((t % cols) * cell_w + 4, head + (t / cols) * cell_h);
        blit(&mut buf, &tile.top, x0, y0 + label_h);
        labels.push((&tile.label, x0, y0));
        if let Some((label, rgb)) = &tile.bottom {
            blit(&mut buf, rgb, x0, y0 + 2 * label_h + h);
            labels.push((label, x0, y0 + label_h + h));
        }
    }
    let bar_texts = match bar {
        Some(b) => colour_bar::paint(b, &mut buf, sw, (4, head + rows * cell_h + 2)),
        None => vec![],
    };
    colour_bar::draw_texts(&mut buf, (sw, sh), &bar_texts, 13, out)?;
    {
        let root = BitMapBackend::with_buffer(&mut buf, (sw as u32, sh as u32)).into_drawing_area();
        let e = |e| Error::format(out, format!("plotting failed: {e}"));
        let font = ("sans-serif", 15).into_font().color(&BLACK);
        root.draw_text(title, &font, (6, 8)).map_err(e)?;
        for (text, x, y) in &labels {
            root.draw_text(text, &font, (*x as i32, *y as i32 + 3))
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    plot::write_png(buf, sw as u32, sh as u32, out)
}
