//! The light-space directional block of a scene comparison as a reader
//! sees it: its table (each method's errors by region against the
//! path-traced image, its cost) and the page section that shows it; the
//! numbers come from [`crate::report::eval::scene::directional`].

use super::number::{pct_cell, pct_cell_rgb};
use super::table::Table;
use crate::report::eval::scene::compare::SceneComparison;
use crate::report::eval::scene::directional::DirectionalBlock;

/// Per method and sample count: RMS (r / g / b) and bias over all seen
/// pixels, the worst channel's RMS by region, FLIP, the cost.
pub fn directional_table(b: &DirectionalBlock) -> Table {
    let mut t = Table::new(&[
        "method",
        "samples/px",
        "RMS % (r / g / b)",
        "bias % (r / g / b)",
        "lit RMS %",
        "unlit RMS %",
        "terminator RMS %",
        "grazing RMS %",
        "FLIP",
        "work/px",
        "CPU ms/MP (loaded)",
    ]);
    let worst = |r: &crate::report::eval::scene::score::RegionError| {
        pct_cell(r.rel_rms.iter().cloned().fold(f64::NAN, f64::max))
    };
    for r in &b.rows {
        let region = |name: &str| {
            r.regions
                .iter()
                .find(|x| x.region == name)
                .map_or("-".into(), worst)
        };
        let all = r.regions.first();
        t.push(vec![
            r.method.clone(),
            r.samples_per_pixel.to_string(),
            all.map_or("-".into(), |a| pct_cell_rgb(a.rel_rms)),
            all.map_or("-".into(), |a| pct_cell_rgb(a.bias)),
            region("lit"),
            region("unlit"),
            region("terminator"),
            region("grazing"),
            all.map_or("-".into(), |a| format!("{:.3}", a.flip)),
            format!("{:.0}", r.work_per_pixel),
            format!("{:.0}", r.ms_per_megapixel),
        ]);
    }
    t
}

/// The block's table under its record name, when the comparison ran it.
pub fn named_table(cmp: &SceneComparison) -> Option<(&'static str, Table)> {
    match &cmp.directional {
        Some(Ok(b)) => Some(("directional", directional_table(b))),
        _ => None,
    }
}

/// The first lines of the comparison's output: which method the scene
/// needs and what it buys, or why the method did not run.
pub fn headline(cmp: &SceneComparison) -> Option<String> {
    match &cmp.directional {
        Some(Ok(b)) => Some(b.verdict.clone()),
        Some(Err(why)) => Some(format!(
            "The light-space directional method did not run on this scene: {why}."
        )),
        None => None,
    }
}

/// The page section: the verdict, the table in a `compare:directional`
/// block, what the columns mean and the model's warnings.
pub fn section(cmp: &SceneComparison) -> String {
    let Some(head) = headline(cmp) else {
        return String::new();
    };
    let Some((name, t)) = named_table(cmp) else {
        return format!("\n## Light-space directional method\n\n{head}\n");
    };
    let warnings: String = match &cmp.directional {
        Some(Ok(b)) => b
            .warnings
            .iter()
            .map(|w| format!("\nWarning: {w}.\n"))
            .collect(),
        _ => String::new(),
    };
    format!(
        "\n## Light-space directional method\n\n{head}\n\nThe light-space directional dipole \
         (Dal Corso et al. 2017) beside the best screen-space model's separable pass of half \
         as many taps per pass and a disk kernel of as many samples, at each sample count: \
         relative RMS of (method - path traced) over the 99th-percentile radiance, mean bias, \
         the worst channel's RMS by region, FLIP; work per pixel in dipole evaluations (light \
         space, over the three channels) or taps read (screen space); CPU milliseconds per \
         megapixel on this machine, which was loaded (read the work).\n\n<!-- BEGIN \
         compare:{name} -->\n{}<!-- END compare:{name} -->\n{warnings}",
        t.markdown()
    )
}
