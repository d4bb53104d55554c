//! report.md's section on the engine the main job wrote files for
//! (`kernels --engine`): the files and how to import them, the values,
//! what they cost in colour and shape, and what the error assumes, as
//! [`crate::report::eval::ship::engine_step`] read them off the fit.

use crate::numerics::Bounded;
use crate::report::eval::ship::engine_step::EngineSection;
use std::fmt::Write as _;

fn pct(v: [f64; 3]) -> String {
    v.map(|x| format!("{:.1}%", Bounded(100.0 * x))).join(", ")
}

/// The section.
pub fn section(fit: &EngineSection) -> String {
    let mut s = format!(
        "\n## Into {} ({})\n\nThe engine's own subsurface model fitted to this profile \
         (`ssskit engine --engine {}` with its defaults; {}). Import:\n\n",
        fit.engine, fit.version, fit.engine, fit.error_for
    );
    for (name, what) in &fit.files {
        let _ = writeln!(s, "- [{name}]({name}): {what}");
    }
    if let Some(w) = &fit.cannot_match {
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
        pct(fit.total),
        pct(fit.shape)
    );
    if let Some(o) = &fit.other {
        let how = o.note.as_ref().map_or(String::new(), |n| format!(" ({n})"));
        let _ = match o.colour_kept_pct {
            Some(kept) => writeln!(
                s,
                "Each channel's colour is kept to {}% of the profile's; fitting the shape first \
                 instead gives shape {} with total {}{how}.",
                kept,
                pct(o.shape),
                pct(o.total)
            ),
            None => writeln!(
                s,
                "The shape was fitted first; keeping the colour gives shape {} with total \
                 {}{how}.",
                pct(o.shape),
                pct(o.total)
            ),
        };
    }
    if !fit.conditions.is_empty() {
        s += "\nWhat the error assumes (conditions, not values to type):\n\n";
        for line in &fit.conditions {
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
