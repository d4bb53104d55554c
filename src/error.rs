//! One error type for the library. Every variant says which input was wrong
//! and why, so the CLI can print it as is (never a panic on user input).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A physical or numerical parameter is out of its domain.
    #[error("{context}: invalid {field} = {value}: {reason}")]
    Invalid {
        context: String,
        field: String,
        value: String,
        reason: String,
    },
    /// Input samples that are NaN or infinite where only finite ones make
    /// sense; replacing them by `fill` is the caller's choice, not ours.
    #[error("{what}: {count} NaN/Inf {unit}, the first at {first}")]
    NonFinite {
        what: String,
        count: usize,
        /// What was counted ("samples", "values").
        unit: &'static str,
        /// Where the first one is ("pixel (3, 2) channel R").
        first: String,
        /// The value a sanitising caller puts in their place.
        fill: f64,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its content is malformed.
    #[error("{}: {msg}", path.display())]
    Format { path: PathBuf, msg: String },
    /// Anything else the user asked for that cannot be done.
    #[error("{0}")]
    Unsupported(String),
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// f64's Display writes 1e300 with 300 digits: numbers longer than a
/// screenful of digits are shown in scientific notation instead.
fn short_number(s: String) -> String {
    match s.parse::<f64>() {
        Ok(v) if s.len() > 16 => format!("{v:e}"),
        _ => s,
    }
}

/// Digits a number may have in a message before it is shown in
/// scientific notation: more than any count or id ssskit prints (u64 has
/// 20), far fewer than the 300 of a finite f64 near its largest.
const MAX_MESSAGE_DIGITS: usize = 24;

/// `text` with every number of more than [`MAX_MESSAGE_DIGITS`] digits (a
/// huge or tiny f64 printed by Display: 1e300 has 301) rewritten in
/// scientific notation; the one pass every message printed goes through.
pub fn short_numbers(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_ascii_alphanumeric());
        if !starts {
            let ch = text[i..].chars().next().unwrap_or(' ');
            out.push(ch);
            i += ch.len_utf8().max(1);
            continue;
        }
        let mut j = i;
        let mut dot = false;
        while j < b.len() && (b[j].is_ascii_digit() || (b[j] == b'.' && !dot)) {
            dot |= b[j] == b'.';
            j += 1;
        }
        let token = &text[i..j];
        let digits = token.bytes().filter(u8::is_ascii_digit).count();
        match token.trim_end_matches('.').parse::<f64>() {
            Ok(v) if digits > MAX_MESSAGE_DIGITS => {
                out.push_str(&format!("{v:e}"));
                if token.ends_with('.') {
                    out.push('.');
                }
            }
            _ => out.push_str(token),
        }
        i = j;
    }
    out
}

/// `v` when it is finite and > 0; otherwise the one error of that check,
/// its reason "must be finite and > 0" followed by `unit` when one is given
/// (" (mm)").
pub fn finite_positive(context: &str, field: &str, v: f64, unit: &str) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        return Ok(v);
    }
    Err(Error::invalid(
        context,
        field,
        v,
        format!("must be finite and > 0{unit}"),
    ))
}

/// `v` when it is a count from 1 to `max`; otherwise the one error of that
/// check, its reason "must be between 1 and `max`".
pub fn count_up_to(context: &str, field: &str, v: usize, max: usize) -> Result<usize> {
    if (1..=max).contains(&v) {
        return Ok(v);
    }
    let reason = format!("must be between 1 and {max}");
    Err(Error::invalid(context, field, v, reason))
}

/// The header every ssskit file starts with: `schema` must be `expected`
/// and `units` "mm"; otherwise a format error of `context`.
pub fn check_header(context: &str, schema: &str, expected: &str, units: &str) -> Result<()> {
    if schema != expected {
        return Err(Error::format(
            context,
            format!("schema is '{schema}', expected '{expected}'"),
        ));
    }
    if units != "mm" {
        return Err(Error::format(
            context,
            format!("units is '{units}', expected 'mm'"),
        ));
    }
    Ok(())
}

/// `v` when it is finite and >= 0; otherwise the one error of that check.
pub fn finite_non_negative(context: &str, field: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        return Ok(v);
    }
    Err(Error::invalid(context, field, v, "must be finite and >= 0"))
}

impl Error {
    pub fn invalid(
        context: impl Into<String>,
        field: impl Into<String>,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Error::Invalid {
            context: context.into(),
            field: field.into(),
            value: short_number(value.to_string()),
            reason: reason.into(),
        }
    }

    pub fn format(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Error::Format {
            path: path.into(),
            msg: msg.into(),
        }
    }

    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// This error with where it happened (`material 'skin1', image edge`):
    /// a bad parameter stays a bad parameter, so that a caller still names
    /// it by its own spelling (a flag), the place said after its reason;
    /// any other error is prefixed with the place.
    pub fn within(self, place: &str) -> Error {
        match self {
            Error::Invalid {
                context,
                field,
                value,
                reason,
            } if !reason.contains(place) => Error::Invalid {
                context,
                field,
                value,
                reason: format!("{reason} ({place})"),
            },
            e @ Error::Invalid { .. } => e,
            e => Error::Unsupported(format!("{place}: {e}")),
        }
    }
}

#[cfg(test)]
mod tests {
    /// The shared checks pass a good value through and refuse the edge,
    /// the wrong sign, NaN and infinity with the one reason.
    /// A bad parameter keeps its kind and says where; other errors are
    /// prefixed.
    #[test]
    fn errors_within_a_place() {
        let e = super::Error::invalid("kernel scale", "mm_per_pixel", 0.001, "too fine")
            .within("material 'skin1', image edge")
            .within("material 'skin1', image edge");
        match &e {
            super::Error::Invalid { field, reason, .. } => {
                assert_eq!(field, "mm_per_pixel");
                assert_eq!(reason, "too fine (material 'skin1', image edge)");
            }
            other => panic!("{other:?}"),
        }
        let e = super::Error::Unsupported("no".into()).within("material 'x'");
        assert_eq!(e.to_string(), "material 'x': no");
    }

    #[test]
    fn positive_and_non_negative_checks() {
        assert_eq!(super::finite_positive("c", "f", 2.5, "").unwrap(), 2.5);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = super::finite_positive("c", "f", bad, " (mm)").unwrap_err();
            assert!(
                e.to_string().contains("must be finite and > 0 (mm)"),
                "{bad}: {e}"
            );
        }
        assert_eq!(super::finite_non_negative("c", "f", 0.0).unwrap(), 0.0);
        for bad in [-1e-300, f64::NAN, f64::NEG_INFINITY] {
            let e = super::finite_non_negative("c", "f", bad).unwrap_err();
            assert!(
                e.to_string().contains("must be finite and >= 0"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn long_numbers_are_shortened_in_messages() {
        let huge = format!("sample {} at pixel (3, 4).", 1e300f64);
        assert_eq!(super::short_numbers(&huge), "sample 1e300 at pixel (3, 4).");
        let tiny = format!("R_d {}%", 1e-298f64);
        assert_eq!(super::short_numbers(&tiny), "R_d 1e-298%");
        let plain = "x 18446744073709551616 y2024 0.5";
        assert_eq!(super::short_numbers(plain), plain);
    }
}
