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
}
