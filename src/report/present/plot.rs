//! PNG plots of radial profiles with plotters' bitmap backend. The image is
//! drawn into memory and written atomically; the only font is the bundled
//! DejaVu Sans, registered once as "sans-serif" (no system fonts).

use crate::error::{Error, Result};
use crate::profile::radius_holding;
use crate::profile::Profile;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// Registers DejaVu Sans as "sans-serif" (idempotent).
pub fn register_fonts() {
    REGISTER.call_once(|| {
        // The bytes are a valid TTF shipped with the crate; a failure here
        // would only make text invisible, never wrong numbers.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One line on a panel, optionally with a shaded band (lo, hi) per point.
#[derive(Clone, Debug)]
pub struct Curve {
    pub label: String,
    pub color: RGBColor,
    pub points: Vec<(f64, f64)>,
    pub band: Option<Vec<(f64, f64, f64)>>,
    pub dashed: bool,
}

/// One chart: curves over an x range, linear or logarithmic in y.
#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_max: f64,
    pub log_y: bool,
    pub curves: Vec<Curve>,
}

/// Distinct colours for curves (colour-blind friendly order, Okabe-Ito).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 0, 0),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 158, 115),
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(204, 121, 167),
    RGBColor(120, 120, 120),
];

pub fn plot_err(out: &Path, e: impl std::fmt::Display) -> Error {
    Error::format(out, format!("plotting failed: {e}"))
}

/// Draws `panels` on a grid with `cols` columns and writes a PNG.
pub fn render(panels: &[Panel], cols: usize, title: &str, out: &Path) -> Result<()> {
    crate::io::check_extension(out, &["png"], "plot")?;
    render_grid(panels, cols, (640, 440), title, out, |panel, area| {
        draw_panel(panel, area, out)
    })
}

/// A drawing area of one panel.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// The page of every plot: `title` over a grid of `cols` columns of panels
/// of `size` pixels, each drawn by `draw`, written as a PNG to `out`.
pub fn render_grid<T>(
    panels: &[T],
    cols: usize,
    size: (u32, u32),
    title: &str,
    out: &Path,
    mut draw: impl FnMut(&T, &Area) -> Result<()>,
) -> Result<()> {
    register_fonts();
    if panels.is_empty() {
        return Err(Error::Unsupported("nothing to plot".into()));
    }
    let cols = cols.clamp(1, panels.len());
    let rows = panels.len().div_ceil(cols);
    let (pw, ph) = size;
    let (w, h) = (pw * cols as u32, ph * rows as u32 + 40);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(out, e))?;
        let (top, body) = root.split_vertically(40);
        top.draw_text(
            title,
            &("sans-serif", 22).into_font().color(&BLACK),
            (12, 10),
        )
        .map_err(|e| plot_err(out, e))?;
        let areas = body.split_evenly((rows, cols));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            draw(panel, area)?;
        }
        root.present().map_err(|e| plot_err(out, e))?;
    }
    write_png(buf, w, h, out)
}

/// Writes an RGB8 buffer of `w` x `h` pixels as a PNG, atomically.
pub fn write_png(buf: Vec<u8>, w: u32, h: u32, out: &Path) -> Result<()> {
    let img = image::RgbImage::from_raw(w, h, buf)
        .ok_or_else(|| plot_err(out, "image buffer has the wrong size"))?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| plot_err(out, e))?;
    crate::io::write_atomic(out, &png)
}

fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, plotters::coord::Shift>,
    out: &Path,
) -> Result<()> {
    let visible = |x: f64, y: f64| x <= panel.x_max && y.is_finite() && (!panel.log_y || y > 0.0);
    let mut y_max = 0.0f64;
    let mut y_min = f64::INFINITY;
    for c in &panel.curves {
        for &(x, y) in &c.points {
            if visible(x, y) {
                y_max = y_max.max(y);
                y_min = y_min.min(y);
            }
        }
    }
    if !(y_max > 0.0) {
        y_max = 1.0;
        y_min = 1e-6;
    }
    // Axis ranges are padded by a few percent and cut into ticks: values
    // near f64::MAX would overflow them (an endless tick loop in plotters).
    if !(y_max <= 1e300 && panel.x_max.is_finite()) {
        return Err(plot_err(
            out,
            format!(
                "panel '{}': values up to {y_max:.3e} over x up to {:.3e} cannot be drawn",
                panel.title, panel.x_max
            ),
        ));
    }
    let x_range = 0.0..panel.x_max.max(1e-12);
    let mut chart_builder = ChartBuilder::on(area);
    chart_builder
        .caption(&panel.title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70);
    let e = |e| plot_err(out, e);
    if panel.log_y {
        // Six decades below the peak keep the tail readable without letting
        // the last noisy bins squash the plot.
        let lo = y_min.max(y_max * 1e-7);
        let mut chart = chart_builder
            .build_cartesian_2d(x_range, (lo..y_max * 2.0).log_scale())
            .map_err(e)?;
        draw_mesh(&mut chart, panel, &|v| format!("{v:.0e}"), out)?;
        draw_curves(&mut chart, panel, lo, out)?;
    } else {
        let mut chart = chart_builder
            .build_cartesian_2d(x_range, 0.0..y_max * 1.05)
            .map_err(e)?;
        draw_mesh(&mut chart, panel, &|v| format!("{v:.3}"), out)?;
        draw_curves(&mut chart, panel, f64::NEG_INFINITY, out)?;
    }
    Ok(())
}

/// The axes of a profile panel, the y labels written by `y_format`.
fn draw_mesh<'a, DB: DrawingBackend + 'a, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    panel: &Panel,
    y_format: &dyn Fn(&f64) -> String,
    out: &Path,
) -> Result<()>
where
    Y: Ranged<ValueType = f64> + plotters::coord::ranged1d::ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .y_label_formatter(y_format)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| plot_err(out, e))
}

/// The legend of every plot, upper right, labels of `font_px` pixels.
pub fn draw_legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    font_px: i32,
    out: &Path,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", font_px))
        .draw()
        .map_err(|e| plot_err(out, e))
}

/// Dash and gap lengths of dashed curves, pixels (short enough that the
/// 20-pixel legend sample shows two dashes).
const DASH: u32 = 6;
const GAP: u32 = 4;

fn draw_curves<'a, DB: DrawingBackend + 'a, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<plotters::coord::types::RangedCoordf64, Y>>,
    panel: &Panel,
    floor: f64,
    out: &Path,
) -> Result<()>
where
    Y: Ranged<ValueType = f64>,
{
    let e = |e| plot_err(out, e);
    let keep = |x: f64, y: f64| x <= panel.x_max && y.is_finite() && y > floor;
    // Bands first, then lines, so no band hides a line.
    for c in &panel.curves {
        if let Some(band) = &c.band {
            let mut poly: Vec<(f64, f64)> = band
                .iter()
                .filter(|(x, _, hi)| keep(*x, *hi))
                .map(|&(x, lo, _)| (x, lo.max(if floor.is_finite() { floor } else { 0.0 })))
                .collect();
            let upper: Vec<(f64, f64)> = band
                .iter()
                .filter(|(x, _, hi)| keep(*x, *hi))
                .map(|&(x, _, hi)| (x, hi))
                .collect();
            poly.extend(upper.into_iter().rev());
            if poly.len() > 2 {
                chart
                    .draw_series(std::iter::once(Polygon::new(
                        poly,
                        c.color.mix(0.25).filled(),
                    )))
                    .map_err(e)?;
            }
        }
    }
    for c in &panel.curves {
        let pts: Vec<(f64, f64)> = c
            .points
            .iter()
            .cloned()
            .filter(|&(x, y)| keep(x, y))
            .collect();
        let style = c.color.stroke_width(if c.band.is_some() { 1 } else { 2 });
        let color = c.color;
        if c.dashed {
            // The legend's sample carries the same dash pattern as the line.
            chart
                .draw_series(DashedLineSeries::new(pts, DASH, GAP, style))
                .map_err(e)?
                .label(&c.label)
                .legend(move |(x, y)| {
                    plotters::element::DashedPathElement::new(
                        vec![(x, y), (x + 20, y)],
                        DASH,
                        GAP,
                        color.stroke_width(2),
                    )
                });
        } else {
            chart
                .draw_series(LineSeries::new(pts, style))
                .map_err(e)?
                .label(&c.label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
    }
    draw_legend(chart, 14, out)
}

/// Freude 2014, figure 6.1 layout for one or more profiles: one row per channel,
/// linear R_d near the origin on the left, log R_d over the whole range on
/// the right; one colour per file.
pub fn profile_panels(profiles: &[(String, Profile)]) -> Vec<Panel> {
    let mut chans: Vec<crate::material::Channel> = Vec::new();
    for (_, p) in profiles {
        for c in &p.channels {
            if !chans.contains(c) {
                chans.push(*c);
            }
        }
    }
    chans.sort();
    let r_full = profiles
        .iter()
        .map(|(_, p)| *p.r_edges.last().unwrap_or(&1.0))
        .fold(0.0, f64::max);
    let mut panels = Vec::new();
    for ch in chans {
        // "Near the origin": the radius holding 60% of R_d, the largest over
        // the profiles, so that the peak and its shoulder fill the panel.
        let r_near = profiles
            .iter()
            .filter_map(|(_, p)| p.channel_index(ch).map(|i| radius_holding(p, i, 0.6)))
            .fold(0.0, f64::max)
            .min(r_full);
        let curves: Vec<Curve> = profiles
            .iter()
            .enumerate()
            .filter_map(|(k, (label, p))| {
                let i = p.channel_index(ch)?;
                Some(Curve {
                    label: label.clone(),
                    color: PALETTE[k % PALETTE.len()],
                    points: p.r.iter().cloned().zip(p.rd[i].iter().cloned()).collect(),
                    band: None,
                    dashed: false,
                })
            })
            .collect();
        for (log_y, x_max) in [(false, r_near), (true, r_full)] {
            panels.push(Panel {
                title: format!(
                    "channel {} - {}",
                    ch.name(),
                    if log_y {
                        "log, full range"
                    } else {
                        "linear, near origin"
                    }
                ),
                x_label: "r (mm)".into(),
                y_label: "R_d (1/mm^2)".into(),
                x_max,
                log_y,
                curves: curves.clone(),
            });
        }
    }
    panels
}
