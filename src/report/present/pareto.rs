//! Error-against-cost plots with both axes logarithmic: one marker per
//! configuration, labelled, the Pareto front (no other point is both
//! cheaper and more accurate) joined by a line.

use super::axes::{plot_err, Area, Axis, Frame, Scale, Writer, X_AREA, Y_AREA};
use super::layout::{place_labels, Rect, TextBox};
use super::plot::{render_grid, PALETTE};
use crate::error::Result;
use plotters::coord::combinators::LogCoord;
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
/// Font sizes, pixels: title, point labels and the side column.
const TITLE_PX: u32 = 18;
const LABEL_PX: u32 = 11;
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
    render_grid(panels, cols, PANEL, title, out, |panel, area| {
        draw_panel(panel, area, out)
    })
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
    let mut w = Writer::new(area, out);
    let base = w.base;
    w.text(&panel.title, TITLE_PX, BLACK, (base.0 + 12, base.1 + 6))?;
    let (chart_area, side) = area.split_horizontally(PANEL.0 - SIDE);
    let (_, body) = chart_area.split_vertically(TITLE_PX + 14);
    let builder = || {
        let mut b = ChartBuilder::on(&body);
        b.margin(12)
            .x_label_area_size(X_AREA)
            .y_label_area_size(Y_AREA);
        b.build_cartesian_2d((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale())
    };
    let mut chart = builder().map_err(e)?;
    let (x_px, y_px) = chart.plotting_area().get_pixel_range();
    let axis = |(lo, hi): (f64, f64), title: &str| Axis {
        scale: Scale::Log,
        lo,
        hi,
        title: title.to_string(),
    };
    let frame = Frame {
        x_px,
        y_px,
        x: axis(xr, &panel.x_label),
        y: axis(yr, &panel.y_label),
    };
    let ticks = frame.ticks(&w);
    frame.draw_grid(&w, &ticks)?;
    frame.draw_text(&mut w, &ticks, body.get_base_pixel().0 + 2)?;
    let to_x = frame.x.to_px(frame.x_px.start, frame.x_px.end);
    let to_y = frame.y.to_px(frame.y_px.end, frame.y_px.start);
    draw_points(panel, &mut chart, &mut w, (&to_x, &to_y), &side)?;
    Ok(w.boxes)
}

type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

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
