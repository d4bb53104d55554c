//! The one place where the library's parameter names meet the flags that
//! set them, and the one format of a bad-value message:
//! `--flag: invalid value V: reason`.
//!
//! The library describes a bad parameter as `Error::Invalid { context,
//! field, value, reason }` in its own terms (context "kernel", field
//! "extent_mm"); it knows no flags. Errors whose parameter no flag sets (a
//! field of a material file, say) keep the library's wording.

use ssskit::profile::mc;
use ssskit::Error;

/// (library context, parameter, flag).
const FLAGS: &[(&str, &str, &str)] = &[
    ("radial grid", "dr", "--dr"),
    ("radial grid", "rmax", "--rmax"),
    ("kernel", "extent_mm", "--extent"),
    ("kernel", "size", "--size"),
    ("analytic profile", "model", "--model"),
    ("channels", "channels", "--channels"),
    ("channels", "channel", "--channels"),
    ("manual", "preset", "--preset"),
    ("manual", "w", "--w"),
    ("manual", "sqrt_tau_near", "--near"),
    ("manual", "sqrt_tau_far", "--far"),
    ("jimenez", "width", "--width"),
    ("jimenez", "strength", "--strength"),
    ("jimenez", "falloff", "--falloff"),
    ("gaussians", "count", "--count"),
    ("guided", "k", "--k"),
    ("guided", "b", "--b"),
    ("worker threads", "threads", "--threads"),
    ("svd", "rank", "--rank"),
    ("taps", "count", "--taps"),
    ("taps", "extent_mm", "--tap-extent"),
    ("shader", "language", "--emit"),
    (mc::CONTEXT, "photons", "--photons"),
    (mc::CONTEXT, "target_error", "--target-error"),
    (mc::CONTEXT, "kernel_error", "--kernel-error"),
    (mc::CONTEXT, "max_photons", "--max-photons"),
    (mc::CONTEXT, "shard", "--shard"),
    (mc::CONTEXT, "channels", "--channels"),
    (mc::CONTEXT, "max_work", "--max-work"),
    (mc::CONTEXT, "roulette_threshold", "--roulette"),
    (mc::CONTEXT, "event_roulette", "--event-roulette"),
    (mc::CONTEXT, "max_events", "--max-events"),
    ("kernel scale", "mm_per_pixel", "--mm-per-pixel"),
    ("kernel scale", "fov_y_deg", "--fov-y"),
    ("kernel scale", "sss_width", "--sss-width"),
    ("filter setup", "follow_surface", "--follow-surface"),
    ("filter setup", "depth", "--depth"),
];

/// Where the value is fine but a setting does not suit it: (context,
/// parameter, what to do).
const ADVICE: &[(&str, &str, &str)] = &[("Fresnel fits", "eta", "use --fresnel exact")];

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

/// The flag that sets `field` of `context`, if one does.
pub fn flag_of(context: &str, field: &str) -> Option<&'static str> {
    FLAGS
        .iter()
        .find(|(c, f, _)| *c == context && *f == field)
        .map(|(_, _, flag)| *flag)
}

fn describe(e: &Error) -> Option<String> {
    let Error::Invalid {
        context,
        field,
        value,
        reason,
    } = e
    else {
        return None;
    };
    if let Some(flag) = flag_of(context, field) {
        return Some(invalid(flag, value, reason).to_string());
    }
    ADVICE
        .iter()
        .find(|(c, f, _)| c == context && f == field)
        .map(|(_, _, advice)| format!("{e}; {advice}"))
}

/// The message printed for an error: its context chain, with a library
/// parameter error told in terms of the flag that set it.
pub fn message(e: &anyhow::Error) -> String {
    e.chain()
        .map(|cause| {
            cause
                .downcast_ref::<Error>()
                .and_then(describe)
                .unwrap_or_else(|| cause.to_string())
        })
        .collect::<Vec<_>>()
        .join(": ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_map_to_flags_in_one_format() {
        let e = anyhow::Error::new(Error::invalid("kernel", "extent_mm", -1, "must be > 0"));
        assert_eq!(message(&e), "--extent: invalid value -1: must be > 0");
        let e = e.context("fitting skin1.json");
        assert_eq!(
            message(&e),
            "fitting skin1.json: --extent: invalid value -1: must be > 0"
        );
        // No flag sets a material file's field: the library's own words.
        let e = anyhow::Error::new(Error::invalid("m.toml", "g[r]", 1.5, "must be < 1"));
        assert_eq!(message(&e), "m.toml: invalid g[r] = 1.5: must be < 1");
        let e = anyhow::Error::new(Error::invalid("Fresnel fits", "eta", 3, "outside"));
        assert!(message(&e).ends_with("; use --fresnel exact"));
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

    #[test]
    fn every_flag_in_the_table_is_a_flag() {
        for (_, field, flag) in FLAGS {
            assert!(flag.starts_with("--") && !field.starts_with('-'), "{flag}");
        }
    }
}
