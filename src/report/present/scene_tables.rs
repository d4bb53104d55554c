//! The scene comparison as a reader sees it: its tables (summary, regions,
//! noise, the angular factors), the markdown page that shows them and the
//! contact sheet; the numbers come from [`crate::report::eval::scene::compare`].

// Colour loops index several [_; 3] arrays by channel at once.
#![allow(clippy::needless_range_loop)]

use super::number::{pct_cell, pct_cell_rgb};
use super::table::Table;
use crate::error::Result;
use crate::filter::Image;
use crate::kernel::angular::AngularFactors;
use crate::report::eval::scene::compare::SceneComparison;
use crate::report::eval::scene::score::REGIONS;

/// Per row: flat-plane errors beside the scene's, over all seen pixels.
pub fn summary_table(cmp: &SceneComparison) -> Table {
    let mut t = Table::new(&[
        "model",
        "flat edge %",
        "flat shapes %",
        "scene RMS % (r / g / b)",
        "scene bias % (r / g / b)",
        "FLIP",
    ]);
    for r in &cmp.rows {
        let all = r.region("all");
        t.push(vec![
            r.name(),
            r.flat_edge.map_or("-".into(), pct_cell),
            r.flat_shapes.map_or("-".into(), pct_cell),
            all.map_or("-".into(), |a| pct_cell_rgb(a.rel_rms)),
            all.map_or("-".into(), |a| pct_cell_rgb(a.bias)),
            all.map_or("-".into(), |a| format!("{:.3}", a.flip)),
        ]);
    }
    t
}

/// Per row and region: the largest relative RMS over the channels and the
/// region's FLIP.
pub fn region_table(cmp: &SceneComparison) -> Table {
    let mut head = vec!["model".to_string()];
    for r in REGIONS {
        head.push(format!("{r} RMS %"));
        head.push(format!("{r} FLIP"));
    }
    let mut t = Table {
        header: head,
        rows: Vec::new(),
    };
    for r in &cmp.rows {
        let mut row = vec![r.name()];
        for name in REGIONS {
            match r.region(name) {
                Some(e) if e.pixels > 0 => {
                    row.push(pct_cell(e.rel_rms.iter().cloned().fold(0.0, f64::max)));
                    row.push(format!("{:.3}", e.flip));
                }
                _ => {
                    row.push("-".into());
                    row.push("-".into());
                }
            }
        }
        t.push(row);
    }
    t
}

/// The path-traced image's noise per region (the floor under the RMS).
pub fn noise_table(cmp: &SceneComparison) -> Table {
    let mut t = Table::new(&["region", "pixels", "noise % (r / g / b)"]);
    if let Some(r) = cmp.rows.first() {
        for e in &r.regions {
            t.push(vec![
                e.region.clone(),
                e.pixels.to_string(),
                if e.pixels > 0 {
                    pct_cell_rgb(e.noise)
                } else {
                    "-".into()
                },
            ]);
        }
    }
    t
}

/// The angular factors the comparison applied, per node: entry and exit
/// factor with their standard errors (r / g / b).
pub fn angular_table(f: &AngularFactors) -> Table {
    let mut t = Table::new(&[
        "cosine",
        "entry E(N.L) (r / g / b)",
        "+- (r / g / b)",
        "exit X(N.V) (r / g / b)",
        "+- (r / g / b)",
    ]);
    let three =
        |v: [f64; 3], d: usize| format!("{:.d$} / {:.d$} / {:.d$}", v[0], v[1], v[2], d = d);
    for k in 0..f.mu.len() {
        t.push(vec![
            format!("{:.3}", f.mu[k]),
            three(f.entry[k], 4),
            three(f.entry_stderr[k], 4),
            three(f.exit[k], 4),
            three(f.exit_stderr[k], 4),
        ]);
    }
    t
}

/// The comparison's tables by name, the summary first: what the page
/// shows and the record keeps.
pub fn named_tables(cmp: &SceneComparison) -> Vec<(&'static str, Table)> {
    let mut v = vec![
        ("summary", summary_table(cmp)),
        ("regions", region_table(cmp)),
        ("noise", noise_table(cmp)),
    ];
    if let Some(f) = &cmp.angular {
        v.push(("angular", angular_table(f)));
    }
    v
}

/// The markdown page of a comparison under the sentence `head`: each table
/// in a `compare:NAME` block, and why there are no angular rows when the
/// scene allows none.
pub fn page(cmp: &SceneComparison, head: &str) -> String {
    let block = |name: &str| {
        let t = named_tables(cmp)
            .into_iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| t.markdown())
            .unwrap_or_default();
        format!("<!-- BEGIN compare:{name} -->\n{t}<!-- END compare:{name} -->\n")
    };
    let angular = match (&cmp.angular, &cmp.angular_note) {
        (Some(f), _) => format!(
            "\nThe angular factors applied around the pass (rows `entry`, `exit`, `entry+exit` \
             and `depth+follow+angular`): entry E(N.L) = R_d(theta_in) / R_d(0) multiplies the \
             irradiance before the blur, exit X(N.V) = pi L / M the result after it; {} photons \
             per channel and incidence.\n\n{}",
            f.photons,
            block("angular")
        ),
        (None, Some(why)) => format!("\nNo angular rows: {why}.\n"),
        (None, None) => String::new(),
    };
    let d = cmp.dominance.as_ref();
    let sentence = d
        .as_ref()
        .map_or(String::new(), |d| format!("{}\n\n", d.sentence()));
    let ranking = d
        .and_then(|d| d.headline())
        .map_or(String::new(), |h| format!("```text\n{h}```\n\n"));
    format!(
        "# Screen-space SSS against the path-traced scene\n\n{ranking}{head}\n\n{sentence}All seen \
         pixels: relative RMS of (pass - path traced) over the 99th-percentile radiance, mean \
         bias, FLIP; flat-plane errors of the same tap table beside them.\n\n{}\nLargest RMS \
         over the channels and FLIP by region.\n\n{}\nThe path-traced image's noise by region \
         (the floor under the RMS).\n\n{}{angular}",
        block("summary"),
        block("regions"),
        block("noise")
    )
}

/// Fraction of the path-traced peak shown as white in difference tiles.
pub const SCENE_DIFF_SCALE: f64 = 0.1;

/// A contact sheet: the path-traced image, then the baselines and each
/// model with the lerp (its image above |image - path traced|, white =
/// [`SCENE_DIFF_SCALE`] of the peak), one exposure for all.
pub fn contact_sheet(cmp: &SceneComparison, title: &str, out: &std::path::Path) -> Result<()> {
    let images = cmp.images.iter().filter(|(l, _)| {
        !l.contains('(')
            || l.ends_with("(depth+follow)")
            || l.ends_with("(depth+follow+angular)")
            || l.ends_with("(entry+exit)")
    });
    let images = images.map(|(label, img)| {
        let label = label
            .replace(" (depth+follow+angular)", " + angular")
            .replace(" (depth+follow)", "");
        (label, img)
    });
    let title = format!("{title}: screen-space pass (depth + follow) above |pass - path traced|");
    difference_sheet(cmp, images, &title, "pass", out)
}

/// A scene's sheet: the path-traced image, then each of `images` above its
/// difference from it (white = [`SCENE_DIFF_SCALE`] of the peak), all at
/// the scene's exposure; `what` names the images in the colour bar.
pub fn difference_sheet<'a>(
    cmp: &SceneComparison,
    images: impl Iterator<Item = (String, &'a Image)>,
    title: &str,
    what: &str,
    out: &std::path::Path,
) -> Result<()> {
    use super::kernel_plots::to_rgb8;
    use super::sheet::{draw_sheet, SheetTile};
    let truth = &cmp.truth;
    let mut tiles = vec![SheetTile {
        label: "path traced".into(),
        top: to_rgb8(truth, cmp.exposure),
        bottom: None,
        flag: None,
    }];
    for (label, img) in images {
        let d = crate::filter::diff::false_colour(truth, img, Some(SCENE_DIFF_SCALE * cmp.peak));
        tiles.push(SheetTile {
            label,
            top: to_rgb8(img, cmp.exposure),
            bottom: Some(("difference".into(), to_rgb8(&d, 1.0))),
            flag: None,
        });
    }
    let bar = super::colour_bar::ColourBar {
        white: 100.0 * SCENE_DIFF_SCALE,
        unit: "% of the path-traced peak".into(),
        quantity: format!("difference tiles: |{what} - path traced|, largest channel"),
    };
    draw_sheet(&tiles, (truth.width, truth.height), title, Some(&bar), out)?;
    Ok(())
}
