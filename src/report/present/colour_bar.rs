//! The colour bar of every heat image (difference tiles of the contact
//! sheets, `ssskit diff`'s PNG): the false-colour ramp of
//! [`crate::filter::diff::heat`] from 0 to the value shown as white, with
//! ticks labelled in the data's unit (% of the exact peak), drawn in the
//! same file as the image it explains.

use super::number::sig;
use super::plot::{register_fonts, write_png};
use crate::error::{Error, Result};
use crate::filter::diff::heat;
use plotters::prelude::*;
use std::path::Path;

/// What the ramp of a heat image means.
#[derive(Clone, Debug, PartialEq)]
pub struct ColourBar {
    /// The value drawn white (the top of the ramp), in `unit`.
    pub white: f64,
    /// The unit of `white` and the ticks ("% of the exact peak").
    pub unit: String,
    /// What the heat shows ("|result - exact|, largest channel").
    pub quantity: String,
}

/// Pixels the bar takes below the image: its caption, the ramp and the
/// tick labels.
pub const HEIGHT: usize = 62;
/// The ramp's width (narrower where the page is), pixels.
const RAMP_W: usize = 360;
const RAMP_H: usize = 14;
/// Size of the bar's texts on a contact sheet, pixels.
pub const TEXT_PX: u32 = 13;
/// Ticks at 0, 1/4, 1/2, 3/4 and 1 of the ramp.
const TICKS: usize = 4;

/// A tick value: three significant digits ([`sig`]) without trailing
/// zeros after the point.
fn tick(v: f64) -> String {
    let s = sig(v);
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The text above the ramp: what it shows and the value drawn white.
pub fn caption(bar: &ColourBar) -> String {
    format!(
        "{} (white = {} {})",
        bar.quantity,
        tick(bar.white),
        bar.unit
    )
}

/// The narrowest page the bar fits on, ticks and ramp (not the caption).
pub const MIN_PAGE_W: usize = RAMP_W + 40;

/// Paints the ramp into the RGB8 page `buf` (`page_w` pixels wide) with
/// its top-left corner at `(x0, y0)`, and returns the texts to draw: the
/// caption above it and the tick labels below, each with its position.
pub fn paint(
    bar: &ColourBar,
    buf: &mut [u8],
    page_w: usize,
    (x0, y0): (usize, usize),
) -> Vec<(String, i32, i32)> {
    let w = RAMP_W.min(page_w.saturating_sub(x0 + 24)).max(TICKS * 40);
    let top = y0 + 20;
    for x in 0..w {
        let c = heat(x as f64 / (w - 1) as f64);
        for y in top..top + RAMP_H {
            let i = (y * page_w + x0 + x) * 3;
            if i + 3 <= buf.len() {
                for k in 0..3 {
                    buf[i + k] = (c[k] * 255.0).round() as u8;
                }
            }
        }
    }
    let mut texts = vec![(caption(bar), x0 as i32, y0 as i32)];
    for k in 0..=TICKS {
        let x = x0 + k * (w - 1) / TICKS;
        for y in top + RAMP_H..top + RAMP_H + 4 {
            let i = (y * page_w + x) * 3;
            if i + 3 <= buf.len() {
                buf[i..i + 3].copy_from_slice(&[0, 0, 0]);
            }
        }
        let label = tick(bar.white * k as f64 / TICKS as f64);
        // Centred under the tick; the first starts at the ramp's edge.
        let dx = if k == 0 { 0 } else { 4 * label.len() as i32 };
        texts.push((label, x as i32 - dx, (top + RAMP_H + 6) as i32));
    }
    texts
}

/// Draws `texts` (from [`paint`]) onto the RGB8 page.
pub fn draw_texts(
    buf: &mut [u8],
    (w, h): (usize, usize),
    texts: &[(String, i32, i32)],
    px: u32,
    out: &Path,
) -> Result<()> {
    register_fonts();
    let root = BitMapBackend::with_buffer(buf, (w as u32, h as u32)).into_drawing_area();
    let e = |e| Error::format(out, format!("plotting failed: {e}"));
    let font = ("sans-serif", px).into_font().color(&BLACK);
    for (t, x, y) in texts {
        root.draw_text(t, &font, (*x, *y)).map_err(e)?;
    }
    root.present().map_err(e)
}

/// Writes the heat image `rgb` (`w` x `h`, RGB8) with its colour bar below
/// it as a PNG at `out`; the page is at least wide enough for the bar.
pub fn write_heat_png(
    rgb: &[u8],
    (w, h): (usize, usize),
    bar: &ColourBar,
    out: &Path,
) -> Result<()> {
    let page_w = w.max(MIN_PAGE_W);
    let page_h = h + HEIGHT;
    crate::limits::check_image_size(&out.display().to_string(), page_w, page_h)?;
    let mut buf = vec![255u8; page_w * page_h * 3];
    for y in 0..h {
        let dst = y * page_w * 3;
        buf[dst..dst + 3 * w].copy_from_slice(&rgb[y * w * 3..(y + 1) * w * 3]);
    }
    let texts = paint(bar, &mut buf, page_w, (8, h + 6));
    draw_texts(&mut buf, (page_w, page_h), &texts, 12, out)?;
    write_png(buf, page_w as u32, page_h as u32, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ramp_runs_from_black_to_white_with_labelled_ticks() {
        let bar = ColourBar {
            white: 5.0,
            unit: "% of the exact peak".into(),
            quantity: "|result - exact|".into(),
        };
        let page_w = 400;
        let mut buf = vec![255u8; page_w * HEIGHT * 3];
        let texts = paint(&bar, &mut buf, page_w, (8, 0));
        let px = |x: usize, y: usize| &buf[(y * page_w + x) * 3..(y * page_w + x) * 3 + 3];
        assert_eq!(px(8, 25), &[0, 0, 0], "the ramp starts black");
        assert_eq!(px(8 + RAMP_W - 1, 25), &[255, 255, 255], "and ends white");
        let labels: Vec<&str> = texts[1..].iter().map(|t| t.0.as_str()).collect();
        assert_eq!(labels, ["0", "1.25", "2.5", "3.75", "5"]);
        assert!(texts[0].0.contains("white = 5 % of the exact peak"));
    }
}
