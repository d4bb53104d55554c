//! The advice in words: the chosen configuration, the cheapest per model
//! variant with its cost and error, the predicted errors, and which error
//! dominates against the recorded screen-space scene
//! ([`crate::report::eval::advise`] makes the choice).

use super::number::sig;
use crate::numerics::Bounded;
use crate::report::eval::advise::decide::Cost;
use crate::report::eval::advise::scene::SceneCheck;
use crate::report::eval::advise::{
    Advice, Candidate, Remedy, COARSER_SCALES, FULL_MAX_PIXELS, NOISE_K,
};
use crate::report::eval::disk::{DISK_SAMPLES, DISK_SEED};
use std::cmp::Ordering;

/// The rule behind the automatic extent, for the record: `hold`, the
/// fraction of the factor's mass the extent of `taps` taps holds.
pub fn extent_rule_text(taps: usize, hold: f64) -> String {
    format!(
        "radius holding {:.2}% of the factor's mass (1 - 0.7 N^-1.2 at N = {taps})",
        Bounded(100.0 * hold)
    )
}

/// "2 passes x 11 taps = 22 samples per pixel, unsigned target".
pub fn cost_text(c: &Candidate) -> String {
    if c.disk.is_some() {
        return format!(
            "1 pass of {} samples = {} samples per pixel, {} target",
            c.taps_per_pass,
            c.cost,
            c.target_format()
        );
    }
    format!(
        "{} passes x {} taps = {} samples per pixel, {} target",
        c.passes,
        c.taps_per_pass,
        c.cost,
        c.target_format()
    )
}

/// What ships and its cost: "disk, 32 samples within 12.366 mm, mean of 8
/// frames (1 pass of 32 samples = 32 samples per pixel, unsigned target)".
pub fn ship_text(a: &Advice) -> String {
    let c = a.chosen();
    format!("{} ({})", c.describe(), cost_text(c))
}

/// The chosen configuration's worst case, its deciding signal and whether
/// it meets the target within the budget.
pub fn worst_case_text(a: &Advice) -> String {
    let c = a.chosen();
    format!(
        "worst case {:.2}% +- {:.2}% on {}, deciding signal {}; target {:.1}% {} within the \
         budget ({})",
        Bounded(100.0 * c.verdict.rel_rms),
        Bounded(100.0 * c.verdict.rel_rms_sigma),
        c.verdict.worst_signal,
        c.verdict.deciding_signal,
        Bounded(100.0 * a.target),
        if a.meets_target { "met" } else { "NOT met" },
        a.budget.describe()
    )
}

/// "5.050% +- 0.040% on checker2px".
fn worst_text(c: &Candidate) -> String {
    format!(
        "{:.3}% +- {:.3}% on {}",
        Bounded(100.0 * c.verdict.rel_rms),
        Bounded(100.0 * c.verdict.rel_rms_sigma),
        c.verdict.worst_signal
    )
}

/// Why a row is not the chosen one (or that it is).
fn why(b: &Candidate, chosen: &Candidate, a: &Advice) -> String {
    if std::ptr::eq(b, chosen) {
        return "chosen".into();
    }
    why_not(b, chosen, a.meets_target, a.target)
}

/// Why `b` lost to `chosen` (the search met `target` or not): what it
/// misses, and how it stands to the chosen in accuracy and in cost, both
/// as the choice weighs them (samples per pixel, then passes:
/// [`Cost::cost_order`]).
fn why_not(b: &Candidate, chosen: &Candidate, meets_target: bool, target: f64) -> String {
    let v = &b.verdict;
    let cost = match b.cost_order(chosen) {
        Ordering::Greater => format!(
            "costs more ({} against {} samples per pixel{})",
            b.cost,
            chosen.cost,
            if b.cost == chosen.cost {
                format!(", {} passes against {}", b.passes, chosen.passes)
            } else {
                String::new()
            }
        ),
        Ordering::Less => format!(
            "costs less ({} against {} samples per pixel)",
            b.cost, chosen.cost
        ),
        Ordering::Equal => "costs the same".to_string(),
    };
    if v.meets {
        return if b.cost_order(chosen) == Ordering::Equal {
            format!("meets it, {cost}, less accurate")
        } else {
            format!("meets it, {cost}")
        };
    }
    let miss = format!(
        "misses on {}: {:.3}% - {NOISE_K} sd > {:.2}%",
        v.deciding_signal,
        Bounded(100.0 * v.per_signal[&v.deciding_signal]),
        Bounded(100.0 * target)
    );
    if meets_target {
        return miss;
    }
    if !v.ties(&chosen.verdict) {
        return format!("{miss}; less accurate than the chosen");
    }
    match b.cost_order(chosen) {
        // Cheaper and tied with the chosen, yet not chosen: the chosen is
        // the cheapest row that ties the most accurate one; this one does
        // not.
        Ordering::Less => format!(
            "{miss}; ties the chosen (within {NOISE_K} sd) and {cost}, but not the most \
             accurate row"
        ),
        _ => format!("{miss}; ties the chosen (within {NOISE_K} sd), {cost}"),
    }
}

/// The scene check's lines: its sentence, then each configuration's
/// error on the scene, the chosen and the best marked.
fn scene_lines(s: &mut String, sc: &SceneCheck) {
    use std::fmt::Write as _;
    let _ = writeln!(s, "\n  {}", sc.sentence());
    for (i, r) in sc.rows.iter().enumerate() {
        let mark = match (i == sc.chosen, i == sc.best) {
            (true, true) => "chosen, best",
            (true, false) => "chosen",
            (false, true) => "best",
            _ => "",
        };
        let pct = |v: [f64; 3]| {
            format!(
                "{:>6.2} / {:>6.2} / {:>6.2}%",
                100.0 * v[0],
                100.0 * v[1],
                100.0 * v[2]
            )
        };
        let with = r
            .rel_rms_with_factors
            .map_or(String::new(), |v| format!("  with factors {}", pct(v)));
        let _ = writeln!(
            s,
            "    {:<52} {:>2} passes {:>4} spp  {}{with}  {mark}",
            r.configuration,
            r.passes,
            r.samples_per_pixel,
            pct(r.rel_rms)
        );
    }
}

/// Why: the answer with its cost, worst case and deciding signal, what
/// would make it meet the target where it does not, then per model variant
/// its winner on every signal, cheapest first, and why each lost.
pub fn explain(a: &Advice) -> String {
    use std::fmt::Write as _;
    let c = a.chosen();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} at {} mm per pixel (kernel radius holding 99%: {:.3} mm = {:.1} px), target {:.2}% \
         relative RMS",
        a.kernel.material.as_ref().map_or("?", |m| m.name.as_str()),
        sig(a.mm_per_pixel),
        a.kernel_radius_mm,
        a.kernel_radius_mm / a.mm_per_pixel,
        Bounded(100.0 * a.target)
    );
    let _ = writeln!(
        s,
        "  budget: {} ({} layouts outside it not tried)",
        a.budget.describe(),
        a.out_of_budget
    );
    let _ = writeln!(
        s,
        "  {}",
        if a.replicates > 0 {
            format!(
                "score uncertainty (+-): standard deviation over {} replicate profiles drawn \
                 from the profile's Monte Carlo standard errors; a signal is missed only by \
                 more than {NOISE_K} of them",
                a.replicates
            )
        } else {
            "score uncertainty: none (the profile has no standard errors)".to_string()
        }
    );
    let _ = writeln!(
        s,
        "  {}: {}; {}{}",
        if a.meets_target {
            "cheapest meeting it"
        } else {
            "none meets it within the budget; most accurate"
        },
        c.describe(),
        cost_text(c),
        match (c.taps, a.auto_extent_hold) {
            (Some(n), Some(hold)) => format!("; extent = {}", extent_rule_text(n, hold)),
            _ => String::new(),
        }
    );
    let _ = writeln!(
        s,
        "    worst case {}; deciding signal {}",
        worst_text(c),
        c.verdict.deciding_signal
    );
    if let Some(r) = &a.remedy {
        let _ = writeln!(s, "    {}", remedy_text(r));
    }
    table(&mut s, a, c);
    for (sig, e) in &a.predicted {
        let _ = writeln!(
            s,
            "  predicted on {sig}: relative RMS {:.3}% / {:.3}% / {:.3}% (r/g/b), FLIP {:.4}",
            Bounded(100.0 * e.rel_rms[0]),
            Bounded(100.0 * e.rel_rms[1]),
            Bounded(100.0 * e.rel_rms[2]),
            e.flip_rgb
        );
    }
    if let Some(note) = screen_space_note(c.verdict.rel_rms, a.mm_per_pixel) {
        let _ = writeln!(s, "  {note}");
    }
    if let Some(sc) = &a.scene {
        scene_lines(&mut s, sc);
    }
    s
}

/// What would make the best within the budget meet: a looser target (its
/// deciding score less the margin), or the cheapest candidate outside the
/// budget that meets it.
pub fn remedy_text(r: &Remedy) -> String {
    let target = format!(
        "it meets a target of {:.2}% or looser",
        Bounded(100.0 * r.target_met_by_best)
    );
    let budget = match (&r.outside_budget, r.searched_outside) {
        (Some(o), _) => format!(
            "; or a budget of {} passes, {} samples per pixel, {} taps per pass buys {} ({}, \
             worst case {})",
            o.passes,
            o.cost,
            o.taps_per_pass,
            o.describe(),
            cost_text(o),
            worst_text(o)
        ),
        (None, true) => "; no kernel outside the budget meets it".to_string(),
        (None, false) => String::new(),
    };
    let scale = match &r.coarser {
        Some(c) => format!(
            "; or, within the budget, at --mm-per-pixel {} (the finest of {} times the scale \
             that meets it): {} ({}, worst case {})",
            sig(c.mm_per_pixel),
            COARSER_SCALES.map(|f| f.to_string()).join(", "),
            c.candidate.describe(),
            cost_text(&c.candidate),
            worst_text(&c.candidate)
        ),
        None => format!(
            "; no scale up to {}x coarser meets it within the budget",
            COARSER_SCALES[COARSER_SCALES.len() - 1]
        ),
    };
    format!("to meet it: {target}{budget}{scale}")
}

/// The table: per model variant its winner on every signal, cheapest first.
fn table(s: &mut String, a: &Advice, c: &Candidate) {
    use std::fmt::Write as _;
    let signals: Vec<&String> = c.verdict.per_signal.keys().collect();
    let _ = write!(
        s,
        "\n  {:<18} {:>6} {:>5} {:>7} {:>7} {:>9}",
        "model", "passes", "taps", "samples", "format", "extent mm"
    );
    for sig in &signals {
        let _ = write!(s, " {:>10}", format!("{sig} %"));
    }
    let _ = writeln!(s, " {:>16}  why", "worst % +- sd");
    for b in a.best_per_model() {
        let _ = write!(
            s,
            "  {:<18} {:>6} {:>5} {:>7} {:>7} {:>9.3}",
            b.label,
            b.passes,
            b.taps
                .map_or(format!("{}*", b.taps_per_pass), |n| n.to_string()),
            b.cost,
            if b.signed { "signed" } else { "unsigned" },
            b.extent_mm
        );
        for sig in &signals {
            match b.verdict.per_signal.get(*sig) {
                Some(v) => {
                    let _ = write!(s, " {:>10.3}", 100.0 * v);
                }
                None => {
                    let _ = write!(s, " {:>10}", "-");
                }
            }
        }
        let _ = writeln!(
            s,
            " {:>16}  {}",
            format!(
                "{:.3} +- {:.3}",
                Bounded(100.0 * b.verdict.rel_rms),
                Bounded(100.0 * b.verdict.rel_rms_sigma)
            ),
            why(b, c, a)
        );
    }
    for b in a.best_per_model() {
        if let Some(t) = disk_text(b) {
            let _ = writeln!(s, "  {}: {t}", b.label);
        }
    }
    let _ = writeln!(
        s,
        "  ({} configurations filtered: every model x taps {:?} x 3 extents, plus full factors \
         (taps*: pixels spanned) up to {} px, and disk kernels of {:?} samples (one pass; taps: \
         samples), within the budget; passes = 2 x separable terms; each model stops at its \
         cheapest layout meeting the target; format: the render target the weights need, \
         signed float where one is negative)",
        a.candidates.len(),
        a.taps,
        FULL_MAX_PIXELS,
        DISK_SAMPLES
    );
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
        Bounded(100.0 * best),
        Bounded(100.0 * exact),
        Bounded(100.0 * kernel_rms),
        sig(mm_per_pixel),
        if best > kernel_rms {
            format!(
                "the screen-space model's own error dominates ({:.1}x); a tighter target buys \
                 nothing visible on lit, curved surfaces",
                best / kernel_rms.max(1e-12)
            )
        } else {
            "the kernel's error dominates".to_string()
        }
    ))
}

/// "on checker3px, channel r: one accumulation of 8 frames errs 3.474%
/// ...": the disk row's score on its worst signal and where it comes from,
/// every figure of the one channel the score is in.
pub fn disk_text(c: &Candidate) -> Option<String> {
    let d = c.disk.as_ref()?;
    let s = d.signals.get(&c.verdict.worst_signal)?;
    let pct = |v: f64| format!("{:.3}%", Bounded(100.0 * v));
    Some(format!(
        "on {}, channel {}: one accumulation of {k} frames errs {} (the first, frames {DISK_SEED} \
         to {}, what apply --frames {k} makes; sd {} over the {} accumulations measured, in the \
         +- with the bootstrap's); the mean of all {} rotations errs {} (the bias a converged \
         filter shows, with that mean's own residual noise), the noise is {} in one frame and {} \
         after {k} frames",
        c.verdict.worst_signal,
        s.channel,
        pct(s.error),
        DISK_SEED + d.frames - 1,
        pct(s.error_sd),
        d.rotations / d.frames,
        d.rotations,
        pct(s.bias),
        pct(s.noise),
        pct(s.noise_after),
        k = d.frames,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::eval::advise::Verdict;
    use serde_json::json;

    /// A separable row of `samples` per pixel in 2 passes scoring `worst`
    /// +- `sd` on one signal, at the default 5% target.
    fn row(label: &str, samples: usize, worst: f64, sd: f64) -> Candidate {
        let v = Verdict::new(&[("checker2px".into(), worst, sd)], 0.05, true);
        Candidate {
            label: label.into(),
            model: label.into(),
            params: serde_json::json!({}),
            rank: 1,
            passes: 2,
            taps: Some(samples / 2),
            taps_per_pass: samples / 2,
            extent_rule: None,
            extent_mm: 1.0,
            cost: samples,
            signed: false,
            verdict: v,
            disk: None,
            fingerprint: None,
        }
    }

    /// "costs more" and "costs less" say how the row's samples per pixel
    /// stand to the chosen's: where none meets the target, a 10-sample row
    /// tied with a chosen 32-sample one costs less (it lost because it is
    /// not within the noise of the most accurate row), a 64-sample one
    /// costs more; a row that meets the target costs more than the
    /// cheapest that does.
    #[test]
    fn costs_more_compares_samples_per_pixel() {
        let chosen = row("disk", 32, 0.060, 0.002);
        let cheap = row("preintegrate", 10, 0.063, 0.002);
        let dear = row("svd2", 64, 0.061, 0.002);
        assert!(cheap.verdict.ties(&chosen.verdict) && dear.verdict.ties(&chosen.verdict));
        let t = why_not(&cheap, &chosen, false, 0.05);
        assert!(
            t.contains("costs less (10 against 32 samples per pixel)") && !t.contains("more"),
            "{t}"
        );
        let t = why_not(&dear, &chosen, false, 0.05);
        assert!(
            t.contains("costs more (64 against 32 samples per pixel)"),
            "{t}"
        );
        let met = row("guided", 34, 0.040, 0.001);
        let cheaper = row("preintegrate", 26, 0.045, 0.001);
        let t = why_not(&met, &cheaper, true, 0.05);
        assert_eq!(t, "meets it, costs more (34 against 26 samples per pixel)");
        let far = row("svd1", 10, 0.2, 0.001);
        let t = why_not(&far, &chosen, false, 0.05);
        assert!(t.ends_with("less accurate than the chosen"), "{t}");
    }

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

    /// The disk line's score is the row's worst case, printed as the table
    /// prints it, and every figure beside it is of the same channel.
    #[test]
    fn the_disk_line_prints_the_score_of_its_row() {
        let c: Candidate = serde_json::from_value(json!({
            "label": "disk", "model": "disk", "params": {}, "rank": 1, "passes": 1,
            "taps": 32, "taps_per_pass": 32, "extent_rule": null, "extent_mm": 12.0,
            "cost": 32, "signed": false,
            "per_signal": {"checker2px": 0.0338, "checker3px": 0.034737},
            "per_signal_sigma": {"checker2px": 0.0, "checker3px": 0.00005},
            "rel_rms": 0.034737, "rel_rms_sigma": 0.00005, "worst_signal": "checker3px",
            "deciding_signal": "checker3px", "decided_at": 0.034637, "meets": true,
            "complete": true,
            "disk": {"frames": 8, "rotations": 32, "signals": {
                "checker2px": {"channel": "b", "error": 0.0338, "error_sd": 0.0001,
                               "bias": 0.02, "noise": 0.1, "noise_after": 0.035},
                "checker3px": {"channel": "r", "error": 0.034737, "error_sd": 0.00005,
                               "bias": 0.0144, "noise": 0.1024, "noise_after": 0.03644}}}
        }))
        .unwrap();
        let t = disk_text(&c).unwrap();
        assert!(t.starts_with("on checker3px, channel r: "), "{t}");
        assert!(t.contains("errs 3.474% (the first, frames 0 to 7"), "{t}");
        assert!(t.contains("sd 0.005% over the 4 accumulations"), "{t}");
        assert!(t.contains("32 rotations errs 1.440%"), "{t}");
        assert!(t.contains("10.240% in one frame and 3.644% after 8"), "{t}");
    }
}
