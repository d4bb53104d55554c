//! The material's preview ([`crate::report::eval::ship::preview`]) as a
//! reader sees it: one PNG of three tiles (the path trace, what ships
//! through the screen-space pass, no blur), each above its difference from
//! the path trace (the path trace above its own noise), and the lines of
//! report.md that give their scores. Every number shown is the preview's.

use super::colour_bar::ColourBar;
use super::figures::Figure;
use super::kernel_plots::to_rgb8;
use super::sheet::{draw_sheet_in, SheetLayout, SheetTile};
use crate::error::Result;
use crate::filter::diff::false_colour;
use crate::filter::Image;
use crate::report::eval::ship::preview::{Preview, PreviewRow, WINDOW};
use std::path::Path;

/// Each pixel of the preview becomes a MAGNIFY x MAGNIFY block (nearest
/// neighbour): the 48-pixel render is shown 192 pixels wide, its pixels
/// plain to see rather than smoothed into a picture it is not.
pub const MAGNIFY: usize = 4;

/// The window mean drawn white, as a fraction of the path trace's peak
/// (the 99th percentile of its largest channel): the screen-space model
/// misses a lit sphere by about 10% of it (docs/scene.md), mid-ramp, and
/// the window's noise (about 2%) stays dark.
pub const DIFF_WHITE: f64 = 0.2;

/// Percent per channel, r / g / b.
fn pct3(v: [f64; 3]) -> String {
    v.map(|x| format!("{:.1}", 100.0 * x)).join(" / ")
}

/// `rgb` (an RGB8 image `w` pixels square) blown up [`MAGNIFY`] times.
fn magnified(rgb: &[u8], w: usize) -> Vec<u8> {
    let s = w * MAGNIFY;
    let mut out = Vec::with_capacity(s * s * 3);
    for y in 0..s {
        for x in 0..s {
            let i = ((y / MAGNIFY) * w + x / MAGNIFY) * 3;
            out.extend_from_slice(&rgb[i..i + 3]);
        }
    }
    out
}

/// A tile's label: the image and its scores.
fn scored(what: &str, r: &PreviewRow) -> String {
    format!(
        "{what}: relative RMS {}% (r / g / b), FLIP {:.3}",
        pct3(r.rel_rms),
        r.flip
    )
}

/// Draws the preview's panel to `out` (a PNG) and returns where its texts
/// and images went.
pub fn preview_panel(p: &Preview, out: &Path) -> Result<SheetLayout> {
    let im = &p.images;
    let w = p.side;
    let white = DIFF_WHITE / p.exposure;
    let zero = Image::new(w, w);
    // The difference images hold magnitudes already: drawn against zero.
    let heat = |a: &Image| magnified(&to_rgb8(&false_colour(a, &zero, Some(white)), 1.0), w);
    let tone = |img: &Image| magnified(&to_rgb8(img, p.exposure), w);
    let factors = if p.with_factors {
        ", with its entry and exit factors"
    } else {
        ", no entry and exit factors (the profile has none)"
    };
    let tile = |label: String, top: &Image, below: String, bottom: &Image| SheetTile {
        label,
        top: tone(top),
        bottom: Some((below, heat(bottom))),
        flag: None,
    };
    let mean = format!("{WINDOW}x{WINDOW}-pixel mean");
    let tiles = vec![
        tile(
            format!(
                "path traced (ssskit scene, {} samples per pixel): noise {}% of the peak",
                p.samples_per_pixel,
                pct3(p.noise)
            ),
            &im.path_traced,
            format!("its noise in a {mean} (1 standard error)"),
            &im.window_noise,
        ),
        tile(
            scored(&format!("what ships{factors}"), &p.shipped),
            &im.shipped,
            format!("|what ships - path traced|, {mean}"),
            &im.shipped_diff,
        ),
        tile(
            scored("no blur (the lit irradiance)", &p.no_blur),
            &im.no_blur,
            format!("|no blur - path traced|, {mean}"),
            &im.no_blur_diff,
        ),
    ];
    let title = format!(
        "{}: a {} mm sphere lit from the right, {}x{} px ({:.2} mm per pixel); the screen-space \
         pass of {} on the render's G-buffer",
        p.material,
        2.0 * p.radius_mm,
        w,
        w,
        p.mm_per_pixel,
        p.shipped.label
    );
    let bar = ColourBar {
        white: 100.0 * DIFF_WHITE,
        unit: "% of the path trace's peak".into(),
        quantity: format!("lower tiles: {WINDOW}x{WINDOW}-pixel means, largest channel"),
    };
    let s = w * MAGNIFY;
    draw_sheet_in(&tiles, (s, s), 3, &title, Some(&bar), out)
}

/// The preview's figure entry.
pub fn figure(p: &Preview, file: &str) -> Figure {
    Figure {
        file: file.into(),
        caption: format!(
            "{} on a {} mm sphere path-traced by `ssskit scene` ({} samples per pixel), beside \
             what ships and no blur through the screen-space pass on the render's G-buffer, each \
             above its difference from the path trace (the path trace above its noise)",
            p.material,
            2.0 * p.radius_mm,
            p.samples_per_pixel
        ),
    }
}

/// report.md's lines on the preview: the image, what it is, the scores
/// with the noise floor, and the difference between no blur and what
/// ships with its uncertainty.
pub fn preview_markdown(p: &Preview, file: &str, chosen_mm_per_pixel: f64) -> String {
    let mut s = format!(
        "![the preview: path trace, what ships, no blur]({file})\n\n\
         **Preview** ([{file}]({file})): {} on a {} mm sphere lit 60 degrees from the view, \
         path-traced by `ssskit scene` ({}x{} px, {:.2} mm per pixel at its median depth, \
         {} samples per pixel, seed {}), and what ships run through the screen-space pass on \
         the render's G-buffer (the irradiance, depth-scaled, with the depth-aware lerp{}), \
         beside no blur. At {:.2} mm per pixel, not the chosen {}: it shows the material on a \
         curved, lit surface, where the screen-space model's own error adds to the kernel's.\n\n",
        p.material,
        2.0 * p.radius_mm,
        p.side,
        p.side,
        p.mm_per_pixel,
        p.samples_per_pixel,
        p.seed,
        if p.with_factors {
            " and the kernel file's entry and exit factors"
        } else {
            "; the profile carries no entry and exit factors, without which the pass misses how \
             the light enters and leaves, on a lit sphere more than the blur gains \
             (docs/scene.md)"
        },
        p.mm_per_pixel,
        chosen_mm_per_pixel,
    );
    let mut t = super::table::Table::new(&[
        "against the path trace",
        "relative RMS % (r / g / b)",
        "beyond the noise %",
        "FLIP",
    ]);
    for (what, r) in [("what ships: ", &p.shipped), ("", &p.no_blur)] {
        t.push(vec![
            format!("{what}{}", r.label),
            pct3(r.rel_rms),
            pct3(r.beyond_noise),
            format!("{:.3}", r.flip),
        ]);
    }
    t.push(vec![
        "the path trace's own noise".into(),
        pct3(p.noise),
        "-".into(),
        "-".into(),
    ]);
    s += &t.markdown();
    let d = |v: [f64; 3]| v.map(|x| format!("{:.2}", 100.0 * x)).join(" / ");
    s += &format!(
        "\nNo blur's relative RMS less what ships': {} points (r / g / b), +- {} (one \
         standard deviation from the render's noise, which both share and which cancels in the \
         difference); positive where what ships is the closer to the path trace. Relative RMS: over the {} pixels that see the sphere, of \
         its 99th-percentile radiance; beyond the noise: sqrt(RMS^2 - noise^2); FLIP against \
         the noisy path trace, so read it as a comparison between the rows. The render took {} \
         scattering events and boundary crossings (r / g / b).\n",
        d(p.gap),
        d(p.gap_sigma),
        p.pixels,
        p.events.map(|e| e.to_string()).join(" / "),
    );
    s
}
