//! Analytic profile models against a Monte Carlo reference: the error of
//! the total, the relative L2 error of r R_d(r) where R_d lives, and time.

use super::plot::{Curve, Panel, PALETTE};
use super::table::Table;
use crate::error::{Error, Result};
use crate::material::Channel;
use crate::profile::Profile;
use plotters::style::RGBColor;

/// One model in one channel of one material.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Row {
    pub material: String,
    pub channel: Channel,
    pub model: String,
    pub reduced_albedo: f64,
    pub total_model: f64,
    pub total_mc: f64,
    pub total_mc_stderr: f64,
    /// (model - mc) / mc; +inf when the reference is 0 and the model is not.
    pub rel_total_error: f64,
    /// ||r (model - mc)|| / ||r mc|| over [0, r99].
    pub rel_l2_error: f64,
    /// The same norm of the reference's own standard errors: the smallest
    /// L2 error this reference can resolve.
    pub mc_noise_l2: f64,
    /// The model's own L2 error with the reference's noise removed,
    /// sqrt(max(L2^2 - noise^2, 0)) (noise and model error add in
    /// quadrature in expectation).
    pub rel_l2_model: f64,
    /// Radius holding 99% of the reference's tabulated R_d, mm.
    pub r99: f64,
    pub model_time_s: f64,
    pub mc_time_s: f64,
}

/// (model - mc) / mc with the 0/0 and x/0 cases made explicit.
pub fn relative(model: f64, reference: f64) -> f64 {
    if reference > 0.0 {
        (model - reference) / reference
    } else if model > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// Radius where the cumulative tabulated R_d of channel `c` reaches
/// `fraction` of the tabulated total (the last edge if never).
pub fn radius_holding(p: &Profile, c: usize, fraction: f64) -> f64 {
    super::plot::radius_holding(p, c, fraction)
}

/// Relative L2 error of r R_d(r) over [0, r_lim] on the bins of `reference`
/// (bin-width weights), and the same norm of the reference's stderr.
pub fn l2_errors(model: &[f64], reference: &Profile, c: usize, r_lim: f64) -> (f64, f64) {
    let (mut num, mut den, mut noise) = (0.0, 0.0, 0.0);
    for (i, e) in reference.r_edges.windows(2).enumerate() {
        if e[0] >= r_lim {
            break;
        }
        let (w, r) = (e[1] - e[0], reference.r[i]);
        let mc = reference.rd[c][i];
        num += w * (r * (model[i] - mc)).powi(2);
        den += w * (r * mc).powi(2);
        if let Some(se) = &reference.rd_stderr {
            noise += w * (r * se[c][i]).powi(2);
        }
    }
    if den > 0.0 {
        ((num / den).sqrt(), (noise / den).sqrt())
    } else if num > 0.0 {
        (f64::INFINITY, 0.0)
    } else {
        (0.0, 0.0)
    }
}

/// Compares one model profile with the reference in every shared channel.
pub fn compare(model: &Profile, reference: &Profile, model_time_s: f64) -> Result<Vec<Row>> {
    if model.r_edges != reference.r_edges {
        return Err(Error::Unsupported(
            "model and reference profiles have different radial grids".into(),
        ));
    }
    let name = model.source.model.clone().unwrap_or_else(|| "?".into());
    let mut rows = Vec::new();
    for (mi, &ch) in model.channels.iter().enumerate() {
        let Some(c) = reference.channel_index(ch) else {
            continue;
        };
        let r99 = radius_holding(reference, c, 0.99);
        let (l2, noise) = l2_errors(&model.rd[mi], reference, c, r99);
        rows.push(Row {
            material: model.material.name.clone(),
            channel: ch,
            model: name.clone(),
            reduced_albedo: model.material.top(ch).reduced_albedo(),
            total_model: model.total_rd[mi],
            total_mc: reference.total_rd[c],
            total_mc_stderr: reference
                .total_rd_stderr
                .as_ref()
                .map(|s| s[c])
                .unwrap_or(0.0),
            rel_total_error: relative(model.total_rd[mi], reference.total_rd[c]),
            rel_l2_error: l2,
            mc_noise_l2: noise,
            rel_l2_model: (l2 * l2 - noise * noise).max(0.0).sqrt(),
            r99,
            model_time_s,
            mc_time_s: reference.elapsed_s,
        });
    }
    Ok(rows)
}

fn pct(x: f64) -> String {
    if x.is_finite() {
        format!("{:+.1}%", 100.0 * x)
    } else {
        "inf".into()
    }
}

fn num(x: f64) -> String {
    if x == 0.0 || x >= 1e-3 {
        format!("{x:.4}")
    } else {
        format!("{x:.2e}")
    }
}

fn pct_abs(x: f64) -> String {
    if x.is_finite() {
        format!("{:.1}%", 100.0 * x)
    } else {
        "inf".into()
    }
}

fn time(s: f64) -> String {
    if s < 1e-3 {
        format!("{:.0} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

/// The speed/accuracy table: markdown-friendly strings.
pub fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(&[
        "material",
        "ch",
        "albedo'",
        "model",
        "total model",
        "total MC",
        "total error",
        "L2 error r R_d (99%)",
        "MC noise L2",
        "L2 noise removed",
        "model time",
        "MC time",
        "speed-up",
    ]);
    for r in rows {
        t.push(vec![
            r.material.clone(),
            r.channel.name().into(),
            format!("{:.4}", r.reduced_albedo),
            r.model.clone(),
            num(r.total_model),
            format!("{} ± {}", num(r.total_mc), num(r.total_mc_stderr)),
            pct(r.rel_total_error),
            pct_abs(r.rel_l2_error),
            pct_abs(r.mc_noise_l2),
            pct_abs(r.rel_l2_model),
            time(r.model_time_s),
            time(r.mc_time_s),
            format!("{:.0}x", r.mc_time_s / r.model_time_s.max(1e-12)),
        ]);
    }
    t
}

/// The same rows with full-precision numbers for CSV.
pub fn csv_table(rows: &[Row]) -> Table {
    let mut t = Table::new(&[
        "material",
        "channel",
        "reduced_albedo",
        "model",
        "total_model",
        "total_mc",
        "total_mc_stderr",
        "rel_total_error",
        "rel_l2_error",
        "mc_noise_l2",
        "rel_l2_model",
        "r99_mm",
        "model_time_s",
        "mc_time_s",
    ]);
    for r in rows {
        t.push(vec![
            r.material.clone(),
            r.channel.name().into(),
            format!("{:e}", r.reduced_albedo),
            r.model.clone(),
            format!("{:e}", r.total_model),
            format!("{:e}", r.total_mc),
            format!("{:e}", r.total_mc_stderr),
            format!("{:e}", r.rel_total_error),
            format!("{:e}", r.rel_l2_error),
            format!("{:e}", r.mc_noise_l2),
            format!("{:e}", r.rel_l2_model),
            format!("{:e}", r.r99),
            format!("{:e}", r.model_time_s),
            format!("{:e}", r.mc_time_s),
        ]);
    }
    t
}

/// Log-scale panels per channel, one column each: the top row near the
/// origin (the radius holding 90% of the reference), the bottom row out to
/// 99.9%; the reference with a +-2 sigma band, every model overlaid.
pub fn comparison_panels(reference: &Profile, models: &[Profile]) -> Vec<Panel> {
    let mut panels = Vec::new();
    for (fraction, what) in [(0.9, "90%"), (0.999, "99.9%")] {
        for (c, &ch) in reference.channels.iter().enumerate() {
            let x_max = radius_holding(reference, c, fraction);
            let se = reference.rd_stderr.as_ref().map(|s| &s[c]);
            let mut curves = Vec::new();
            for (k, m) in models.iter().enumerate() {
                if let Some(i) = m.channel_index(ch) {
                    curves.push(Curve {
                        label: m.source.model.clone().unwrap_or_default(),
                        color: PALETTE[(k + 1) % PALETTE.len()],
                        points: m.r.iter().cloned().zip(m.rd[i].iter().cloned()).collect(),
                        band: None,
                        dashed: false,
                    });
                }
            }
            // Drawn last so the reference stays visible over the models.
            curves.push(Curve {
                label: "Monte Carlo (±2σ band)".into(),
                color: RGBColor(0, 0, 0),
                points: reference
                    .r
                    .iter()
                    .cloned()
                    .zip(reference.rd[c].iter().cloned())
                    .collect(),
                band: se.map(|se| {
                    reference
                        .r
                        .iter()
                        .zip(&reference.rd[c])
                        .zip(se)
                        .map(|((&r, &v), &s)| (r, v - 2.0 * s, v + 2.0 * s))
                        .collect()
                }),
                dashed: false,
            });
            panels.push(Panel {
                title: format!(
                    "{} {} (albedo' {:.3}), r holding {what}",
                    reference.material.name,
                    ch.name(),
                    reference.material.top(ch).reduced_albedo()
                ),
                x_label: "r (mm)".into(),
                y_label: "R_d (1/mm^2)".into(),
                x_max,
                log_y: true,
                curves,
            });
        }
    }
    panels
}
