//! The written results of a kernel comparison ([`crate::report::eval::compare::kernel`]):
//! tables raw and normalised the way Freude 2014 prints tables 6.3-6.5 (the
//! largest per-channel error of a table is 1, the last column sums the
//! three channels), the thesis's claims checked on the rows with the
//! measured figures, and the markdown report that holds them.
//!
//! Every table of the report sits between `<!-- BEGIN compare:NAME -->` and
//! `<!-- END compare:NAME -->`, so documentation can include it by name and
//! a test can check that the included copy is still what the command
//! produces. Timings change from run to run and are kept out of those
//! blocks.

use super::number::sig;
use super::table::Table;
use crate::filter::Which;
use crate::numerics::Bounded;
use crate::report::eval::compare::claims::Claim;
use crate::report::eval::compare::engine_tables::{EngineTables, Shape};
use crate::report::eval::compare::kernel::{Comparison, Row, Rows};
use std::fmt::Write as _;

/// Per (material, label), three channel values.
type Triples<'a> = Vec<(&'a str, &'a str, usize, [f64; 3])>;

fn triples<'a>(rows: &'a [Row], value: impl Fn(&Row) -> Option<f64>) -> Triples<'a> {
    Rows(rows)
        .grouped()
        .into_iter()
        .filter_map(|(m, l, r)| {
            let v = [value(r[0])?, value(r[1])?, value(r[2])?];
            Some((m, l, r[0].passes, v))
        })
        .collect()
}

/// Table of one error: raw R G B, then normalised R G B and their sum
/// (largest per-channel value of the table = 1).
pub fn error_table(rows: &[Row], value: impl Fn(&Row) -> Option<f64>) -> Table {
    let t = triples(rows, value);
    let top = t
        .iter()
        .flat_map(|x| x.3)
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let mut table = Table::new(&[
        "material", "model", "passes", "R", "G", "B", "R norm", "G norm", "B norm", "Σ norm",
    ]);
    for (m, l, passes, v) in t {
        let n = v.map(|x| if top > 0.0 { x.abs() / top } else { 0.0 });
        let mut row = vec![m.to_string(), l.to_string(), passes.to_string()];
        row.extend(v.iter().map(|&x| sig(x)));
        row.extend(n.iter().map(|x| format!("{x:.3}")));
        row.push(format!("{:.3}", n.iter().sum::<f64>()));
        table.push(row);
    }
    table
}

/// Image-space table for one signal and factor: relative RMS raw and
/// normalised, FLIP per channel and of the colour image.
pub fn image_table(rows: &[Row], signal: &str, factor: Which) -> Table {
    let rms = triples(rows, |r| r.image_error(signal, factor).map(|e| e.rel_rms));
    let flip = triples(rows, |r| r.image_error(signal, factor).map(|e| e.flip));
    let flip_rgb: Vec<f64> = Rows(rows)
        .grouped()
        .iter()
        .filter_map(|(_, _, r)| r[0].image_error(signal, factor).map(|e| e.flip_rgb))
        .collect();
    let top = rms.iter().flat_map(|x| x.3).fold(0.0f64, |m, v| m.max(v));
    let mut table = Table::new(&[
        "material",
        "model",
        "passes",
        "rel RMS R",
        "G",
        "B",
        "norm R",
        "G",
        "B",
        "Σ",
        "FLIP R",
        "G",
        "B",
        "FLIP RGB",
    ]);
    for (i, (m, l, passes, v)) in rms.iter().enumerate() {
        let n = v.map(|x| if top > 0.0 { x / top } else { 0.0 });
        let mut row = vec![m.to_string(), l.to_string(), passes.to_string()];
        row.extend(v.iter().map(|&x| sig(x)));
        row.extend(n.iter().map(|x| format!("{x:.3}")));
        row.push(format!("{:.3}", n.iter().sum::<f64>()));
        row.extend(flip[i].3.iter().map(|x| format!("{x:.4}")));
        row.push(format!("{:.4}", flip_rgb[i]));
        table.push(row);
    }
    table
}

/// Freude 2014 table 6.5 for one material: SVD rank N (renormalised, as the
/// SSSS renderer normalises every kernel) against N Gaussians (renormalised
/// too when available), image-space
/// relative RMS normalised over the table.
pub fn ranks_table(rows: &[Row], material: &str, ranks: &[usize], signal: &str, f: Which) -> Table {
    let mut t = Table::new(&[
        "rank / count",
        "SVD R",
        "G",
        "B",
        "Σ",
        "Gaussians R",
        "G",
        "B",
        "Σ",
    ]);
    let svd: Vec<Option<[f64; 3]>> = ranks
        .iter()
        .map(|r| Rows(rows).image_rms(material, &format!("svd{r}-renorm"), signal, f))
        .collect();
    let gau: Vec<Option<[f64; 3]>> = ranks
        .iter()
        .map(|n| Rows(rows).gaussians_rms(material, *n, signal, f))
        .collect();
    let top = svd
        .iter()
        .chain(&gau)
        .flatten()
        .flatten()
        .fold(0.0f64, |m, &v| m.max(v));
    let cells = |v: &Option<[f64; 3]>| -> Vec<String> {
        match v {
            Some(v) => {
                let n = v.map(|x| if top > 0.0 { x / top } else { 0.0 });
                let mut s: Vec<String> = n.iter().map(|x| format!("{x:.3}")).collect();
                s.push(format!("{:.3}", n.iter().sum::<f64>()));
                s
            }
            None => vec!["-".into(); 4],
        }
    };
    for (i, r) in ranks.iter().enumerate() {
        let mut row = vec![r.to_string()];
        row.extend(cells(&svd[i]));
        row.extend(cells(&gau[i]));
        t.push(row);
    }
    t
}

/// A table of the claims.
pub fn claims_table(claims: &[Claim]) -> Table {
    let mut t = Table::new(&["Freude 2014", "claim", "holds", "measured"]);
    for c in claims {
        t.push(vec![
            c.source.clone(),
            c.statement.clone(),
            format!("{} of {}", c.holds, c.total),
            c.figures.clone(),
        ]);
    }
    t
}

/// Timings (outside the checked blocks): fit seconds and filter
/// milliseconds per megapixel on the first signal.
pub fn timing_table(rows: &[Row], signal: &str, factors: &[Which]) -> Table {
    let mut header = vec!["material".to_string(), "model".into(), "fit s".into()];
    header.extend(factors.iter().map(|f| format!("ms/MP {}", f.describe())));
    let mut t = Table {
        header,
        rows: Vec::new(),
    };
    for (m, l, r) in Rows(rows).grouped() {
        let mut row = vec![
            m.to_string(),
            l.to_string(),
            format!("{:.3}", r[0].fit_seconds),
        ];
        for &f in factors {
            row.push(
                r[0].image_error(signal, f)
                    .map_or("-".into(), |e| format!("{:.1}", e.ms_per_megapixel)),
            );
        }
        t.push(row);
    }
    t
}

/// Wraps `body` in the markers of block `name`.
pub fn block(name: &str, body: &str) -> String {
    format!("<!-- BEGIN compare:{name} -->\n{body}<!-- END compare:{name} -->\n")
}

/// The blocks of a markdown text: (name, body between the markers).
pub fn blocks(text: &str) -> Vec<(String, String)> {
    blocks_of(text, "compare")
}

/// (name, body) of every `<!-- BEGIN KIND:NAME -->` ... `<!-- END KIND:NAME -->`
/// block in `text` (kinds: `compare` for report tables, `record` for
/// recorded measurements, see [`crate::report::present::record`]).
pub fn blocks_of(text: &str, kind: &str) -> Vec<(String, String)> {
    let begin = format!("<!-- BEGIN {kind}:");
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(&begin) {
        let after = &rest[i + begin.len()..];
        let Some(j) = after.find(" -->") else { break };
        let name = after[..j].to_string();
        let body_start = &after[j + " -->".len()..];
        let body_start = body_start.strip_prefix('\n').unwrap_or(body_start);
        let end = format!("<!-- END {kind}:{name} -->");
        let Some(k) = body_start.find(&end) else {
            break;
        };
        out.push((name, body_start[..k].to_string()));
        rest = &body_start[k + end.len()..];
    }
    out
}

/// Shape errors per channel, to a tenth of a point; a Monte Carlo one
/// with its largest standard error.
fn shape_cell(s: &Option<Shape>) -> String {
    let Some(s) = s else {
        return "-".into();
    };
    let pct = s
        .shape
        .iter()
        .map(|x| format!("{:.1}%", Bounded(100.0 * x)))
        .collect::<Vec<_>>()
        .join(", ");
    match s.noise {
        Some(n) => format!(
            "{pct} (± {:.1})",
            Bounded(100.0 * n.iter().fold(0.0, |m: f64, v| m.max(*v)))
        ),
        None => pct,
    }
}

/// Per material, the shape errors of the engine models fitted to its
/// profile and of the forward Burley model (`report::eval::compare::engine_tables`).
pub fn engine_table(t: &EngineTables) -> Table {
    let mut table = Table::new(&[
        "material",
        "Burley fitted",
        "Burley forward",
        "fitted smaller by",
        "Jimenez fitted (iryoku)",
        "Godot",
    ]);
    for r in &t.rows {
        let ratio = match (&r.burley_fitted, &r.burley_forward) {
            (Some(a), Some(b)) => (0..3)
                .map(|c| format!("{:.1}x", b.shape[c] / a.shape[c]))
                .collect::<Vec<_>>()
                .join(", "),
            _ => "-".into(),
        };
        table.push(vec![
            r.material.clone(),
            shape_cell(&r.burley_fitted),
            shape_cell(&r.burley_forward),
            ratio,
            shape_cell(&r.iryoku),
            shape_cell(&r.godot),
        ]);
    }
    table
}

/// Per material, the shape error of each Burley engine's export as that
/// engine renders it (every version, the method fitted by default).
pub fn burley_engine_table(t: &EngineTables) -> Table {
    let mut header = vec!["material".to_string()];
    header.extend(t.labels.iter().cloned());
    let mut table = Table::new(&header.iter().map(String::as_str).collect::<Vec<_>>());
    for r in &t.rows {
        let mut row = vec![r.material.clone()];
        row.extend(r.burley_engines.iter().map(shape_cell));
        table.push(row);
    }
    table
}

/// A number a table reads off each row.
type RowValue = fn(&Row) -> Option<f64>;

/// What the report was made from, for its header.
pub struct ReportContext<'a> {
    pub command: &'a str,
    pub signals: &'a [String],
    pub factors: &'a [Which],
    pub ranks: &'a [usize],
    pub options: &'a crate::report::eval::evaluate::Options,
}

/// The image-space sections: each signal and factor's table (Freude 2014,
/// table 6.4), then, with several ranks, SVD rank N against N Gaussians
/// per material (table 6.5).
fn image_space(cmp: &Comparison, ctx: &ReportContext) -> String {
    let rows = &cmp.rows;
    let mut s = String::new();
    for signal in ctx.signals {
        for f in ctx.factors {
            let name = factor_block(signal, *f);
            let _ = writeln!(
                s,
                "\n## Image space (table 6.4): {signal}, {}\n",
                f.describe()
            );
            s += &block(&name, &image_table(rows, signal, *f).markdown());
        }
    }
    if ctx.ranks.len() > 1 {
        for m in &cmp.materials {
            for signal in ctx.signals {
                for f in ctx.factors {
                    let t = ranks_table(rows, m, ctx.ranks, signal, *f);
                    let _ = writeln!(
                        s,
                        "\n## SVD rank N vs N Gaussians (table 6.5): {m}, {signal}, {}\n",
                        f.describe()
                    );
                    s += &block(
                        &format!("ranks-{m}-{}", factor_block(signal, *f)),
                        &t.markdown(),
                    );
                }
            }
        }
    }
    s
}

/// The markdown report; `engines` the engine tables measured on the same
/// profiles.
pub fn report(
    cmp: &Comparison,
    ctx: &ReportContext,
    engines: &EngineTables,
    claims: &[Claim],
) -> String {
    let rows = &cmp.rows;
    let mut s = String::new();
    let _ = writeln!(s, "# Kernel comparison\n\n`{}`\n", ctx.command);
    let cases: Vec<String> = cmp
        .exact
        .first()
        .map(|e| {
            e.iter()
                .map(|x| {
                    format!(
                        "{} ({}x{} px, {} mm/px)",
                        x.case.name, x.case.image.width, x.case.image.height, x.case.mm_per_pixel
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let _ = writeln!(
        s,
        "Materials: {}. Images: {}. Kernels fitted on each profile's default 2D grid; \
         image errors against the exact 2D convolution with the profile (one pixel per cell). \
         Relative RMS = RMS(filtered - exact) / peak(exact) per channel, as `ssskit diff`. \
         FLIP: mean LDR-FLIP at {} pixels per degree after exposure (the exact image's 99th \
         percentile of lit pixels maps to 1), clamp and sRGB 8-bit. \"norm\" columns divide by \
         the largest per-channel value of the table; Σ sums R, G and B (Freude 2014, tables \
         6.3-6.5). `svdN` is the SVD as fitted, `svdN-renorm` scaled to the ground truth's \
         1-norm (Freude 2014, eq. 5.12).\n",
        cmp.materials.join(", "),
        cases.join(", "),
        ctx.options.pixels_per_degree
    );
    let kernel_space: [(&str, &str, RowValue); 3] = [
        (
            "## Kernel space (table 6.3): kernel RMS",
            "kernel-rms",
            |r| Some(r.kernel_rms),
        ),
        ("\n## Kernel space: 1-norm error (signed)", "norm1", |r| {
            Some(r.norm1_error)
        }),
        (
            "\n## Kernel space: asymmetry (axis vs diagonal)",
            "asymmetry",
            |r| Some(r.asymmetry),
        ),
    ];
    for (title, name, err) in kernel_space {
        s += title;
        s += "\n\n";
        s += &block(name, &error_table(rows, err).markdown());
    }
    s += &image_space(cmp, ctx);
    s += "\n## The thesis's claims, measured\n\n";
    s += &block("claims", &claims_table(claims).markdown());
    s += "\n## Engine parameters fitted to the profiles (`ssskit engine`)\n\n\
          Shape error (relative L2 of r R_d(r), as `profiles compare`) per channel r, g, b \
          of the Burley model fitted with each channel's colour kept (the Unreal export as \
          Unreal renders it) against the forward Burley model from the coefficients (the \
          `burley` analytic profile), and of the fitted Jimenez models (iryoku per channel, \
          Godot one kernel).\n\n";
    s += &block("engines", &engine_table(engines).markdown());
    s += "\nThe Burley engines' exports, each as its engine renders it from the printed \
          values (shape error per channel, every version `ssskit engine --engine-version` \
          takes, with the method `ssskit engine` fits by default; Random Walk from a Monte \
          Carlo of Cycles' walk, the walk's own noise taken out of it, its standard error in \
          brackets).\n\n";
    s += &block("burley-engines", &burley_engine_table(engines).markdown());
    if let Some(signal) = ctx.signals.first() {
        let _ = writeln!(
            s,
            "\n## Timings ({signal}; this machine and load, not reproducible)\n"
        );
        s += &timing_table(rows, signal, ctx.factors).markdown();
    }
    s
}

/// Block name of an image table: "image-edge-full", "image-edge-taps17".
pub fn factor_block(signal: &str, f: Which) -> String {
    match f {
        Which::Full => format!("image-{signal}-full"),
        Which::Taps(n) => format!("image-{signal}-taps{n}"),
    }
}

/// CSV of every row, one line per material x model x channel x signal x
/// factor.
pub fn csv(rows: &[Row]) -> Table {
    let mut t = Table::new(&[
        "material",
        "model",
        "label",
        "channel",
        "kernel_rms",
        "norm1_error",
        "asymmetry",
        "passes",
        "fit_seconds",
        "signal",
        "mm_per_pixel",
        "factors",
        "rel_rms",
        "flip",
        "flip_rgb",
        "ms_per_megapixel",
    ]);
    for r in rows {
        let base = vec![
            r.material.clone(),
            r.model.clone(),
            r.label.clone(),
            r.channel.clone(),
            format!("{:e}", r.kernel_rms),
            format!("{:e}", r.norm1_error),
            format!("{:e}", r.asymmetry),
            r.passes.to_string(),
            format!("{:e}", r.fit_seconds),
        ];
        for (signal, e) in &r.image {
            let all = std::iter::once(("full".to_string(), &e.full))
                .chain(e.taps.iter().map(|(n, x)| (format!("taps{n}"), x)));
            for (name, x) in all {
                let mut row = base.clone();
                row.extend([
                    signal.clone(),
                    format!("{}", e.mm_per_pixel),
                    name,
                    format!("{:e}", x.rel_rms),
                    format!("{:e}", x.flip),
                    format!("{:e}", x.flip_rgb),
                    format!("{:e}", x.ms_per_megapixel),
                ]);
                t.push(row);
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_round_trip_and_sig_digits() {
        let text = format!("x\n{}y\n{}", block("a", "1\n2\n"), block("b-c", "3\n"));
        assert_eq!(
            blocks(&text),
            vec![("a".into(), "1\n2\n".into()), ("b-c".into(), "3\n".into())]
        );
        assert_eq!(sig(0.012345), "0.0123");
        assert_eq!(sig(1.2345), "1.23");
        assert_eq!(sig(123.45), "123");
        assert_eq!(sig(1.5e-5), "1.50e-5");
    }
}
