//! The thickness table shown: T against thickness per channel, log-log,
//! the Monte Carlo with its 4-sigma bars beside each engine's formula with
//! its fitted settings, and the radial spread (radii holding 50% and 90% of
//! T) against thickness; and the table as CSV.

use super::axes::{plot_err, Area, Axis, Frame, Scale, X_AREA, Y_AREA};
use super::layout::TextBox;
use super::plot::{
    draw_legend, draw_line, frame_panel, render_grid, Curve, CHART_RIGHT, CHART_TOP, PALETTE,
};
use crate::error::Result;
use crate::profile::transmission::ThicknessTable;
use plotters::prelude::*;
use std::path::Path;

/// Size of one panel, pixels.
const PANEL: (u32, u32) = (640, 480);
/// Standard errors of the bars on the Monte Carlo points.
const BARS: f64 = 4.0;

/// One log-log chart: curves, and vertical bars (x, lo, hi) on the first.
struct LogLog {
    title: String,
    x_label: String,
    y_label: String,
    curves: Vec<Curve>,
}

/// An engine's fitted T per row of the table and channel (r, g, b): what
/// the plot draws of an engine's transmission fit.
pub struct FittedCurve<'a> {
    pub engine: &'a str,
    pub t: &'a [[f64; 3]],
}

/// The radii holding 50% and 90% of T per channel and thickness.
fn radii_panel(table: &ThicknessTable) -> LogLog {
    let mut spread = Vec::new();
    for (c, ch) in table.channels.iter().enumerate() {
        let color = PALETTE[[5, 3, 1][ch.index()]];
        for (q, dashed, pick) in [
            (
                "50%",
                true,
                (|r: &crate::profile::transmission::ThicknessRow, c| r.r50_mm[c])
                    as fn(&_, usize) -> f64,
            ),
            (
                "90%",
                false,
                |r: &crate::profile::transmission::ThicknessRow, c| r.r90_mm[c],
            ),
        ] {
            spread.push(Curve {
                label: format!("{} {q}", ch.name()),
                color,
                points: table
                    .rows
                    .iter()
                    .map(|r| (r.thickness_mm, pick(r, c)))
                    .collect(),
                band: None,
                dashed,
            });
        }
    }
    LogLog {
        title: "radii holding 50% (dashed) and 90% of T (beam included, at r = 0)".into(),
        x_label: "slab thickness (mm)".into(),
        y_label: "radius around the beam (mm)".into(),
        curves: spread,
    }
}

/// Writes the table's plot: one panel of T per channel, one of the radii.
pub fn render(table: &ThicknessTable, fits: &[FittedCurve], out: &Path) -> Result<Vec<TextBox>> {
    crate::io::check_extension(out, &["png"], "plot")?;
    let t = table.thicknesses();
    let mut panels = Vec::new();
    for (c, ch) in table.channels.iter().enumerate() {
        let mc: Vec<(f64, f64)> = table
            .rows
            .iter()
            .map(|r| (r.thickness_mm, r.diffuse[c]))
            .collect();
        let bars = table
            .rows
            .iter()
            .map(|r| {
                let (v, e) = (r.diffuse[c], BARS * r.diffuse_stderr[c]);
                (r.thickness_mm, (v - e).max(v * 1e-3), v + e)
            })
            .collect();
        let all: Vec<(f64, f64)> = table
            .rows
            .iter()
            .map(|r| (r.thickness_mm, r.transmittance[c]))
            .collect();
        let mut curves = vec![
            Curve {
                label: format!("Monte Carlo, scattered light, +-{BARS} standard errors"),
                color: PALETTE[0],
                points: mc,
                band: Some(bars),
                dashed: false,
            },
            Curve {
                label: "Monte Carlo, all (with the unscattered beam)".into(),
                color: PALETTE[7],
                points: all,
                band: None,
                dashed: false,
            },
        ];
        let ci = ch.index();
        for (k, f) in fits.iter().enumerate() {
            curves.push(Curve {
                label: format!("{} (fitted)", f.engine),
                color: PALETTE[1 + k % (PALETTE.len() - 1)],
                points: t.iter().zip(f.t).map(|(&x, y)| (x, y[ci])).collect(),
                band: None,
                dashed: true,
            });
        }
        panels.push(LogLog {
            title: format!("channel {}: light through the slab", ch.name()),
            x_label: "slab thickness (mm)".into(),
            y_label: "T, transmitted / incident".into(),
            curves,
        });
    }
    panels.push(radii_panel(table));
    let title = format!(
        "{}: light leaving the unlit face of a slab lit from behind, per thickness",
        table.material.name
    );
    render_grid(&panels, 2, PANEL, &title, out, |p, area| draw(p, area, out))
}

/// The positive range of a panel's points, padded to whole decades' room.
fn extent(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = vals
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !(hi > 0.0) {
        (1e-6, 1.0)
    } else {
        (lo / 1.5, hi * 1.5)
    }
}

fn draw(panel: &LogLog, area: &Area, out: &Path) -> Result<Vec<TextBox>> {
    let (mut w, entries, chart_area) = frame_panel(area, out, &panel.title, &panel.curves)?;
    let xs = panel
        .curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.0));
    let ys = panel.curves.iter().flat_map(|c| {
        c.points
            .iter()
            .map(|p| p.1)
            .chain(c.band.iter().flatten().flat_map(|b| [b.1, b.2]))
    });
    let (xlo, xhi) = extent(xs);
    let (ylo, yhi) = extent(ys);
    // Seven decades below the top keep a deep tail readable.
    let ylo = ylo.max(yhi * 1e-7);
    let x = Axis {
        scale: Scale::Log,
        lo: xlo,
        hi: xhi,
        title: panel.x_label.clone(),
    };
    let y = Axis {
        scale: Scale::Log,
        lo: ylo,
        hi: yhi,
        title: panel.y_label.clone(),
    };
    let e = |e| plot_err(out, e);
    let mut chart = ChartBuilder::on(&chart_area)
        .margin_top(CHART_TOP)
        .margin_right(CHART_RIGHT)
        .x_label_area_size(X_AREA)
        .y_label_area_size(Y_AREA)
        .build_cartesian_2d((xlo..xhi).log_scale(), (ylo..yhi).log_scale())
        .map_err(e)?;
    let (x_px, y_px) = chart.plotting_area().get_pixel_range();
    let frame = Frame { x_px, y_px, x, y };
    let ticks = frame.ticks(&w);
    frame.draw_grid(&w, &ticks)?;
    let keep = |(x, y): (f64, f64)| x > 0.0 && y >= ylo && y <= yhi && x >= xlo && x <= xhi;
    for c in &panel.curves {
        if let Some(bars) = &c.band {
            for &(x, lo, hi) in bars {
                let (lo, hi) = (lo.max(ylo), hi.min(yhi));
                if x >= xlo && x <= xhi && hi > lo {
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            vec![(x, lo), (x, hi)],
                            c.color.stroke_width(1),
                        )))
                        .map_err(e)?;
                }
            }
        }
        let pts: Vec<(f64, f64)> = c.points.iter().copied().filter(|&p| keep(p)).collect();
        draw_line(&mut chart, &pts, c.color.stroke_width(2), c.dashed).map_err(e)?;
        if c.band.is_some() {
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.color.filled())))
                .map_err(e)?;
        }
    }
    let (cx, cy) = chart_area.get_base_pixel();
    frame.draw_text(&mut w, &ticks, cx + 2)?;
    let legend_top = cy + chart_area.dim_in_pixel().1 as i32;
    let left = w.base.0 + 12;
    draw_legend(&mut w, &entries, (left, legend_top))?;
    Ok(w.boxes)
}

/// The table as CSV: one row per thickness, T and its scattered part with
/// their standard errors, R_d and the radii per channel.
pub fn csv(t: &ThicknessTable) -> String {
    let mut s = String::from("thickness_mm");
    for c in &t.channels {
        let n = c.name();
        s += &format!(
            ",t_{n},t_{n}_stderr,t_scattered_{n},t_scattered_{n}_stderr,rd_{n},r50_{n}_mm,r90_{n}_mm"
        );
    }
    s.push('\n');
    for r in &t.rows {
        s += &format!("{}", r.thickness_mm);
        for c in 0..t.channels.len() {
            s += &format!(
                ",{:e},{:e},{:e},{:e},{:e},{},{}",
                r.transmittance[c],
                r.transmittance_stderr[c],
                r.diffuse[c],
                r.diffuse_stderr[c],
                r.rd[c],
                r.r50_mm[c],
                r.r90_mm[c]
            );
        }
        s.push('\n');
    }
    s
}

/// The back-lit block of `compare --scene` as a table: per row, the
/// relative RMS and bias over the seen pixels (r / g / b) and FLIP, and the
/// relative RMS where the surface faces away from the light.
pub fn scene_table(
    cmp: &crate::report::eval::scene::transmission::TransmissionComparison,
) -> super::table::Table {
    let mut t = super::table::Table::new(&[
        "back-lit object: what the camera gets",
        "thickness from",
        "RMS % of peak (r / g / b)",
        "bias % (r / g / b)",
        "FLIP",
        "RMS %, facing away from the light (r / g / b)",
    ]);
    let trio = |v: [f64; 3]| {
        v.map(|x| {
            if x.is_finite() {
                format!("{:.2}", 100.0 * x)
            } else {
                "-".into()
            }
        })
        .join(" / ")
    };
    for r in &cmp.rows {
        let all = &r.regions[0];
        let unlit = r.regions.iter().find(|x| x.region == "unlit");
        t.push(vec![
            r.label.clone(),
            r.thickness.clone(),
            trio(all.rel_rms),
            trio(all.bias),
            format!("{:.3}", all.flip),
            unlit.map_or("-".into(), |u| trio(u.rel_rms)),
        ]);
    }
    t
}

/// The back-lit block's images: the path-traced image of `scene`, then
/// each row above its difference from it (white = `SCENE_DIFF_SCALE` of
/// the peak).
pub fn scene_sheet(
    cmp: &crate::report::eval::scene::transmission::TransmissionComparison,
    scene: &crate::report::eval::scene::compare::SceneComparison,
    title: &str,
    out: &Path,
) -> Result<()> {
    let images = cmp.images.iter().map(|(l, img)| (l.clone(), img));
    super::scene_tables::difference_sheet(scene, images, title, "image", out)
}
