//! PNG plots of radial profiles with plotters' bitmap backend. The image is
//! drawn into memory and written atomically; the only font is the bundled
//! DejaVu Sans, registered once as "sans-serif" (no system fonts).

use super::axes::{plot_err, Area, Axis, Frame, Scale, Writer, X_AREA, Y_AREA};
use super::layout::TextBox;
use crate::error::{Error, Result};
use crate::report::eval::radial::ProfileFigure;
use plotters::coord::types::RangedCoordf64;
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

/// Draws `panels` on a grid with `cols` columns and writes a PNG; returns
/// every text box it drew, in the image's pixels (for tests of the
/// layout).
pub fn render(panels: &[Panel], cols: usize, title: &str, out: &Path) -> Result<Vec<TextBox>> {
    crate::io::check_extension(out, &["png"], "plot")?;
    render_grid(panels, cols, PANEL, title, out, |panel, area| {
        draw_panel(panel, area, out)
    })
}

/// Size of one profile panel, pixels.
const PANEL: (u32, u32) = (640, 460);
/// Font sizes, pixels: the page title, a panel's title, legend entries.
const PAGE_PX: u32 = 22;
pub const TITLE_PX: u32 = 16;
const LEGEND_PX: u32 = 12;
/// Length of a legend's line sample and the space between two entries,
/// pixels (the sample long enough for two dashes of a dashed curve).
const SAMPLE: i32 = 22;
const ENTRY_GAP: i32 = 16;
/// Space kept right of and above a chart's plotting area, pixels (room
/// for the last x tick label's right half and the top y label's upper
/// half).
pub(super) const CHART_RIGHT: u32 = 24;
pub(super) const CHART_TOP: u32 = 10;
/// Left and right margin of titles and legends inside their area, pixels.
const MARGIN: i32 = 12;

/// The page of every plot: `title` (wrapped to the page's width) over a
/// grid of `cols` columns of panels of `size` pixels, each drawn by
/// `draw` (which returns the text boxes it drew), written as a PNG to
/// `out`; returns every text box of the page, the title's and the panels'.
pub fn render_grid<T>(
    panels: &[T],
    cols: usize,
    size: (u32, u32),
    title: &str,
    out: &Path,
    mut draw: impl FnMut(&T, &Area) -> Result<Vec<TextBox>>,
) -> Result<Vec<TextBox>> {
    register_fonts();
    if panels.is_empty() {
        return Err(Error::Unsupported("nothing to plot".into()));
    }
    let cols = cols.clamp(1, panels.len());
    let rows = panels.len().div_ceil(cols);
    let (pw, ph) = size;
    let w = pw * cols as u32;
    // The title's lines are measured on a scratch area of the page's
    // width before the page (whose height they set) exists.
    let lines = {
        let mut scratch = vec![255u8; (w * 8 * 3) as usize];
        let area = BitMapBackend::with_buffer(&mut scratch, (w, 8)).into_drawing_area();
        Writer::new(&area, out).wrap(title, PAGE_PX, w - 2 * MARGIN as u32)?
    };
    let line_h = PAGE_PX + 6;
    let top = (lines.len() as u32 * line_h + 12).max(40);
    let h = ph * rows as u32 + top;
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let mut boxes;
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_err(out, e))?;
        let (head, body) = root.split_vertically(top);
        let mut writer = Writer::new(&head, out);
        for (i, line) in lines.iter().enumerate() {
            writer.text(
                line,
                PAGE_PX,
                BLACK,
                (MARGIN, 8 + (i as u32 * line_h) as i32),
            )?;
        }
        boxes = writer.boxes;
        let areas = body.split_evenly((rows, cols));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            boxes.extend(draw(panel, area)?);
        }
        root.present().map_err(|e| plot_err(out, e))?;
    }
    write_png(buf, w, h, out)?;
    Ok(boxes)
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

/// Draws a panel's title wrapped to the area's width from its top;
/// returns the height it took, pixels.
pub fn draw_title(w: &mut Writer, title: &str, width: u32) -> Result<u32> {
    let line_h = TITLE_PX + 4;
    let lines = w.wrap(title, TITLE_PX, width - 2 * MARGIN as u32)?;
    for (i, line) in lines.iter().enumerate() {
        let at = (w.base.0 + MARGIN, w.base.1 + 6 + (i as u32 * line_h) as i32);
        w.text(line, TITLE_PX, BLACK, at)?;
    }
    Ok(lines.len() as u32 * line_h + 8)
}

/// One legend entry placed: its curve, its lines of text and the
/// top-left corner of its sample, relative to the legend's top-left.
pub(super) struct Entry<'a> {
    curve: &'a Curve,
    lines: Vec<String>,
    at: (i32, i32),
}

/// A panel's frame in `area`: its title drawn at the top, its legend laid
/// out for the bottom, and the chart's area between them.
pub(super) fn frame_panel<'a, 'b, 'c>(
    area: &'a Area<'b>,
    out: &'a Path,
    title: &str,
    curves: &'c [Curve],
) -> Result<(Writer<'a, 'b>, Vec<Entry<'c>>, Area<'b>)> {
    let (pw, ph) = area.dim_in_pixel();
    let mut w = Writer::new(area, out);
    let title_h = draw_title(&mut w, title, pw)?;
    let (entries, legend_h) = legend_layout(&w, curves, pw)?;
    let (_, rest) = area.split_vertically(title_h);
    let (chart_area, _) = rest.split_vertically(ph.saturating_sub(title_h + legend_h));
    Ok((w, entries, chart_area))
}

/// The legend of `curves` flowed in rows under a chart `width` pixels
/// wide: entries left to right, a new row where the next one does not
/// fit, an entry wider than the row wrapped onto lines of its own.
/// Returns the entries and the legend's height.
pub(super) fn legend_layout<'a>(
    w: &Writer,
    curves: &'a [Curve],
    width: u32,
) -> Result<(Vec<Entry<'a>>, u32)> {
    let line_h = LEGEND_PX as i32 + 5;
    let room = width as i32 - 2 * MARGIN;
    let text_room = (room - SAMPLE - 6).max(1) as u32;
    let (mut x, mut y, mut row_h) = (0i32, 0i32, 0i32);
    let mut entries = Vec::new();
    for c in curves {
        let lines = w.wrap(&c.label, LEGEND_PX, text_room)?;
        let text_w = lines
            .iter()
            .map(|l| w.size(l, LEGEND_PX).map(|s| s.0 as i32))
            .collect::<Result<Vec<_>>>()?
            .into_iter()
            .max()
            .unwrap_or(0);
        let entry_w = SAMPLE + 6 + text_w;
        if x > 0 && (x + entry_w > room || lines.len() > 1) {
            (x, y, row_h) = (0, y + row_h, 0);
        }
        let h = lines.len() as i32 * line_h;
        entries.push(Entry {
            curve: c,
            lines,
            at: (x, y),
        });
        row_h = row_h.max(h);
        x += entry_w + ENTRY_GAP;
    }
    Ok((entries, (y + row_h + 6) as u32))
}

/// Draws the legend laid out by [`legend_layout`] with its top-left at
/// image pixel `origin`.
pub(super) fn draw_legend(w: &mut Writer, entries: &[Entry], origin: (i32, i32)) -> Result<()> {
    let line_h = LEGEND_PX as i32 + 5;
    let e = |e| plot_err(w.out, e);
    for en in entries {
        let (x, y) = (origin.0 + en.at.0, origin.1 + en.at.1);
        let mid = y + line_h / 2 - 1;
        let (sx, sy) = (x - w.base.0, mid - w.base.1);
        let c = en.curve.color;
        if en.curve.band.is_some() {
            let r = Rectangle::new([(sx, sy - 4), (sx + SAMPLE, sy + 4)], c.mix(0.25).filled());
            w.area.draw(&r).map_err(e)?;
        }
        let path = vec![(sx, sy), (sx + SAMPLE, sy)];
        if en.curve.dashed {
            let d = plotters::element::DashedPathElement::new(path, DASH, GAP, c.stroke_width(2));
            w.area.draw(&d).map_err(e)?;
        } else {
            w.area
                .draw(&PathElement::new(path, c.stroke_width(2)))
                .map_err(e)?;
        }
        for (i, line) in en.lines.iter().enumerate() {
            let at = (x + SAMPLE + 6, y + i as i32 * line_h);
            w.text(line, LEGEND_PX, BLACK, at)?;
        }
    }
    Ok(())
}

/// The y range of a panel's visible points, (lowest, highest).
fn y_extent(panel: &Panel) -> (f64, f64) {
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
        (1e-6, 1.0)
    } else {
        (y_min, y_max)
    }
}

/// One profile panel: title, chart with its axes, legend under it.
/// Returns the boxes of its texts in image pixels.
fn draw_panel(panel: &Panel, area: &Area, out: &Path) -> Result<Vec<TextBox>> {
    let (y_min, y_max) = y_extent(panel);
    // Axis ranges are padded by a few percent and cut into ticks: values
    // near f64::MAX would overflow them.
    if !(y_max <= 1e300 && panel.x_max.is_finite()) {
        return Err(plot_err(
            out,
            format!(
                "panel '{}': values up to {y_max:.3e} over x up to {:.3e} cannot be drawn",
                panel.title, panel.x_max
            ),
        ));
    }
    let (mut w, entries, chart_area) = frame_panel(area, out, &panel.title, &panel.curves)?;
    let y = if panel.log_y {
        // Six decades below the peak keep the tail readable without
        // letting the last noisy bins squash the plot.
        let lo = y_min.max(y_max * 1e-7);
        Axis {
            scale: Scale::Log,
            lo,
            hi: y_max * 2.0,
            title: panel.y_label.clone(),
        }
    } else {
        Axis {
            scale: Scale::Linear,
            lo: 0.0,
            hi: y_max * 1.05,
            title: panel.y_label.clone(),
        }
    };
    let x = Axis {
        scale: Scale::Linear,
        lo: 0.0,
        hi: panel.x_max.max(1e-12),
        title: panel.x_label.clone(),
    };
    let builder = || {
        let mut b = ChartBuilder::on(&chart_area);
        b.margin_top(CHART_TOP)
            .margin_right(CHART_RIGHT)
            .x_label_area_size(X_AREA)
            .y_label_area_size(Y_AREA);
        b
    };
    let e = |e| plot_err(out, e);
    let (x_px, y_px) = builder()
        .build_cartesian_2d(x.lo..x.hi, y.lo..y.hi)
        .map_err(e)?
        .plotting_area()
        .get_pixel_range();
    let frame = Frame { x_px, y_px, x, y };
    let ticks = frame.ticks(&w);
    frame.draw_grid(&w, &ticks)?;
    let xr = frame.x.lo..frame.x.hi;
    if panel.log_y {
        let yr = (frame.y.lo..frame.y.hi).log_scale();
        let mut chart = builder().build_cartesian_2d(xr, yr).map_err(e)?;
        draw_curves(&mut chart, panel, frame.y.lo, out)?;
    } else {
        let yr = frame.y.lo..frame.y.hi;
        let mut chart = builder().build_cartesian_2d(xr, yr).map_err(e)?;
        draw_curves(&mut chart, panel, f64::NEG_INFINITY, out)?;
    }
    let (cx, cy) = chart_area.get_base_pixel();
    frame.draw_text(&mut w, &ticks, cx + 2)?;
    let legend_top = cy + chart_area.dim_in_pixel().1 as i32;
    let left = w.base.0 + MARGIN;
    draw_legend(&mut w, &entries, (left, legend_top))?;
    Ok(w.boxes)
}

type Chart<'a, 'b, Y> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, Y>>;

/// Dash and gap lengths of dashed curves, pixels (short enough that the
/// legend's sample shows two dashes).
pub(super) const DASH: u32 = 6;
pub(super) const GAP: u32 = 4;

fn draw_curves<Y>(chart: &mut Chart<Y>, panel: &Panel, floor: f64, out: &Path) -> Result<()>
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
        draw_line(chart, &pts, style, c.dashed).map_err(e)?;
    }
    Ok(())
}

/// A curve's line on `chart`, dashed or solid; solid segment by segment:
/// plotters joins the segments of a wide polyline with miters, and a noisy
/// Monte Carlo tail's sharp zigzags then shoot spikes far past their
/// points (through the axis and its labels).
pub(super) fn draw_line<'a, DB, CT>(
    chart: &mut ChartContext<'a, DB, CT>,
    pts: &[(f64, f64)],
    style: ShapeStyle,
    dashed: bool,
) -> std::result::Result<(), plotters::drawing::DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend,
    CT: plotters::coord::CoordTranslate<From = (f64, f64)>,
{
    if dashed {
        chart.draw_series(DashedLineSeries::new(pts.to_vec(), DASH, GAP, style))?;
    } else {
        let segments = pts
            .windows(2)
            .map(|s| PathElement::new(vec![s[0], s[1]], style));
        chart.draw_series(segments)?;
    }
    Ok(())
}

/// Freude 2014, figure 6.1 layout for one or more profiles: one row per channel,
/// linear R_d near the origin on the left (out to the radius
/// [`ProfileFigure::near`] gives), log R_d over the whole range on the
/// right; one colour per file.
pub fn profile_panels(figure: &ProfileFigure) -> Vec<Panel> {
    let (profiles, r_full) = (figure.profiles, figure.r_full);
    let mut panels = Vec::new();
    for &(ch, r_near) in &figure.near {
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
                y_label: "R_d (1/mm²)".into(),
                x_max,
                log_y,
                curves: curves.clone(),
            });
        }
    }
    panels
}
