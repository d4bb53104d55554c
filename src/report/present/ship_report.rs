//! The main job's report.md (`ssskit kernels`): its first screen says
//! what to ship (the kernel file with its model, taps or samples and
//! frames, at the chosen scale), its worst case, the material's preview
//! with the errors, the contact sheet and every figure with its caption;
//! then why (the advice in full), the comparison and the stage times.

use super::advice_text;
use super::figures::{self, Figure};
use super::preview_panel::preview_markdown;
use super::table::Table;
use crate::report::eval::advise::Advice;
use crate::report::eval::ship::preview::Preview;
use crate::report::eval::ship::stage_times::StageTimes;

/// What the report is made of.
pub struct ShipReport<'a> {
    pub advice: &'a Advice,
    pub material: &'a str,
    /// The command line, the output folder as OUT.
    pub command: &'a str,
    /// The recommended kernel's file stem ("recommended": .json and the
    /// shader arrays .hlsl, .glsl, .wgsl beside it).
    pub stem: &'a str,
    /// The preview and its file, or why there is none; None without plots.
    pub preview: Option<Result<(&'a Preview, &'a str), String>>,
    /// The contact sheet the first screen points to.
    pub sheet: Option<&'a Figure>,
    pub figures: &'a [Figure],
    /// The comparison's markdown (its own title first).
    pub comparison: &'a str,
    /// The section on the engine whose files were written beside the
    /// kernel (`kernels --engine`), where asked.
    pub engine: Option<&'a str>,
    /// The stage times' table.
    pub stage_times: &'a str,
}

/// `md` with every heading one level deeper (outside code blocks), to sit
/// under another title.
fn demoted(md: &str) -> String {
    let mut fenced = false;
    let mut out = String::with_capacity(md.len() + 64);
    for line in md.lines() {
        if line.starts_with("```") {
            fenced = !fenced;
        }
        if !fenced && line.starts_with('#') {
            out.push('#');
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// The first screen: title, command, what ships, its worst case, the
/// scene check's ranking where a scene was given, the preview, the sheet.
fn head(r: &ShipReport) -> String {
    let a = r.advice;
    let stem = r.stem;
    let mut s = format!(
        "# {}: what to ship at {} mm per pixel\n\n`{}`\n\n",
        r.material, a.mm_per_pixel, r.command
    );
    s += &format!(
        "**Ship [{stem}.json]({stem}.json)** (shader arrays [{stem}.hlsl]({stem}.hlsl), \
         [{stem}.glsl]({stem}.glsl), [{stem}.wgsl]({stem}.wgsl)): {}.\n\n",
        advice_text::ship_text(a)
    );
    s += &format!(
        "**Its {}** (relative RMS against the exact 2D convolution on the flat test \
         signals at {} mm per pixel).\n\n",
        advice_text::worst_case_text(a),
        a.mm_per_pixel
    );
    if let Some(sc) = &a.scene {
        s += &format!("{}\n", sc.headline());
    }
    match &r.preview {
        Some(Ok((p, file))) => s += &format!("{}\n", preview_markdown(p, file, a.mm_per_pixel)),
        Some(Err(why)) => s += &format!("No preview of the material: {why}.\n\n"),
        None => {}
    }
    if let Some(f) = r.sheet {
        s += &format!(
            "**Contact sheet** ([{0}]({0})): {1}.\n\n",
            f.file, f.caption
        );
    }
    s
}

/// The whole report.md.
pub fn report(r: &ShipReport) -> String {
    let mut s = head(r);
    let figures = if r.figures.is_empty() {
        ""
    } else {
        "[the figures](#figures), "
    };
    s += &format!(
        "Further down: [why this kernel](#what-to-ship-{}json-advicejson), {figures}[the \
         comparison of every model](#kernel-comparison), [stage times](#stage-times).\n",
        r.stem
    );
    if !r.figures.is_empty() {
        s += &figures::markdown(r.figures);
    }
    s += &format!(
        "\n## What to ship ({}.json, advice.json)\n\n```text\n{}```\n\n",
        r.stem,
        advice_text::explain(r.advice)
    );
    if let Some(e) = r.engine {
        s += e;
    }
    s += &demoted(r.comparison);
    s += &format!(
        "\n## Stage times\n\nWall and CPU seconds of this run's stages (CPU: every thread; \
         the profile's include the command's start-up); the truth and each fit were made once, \
         for the comparison, and the advice scored those same fits.\n\n{}",
        r.stage_times
    );
    s
}

/// report.md's "Stage times" table: one row per stage and the total, wall
/// and CPU seconds.
pub fn stage_table(times: &StageTimes) -> String {
    let mut t = Table::new(&["stage", "wall s", "CPU s"]);
    let rows = times.stages().into_iter().chain([("total", times.total)]);
    for ((name, s), cpu) in rows.zip(times.cpu_seconds()) {
        // Milliseconds, so that the rows add up as the numbers do.
        t.push(vec![
            name.to_string(),
            format!("{s:.3}"),
            format!("{cpu:.3}"),
        ]);
    }
    t.markdown()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_go_one_level_down_outside_code() {
        let md = "# A\n## B\n```text\n# not a heading\n```\ntext # no\n";
        assert_eq!(
            demoted(md),
            "## A\n### B\n```text\n# not a heading\n```\ntext # no\n"
        );
    }
}
