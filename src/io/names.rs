//! Names are labels, never paths: a file name made from a label goes
//! through [`file_stem`], and [`join_inside`] refuses a name that would
//! leave its folder.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// A file name stem made from a label (a material's name): letters and
/// digits of any script, '-', '_', '+' and '.' are kept, every other
/// character (path separators, control characters, spaces, quotes) becomes
/// '_'; a leading '.' becomes '_' (no hidden files, no '..'); at most 100
/// bytes; "unnamed" for an empty label. The same label always gives the
/// same stem; two labels may give one stem (callers that write several
/// check that theirs differ).
pub fn file_stem(label: &str) -> String {
    const MAX_STEM_BYTES: usize = 100;
    let mut out = String::new();
    for c in label.chars() {
        let keep = c.is_alphanumeric() || matches!(c, '-' | '_' | '+' | '.');
        let c = if !keep || (out.is_empty() && c == '.') {
            '_'
        } else {
            c
        };
        if out.len() + c.len_utf8() > MAX_STEM_BYTES {
            break;
        }
        out.push(c);
    }
    if out.is_empty() {
        out.push_str("unnamed");
    }
    out
}

/// `dir/name` when `name` is one plain file name (not empty, no separator,
/// not '.' or '..', not absolute): a write there lands inside `dir`.
/// Refuses anything else, naming it.
pub fn join_inside(dir: &Path, name: &str) -> Result<PathBuf> {
    use std::path::Component;
    let mut parts = Path::new(name).components();
    match (parts.next(), parts.next()) {
        (Some(Component::Normal(n)), None) if n == std::ffi::OsStr::new(name) => Ok(dir.join(n)),
        _ => Err(Error::invalid(
            format!("output folder {}", dir.display()),
            "file name",
            format!("'{}'", name.escape_debug()),
            "must be one plain file name inside the folder (no separator, '.' or '..')",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stems_are_plain_names_and_joins_stay_inside() {
        for (label, stem) in [
            ("skin1", "skin1"),
            ("../x", "_._x"),
            ("/etc/passwd", "_etc_passwd"),
            ("a\u{1b}[31mRED", "a__31mRED"),
            (".hidden", "_hidden"),
            ("..", "_."),
            ("", "unnamed"),
            ("peau claire", "peau_claire"),
            ("crème", "crème"),
        ] {
            assert_eq!(file_stem(label), stem, "{label:?}");
            let dir = Path::new("out");
            assert_eq!(join_inside(dir, stem).unwrap(), dir.join(stem));
        }
        assert!(file_stem(&"x".repeat(500)).len() <= 100);
        assert!(file_stem(&"é".repeat(500)).len() <= 100);
        for bad in ["../x", "/abs", "a/b", "", ".", "..", "a/"] {
            let e = join_inside(Path::new("out"), bad).unwrap_err().to_string();
            assert!(e.contains("one plain file name"), "{bad}: {e}");
        }
    }
}
