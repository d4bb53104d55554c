//! The tables, report and plots of `profiles compare`: analytic profile
//! models against a Monte Carlo reference ([`crate::report::eval::compare::profile`]),
//! per channel, summarised by reduced-albedo class.

use super::number::{num, pct, pct_abs, short, time};
use super::plot::{Curve, Panel, PALETTE};
use super::table::Table;
use crate::report::eval::compare::profile::Row;
use crate::report::eval::radial::ComparisonFigure;
use plotters::style::RGBColor;

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

/// The accuracy columns of [`table`] without the timings, which depend on
/// the machine and its load (they stay in the CSV and on standard output;
/// the benchmark `cargo bench --bench profiles` records them).
pub fn accuracy_table(rows: &[Row]) -> Table {
    let t = table(rows);
    let keep = t.header.len() - 3;
    Table {
        header: t.header[..keep].to_vec(),
        rows: t.rows.into_iter().map(|r| r[..keep].to_vec()).collect(),
    }
}

/// Reduced-albedo classes of the summaries: (label, lower bound inclusive,
/// upper bound exclusive). Diffusion theory is exact in the limit of
/// albedo 1 and fails where absorption dominates.
pub const ALBEDO_CLASSES: [(&str, f64, f64); 4] = [
    ("≥ 0.99", 0.99, f64::INFINITY),
    ("0.9–0.99", 0.9, 0.99),
    ("0.5–0.9", 0.5, 0.9),
    ("< 0.5", f64::NEG_INFINITY, 0.5),
];

/// Rows of `model` in reduced-albedo class `class` whose reference total is
/// not 0 (a channel that reflects nothing has no relative error).
fn in_class<'a>(rows: &'a [Row], model: &'a str, class: usize) -> impl Iterator<Item = &'a Row> {
    let (_, lo, hi) = ALBEDO_CLASSES[class];
    rows.iter().filter(move |r| {
        r.model == model && r.reduced_albedo >= lo && r.reduced_albedo < hi && r.total_mc > 0.0
    })
}

/// (median, max) of `v`; NaN when empty.
fn median_max(mut v: Vec<f64>) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    let med = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    (med, v[n - 1])
}

/// The channels of a class, "ketchup g/b, coffee, wine r" (all three
/// channels: the material's name alone).
fn members(rows: &[Row], model: &str, class: usize) -> String {
    let mut by: Vec<(String, Vec<&str>)> = Vec::new();
    for r in in_class(rows, model, class) {
        match by.iter_mut().find(|(m, _)| *m == r.material) {
            Some((_, v)) => v.push(r.channel.name()),
            None => by.push((r.material.clone(), vec![r.channel.name()])),
        }
    }
    by.iter()
        .map(|(m, ch)| {
            if ch.len() == 3 {
                m.clone()
            } else {
                format!("{m} {}", ch.join("/"))
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn models_of(rows: &[Row]) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for r in rows {
        if !v.contains(&r.model) {
            v.push(r.model.clone());
        }
    }
    v
}

fn class_label(rows: &[Row], model: &str, class: usize, list_members: bool) -> String {
    let n = in_class(rows, model, class).count();
    if list_members {
        format!(
            "{} ({n}: {})",
            ALBEDO_CLASSES[class].0,
            members(rows, model, class)
        )
    } else {
        format!("{} ({n} ch.)", ALBEDO_CLASSES[class].0)
    }
}

/// Per reduced-albedo class and model: median / max of the absolute error
/// of the total and of the L2 error of r R_d(r) with the reference noise
/// removed. The best median L2 of a class is bold.
pub fn class_table(rows: &[Row]) -> Table {
    let mut t = Table::new(&[
        "reduced albedo",
        "model",
        "median / max abs. total error",
        "median / max L2",
    ]);
    let models = models_of(rows);
    for class in 0..ALBEDO_CLASSES.len() {
        let Some(first) = models.first() else { break };
        if in_class(rows, first, class).next().is_none() {
            continue;
        }
        let l2 = |m: &str| median_max(in_class(rows, m, class).map(|r| r.rel_l2_model).collect());
        let best = models
            .iter()
            .min_by(|a, b| l2(a).0.total_cmp(&l2(b).0))
            .cloned()
            .unwrap_or_default();
        for (i, m) in models.iter().enumerate() {
            let (tm, tx) = median_max(
                in_class(rows, m, class)
                    .map(|r| r.rel_total_error.abs())
                    .collect(),
            );
            let (lm, lx) = l2(m);
            let l2s = format!("{} / {}", short(lm), short(lx));
            t.push(vec![
                if i == 0 {
                    class_label(rows, m, class, class == ALBEDO_CLASSES.len() - 1)
                } else {
                    String::new()
                },
                m.clone(),
                format!("{} / {}", short(tm), short(tx)),
                if *m == best {
                    format!("**{l2s}**")
                } else {
                    l2s
                },
            ]);
        }
    }
    t
}

/// One line per reduced-albedo class: the model with the smallest median
/// error of the total (models within 0.05 percentage points of it listed
/// too) and of the shape, and the dipole's and PBD's medians.
pub fn summary_table(rows: &[Row]) -> Table {
    let mut t = Table::new(&[
        "reduced albedo",
        "best total",
        "best shape",
        "dipole total / L2",
        "pbd total / L2",
    ]);
    let models = models_of(rows);
    for class in 0..ALBEDO_CLASSES.len() {
        let med = |m: &str, f: &dyn Fn(&Row) -> f64| {
            median_max(in_class(rows, m, class).map(f).collect()).0
        };
        let total = |m: &str| med(m, &|r: &Row| r.rel_total_error.abs());
        let shape = |m: &str| med(m, &|r: &Row| r.rel_l2_model);
        let ok: Vec<&String> = models.iter().filter(|m| total(m).is_finite()).collect();
        if ok.is_empty() {
            continue;
        }
        let best = |f: &dyn Fn(&str) -> f64| -> String {
            let lo = ok.iter().map(|m| f(m)).fold(f64::INFINITY, f64::min);
            let names: Vec<&str> = ok
                .iter()
                .filter(|m| f(m) <= lo + 5e-4)
                .map(|m| m.as_str())
                .collect();
            format!("{} ({})", names.join(", "), short(lo))
        };
        let pair = |m: &str| format!("{} / {}", short(total(m)), short(shape(m)));
        t.push(vec![
            class_label(rows, ok[0], class, class == ALBEDO_CLASSES.len() - 1),
            best(&total),
            best(&shape),
            pair("dipole"),
            pair("pbd"),
        ]);
    }
    t
}

/// Relative indices of the Fresnel table: both sides of 1 and the range
/// where the fits break down (eta = 3).
pub const FRESNEL_ETAS: [f64; 7] = [0.7, 1.0, 1.1, 1.3, 1.5, 2.5, 3.0];

/// The constants the models take from the Fresnel moments, by the
/// polynomial fits and by exact integration: C_phi, C_E (Dal Corso 2014,
/// eq. 3.15) and A = (1 - C_E) / (2 C_phi).
pub fn fresnel_table(etas: &[f64]) -> Table {
    use crate::profile::fresnel::FresnelMode::{Exact, Fit};
    let mut t = Table::new(&[
        "eta",
        "C_phi fit",
        "C_phi exact",
        "C_E fit",
        "C_E exact",
        "A fit",
        "A exact",
    ]);
    for &eta in etas {
        t.push(vec![
            format!("{eta:.1}"),
            format!("{:.5}", Fit.c_phi(eta)),
            format!("{:.5}", Exact.c_phi(eta)),
            format!("{:.5}", Fit.c_e(eta)),
            format!("{:.5}", Exact.c_e(eta)),
            format!("{:.4}", Fit.boundary_a(eta)),
            format!("{:.4}", Exact.boundary_a(eta)),
        ]);
    }
    t
}

/// The written report of `profiles compare`: the per-channel accuracy
/// table, the summary by reduced albedo, and its one-line-per-class digest,
/// each between `<!-- BEGIN compare:BLOCK -->` and `<!-- END compare:BLOCK -->`
/// (blocks `all`, `classes`, `summary`, and `fresnel`: the Fresnel
/// constants of the models by fit and exact) so that docs can include them and a
/// test can check them (docs/compare-runs.txt).
pub fn report(rows: &[Row]) -> String {
    let block = |name: &str, t: Table| {
        format!(
            "<!-- BEGIN compare:{name} -->\n{}<!-- END compare:{name} -->\n",
            t.markdown()
        )
    };
    format!(
        "# Analytic models vs Monte Carlo\n\n\
         Relative L2 error of r R_d(r) over the radius holding 99% of the \
         reference's R_d, with the reference's noise removed in quadrature; \
         medians leave out channels whose reference total is 0. Times are in \
         compare.csv.\n\n## By reduced albedo\n\n{}\n{}\n## Every material \
         and channel\n\n{}\n## Fresnel constants of the models, fit and exact\n\n{}",
        block("summary", summary_table(rows)),
        block("classes", class_table(rows)),
        block("all", accuracy_table(rows)),
        block("fresnel", fresnel_table(&FRESNEL_ETAS)),
    )
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
pub fn comparison_panels(figure: &ComparisonFigure) -> Vec<Panel> {
    let (reference, models) = (figure.reference, figure.models);
    let mut panels = Vec::new();
    for (what, radii) in &figure.rows {
        for (c, &ch) in reference.channels.iter().enumerate() {
            let x_max = radii[c];
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
                y_label: "R_d (1/mm²)".into(),
                x_max,
                log_y: true,
                curves,
            });
        }
    }
    panels
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Channel;

    fn row(material: &str, ch: Channel, model: &str, albedo: f64, total: f64, l2: f64) -> Row {
        Row {
            material: material.into(),
            channel: ch,
            model: model.into(),
            reduced_albedo: albedo,
            total_model: 1.0 + total,
            total_mc: 1.0,
            total_mc_stderr: 0.0,
            rel_total_error: total,
            rel_l2_error: l2,
            mc_noise_l2: 0.0,
            rel_l2_model: l2,
            r99: 1.0,
            model_time_s: 1e-3,
            mc_time_s: 1.0,
        }
    }

    #[test]
    fn summaries_take_medians_per_albedo_class() {
        let mut rows = Vec::new();
        for (m, t, l) in [("dipole", 0.01, 0.4), ("pbd", 0.04, 0.06)] {
            rows.push(row("a", Channel::R, m, 0.995, t, l));
            rows.push(row("a", Channel::G, m, 0.999, -3.0 * t, 3.0 * l));
            rows.push(row("a", Channel::B, m, 0.998, 2.0 * t, 2.0 * l));
            rows.push(row("k", Channel::G, m, 0.1, 2.0, 0.3));
        }
        let c = class_table(&rows);
        assert_eq!(c.rows.len(), 4, "{}", c.markdown());
        assert_eq!(c.rows[0][0], "≥ 0.99 (3 ch.)");
        assert_eq!(c.rows[0][2], "2.0% / 3.0%");
        assert_eq!(c.rows[1][3], "**12% / 18%**");
        assert_eq!(c.rows[2][0], "< 0.5 (1: k g)");
        let s = summary_table(&rows);
        assert_eq!(s.rows[0][1], "dipole (2.0%)");
        assert_eq!(s.rows[0][2], "pbd (12%)");
        assert_eq!(s.rows[0][4], "8.0% / 12%");
        assert_eq!(short(90.4), "90×");
        assert_eq!(short(2.04), "204%");
        assert_eq!(short(0.0045), "0.45%");
        let r = report(&rows);
        for b in ["summary", "classes", "all", "fresnel"] {
            assert!(r.contains(&format!("<!-- END compare:{b} -->")), "{r}");
        }
        assert!(!accuracy_table(&rows)
            .header
            .contains(&"MC time".to_string()));
    }
}
