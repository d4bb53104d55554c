//! Error-against-cost plots with both axes logarithmic: one marker per
//! configuration, labelled, the Pareto front (no other point is both
//! cheaper and more accurate) joined by a line.

use super::plot::{draw_legend, plot_err, render_grid, Area, PALETTE};
use crate::error::Result;
use plotters::prelude::*;
use std::path::Path;

/// One configuration: cost, error and its label.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub cost: f64,
    pub error: f64,
    pub label: String,
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

/// Draws `panels` on a grid with `cols` columns into a PNG.
pub fn render(panels: &[ParetoPanel], cols: usize, title: &str, out: &Path) -> Result<()> {
    render_grid(panels, cols, (720, 500), title, out, |panel, area| {
        draw_panel(panel, area, out)
    })
}

/// One panel: every series' points, labelled, and its Pareto front.
fn draw_panel(panel: &ParetoPanel, area: &Area, out: &Path) -> Result<()> {
    let e = |e| plot_err(out, e);
    let all = || panel.series.iter().flat_map(|s| s.points.iter());
    let (Some(xr), Some(yr)) = (
        decade_range(all().map(|p| p.cost)),
        decade_range(all().map(|p| p.error)),
    ) else {
        return Ok(());
    };
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale())
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .x_label_formatter(&|v| format!("{v:.1e}"))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    for (si, s) in panel.series.iter().enumerate() {
        let color = PALETTE[si % PALETTE.len()];
        let pts: Vec<&Point> = s
            .points
            .iter()
            .filter(|p| p.cost > 0.0 && p.error > 0.0 && p.error.is_finite())
            .collect();
        let owned: Vec<Point> = pts.iter().map(|p| (*p).clone()).collect();
        let line: Vec<(f64, f64)> = front(&owned)
            .into_iter()
            .map(|i| (owned[i].cost, owned[i].error))
            .collect();
        chart
            .draw_series(LineSeries::new(line, color.stroke_width(1)))
            .map_err(e)?
            .label(&s.name)
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, color.filled()));
        chart
            .draw_series(pts.iter().map(|p| {
                EmptyElement::at((p.cost, p.error))
                    + Circle::new((0, 0), 4, color.filled())
                    + Text::new(
                        p.label.clone(),
                        (6, -12),
                        ("sans-serif", 11).into_font().color(&color),
                    )
            }))
            .map_err(e)?;
    }
    draw_legend(&mut chart, 13, out)
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
