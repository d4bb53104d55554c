//! The text of every chart, drawn once: a writer that records the box of
//! each text it draws (measured with the plot's own font), axes whose tick
//! labels read (decades in plain notation on log axes, round steps on
//! linear ones, never two labels touching) with a title naming quantity
//! and unit, and text wrapped to the width it is given.

use super::layout::{linear_tick_sets, log_tick_sets, pick_ticks, tick_label, Rect, TextBox};
use crate::error::{Error, Result};
use plotters::prelude::*;
use plotters::style::FontTransform;
use std::ops::Range;
use std::path::Path;

/// A drawing area of one panel.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// The error of a plot that could not be drawn into `out`.
pub fn plot_err(out: &Path, e: impl std::fmt::Display) -> Error {
    Error::format(out, format!("plotting failed: {e}"))
}

/// Font size of tick labels and axis titles, pixels.
pub const TICK_PX: u32 = 13;
/// Pixels kept free between two tick labels of a log axis: its ticks are
/// decades (or 1-2-5), already far apart where they fit at all.
const LOG_GAP: i32 = 8;
/// Pixels kept free between two tick labels of a linear axis: about three
/// label heights, so that a 300-pixel axis carries five to eight round
/// steps rather than a label every 20 pixels.
const LINEAR_GAP: i32 = 40;
/// Pixels between the plotting area and its tick labels, and between the
/// tick labels and the axis title.
const PAD: i32 = 6;
/// Colour of grid lines: a light grey that no curve is drawn in.
const GRID: RGBAColor = RGBAColor(0, 0, 0, 0.12);
/// Length of a tick mark outside the plotting area, pixels (under
/// [`PAD`], so it never reaches a label).
const TICK_MARK: i32 = 4;
/// Space below the plotting area for the x tick labels and the x title,
/// and left of it for the y tick labels and the rotated y title, pixels.
pub const X_AREA: u32 = 2 * TICK_PX + 3 * PAD as u32 + 4;
pub const Y_AREA: u32 = 72;

/// Texts drawn on an area in image pixels, each box recorded.
pub struct Writer<'a, 'b> {
    pub area: &'a Area<'b>,
    /// The area's top-left corner in image pixels.
    pub base: (i32, i32),
    pub out: &'a Path,
    pub boxes: Vec<TextBox>,
}

impl<'a, 'b> Writer<'a, 'b> {
    pub fn new(area: &'a Area<'b>, out: &'a Path) -> Self {
        Writer {
            area,
            base: area.get_base_pixel(),
            out,
            boxes: Vec::new(),
        }
    }

    /// The box of `text` at `px` pixels: the font's measured width, and
    /// at least the font size in height (the estimate measures the glyphs'
    /// ink, which leaves out descenders on some strings).
    pub fn size(&self, text: &str, px: u32) -> Result<(u32, u32)> {
        let (w, h) = self
            .area
            .estimate_text_size(text, &("sans-serif", px).into_font().into())
            .map_err(|e| plot_err(self.out, e))?;
        Ok((w, h.max(px)))
    }

    /// Draws `text` with its top-left corner at image pixel `at`.
    pub fn text(&mut self, text: &str, px: u32, color: RGBColor, at: (i32, i32)) -> Result<Rect> {
        let size = self.size(text, px)?;
        let style = ("sans-serif", px).into_font().color(&color);
        self.area
            .draw_text(text, &style, (at.0 - self.base.0, at.1 - self.base.1))
            .map_err(|e| plot_err(self.out, e))?;
        let rect = Rect::at(at.0, at.1, size);
        self.boxes.push(TextBox {
            text: text.to_string(),
            rect,
        });
        Ok(rect)
    }

    /// Draws `text` turned a quarter left (read bottom to top) with the
    /// bottom-left corner of its box at image pixel `at`.
    pub fn text_up(&mut self, text: &str, px: u32, at: (i32, i32)) -> Result<Rect> {
        let (w, h) = self.size(text, px)?;
        let style = ("sans-serif", px)
            .into_font()
            .transform(FontTransform::Rotate270)
            .color(&BLACK);
        self.area
            .draw_text(text, &style, (at.0 - self.base.0, at.1 - self.base.1))
            .map_err(|e| plot_err(self.out, e))?;
        let rect = Rect::at(at.0, at.1 - w as i32, (h, w));
        self.boxes.push(TextBox {
            text: text.to_string(),
            rect,
        });
        Ok(rect)
    }

    /// `text` cut at spaces into lines no wider than `width` pixels at
    /// `px` (a single word wider than that stays whole on its line).
    pub fn wrap(&self, text: &str, px: u32, width: u32) -> Result<Vec<String>> {
        let mut lines: Vec<String> = Vec::new();
        let mut line = String::new();
        for word in text.split(' ') {
            let longer = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            if !line.is_empty() && self.size(&longer, px)?.0 > width {
                lines.push(std::mem::replace(&mut line, word.to_string()));
            } else {
                line = longer;
            }
        }
        lines.push(line);
        Ok(lines)
    }
}

/// How an axis maps values to pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    Linear,
    Log,
}

/// One axis: its scale, its range and its title (quantity and unit).
#[derive(Clone, Debug)]
pub struct Axis {
    pub scale: Scale,
    pub lo: f64,
    pub hi: f64,
    pub title: String,
}

impl Axis {
    /// The pixel of value `v` on this axis drawn over pixels `p0..p1`
    /// (`p1` below `p0` for a y axis).
    pub fn to_px(&self, p0: i32, p1: i32) -> impl Fn(f64) -> i32 {
        let f = match self.scale {
            Scale::Linear => |v: f64| v,
            Scale::Log => |v: f64| v.ln(),
        };
        let (a, b) = (f(self.lo), f(self.hi));
        move |v| p0 + ((f(v) - a) / (b - a) * (p1 - p0) as f64).round() as i32
    }

    /// Candidate tick sets, densest first, and the gap their labels keep.
    fn candidates(&self) -> (Vec<Vec<f64>>, i32) {
        match self.scale {
            Scale::Log => (log_tick_sets(self.lo, self.hi), LOG_GAP),
            Scale::Linear => (linear_tick_sets(self.lo, self.hi), LINEAR_GAP),
        }
    }

    /// The label of tick `v` among `ticks`.
    fn label(&self, v: f64, ticks: &[f64]) -> String {
        match self.scale {
            Scale::Log => tick_label(v),
            Scale::Linear => {
                let step = match ticks {
                    [a, b, ..] => b - a,
                    _ => v.abs(),
                };
                super::layout::linear_tick_label(v, step)
            }
        }
    }
}

/// The plotting area of a chart in image pixels (x left to right, y top
/// to bottom) and its two axes.
pub struct Frame {
    pub x_px: Range<i32>,
    pub y_px: Range<i32>,
    pub x: Axis,
    pub y: Axis,
}

/// The ticks chosen for the two axes of a [`Frame`].
pub struct Ticks {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

impl Frame {
    fn x_box(&self, w: &Writer, v: f64, ticks: &[f64]) -> Rect {
        let s = w.size(&self.x.label(v, ticks), TICK_PX).unwrap_or((0, 0));
        let x = self.x.to_px(self.x_px.start, self.x_px.end)(v);
        Rect::at(x - s.0 as i32 / 2, self.y_px.end + PAD, s)
    }

    fn y_box(&self, w: &Writer, v: f64, ticks: &[f64]) -> Rect {
        let s = w.size(&self.y.label(v, ticks), TICK_PX).unwrap_or((0, 0));
        let y = self.y.to_px(self.y_px.end, self.y_px.start)(v);
        Rect::at(self.x_px.start - PAD - s.0 as i32, y - s.1 as i32 / 2, s)
    }

    /// The densest tick sets whose labels keep their axis' gap apart
    /// (each set judged by its own labels: a linear step sets the
    /// decimals).
    pub fn ticks(&self, w: &Writer) -> Ticks {
        let (xs, xg) = self.x.candidates();
        let (ys, yg) = self.y.candidates();
        Ticks {
            x: pick_ticks(&xs, xg, |v, s| self.x_box(w, v, s)),
            y: pick_ticks(&ys, yg, |v, s| self.y_box(w, v, s)),
        }
    }

    /// Draws the grid lines at `ticks` (light), the frame of the
    /// plotting area and a short mark outside it at every tick.
    pub fn draw_grid(&self, w: &Writer, ticks: &Ticks) -> Result<()> {
        let e = |e| plot_err(w.out, e);
        let (bx, by) = w.base;
        let (x0, x1) = (self.x_px.start - bx, self.x_px.end - bx);
        let (y0, y1) = (self.y_px.start - by, self.y_px.end - by);
        let tx = self.x.to_px(x0, x1);
        let ty = self.y.to_px(y1, y0);
        let line = |a: (i32, i32), b: (i32, i32), c: RGBAColor| {
            w.area.draw(&PathElement::new(vec![a, b], c)).map_err(e)
        };
        for &v in &ticks.x {
            line((tx(v), y0), (tx(v), y1), GRID)?;
            line((tx(v), y1), (tx(v), y1 + TICK_MARK), BLACK.to_rgba())?;
        }
        for &v in &ticks.y {
            line((x0, ty(v)), (x1, ty(v)), GRID)?;
            line((x0 - TICK_MARK, ty(v)), (x0, ty(v)), BLACK.to_rgba())?;
        }
        let frame = Rectangle::new([(x0, y0), (x1, y1)], BLACK.stroke_width(1));
        w.area.draw(&frame).map_err(e)
    }

    /// Draws the tick labels of `ticks`, the x title centred under them
    /// and the y title turned up at `y_title_x` (image pixels).
    pub fn draw_text(&self, w: &mut Writer, ticks: &Ticks, y_title_x: i32) -> Result<()> {
        for &v in &ticks.x {
            let b = self.x_box(w, v, &ticks.x);
            w.text(&self.x.label(v, &ticks.x), TICK_PX, BLACK, (b.x0, b.y0))?;
        }
        for &v in &ticks.y {
            let b = self.y_box(w, v, &ticks.y);
            w.text(&self.y.label(v, &ticks.y), TICK_PX, BLACK, (b.x0, b.y0))?;
        }
        let (xw, _) = w.size(&self.x.title, TICK_PX)?;
        let mid = (self.x_px.start + self.x_px.end) / 2;
        let top = self.y_px.end + 2 * PAD + TICK_PX as i32 + 2;
        w.text(&self.x.title, TICK_PX, BLACK, (mid - xw as i32 / 2, top))?;
        let (yw, _) = w.size(&self.y.title, TICK_PX)?;
        let ymid = (self.y_px.start + self.y_px.end) / 2;
        w.text_up(&self.y.title, TICK_PX, (y_title_x, ymid + yw as i32 / 2))?;
        Ok(())
    }
}
