//! The advice in words: the chosen configuration, the cheapest per model
//! variant with its cost and error, the predicted errors, and which error
//! dominates against the recorded screen-space scene
//! ([`crate::report::advise`] makes the choice).

use super::number::sig;
use crate::kernel::taps::hold_for_taps;
use crate::report::eval::advise::{meets, Advice, ExtentRule, FULL_MAX_PIXELS};

/// The rule behind the automatic extent, for the record.
pub fn extent_rule_text(taps: usize) -> String {
    format!(
        "radius holding {:.2}% of the factor's mass (1 - 0.7 N^-1.2 at N = {taps})",
        100.0 * hold_for_taps(taps)
    )
}

/// Why: the answer, then per model variant its cheapest configuration that
/// meets the target (or its most accurate), with cost and error.
pub fn explain(a: &Advice) -> String {
    use std::fmt::Write as _;
    let c = a.chosen();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} at {} mm per pixel (kernel radius holding 99%: {:.3} mm = {:.1} px), target {:.2}% \
         relative RMS:",
        a.kernel.material.as_ref().map_or("?", |m| m.name.as_str()),
        sig(a.mm_per_pixel),
        a.kernel_radius_mm,
        a.kernel_radius_mm / a.mm_per_pixel,
        100.0 * a.target
    );
    let _ = writeln!(
        s,
        "  {}: {}, {} samples per pixel, error {:.3}%{}",
        if a.meets_target {
            "cheapest meeting it"
        } else {
            "NONE meets it; most accurate"
        },
        c.describe(),
        c.cost,
        100.0 * c.rel_rms,
        match c.taps {
            Some(n) if Some(ExtentRule::Auto) == c.extent_rule =>
                format!("; extent = {}", extent_rule_text(n)),
            _ => String::new(),
        }
    );
    let signals: Vec<&String> = c.per_signal.keys().collect();
    let _ = write!(
        s,
        "\n  {:<18} {:>7} {:>6} {:>5} {:>10}",
        "model", "taps", "rank", "cost", "extent mm"
    );
    for sig in &signals {
        let _ = write!(s, " {:>9}", format!("{sig} %"));
    }
    let _ = writeln!(s, " {:>6}", "meets");
    for b in a.best_per_model() {
        let _ = write!(
            s,
            "  {:<18} {:>7} {:>6} {:>5} {:>10.3}",
            b.label,
            b.taps.map_or("full".into(), |n| n.to_string()),
            b.rank,
            b.cost,
            b.extent_mm
        );
        for sig in &signals {
            match b.per_signal.get(*sig) {
                Some(v) => {
                    let _ = write!(s, " {:>9.3}", 100.0 * v);
                }
                // Not filtered: over the target on an earlier signal.
                None => {
                    let _ = write!(s, " {:>9}", "-");
                }
            }
        }
        let _ = writeln!(s, " {:>6}", if meets(b, a.target) { "yes" } else { "no" });
    }
    let _ = writeln!(
        s,
        "  ({} configurations evaluated: every model x taps {:?} x 3 extents, plus full factors \
         up to {} px; cost = 2 x rank x taps samples per pixel)",
        a.candidates.len(),
        a.taps,
        FULL_MAX_PIXELS
    );
    for (sig, e) in &a.predicted {
        let _ = writeln!(
            s,
            "  predicted on {sig}: relative RMS {:.3}% / {:.3}% / {:.3}% (r/g/b), FLIP {:.4}",
            100.0 * e.rel_rms[0],
            100.0 * e.rel_rms[1],
            100.0 * e.rel_rms[2],
            e.flip_rgb
        );
    }
    if let Some(note) = screen_space_note(c.rel_rms, a.mm_per_pixel) {
        let _ = writeln!(s, "  {note}");
    }
    s
}

/// The screen-space model's own error as `compare --scene` measured it on
/// the path-traced sphere of docs/scene.md (the committed record
/// docs/records/scene-compare.json, made by scripts/scene-record).
const SCENE_RECORD: &str = include_str!("../../../docs/records/scene-compare.json");

/// Which error dominates: a kernel error `kernel_rms` (flat plane, at
/// `mm_per_pixel`) against the screen-space model's error on the recorded
/// scene.
pub fn screen_space_note(kernel_rms: f64, mm_per_pixel: f64) -> Option<String> {
    let r: serde_json::Value = serde_json::from_str(SCENE_RECORD).ok()?;
    let d = &r["data"]["dominance"];
    let (best, exact, at) = (
        d["best_scene_rms"].as_f64()?,
        d["exact_scene_rms"].as_f64()?,
        d["mm_per_pixel"].as_f64()?,
    );
    let scene = r["data"]["scene"].as_str()?;
    Some(format!(
        "screen-space model: on the path-traced sphere of {scene} ({at:.3} mm per pixel, \
         docs/scene.md) the best kernel through the screen-space pass misses by {:.1}% RMS of \
         the peak and the exact flat kernel by {:.1}%, against this choice's {:.2}% at {} mm per \
         pixel: {}",
        100.0 * best,
        100.0 * exact,
        100.0 * kernel_rms,
        sig(mm_per_pixel),
        if best > kernel_rms {
            format!(
                "the screen-space model's own error dominates ({:.0}x); a tighter target buys \
                 nothing visible on lit, curved surfaces",
                best / kernel_rms.max(1e-12)
            )
        } else {
            "the kernel's error dominates".to_string()
        }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note reads the committed record of the path-traced sphere and
    /// says which error is the larger.
    #[test]
    fn the_note_says_which_error_dominates() {
        let small = screen_space_note(1e-4, 0.1).expect("the scene record");
        assert!(
            small.contains("screen-space model's own error dominates"),
            "{small}"
        );
        assert!(small.contains("0.01% at 0.100 mm per pixel"), "{small}");
        let big = screen_space_note(0.9, 0.1).unwrap();
        assert!(big.contains("the kernel's error dominates"), "{big}");
    }
}
