//! The one place where the library's parameter names meet the flags that
//! set them, and the one format of a bad-value message:
//! `--flag: invalid value V: reason`.
//!
//! The library describes a bad parameter as `Error::Invalid { context,
//! field, value, reason }` in its own terms (context "kernel", field
//! "extent_mm"), and names a parameter in the text of a warning in
//! backticks (`` `max_work` ``); it knows no flags. The flag is looked up
//! in the subcommand that ran, since two subcommands may spell one
//! parameter differently (`apply --fov-y`, `advise --fov`) or not have it
//! at all. Errors whose parameter no flag of the subcommand sets (a field of
//! a material file, say) keep the library's wording. A flag typed in a
//! deprecated spelling (`--size` for `--signal-size`) is named as typed.

use ssskit::profile::mc;
use ssskit::Error;
use std::sync::OnceLock;

/// (library context, parameter, flags that set it, first match wins).
#[rustfmt::skip] // one row a line: the table reads as a table
const FLAGS: &[(&str, &str, &[&str])] = &[
    ("radial grid", "dr", &["--dr"]),
    ("radial grid", "rmax", &["--rmax"]),
    ("radial grid", "log_bins", &["--log-bins"]),
    ("kernel", "extent_mm", &["--extent"]),
    ("kernel", "size", &["--grid-size"]),
    ("analytic profile", "model", &["--profile-model"]),
    ("channels", "channels", &["--channels"]),
    ("channels", "channel", &["--channels"]),
    ("manual", "preset", &["--preset"]),
    ("manual", "w", &["--w"]),
    ("manual", "sqrt_tau_near", &["--near"]),
    ("manual", "sqrt_tau_far", &["--far"]),
    ("jimenez", "width", &["--jimenez-width"]),
    ("jimenez", "strength", &["--jimenez-strength"]),
    ("jimenez", "falloff", &["--jimenez-falloff"]),
    ("gaussians", "count", &["--count"]),
    ("guided", "k", &["--k"]),
    ("guided", "b", &["--b"]),
    ("worker threads", "threads", &["--threads"]),
    ("svd", "rank", &["--rank"]),
    ("taps", "count", &["--taps"]),
    ("taps", "extent_mm", &["--tap-extent"]),
    ("shader", "language", &["--emit"]),
    (mc::CONTEXT, "photons", &["--photons", "--max-photons"]),
    (mc::CONTEXT, "target_error", &["--mc-error"]),
    (mc::CONTEXT, "kernel_error", &["--kernel-error", "--mc-error"]),
    (mc::CONTEXT, "max_photons", &["--max-photons"]),
    (mc::CONTEXT, "shard", &["--shard"]),
    (mc::CONTEXT, "channels", &["--channels"]),
    (mc::CONTEXT, "max_work", &["--max-work"]),
    (mc::CONTEXT, "roulette_threshold", &["--roulette"]),
    (mc::CONTEXT, "event_roulette", &["--event-roulette"]),
    (mc::CONTEXT, "max_events", &["--max-events"]),
    (mc::CONTEXT, "abs_floor", &["--abs-floor"]),
    (mc::CONTEXT, "angle_bins", &["--angle-bins"]),
    (mc::CONTEXT, "incidence_deg", &["--incidence"]),
    (mc::CONTEXT, "view_deg", &["--view-angle"]),
    ("kernel scale", "mm_per_pixel", &["--mm-per-pixel"]),
    ("disk error", "mm_per_pixel", &["--mm-per-pixel"]),
    ("kernel scale", "fov_y_deg", &["--fov-y"]),
    ("kernel scale", "sss_width", &["--units-per-mm"]),
    ("filter setup", "follow_surface", &["--follow-surface"]),
    ("filter setup", "follow_surface_scene_units", &["--follow-surface-scene-units"]),
    ("filter setup", "depth", &["--depth"]),
    ("angular factors", "light direction", &["--light-toward"]),
    ("advise", "depth", &["--view-depth"]),
    ("advise", "height", &["--image-height"]),
    ("advise", "target error", &["--image-error"]),
    ("advise", "max_passes", &["--max-passes"]),
    ("advise", "max_samples", &["--max-samples"]),
    ("advise", "max_taps", &["--max-taps"]),
    ("advise", "frames", &["--frames"]),
    ("compare", "model", &["--models"]),
    ("light-space method", "samples", &["--directional-spp"]),
    ("light-space method", "light_map_side", &["--light-map-side"]),
    ("compare", "ranks", &["--ranks"]),
    ("evaluate", "pixels per degree", &["--pixels-per-degree"]),
    ("engine", "scene units per mm", &["--units-per-mm"]),
    ("engine", "engine version", &["--engine-version"]),
    ("engine files", "engine", &["--engine"]),
    ("engine files", "engine version", &["--engine-version"]),
    ("bench", "frames", &["--frames"]),
    ("disk pass", "frames", &["--frames"]),
    ("scene render", "spp", &["--spp"]),
    ("scene render", "target_error", &["--render-error"]),
    ("scene render", "max_spp", &["--max-spp"]),
    ("scene render", "max_work", &["--max-work"]),
    ("scene render", "gbuffer_side", &["--gbuffer-side"]),
    (mc::CONTEXT, "photons", &["--profile-photons"]),
];

/// Where the value is fine but a setting does not suit it: (context,
/// parameter, flag that changes the setting, what to do). Given only where
/// the subcommand has the flag.
const ADVICE: &[(&str, &str, &str, &str)] =
    &[("Fresnel fits", "eta", "--fresnel", "use --fresnel exact")];

/// The path of the subcommand that runs (`["profiles", "compare"]`), set
/// once after parsing.
static RUNNING: OnceLock<Vec<String>> = OnceLock::new();

/// The flags typed in a deprecated spelling: (flag, as typed), set once
/// before parsing.
static TYPED: OnceLock<Vec<(String, String)>> = OnceLock::new();

/// Records the flags typed in a deprecated spelling: messages name them as
/// typed.
pub fn set_typed(pairs: Vec<(String, String)>) {
    let _ = TYPED.set(pairs);
}

/// `text` with every flag the user typed in a deprecated spelling named as
/// typed (a whole flag only: `--out` is not a part of `--out-dir`).
pub fn as_typed(text: &str) -> String {
    let pairs = TYPED.get().map(Vec::as_slice).unwrap_or_default();
    with_spellings(&ssskit::error::short_numbers(text), pairs)
}

fn with_spellings(text: &str, pairs: &[(String, String)]) -> String {
    let part_of_flag = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
    let mut out = text.to_string();
    for (flag, typed) in pairs.iter().filter(|(f, t)| f != t) {
        let mut result = String::with_capacity(out.len());
        let mut rest = out.as_str();
        while let Some(i) = rest.find(flag.as_str()) {
            let end = i + flag.len();
            let before = rest[..i].chars().next_back();
            let after = rest[end..].chars().next();
            result.push_str(&rest[..i]);
            if before.is_some_and(part_of_flag) || after.is_some_and(part_of_flag) {
                result.push_str(flag);
            } else {
                result.push_str(typed);
            }
            rest = &rest[end..];
        }
        result.push_str(rest);
        out = result;
    }
    out
}

/// Records which subcommand runs, for [`running`] and [`warn`].
pub fn set_running(path: Vec<String>) {
    let _ = RUNNING.set(path);
}

/// The subcommand that runs (the top-level command before parsing).
pub fn running() -> Scope {
    let path = RUNNING.get().map(Vec::as_slice).unwrap_or_default();
    Scope::of(&path.iter().map(String::as_str).collect::<Vec<_>>())
}

/// Prints a library warning on standard error in the running
/// subcommand's terms.
pub fn warn(text: &str) {
    eprintln!("warning: {}", running().warning(text));
}

/// The subcommand that ran, for looking up its flags.
pub struct Scope {
    command: clap::Command,
}

impl Scope {
    pub fn new(command: clap::Command) -> Scope {
        Scope { command }
    }

    /// The subcommand at `path` (`["profiles", "compare"]`); the top-level
    /// command, whose messages name no flags, if there is none.
    pub fn of(path: &[&str]) -> Scope {
        Scope::new(super::subcommand(path).unwrap_or_else(super::top_command))
    }

    /// Whether the subcommand has `flag` (`--name`).
    pub fn has(&self, flag: &str) -> bool {
        let long = flag.trim_start_matches("--");
        self.command
            .get_arguments()
            .any(|a| a.get_long() == Some(long))
    }

    /// The flag of this subcommand that sets `field` of `context`, if any.
    pub fn flag_of(&self, context: &str, field: &str) -> Option<&'static str> {
        self.first_flag(|c, f| c == context && f == field)
    }

    /// The flag of this subcommand that sets the parameter `field` in any
    /// context: for texts that name a parameter without its context.
    fn flag_of_parameter(&self, field: &str) -> Option<&'static str> {
        self.first_flag(|_, f| f == field)
    }

    /// The first flag of this subcommand among the table rows `row` keeps.
    fn first_flag(&self, row: impl Fn(&str, &str) -> bool) -> Option<&'static str> {
        FLAGS
            .iter()
            .filter(|(c, f, _)| row(c, f))
            .flat_map(|(_, _, flags)| flags.iter().copied())
            .find(|flag| self.has(flag))
    }

    fn describe(&self, e: &Error) -> Option<String> {
        match e {
            Error::Invalid {
                context,
                field,
                value,
                reason,
            } => {
                if let Some(flag) = self.flag_of(context, field) {
                    return Some(invalid(flag, value, reason).to_string());
                }
                ADVICE
                    .iter()
                    .find(|(c, f, flag, _)| c == context && f == field && self.has(flag))
                    .map(|(_, _, _, advice)| format!("{e}; {advice}"))
            }
            Error::NonFinite { fill, .. } if self.has("--sanitize") => {
                Some(format!("{e}; pass --sanitize to replace them by {fill}"))
            }
            _ => None,
        }
    }

    /// The message printed for an error: its context chain, with a library
    /// parameter error told in terms of the flag that set it, as typed.
    pub fn message(&self, e: &anyhow::Error) -> String {
        let mut parts: Vec<String> = Vec::new();
        for cause in e.chain() {
            let text = cause
                .downcast_ref::<Error>()
                .and_then(|e| self.describe(e))
                .unwrap_or_else(|| cause.to_string());
            // A cause its wrapper already prints (an I/O error inside
            // "path: error") is said once.
            if parts.last().is_some_and(|p| p.ends_with(&text)) {
                continue;
            }
            parts.push(text);
        }
        as_typed(&parts.join(": "))
    }

    /// A library warning with each parameter it names in backticks told as
    /// the flag of this subcommand that sets it (left as is when none does).
    pub fn warning(&self, text: &str) -> String {
        let mut out = String::with_capacity(text.len());
        // Odd pieces of a split on backticks are the quoted ones.
        let mut drop_tick = false;
        for (i, piece) in text.split('`').enumerate() {
            let flag = (i % 2 == 1)
                .then(|| self.flag_of_parameter(piece))
                .flatten();
            if i > 0 && !drop_tick && flag.is_none() {
                out.push('`');
            }
            drop_tick = flag.is_some();
            out.push_str(flag.unwrap_or(piece));
        }
        as_typed(&out)
    }
}

/// A value clap's parser refused (a count, a list item...), in the one
/// format of a bad value, the flag named as typed; None for the other
/// errors of clap (unknown flags, missing values, help), printed as clap
/// prints them.
pub fn parse_error(e: &clap::Error) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if e.kind() != ErrorKind::ValueValidation {
        return None;
    }
    let text = |k| match e.get(k) {
        Some(ContextValue::String(s)) => Some(s.clone()),
        _ => None,
    };
    let arg = text(ContextKind::InvalidArg)?;
    let value = text(ContextKind::InvalidValue)?;
    let reason = std::error::Error::source(e)?.to_string();
    let flag = arg.split_whitespace().next()?;
    Some(as_typed(&invalid(flag, value, &reason).to_string()))
}

/// A bad flag value in the one format: `--flag: invalid value V: reason`.
pub fn invalid(flag: &str, value: impl std::fmt::Display, reason: &str) -> anyhow::Error {
    anyhow::anyhow!("{flag}: invalid value {value}: {reason}")
}

/// `v` if finite and > 0.
pub fn positive(flag: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(flag, v, "must be finite and > 0"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sub(name: &str) -> Scope {
        assert!(super::super::subcommand(&[name]).is_some(), "{name}");
        Scope::of(&[name])
    }

    #[test]
    fn parameters_map_to_flags_in_one_format() {
        let fit = sub("fit");
        let e = anyhow::Error::new(Error::invalid("kernel", "extent_mm", -1, "must be > 0"));
        assert_eq!(fit.message(&e), "--extent: invalid value -1: must be > 0");
        let e = e.context("fitting skin1.json");
        assert_eq!(
            fit.message(&e),
            "fitting skin1.json: --extent: invalid value -1: must be > 0"
        );
        // No flag sets a material file's field: the library's own words.
        let e = anyhow::Error::new(Error::invalid("m.toml", "g[r]", 1.5, "must be < 1"));
        assert_eq!(fit.message(&e), "m.toml: invalid g[r] = 1.5: must be < 1");
        let profile = sub("profile");
        let e = anyhow::Error::new(Error::invalid("Fresnel fits", "eta", 3, "outside"));
        assert!(profile.message(&e).ends_with("; use --fresnel exact"));
        // Advice for a flag the subcommand lacks is not given.
        assert_eq!(fit.message(&e), "Fresnel fits: invalid eta = 3: outside");
    }

    /// One parameter, two spellings: each subcommand's own flag, and the
    /// library's words where the subcommand has none.
    #[test]
    fn flags_are_those_of_the_subcommand_that_ran() {
        let e = anyhow::Error::new(Error::invalid("kernel scale", "fov_y_deg", 0, "bad"));
        let (apply, advise, fit) = (sub("apply"), sub("advise"), sub("fit"));
        assert_eq!(apply.message(&e), "--fov-y: invalid value 0: bad");
        let e = anyhow::Error::new(Error::invalid("kernel scale", "sss_width", 0, "bad"));
        assert_eq!(advise.message(&e), "--units-per-mm: invalid value 0: bad");
        let e = anyhow::Error::new(Error::invalid("kernel scale", "fov_y_deg", 0, "bad"));
        assert_eq!(fit.message(&e), "kernel scale: invalid fov_y_deg = 0: bad");
        let nan = anyhow::Error::new(Error::NonFinite {
            what: "in.exr".into(),
            count: 2,
            unit: "samples",
            first: "pixel (3, 2) channel R".into(),
            fill: 0.0,
        });
        let compare = sub("compare");
        assert!(apply
            .message(&nan)
            .ends_with("; pass --sanitize to replace them by 0"));
        assert!(!compare.message(&nan).contains("--sanitize"));
    }

    #[test]
    fn warnings_name_the_flags_of_the_subcommand() {
        let simulate = sub("simulate");
        assert_eq!(
            simulate.warning("the work cap (`max_work`); `log_bins` resolves it"),
            "the work cap (--max-work); --log-bins resolves it"
        );
        // Parameters no flag of the subcommand sets stay quoted.
        let kernels = sub("kernels");
        assert_eq!(
            kernels.warning("see `max_work` and `rd_beyond_rmax`."),
            "see `max_work` and `rd_beyond_rmax`."
        );
        assert_eq!(simulate.warning("no ticks"), "no ticks");
        assert_eq!(simulate.warning("odd ` tick"), "odd ` tick");
    }

    /// A flag typed in a deprecated spelling is named as typed, a whole
    /// flag at a time.
    #[test]
    fn deprecated_spellings_are_named_as_typed() {
        let pairs = [
            ("--signal-size".to_string(), "--size".to_string()),
            ("--out-dir".to_string(), "--out".to_string()),
        ];
        assert_eq!(
            with_spellings("--signal-size: invalid value 5: too small", &pairs),
            "--size: invalid value 5: too small"
        );
        assert_eq!(
            with_spellings("'--signal-size <PX>' and --out-dir DIR, --out-dirs", &pairs),
            "'--size <PX>' and --out DIR, --out-dirs"
        );
        assert_eq!(with_spellings("--signal-sizes", &pairs), "--signal-sizes");
        assert_eq!(with_spellings("no flags", &pairs), "no flags");
    }

    /// An I/O error is said once, not again as the cause of the error that
    /// names its file.
    #[test]
    fn causes_already_printed_are_not_repeated() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = anyhow::Error::new(Error::io("k.json", io)).context("reading the kernel");
        assert_eq!(
            sub("fit").message(&e),
            "reading the kernel: k.json: no such file"
        );
    }

    #[test]
    fn flag_checks_speak_the_same_format() {
        assert_eq!(positive("--scale", 2.0).unwrap(), 2.0);
        for v in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = positive("--scale", v).unwrap_err().to_string();
            assert_eq!(
                e,
                format!("--scale: invalid value {v}: must be finite and > 0")
            );
        }
    }

    /// Every flag in the tables is a flag of some subcommand: a renamed
    /// flag cannot leave a stale name behind.
    #[test]
    fn every_flag_in_the_tables_exists() {
        let all = super::super::leaf_subcommands();
        let scopes: Vec<Scope> = all.into_iter().map(Scope::new).collect();
        let exists = |flag: &str| scopes.iter().any(|s| s.has(flag));
        for (_, field, flags) in FLAGS {
            assert!(!field.starts_with('-'), "{field}");
            for flag in *flags {
                assert!(flag.starts_with("--") && exists(flag), "{flag}");
            }
        }
        for (_, _, flag, _) in ADVICE {
            assert!(exists(flag), "{flag}");
        }
        assert!(exists("--sanitize"));
    }
}
