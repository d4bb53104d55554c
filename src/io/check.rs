//! Checks of an output path made before any work: the extension names the
//! format, and the folder takes a new file.

use super::atomic::{cannot_write, folder_of};
use super::dest::{destination, Destination};
use super::temps::{temp_builder, temp_prefix, LiveTemp};
use crate::error::{Error, Result};
use std::path::Path;

/// Refuses an output path whose extension is not one of `allowed` (lower
/// case, without the dot): the format written is the one the name says, so
/// that ssskit and other tools read back what they expect. `what` names the
/// output in the error ("unknown image type"). A device or a named pipe
/// (`/dev/stdout`) needs no extension where only one format is allowed:
/// the format is not in doubt.
pub fn check_extension(path: &Path, allowed: &[&str], what: &str) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if ext.as_deref().is_some_and(|e| allowed.contains(&e)) {
        return Ok(());
    }
    if allowed.len() == 1 && matches!(destination(path), Ok(Destination::InPlace)) {
        return Ok(());
    }
    let list: Vec<String> = allowed.iter().map(|e| format!(".{e}")).collect();
    Err(Error::format(
        path,
        format!(
            "unknown {what} type: the file name must end in {}",
            list.join(" or ")
        ),
    ))
}

/// Checks, before any work, that a file can be written at `path`: its
/// folder exists, is a folder and takes a new file (a temporary one is
/// created and removed: the only honest test of a permission), and `path`
/// is not a folder itself, nor anything else ssskit would not write to (a
/// socket, a link to nothing: see [`destination`]). A device or a named
/// pipe is written in place, so its folder is not probed. `what` names the
/// output ("--out", "profile").
pub fn check_output_file(path: &Path, what: &str) -> Result<()> {
    let named = |msg: String| Error::io(path, std::io::Error::other(format!("{what}: {msg}")));
    if path.as_os_str().is_empty() {
        return Err(named("an empty path names no file".into()));
    }
    let inner = |e: Error| match e {
        Error::Io { source, .. } => named(source.to_string()),
        e => e,
    };
    let real = match destination(path).map_err(inner)? {
        Destination::InPlace => return Ok(()),
        Destination::Replace(real) => real,
    };
    let path = real.as_path();
    let dir = folder_of(path);
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(named(format!("'{}' is not a folder", dir.display()))),
        Err(_) => {
            return Err(named(format!(
                "folder '{}' does not exist (it is not created for a file output)",
                dir.display()
            )))
        }
    }
    // The probe is registered for the signal clean-up like every other
    // temporary: a signal between its creation and its removal would
    // otherwise leave it behind.
    let prefix = temp_prefix();
    LiveTemp::create(|| temp_builder(&prefix).tempfile_in(dir), |t| t.path())
        .map(drop)
        .map_err(|e| cannot_write(path, dir, &e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_files_are_checked_before_the_work() {
        let dir = tempfile::tempdir().unwrap();
        assert!(check_output_file(&dir.path().join("x.json"), "--out").is_ok());
        let e = check_output_file(&dir.path().join("no/x.json"), "--out")
            .unwrap_err()
            .to_string();
        assert!(e.contains("--out") && e.contains("does not exist"), "{e}");
        let e = check_output_file(dir.path(), "--out")
            .unwrap_err()
            .to_string();
        assert!(e.contains("is a folder"), "{e}");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert!(names.is_empty(), "the probe left a file");
    }
}
