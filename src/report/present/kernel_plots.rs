//! Plots of a kernel comparison: kernel slices along the axis and the
//! diagonal with the ground truth dashed (Freude 2014, fig. 6.2 and the
//! appendix kernel plots), singular value spectra, and a contact sheet per
//! material and signal: the configuration that ships (or the best model)
//! beside the exact convolution with a zoom at native pixels, then each
//! model's filtered image and its difference from the exact convolution,
//! tiles of the wrong mean colour flagged.

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::colour_bar::ColourBar;
use super::layout::TextBox;
use super::number::sig;
use super::plot::{self, Curve, Panel, PALETTE};
use super::sheet::{draw_sheet, SheetLayout, SheetTile};
use crate::error::{Error, Result};
use crate::filter::diff::false_colour;
use crate::filter::image::linear_to_srgb;
use crate::filter::Image;
use crate::report::eval::colour_shift::COLOUR_TOLERANCE_DE;
use crate::report::eval::compare::kernel::Comparison;
use crate::report::eval::compare::sheets::{MeasuredTile, Rebuilt, SheetTiles, SliceKernels};
use plotters::prelude::*;
use std::path::Path;

const CH: [&str; 3] = ["red", "green", "blue"];

/// Points (distance mm, density 1/mm^2).
pub type Slice = Vec<(f64, f64)>;

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

/// The kernel a report recommends, for its plots.
pub enum Recommended {
    /// A separable kernel: the 2D kernel of its full factors (what its
    /// tap table samples).
    Separable { label: String, kernel: Rebuilt },
    /// A disk kernel: its samples' weights per annulus, per channel
    /// (`eval::compare::sheets::disk_annuli`; one curve serves the axis and
    /// the diagonal).
    Disk { label: String, annuli: [Slice; 3] },
}

/// The recommended kernel's colour in the plots: a purple no model uses.
const RECOMMENDED: RGBColor = RGBColor(130, 0, 220);

/// The recommended kernel's slice curve of channel `c` (`which`: 0 the
/// axis, 1 the diagonal).
fn recommended_curve(r: &Recommended, c: usize, which: usize) -> Curve {
    let (label, points) = match r {
        Recommended::Separable { label, kernel } => {
            let (axis, diag) = slices(&kernel.data[c], kernel.size, kernel.cell_mm);
            (label, if which == 0 { axis } else { diag })
        }
        Recommended::Disk { label, annuli } => (label, annuli[c].clone()),
    };
    Curve {
        label: format!("recommended: {label}"),
        color: RECOMMENDED,
        points,
        band: None,
        dashed: false,
    }
}

/// Axis and diagonal slices of the rank-1 models of a material (and the
/// highest-rank renormalised SVD) against the ground truth, log scale,
/// with the `recommended` kernel where given. Returns the boxes of the
/// texts drawn.
pub fn kernel_slices(
    kernels: &SliceKernels,
    recommended: Option<&Recommended>,
    out: &Path,
) -> Result<Vec<TextBox>> {
    let (material, truth) = (&kernels.material, kernels.truth);
    let n = truth.size;
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
            curves.extend(recommended.map(|r| recommended_curve(r, c, which)));
            for (i, (label, k)) in kernels.models.iter().enumerate() {
                let (sa, sd) = slices(&k.data[c], n, truth.cell_mm);
                curves.push(Curve {
                    label: label.clone(),
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
    let title = match recommended {
        Some(Recommended::Disk { .. }) => format!(
            "{material}: kernel slices, ground truth dashed; the recommended disk kernel \
             (purple) as its samples' weights per ring"
        ),
        Some(Recommended::Separable { .. }) => {
            format!(
                "{material}: kernel slices, ground truth dashed, the recommended kernel in purple"
            )
        }
        None => format!("{material}: kernel slices, ground truth dashed"),
    };
    plot::render(&panels, 3, &title, out)
}

/// Singular values sigma_i / sigma_1 of each material's ground truth per
/// channel (from the SVD fits' stored spectra).
/// Returns the boxes of the texts drawn.
pub fn spectra(cmp: &Comparison, out: &Path) -> Result<Vec<TextBox>> {
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

/// Magnification of the zoom tile: each image pixel becomes a ZOOM x ZOOM
/// block (nearest neighbour), so a 128-pixel tile shows a 32-pixel window
/// where one-pixel banding and halos are plain to see.
pub const ZOOM: usize = 4;

/// The outline of the zoom window on the exact tile: a green that no
/// tone-mapped skin or marble tile holds.
const WINDOW: [u8; 3] = [0, 200, 0];

/// A tile whose mean colour lies further from the exact tile's than
/// [`COLOUR_TOLERANCE_DE`].
#[derive(Clone, Debug, PartialEq)]
pub struct ColourFlag {
    pub material: String,
    pub signal: String,
    pub model: String,
    /// Delta E*ab at equal luminance ([`MeasuredTile::delta_e`]).
    pub delta_e: f64,
}

/// What a contact sheet drew: where its texts and images went and the
/// tiles it flagged.
pub struct SheetOutcome {
    pub layout: SheetLayout,
    pub flags: Vec<ColourFlag>,
}

/// The flag text of a tile `delta_e` from the exact colour, if over the
/// tolerance.
fn colour_flag(delta_e: f64) -> Option<String> {
    (delta_e > COLOUR_TOLERANCE_DE).then(|| {
        format!(
            "colour off: ΔE {} > {}",
            sig(delta_e),
            sig(COLOUR_TOLERANCE_DE)
        )
    })
}

/// A contact sheet of a material and case (`sheet`): the input above the
/// exact convolution, the shipped configuration (or the best model) above
/// its difference from the exact image, a zoom at [`ZOOM`] x native pixels
/// of both on the window where the exact image changes most, then per
/// model its filtered image (`factor` names which factors) above its
/// difference (false colour, white = [`DIFF_SCALE`] of the exact peak).
/// Tiles whose mean colour is off are framed in red and returned.
pub fn contact_sheet(sheet: &SheetTiles, factor: &str, out: &Path) -> Result<SheetOutcome> {
    let (material, exact) = (&sheet.material, sheet.exact);
    let (w, h) = (exact.image.width, exact.image.height);
    let peak = exact.image.peak().iter().cloned().fold(0.0f64, f64::max);
    let exposure = exact.exposure_rgb;
    let mut flags = Vec::new();
    let mut tile = |t: &MeasuredTile| {
        let (label, img, delta_e) = (&t.label, t.image, t.delta_e);
        let flag = colour_flag(delta_e);
        if flag.is_some() {
            flags.push(ColourFlag {
                material: material.clone(),
                signal: exact.case.name.clone(),
                model: label.clone(),
                delta_e,
            });
        }
        let d = false_colour(&exact.image, img, Some(DIFF_SCALE * peak));
        SheetTile {
            label: label.to_string(),
            top: to_rgb8(img, exposure),
            bottom: Some(("difference".into(), to_rgb8(&d, 1.0))),
            flag,
        }
    };
    let exact_rgb = to_rgb8(&exact.image, exposure);
    let window = sheet
        .lead
        .as_ref()
        .map(|t| zoom_window(&exact.image, t.image, ZOOM));
    let mut tiles = vec![SheetTile {
        label: "input".into(),
        top: to_rgb8(&exact.case.image, exposure),
        bottom: Some(match window {
            Some(win) => (
                "exact 2D (green: zoomed)".into(),
                outlined(&exact_rgb, w, win),
            ),
            None => ("exact 2D".into(), exact_rgb.clone()),
        }),
        flag: None,
    }];
    if let (Some(lead), Some(window)) = (&sheet.lead, window) {
        let rgb = to_rgb8(lead.image, exposure);
        tiles.push(tile(lead));
        tiles.push(SheetTile {
            label: format!("exact 2D, zoom {ZOOM}x"),
            top: zoomed(&exact_rgb, (w, h), window, ZOOM),
            bottom: Some((
                format!("{}, zoom {ZOOM}x", short(&lead.label)),
                zoomed(&rgb, (w, h), window, ZOOM),
            )),
            flag: None,
        });
    }
    for t in &sheet.models {
        tiles.push(tile(t));
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
    let layout = draw_sheet(&tiles, (w, h), &title, Some(&bar), out)?;
    Ok(SheetOutcome { layout, flags })
}

/// The model of a lead label ("recommended: svd2, 17 taps over ..." is
/// "recommended").
fn short(label: &str) -> &str {
    label.split(':').next().unwrap_or(label)
}

/// The top-left corner and side of the window of side min(w, h) / `zoom`
/// where `result` departs most from `exact`: the largest sum of the
/// largest channel's |result - exact| (first of equals in row order), so
/// the zoom shows the banding and halos of the configuration it opens
/// with.
pub fn zoom_window(exact: &Image, result: &Image, zoom: usize) -> (usize, usize, usize) {
    let (w, h) = (exact.width, exact.height);
    let s = (w.min(h) / zoom).max(1);
    let d = |i: usize| {
        (0..3).fold(0.0f64, |m, c| {
            m.max((exact.rgb[c][i] - result.rgb[c][i]).abs())
        })
    };
    // Summed-area table of the difference.
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        for x in 0..w {
            sat[(y + 1) * (w + 1) + x + 1] =
                d(y * w + x) + sat[y * (w + 1) + x + 1] + sat[(y + 1) * (w + 1) + x]
                    - sat[y * (w + 1) + x];
        }
    }
    let sum = |x: usize, y: usize| {
        let a = |x: usize, y: usize| sat[y * (w + 1) + x];
        a(x + s, y + s) - a(x, y + s) - a(x + s, y) + a(x, y)
    };
    let mut best = (f64::NEG_INFINITY, 0, 0);
    for y in 0..=h - s {
        for x in 0..=w - s {
            let g = sum(x, y);
            if g > best.0 {
                best = (g, x, y);
            }
        }
    }
    (best.1, best.2, s)
}

/// The window `(x0, y0, s)` of the RGB8 image `rgb` (`w` x `h`) blown up
/// `zoom` times by nearest neighbour, centred on a white tile of `w` x `h`.
fn zoomed(
    rgb: &[u8],
    (w, h): (usize, usize),
    (x0, y0, s): (usize, usize, usize),
    zoom: usize,
) -> Vec<u8> {
    let mut out = vec![255u8; w * h * 3];
    let side = (s * zoom).min(w).min(h);
    let (ox, oy) = ((w - side) / 2, (h - side) / 2);
    for y in 0..side {
        for x in 0..side {
            let src = ((y0 + y / zoom) * w + x0 + x / zoom) * 3;
            let dst = ((oy + y) * w + ox + x) * 3;
            out[dst..dst + 3].copy_from_slice(&rgb[src..src + 3]);
        }
    }
    out
}

/// The RGB8 image `rgb` (`w` wide) with the window `(x0, y0, s)` outlined
/// one pixel outside it (inside the image) in [`WINDOW`].
fn outlined(rgb: &[u8], w: usize, (x0, y0, s): (usize, usize, usize)) -> Vec<u8> {
    let mut out = rgb.to_vec();
    let h = rgb.len() / 3 / w;
    let (xa, ya) = (x0.saturating_sub(1), y0.saturating_sub(1));
    let (xb, yb) = ((x0 + s).min(w - 1), (y0 + s).min(h - 1));
    for y in ya..=yb {
        for x in xa..=xb {
            if x == xa || x == xb || y == ya || y == yb {
                out[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&WINDOW);
            }
        }
    }
    out
}

/// The section of report.md that lists the contact sheets' tiles whose
/// mean colour is off.
pub fn flags_markdown(flags: &[ColourFlag]) -> String {
    let mut s = format!(
        "\n## Colour of the contact sheets\n\nA tile is framed in red where the hue and chroma \
         of its mean colour (CIELAB at the exact tile's luminance) lie more than ΔE*ab {} (the \
         just noticeable difference) from the exact tile's.\n\n",
        sig(COLOUR_TOLERANCE_DE)
    );
    if flags.is_empty() {
        s.push_str("No tile is flagged.\n");
    }
    for f in flags {
        s.push_str(&format!(
            "- {} {}: {} (ΔE*ab {})\n",
            f.material,
            f.signal,
            f.model,
            sig(f.delta_e)
        ));
    }
    s
}
