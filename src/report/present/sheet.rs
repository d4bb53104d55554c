//! The contact sheet's page: tiles six to a row, each an image with its
//! label above it and optionally a second image below, a title and a
//! colour bar. Labels are wrapped to their tile's width with the sheet's
//! own font, so that no label runs into its neighbour or leaves the page;
//! the layout returns every text box it drew for a test to check.

use super::colour_bar::{self, ColourBar};
use super::layout::{Rect, TextBox};
use super::plot;
use crate::error::{Error, Result};
use plotters::prelude::*;
use std::path::Path;

/// One cell of a contact sheet: an 8-bit RGB image of the sheet's tile
/// size with its label, and optionally a second one below it; `flag`, a
/// warning drawn in red under the label with a red frame round the tile.
pub(crate) struct SheetTile {
    pub label: String,
    pub top: Vec<u8>,
    pub bottom: Option<(String, Vec<u8>)>,
    pub flag: Option<String>,
}

/// Tiles per row.
const COLS: usize = 6;
/// Pixels between tiles.
const GAP: usize = 8;
const TITLE_PX: u32 = 15;
const LABEL_PX: u32 = 13;
/// A line of text at `px` pixels takes `px + LEADING` pixels.
const LEADING: u32 = 3;
/// The flag's colour: a red that reads on white.
const FLAG: RGBColor = RGBColor(200, 0, 0);
/// The narrowest column of tiles, pixels: a label wraps to its column,
/// and below about 14 characters a line breaks inside words.
const MIN_COLUMN_W: usize = 96;
/// Width of the flag's frame round the tile, pixels.
const FRAME: usize = 2;

/// The width and height of `text` at `px` pixels in the sheet's font (the
/// height at least the font size, as the plots measure it).
pub(crate) fn text_size(text: &str, px: u32) -> (u32, u32) {
    plot::register_fonts();
    let (w, h) = ("sans-serif", px)
        .into_font()
        .box_size(text)
        .unwrap_or((px * text.chars().count() as u32, px));
    (w, h.max(px))
}

/// `text` in lines no wider than `max_w` pixels at `px`: broken between
/// words, and a word wider than a line between characters.
pub(crate) fn wrap(text: &str, px: u32, max_w: u32) -> Vec<String> {
    let fits = |s: &str| text_size(s, px).0 <= max_w;
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let joined = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if fits(&joined) {
            line = joined;
            continue;
        }
        if !line.is_empty() {
            lines.push(std::mem::take(&mut line));
        }
        for ch in word.chars() {
            let longer = format!("{line}{ch}");
            if !line.is_empty() && !fits(&longer) {
                lines.push(std::mem::take(&mut line));
                line.push(ch);
            } else {
                line = longer;
            }
        }
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

/// A text to draw: its box (top-left corner where it is drawn), size and
/// colour.
struct Text {
    text: TextBox,
    px: u32,
    colour: RGBColor,
}

/// Lines of `text` stacked from `(x, y)`, as [`Text`]s; returns the height.
fn stack(out: &mut Vec<Text>, lines: &[String], px: u32, colour: RGBColor, (x, y): (i32, i32)) {
    for (i, l) in lines.iter().enumerate() {
        out.push(Text {
            text: TextBox {
                text: l.clone(),
                rect: Rect::at(x, y + i as i32 * (px + LEADING) as i32, text_size(l, px)),
            },
            px,
            colour,
        });
    }
}

/// Lines of a tile's top label (its label, then its flag in red) and of
/// its bottom label.
fn tile_lines(t: &SheetTile, w: u32) -> (Vec<String>, Vec<String>, Vec<String>) {
    let top = wrap(&t.label, LABEL_PX, w);
    let flag = t.flag.as_ref().map_or(vec![], |f| wrap(f, LABEL_PX, w));
    let bottom = t
        .bottom
        .as_ref()
        .map_or(vec![], |(l, _)| wrap(l, LABEL_PX, w));
    (top, flag, bottom)
}

/// Where a sheet put things, in image pixels: every text box drawn and
/// every image, in tile order (each tile's top image, then its bottom one).
#[derive(Clone, Debug)]
pub struct SheetLayout {
    pub texts: Vec<TextBox>,
    pub images: Vec<Rect>,
}

/// Draws `tiles` of `w` x `h` pixels six to a row under `title`, with the
/// colour bar of its difference tiles below them, writes the PNG
/// atomically and returns where everything went.
pub(crate) fn draw_sheet(
    tiles: &[SheetTile],
    size: (usize, usize),
    title: &str,
    bar: Option<&ColourBar>,
    out: &Path,
) -> Result<SheetLayout> {
    draw_sheet_in(tiles, size, COLS, title, bar, out)
}

/// [`draw_sheet`] with `cols` tiles to a row.
pub(crate) fn draw_sheet_in(
    tiles: &[SheetTile],
    (w, h): (usize, usize),
    cols: usize,
    title: &str,
    bar: Option<&ColourBar>,
    out: &Path,
) -> Result<SheetLayout> {
    let cols = cols.max(1);
    let line = |n: usize| n * (LABEL_PX + LEADING) as usize;
    let col_w = w.max(MIN_COLUMN_W);
    let cell_w = col_w + GAP;
    // Wide enough for a row of tiles, the colour bar and its caption.
    let bar_w = bar.map_or(0, |b| {
        let caption = text_size(&colour_bar::caption(b), colour_bar::TEXT_PX).0 as usize;
        colour_bar::MIN_PAGE_W.max(caption + 2 * GAP)
    });
    let sw = (cols * cell_w).max(bar_w);
    let title_lines = wrap(title, TITLE_PX, (sw - 2 * GAP) as u32);
    let head = GAP + title_lines.len() * (TITLE_PX + LEADING) as usize + GAP;
    let lines: Vec<_> = tiles.iter().map(|t| tile_lines(t, col_w as u32)).collect();
    // Per row of tiles: the label height above the top and above the
    // bottom images (the most lines any tile of the row has).
    let rows: Vec<(usize, usize)> = lines
        .chunks(cols)
        .map(|r| {
            let top = r.iter().map(|l| l.0.len() + l.1.len()).max().unwrap_or(1);
            let bottom = r.iter().map(|l| l.2.len()).max().unwrap_or(0);
            (line(top) + 2, line(bottom) + 4)
        })
        .collect();
    let has_bottom = tiles.iter().any(|t| t.bottom.is_some());
    let row_h = |r: &(usize, usize)| r.0 + h + if has_bottom { r.1 + h } else { 0 } + GAP;
    let body: usize = rows.iter().map(row_h).sum();
    let bar_h = if bar.is_some() { colour_bar::HEIGHT } else { 0 };
    let sh = head + body + bar_h;
    crate::limits::check_image_size(&out.display().to_string(), sw, sh)?;
    let mut buf = vec![255u8; sw * sh * 3];
    let mut texts = Vec::new();
    let mut images = Vec::new();
    let size = (w as u32, h as u32);
    stack(
        &mut texts,
        &title_lines,
        TITLE_PX,
        BLACK,
        (GAP as i32, GAP as i32),
    );
    let mut y0 = head;
    for (r, row) in rows.iter().enumerate() {
        for (k, t) in tiles.iter().enumerate().skip(r * cols).take(cols) {
            let x0 = (k % cols) * cell_w + GAP / 2;
            let (top, flag, bottom) = &lines[k];
            stack(&mut texts, top, LABEL_PX, BLACK, (x0 as i32, y0 as i32));
            let yf = y0 + line(top.len());
            stack(&mut texts, flag, LABEL_PX, FLAG, (x0 as i32, yf as i32));
            let yt = y0 + row.0;
            blit(&mut buf, sw, &t.top, (w, h), (x0, yt));
            images.push(Rect::at(x0 as i32, yt as i32, size));
            if t.flag.is_some() {
                frame(&mut buf, sw, (x0, yt), (w, h));
            }
            if let Some((_, rgb)) = &t.bottom {
                let yb = yt + h + 2;
                stack(&mut texts, bottom, LABEL_PX, BLACK, (x0 as i32, yb as i32));
                blit(&mut buf, sw, rgb, (w, h), (x0, yt + h + row.1));
                images.push(Rect::at(x0 as i32, (yt + h + row.1) as i32, size));
            }
        }
        y0 += row_h(row);
    }
    if let Some(b) = bar {
        for (t, x, y) in colour_bar::paint(b, &mut buf, sw, (GAP / 2, y0 + 2)) {
            let rect = Rect::at(x, y, text_size(&t, colour_bar::TEXT_PX));
            texts.push(Text {
                text: TextBox { text: t, rect },
                px: colour_bar::TEXT_PX,
                colour: BLACK,
            });
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut buf, (sw as u32, sh as u32)).into_drawing_area();
        let e = |e| Error::format(out, format!("plotting failed: {e}"));
        for t in &texts {
            let font = ("sans-serif", t.px).into_font().color(&t.colour);
            root.draw_text(&t.text.text, &font, (t.text.rect.x0, t.text.rect.y0))
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    plot::write_png(buf, sw as u32, sh as u32, out)?;
    Ok(SheetLayout {
        texts: texts.into_iter().map(|t| t.text).collect(),
        images,
    })
}

/// Copies the RGB8 image `rgb` of `w` x `h` into the page at `(x0, y0)`.
fn blit(buf: &mut [u8], sw: usize, rgb: &[u8], (w, h): (usize, usize), (x0, y0): (usize, usize)) {
    for y in 0..h {
        let dst = ((y0 + y) * sw + x0) * 3;
        buf[dst..dst + 3 * w].copy_from_slice(&rgb[y * w * 3..(y + 1) * w * 3]);
    }
}

/// A [`FLAG`]-coloured frame [`FRAME`] pixels wide just inside the tile at
/// `(x0, y0)`.
fn frame(buf: &mut [u8], sw: usize, (x0, y0): (usize, usize), (w, h): (usize, usize)) {
    let RGBColor(r, g, b) = FLAG;
    for y in 0..h {
        for x in 0..w {
            let edge = x < FRAME || y < FRAME || x + FRAME >= w || y + FRAME >= h;
            if edge {
                let i = ((y0 + y) * sw + x0 + x) * 3;
                buf[i..i + 3].copy_from_slice(&[r, g, b]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapped_lines_fit_and_keep_every_character() {
        let text = "exact-2d (entry+exit)preintegrate and svd1-renorm + angularsvd2";
        for max_w in [60, 120, 300] {
            let lines = wrap(text, LABEL_PX, max_w);
            for l in &lines {
                assert!(
                    text_size(l, LABEL_PX).0 <= max_w,
                    "'{l}' wider than {max_w}"
                );
            }
            let joined: String = lines.concat();
            assert_eq!(joined.replace(' ', ""), text.replace(' ', ""));
        }
        assert_eq!(wrap("short", LABEL_PX, 300), vec!["short".to_string()]);
    }
}
