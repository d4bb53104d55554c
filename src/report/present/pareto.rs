//! Error-against-cost plots with both axes logarithmic: one marker per
//! configuration, labelled, the Pareto front (no other point is both
//! cheaper and more accurate) joined by a line.

use super::layout::{log_tick_sets, pick_ticks, place_labels, tick_label, Rect, TextBox};
use super::plot::{plot_err, render_grid, Area, PALETTE};
use crate::error::Result;
use plotters::coord::combinators::{BindKeyPoints, LogCoord, WithKeyPoints};
use plotters::prelude::*;
use std::path::Path;

/// One configuration: cost, error and its label.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub cost: f64,
    pub error: f64,
    pub label: String,
    /// One-dimensional passes the configuration runs (its marker's shape);
    /// None where passes are not the point (photons, profile models).
    pub passes: Option<usize>,
}

/// A group of points drawn in one colour.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<Point>,
}

#[derive(Clone, Debug)]
pub struct ParetoPanel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// Indices of the points on the Pareto front (cheapest first).
pub fn front(points: &[Point]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].cost > 0.0 && points[i].error > 0.0)
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .cost
            .total_cmp(&points[b].cost)
            .then(points[a].error.total_cmp(&points[b].error))
    });
    let mut out = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].error < best {
            best = points[i].error;
            out.push(i);
        }
    }
    out
}

fn decade_range(v: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = v
        .filter(|x| *x > 0.0 && x.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(l, h), x| (l.min(x), h.max(x)));
    (hi > 0.0).then(|| (lo / 1.5, hi * 1.5))
}

/// Size of one panel, pixels: the chart and, right of it, the column that
/// holds the legend and the numbered key (never drawn over data).
const PANEL: (u32, u32) = (900, 500);
const SIDE: u32 = 230;
/// Font sizes, pixels: title, tick labels and axis titles, point labels
/// and the side column.
const TITLE_PX: u32 = 18;
const TICK_PX: u32 = 13;
const LABEL_PX: u32 = 11;
/// Pixels kept free between two tick labels.
const TICK_GAP: i32 = 8;
/// Marker radius, pixels.
const MARKER: i32 = 4;

/// Draws `panels` on a grid with `cols` columns into a PNG; returns every
/// text box it drew, in the image's pixels (for tests of the layout).
pub fn render(
    panels: &[ParetoPanel],
    cols: usize,
    title: &str,
    out: &Path,
) -> Result<Vec<TextBox>> {
    let mut boxes = Vec::new();
    render_grid(panels, cols, PANEL, title, out, |panel, area| {
        boxes.extend(draw_panel(panel, area, out)?);
        Ok(())
    })?;
    Ok(boxes)
}

/// The marker of a configuration run in `passes` one-dimensional passes
/// (circle 2, triangle 4, square 6, cross more), and its legend name.
fn marker_name(passes: usize) -> &'static str {
    match passes {
        0..=2 => "circle",
        3..=4 => "triangle",
        5..=6 => "square",
        _ => "cross",
    }
}

fn draw_marker(
    area: &Area,
    at: (i32, i32),
    passes: Option<usize>,
    color: RGBColor,
    out: &Path,
) -> Result<()> {
    let style = color.filled();
    let r = MARKER;
    let e = |e| plot_err(out, e);
    match marker_name(passes.unwrap_or(2)) {
        "circle" => area.draw(&Circle::new(at, r, style)).map_err(e),
        "triangle" => area.draw(&TriangleMarker::new(at, r + 1, style)).map_err(e),
        "square" => area
            .draw(&Rectangle::new(
                [(at.0 - r, at.1 - r), (at.0 + r, at.1 + r)],
                style,
            ))
            .map_err(e),
        _ => area
            .draw(&Cross::new(at, r, color.stroke_width(2)))
            .map_err(e),
    }
}

/// A log axis from `lo` to `hi` drawn over pixels `p0..p1` (p1 may be
/// below p0 for a y axis): the pixel of a value.
fn log_px(lo: f64, hi: f64, p0: i32, p1: i32) -> impl Fn(f64) -> i32 {
    let (a, b) = (lo.ln(), hi.ln());
    move |v| p0 + ((v.ln() - a) / (b - a) * (p1 - p0) as f64).round() as i32
}

/// Texts drawn in panel-relative pixels, recorded in image pixels.
struct Writer<'a, 'b> {
    area: &'a Area<'b>,
    base: (i32, i32),
    out: &'a Path,
    boxes: Vec<TextBox>,
}

impl Writer<'_, '_> {
    /// The box of `text` at `px` pixels: the font's measured width, and
    /// at least the font size in height (the estimate measures the glyphs'
    /// ink, which leaves out descenders on some strings).
    fn size(&self, text: &str, px: u32) -> Result<(u32, u32)> {
        let (w, h) = self
            .area
            .estimate_text_size(text, &("sans-serif", px).into_font().into())
            .map_err(|e| plot_err(self.out, e))?;
        Ok((w, h.max(px)))
    }

    /// Draws `text` with its top-left corner at image pixel `at`.
    fn text(&mut self, text: &str, px: u32, color: RGBColor, at: (i32, i32)) -> Result<Rect> {
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
}

/// One panel: every series' points, labelled where a label fits and
/// numbered in the key beside the chart where none does, and each series'
/// Pareto front.
fn draw_panel(panel: &ParetoPanel, area: &Area, out: &Path) -> Result<Vec<TextBox>> {
    let e = |e| plot_err(out, e);
    let all = || panel.series.iter().flat_map(|s| s.points.iter());
    let (Some(xr), Some(yr)) = (
        decade_range(all().map(|p| p.cost)),
        decade_range(all().map(|p| p.error)),
    ) else {
        return Ok(vec![]);
    };
    let base = area.get_base_pixel();
    let mut w = Writer {
        area,
        base,
        out,
        boxes: Vec::new(),
    };
    w.text(&panel.title, TITLE_PX, BLACK, (base.0 + 12, base.1 + 6))?;
    let (chart_area, side) = area.split_horizontally(PANEL.0 - SIDE);
    let (_, body) = chart_area.split_vertically(TITLE_PX + 14);
    let builder = |x: Vec<f64>, y: Vec<f64>| {
        let mut b = ChartBuilder::on(&body);
        b.margin(12).x_label_area_size(48).y_label_area_size(70);
        b.build_cartesian_2d(
            (xr.0..xr.1).log_scale().with_key_points(x),
            (yr.0..yr.1).log_scale().with_key_points(y),
        )
    };
    let (px_x, px_y) = builder(vec![], vec![])
        .map_err(e)?
        .plotting_area()
        .get_pixel_range();
    let to_x = log_px(xr.0, xr.1, px_x.start, px_x.end);
    let to_y = log_px(yr.0, yr.1, px_y.end, px_y.start);
    let tick_size = |v: f64| w.size(&tick_label(v), TICK_PX);
    let x_box = |v: f64| {
        let s = tick_size(v).unwrap_or((0, 0));
        Rect::at(to_x(v) - s.0 as i32 / 2, px_y.end + 6, s)
    };
    let y_box = |v: f64| {
        let s = tick_size(v).unwrap_or((0, 0));
        Rect::at(px_x.start - 8 - s.0 as i32, to_y(v) - s.1 as i32 / 2, s)
    };
    let xt = pick_ticks(&log_tick_sets(xr.0, xr.1), TICK_GAP, x_box);
    let yt = pick_ticks(&log_tick_sets(yr.0, yr.1), TICK_GAP, y_box);
    let mut chart = builder(xt.clone(), yt.clone()).map_err(e)?;
    chart
        .configure_mesh()
        .x_label_formatter(&|_| String::new())
        .y_label_formatter(&|_| String::new())
        .y_desc(&panel.y_label)
        .axis_desc_style(("sans-serif", TICK_PX))
        .draw()
        .map_err(e)?;
    let ticks: Vec<(f64, Rect)> = xt
        .iter()
        .map(|&v| (v, x_box(v)))
        .chain(yt.iter().map(|&v| (v, y_box(v))))
        .collect();
    for (v, b) in ticks {
        w.text(&tick_label(v), TICK_PX, BLACK, (b.x0, b.y0))?;
    }
    let xd = w.size(&panel.x_label, TICK_PX)?;
    let mid = (px_x.start + px_x.end) / 2;
    w.text(
        &panel.x_label,
        TICK_PX,
        BLACK,
        (mid - xd.0 as i32 / 2, px_y.end + 26),
    )?;
    // The y axis title, drawn rotated by plotters at the left of the label
    // area: its box, for the layout check.
    let yd = w.size(&panel.y_label, TICK_PX)?;
    let ymid = (px_y.start + px_y.end) / 2;
    w.boxes.push(TextBox {
        text: panel.y_label.clone(),
        rect: Rect::at(px_x.start - 70, ymid - yd.0 as i32 / 2, (yd.1, yd.0)),
    });
    draw_points(panel, &mut chart, &mut w, (&to_x, &to_y), &side)?;
    Ok(w.boxes)
}

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<WithKeyPoints<LogCoord<f64>>, WithKeyPoints<LogCoord<f64>>>,
>;

/// The fronts, the markers, their labels, and the side column: legend,
/// marker shapes by passes, and the numbered key of the labels that did
/// not fit beside their markers.
fn draw_points(
    panel: &ParetoPanel,
    chart: &mut Chart,
    w: &mut Writer,
    (to_x, to_y): (&dyn Fn(f64) -> i32, &dyn Fn(f64) -> i32),
    side: &Area,
) -> Result<()> {
    let e = |e| plot_err(w.out, e);
    let (px_x, px_y) = chart.plotting_area().get_pixel_range();
    let bounds = Rect {
        x0: px_x.start,
        y0: px_y.start,
        x1: px_x.end,
        y1: px_y.end,
    };
    let mut drawn: Vec<(&Point, RGBColor, (i32, i32))> = Vec::new();
    for (si, s) in panel.series.iter().enumerate() {
        let color = PALETTE[si % PALETTE.len()];
        let pts: Vec<Point> = s
            .points
            .iter()
            .filter(|p| p.cost > 0.0 && p.error > 0.0 && p.error.is_finite())
            .cloned()
            .collect();
        let line: Vec<(f64, f64)> = front(&pts)
            .into_iter()
            .map(|i| (pts[i].cost, pts[i].error))
            .collect();
        chart
            .draw_series(LineSeries::new(line, color.stroke_width(1)))
            .map_err(e)?;
        for p in s.points.iter().filter(|p| pts.contains(p)) {
            drawn.push((p, color, (to_x(p.cost), to_y(p.error))));
        }
    }
    for &(p, color, at) in &drawn {
        draw_marker(
            w.area,
            (at.0 - w.base.0, at.1 - w.base.1),
            p.passes,
            color,
            w.out,
        )?;
    }
    let at: Vec<(i32, i32)> = drawn.iter().map(|d| d.2).collect();
    let sizes: Vec<(u32, u32)> = drawn
        .iter()
        .map(|d| w.size(&d.0.label, LABEL_PX))
        .collect::<Result<_>>()?;
    let placed = place_labels(&at, &sizes, MARKER + 1, &bounds, &[]);
    let mut taken: Vec<Rect> = placed.boxes.iter().flatten().cloned().collect();
    let mut key: Vec<(usize, &Point, RGBColor)> = Vec::new();
    for (i, (b, d)) in placed.boxes.iter().zip(&drawn).enumerate() {
        match b {
            Some(b) => {
                w.text(&d.0.label, LABEL_PX, d.1, (b.x0, b.y0))?;
            }
            None => {
                let n = key.len() + 1;
                let s = w.size(&n.to_string(), LABEL_PX)?;
                let p = place_labels(&[at[i]], &[s], MARKER + 1, &bounds, &taken);
                if let Some(b) = p.boxes[0] {
                    w.text(&n.to_string(), LABEL_PX, d.1, (b.x0, b.y0))?;
                    taken.push(b);
                }
                key.push((n, d.0, d.1));
            }
        }
    }
    draw_side(panel, w, side, &key)
}

/// The column right of the chart: one line per series (its colour), one
/// per marker shape in use (passes), then the key of numbered points.
fn draw_side(
    panel: &ParetoPanel,
    w: &mut Writer,
    side: &Area,
    key: &[(usize, &Point, RGBColor)],
) -> Result<()> {
    let (x0, mut y) = side.get_base_pixel();
    y += TITLE_PX as i32 + 30;
    let line = LABEL_PX as i32 + 6;
    for (si, s) in panel.series.iter().enumerate() {
        let color = PALETTE[si % PALETTE.len()];
        side.draw(&Circle::new(
            (8, y - side.get_base_pixel().1 + 6),
            MARKER,
            color.filled(),
        ))
        .map_err(|e| plot_err(w.out, e))?;
        w.text(&s.name, LABEL_PX, BLACK, (x0 + 18, y))?;
        y += line;
    }
    let mut passes: Vec<usize> = panel
        .series
        .iter()
        .flat_map(|s| s.points.iter().filter_map(|p| p.passes))
        .collect();
    passes.sort();
    passes.dedup();
    let mut shapes: Vec<(&str, Vec<usize>)> = Vec::new();
    for p in passes {
        match shapes.last_mut() {
            Some((m, v)) if *m == marker_name(p) => v.push(p),
            _ => shapes.push((marker_name(p), vec![p])),
        }
    }
    if !shapes.is_empty() {
        y += line / 2;
        for (_, v) in &shapes {
            let at = (8, y - side.get_base_pixel().1 + 6);
            draw_marker(side, at, Some(v[0]), BLACK, w.out)?;
            let n: Vec<String> = v.iter().map(|p| p.to_string()).collect();
            w.text(
                &format!("{} passes", n.join(", ")),
                LABEL_PX,
                BLACK,
                (x0 + 18, y),
            )?;
            y += line;
        }
    }
    if !key.is_empty() {
        y += line / 2;
        for (n, p, color) in key {
            w.text(&format!("{n}  {}", p.label), LABEL_PX, *color, (x0 + 8, y))?;
            y += line;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_front_keeps_only_undominated_points() {
        let p = |c: f64, e: f64| Point {
            cost: c,
            error: e,
            label: String::new(),
            passes: None,
        };
        let pts = [
            p(1.0, 0.5),
            p(2.0, 0.6),
            p(3.0, 0.1),
            p(0.5, 0.9),
            p(3.0, 0.05),
        ];
        assert_eq!(front(&pts), vec![3, 0, 4]);
    }
}
