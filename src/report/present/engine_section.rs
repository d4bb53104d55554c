//! report.md's section on the engine the main job wrote files for
//! (`kernels --engine`): the files and how to import them, the values,
//! what they cost in colour and shape, and what the error assumes.

use crate::engine::priority::{Priority, COLOUR_TOL};
use crate::engine::EngineFit;
use crate::numerics::Bounded;
use std::fmt::Write as _;

fn pct(v: [f64; 3]) -> String {
    v.map(|x| format!("{:.1}%", Bounded(100.0 * x))).join(", ")
}

/// The section: `files` are (name, what it is) in the output folder.
pub fn section(fit: &EngineFit, files: &[(String, &str)]) -> String {
    let mut s = format!(
        "\n## Into {} ({})\n\nThe engine's own subsurface model fitted to this profile \
         (`ssskit engine --engine {}` with its defaults; {}). Import:\n\n",
        fit.engine, fit.version, fit.engine, fit.error_for
    );
    for (name, what) in files {
        let _ = writeln!(s, "- [{name}]({name}): {what}");
    }
    if let Some(w) = fit.cannot_match() {
        let _ = writeln!(s, "\n**{} {w}.**", fit.engine);
    }
    s += "\nValues (also in the JSON and the files):\n\n```text\n";
    for (name, v) in &fit.params {
        let _ = writeln!(s, "{name} = {v}");
    }
    s += "```\n\n";
    let _ = writeln!(
        s,
        "Error against the profile (r, g, b): total {}; shape {}.",
        pct(fit.error.total),
        pct(fit.error.shape)
    );
    if let Some(o) = &fit.other {
        let how = o.note.as_ref().map_or(String::new(), |n| format!(" ({n})"));
        let _ = match fit.priority {
            Priority::Colour => writeln!(
                s,
                "Each channel's colour is kept to {}% of the profile's; fitting the shape first \
                 instead gives shape {} with total {}{how}.",
                100.0 * COLOUR_TOL,
                pct(o.error.shape),
                pct(o.error.total)
            ),
            Priority::Shape => writeln!(
                s,
                "The shape was fitted first; keeping the colour gives shape {} with total \
                 {}{how}.",
                pct(o.error.shape),
                pct(o.error.total)
            ),
        };
    }
    if !fit.scene.is_empty() || !fit.requirements.is_empty() {
        s += "\nWhat the error assumes (conditions, not values to type):\n\n";
        for line in fit.scene.iter().chain(&fit.requirements) {
            let _ = writeln!(s, "- {line}");
        }
    }
    if !fit.warnings.is_empty() {
        s += "\nWarnings:\n\n";
        for w in &fit.warnings {
            let _ = writeln!(s, "- {w}");
        }
    }
    s
}
