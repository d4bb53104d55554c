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
//! a material file, say) keep the library's wording.

use ssskit::profile::mc;
use ssskit::Error;
use std::sync::OnceLock;

/// (library context, parameter, flags that set it, first match wins).
const FLAGS: &[(&str, &str, &[&str])] = &[
    ("radial grid", "dr", &["--dr"]),
    ("radial grid", "rmax", &["--rmax"]),
    ("radial grid", "log_bins", &["--log-bins"]),
    ("kernel", "extent_mm", &["--extent"]),
    ("kernel", "size", &["--size"]),
    ("analytic profile", "model", &["--model", "--profile-model"]),
    ("channels", "channels", &["--channels"]),
    ("channels", "channel", &["--channels"]),
    ("manual", "preset", &["--preset"]),
    ("manual", "w", &["--w"]),
    ("manual", "sqrt_tau_near", &["--near"]),
    ("manual", "sqrt_tau_far", &["--far"]),
    ("jimenez", "width", &["--width"]),
    ("jimenez", "strength", &["--strength"]),
    ("jimenez", "falloff", &["--falloff"]),
    ("gaussians", "count", &["--count"]),
    ("guided", "k", &["--k"]),
    ("guided", "b", &["--b"]),
    ("worker threads", "threads", &["--threads"]),
    ("svd", "rank", &["--rank"]),
    ("taps", "count", &["--taps"]),
    ("taps", "extent_mm", &["--tap-extent"]),
    ("shader", "language", &["--emit"]),
    (mc::CONTEXT, "photons", &["--photons", "--mc-photons"]),
    (
        mc::CONTEXT,
        "target_error",
        &["--target-error", "--mc-error"],
    ),
    (
        mc::CONTEXT,
        "kernel_error",
        &["--kernel-error", "--mc-error"],
    ),
    (
        mc::CONTEXT,
        "max_photons",
        &["--max-photons", "--mc-photons"],
    ),
    (mc::CONTEXT, "shard", &["--shard"]),
    (mc::CONTEXT, "channels", &["--channels"]),
    (mc::CONTEXT, "max_work", &["--max-work"]),
    (mc::CONTEXT, "roulette_threshold", &["--roulette"]),
    (mc::CONTEXT, "event_roulette", &["--event-roulette"]),
    (mc::CONTEXT, "max_events", &["--max-events"]),
    (mc::CONTEXT, "abs_floor", &["--abs-floor"]),
    ("kernel scale", "mm_per_pixel", &["--mm-per-pixel"]),
    ("kernel scale", "fov_y_deg", &["--fov-y", "--fov"]),
    ("kernel scale", "sss_width", &["--sss-width"]),
    ("filter setup", "follow_surface", &["--follow-surface"]),
    ("filter setup", "depth", &["--depth"]),
    ("advise", "depth", &["--depth"]),
    ("advise", "height", &["--height"]),
    ("advise", "target error", &["--target-error"]),
    ("compare", "model", &["--models"]),
    ("compare", "ranks", &["--ranks"]),
    ("evaluate", "pixels per degree", &["--pixels-per-degree"]),
    ("engine", "scene units per mm", &["--units-per-mm"]),
    ("bench", "frames", &["--frames"]),
    ("scene render", "spp", &["--spp"]),
    ("scene render", "target_error", &["--target-error"]),
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
    /// parameter error told in terms of the flag that set it.
    pub fn message(&self, e: &anyhow::Error) -> String {
        e.chain()
            .map(|cause| {
                cause
                    .downcast_ref::<Error>()
                    .and_then(|e| self.describe(e))
                    .unwrap_or_else(|| cause.to_string())
            })
            .collect::<Vec<_>>()
            .join(": ")
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
        out
    }
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

/// `v` if `lo <= v <= hi`.
pub fn between(flag: &str, v: usize, lo: usize, hi: usize) -> anyhow::Result<usize> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(invalid(flag, v, &format!("must be between {lo} and {hi}")))
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
        assert_eq!(advise.message(&e), "--fov: invalid value 0: bad");
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
        assert_eq!(between("--size", 8, 8, 16).unwrap(), 8);
        let e = between("--size", 17, 8, 16).unwrap_err().to_string();
        assert_eq!(e, "--size: invalid value 17: must be between 8 and 16");
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
