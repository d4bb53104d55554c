//! Atomic file writes: a file is written to a temporary name in its
//! folder, synced, then renamed over the target; an [`AtomicGroup`] renames
//! the files of one run together under exclusive locks on their folders.
//! What sits at the path decides first ([`destination`]): a device or a
//! named pipe is written in place, never renamed over.

use super::dest::{destination, write_in_place, Destination};
use super::temps::{sweep_stale_temps, temp_builder, temp_prefix, LiveTemp};
use crate::error::{Error, Result};
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file written to its temporary name, synced, waiting to be renamed
/// over `path` (the regular file to replace); or, `tmp` None, an output
/// already written in place into a device or a pipe.
struct Staged {
    path: PathBuf,
    tmp: Option<(tempfile::NamedTempFile, LiveTemp)>,
}

pub(super) fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Why a file cannot be created in `dir`, for the output `path`: the
/// folder and the reason, without the temporary name (an implementation
/// detail the user never asked for).
pub(super) fn cannot_write(path: &Path, dir: &Path, e: &std::io::Error) -> Error {
    let why = match e.kind() {
        std::io::ErrorKind::NotFound => "the folder does not exist".to_string(),
        std::io::ErrorKind::NotADirectory => "that is not a folder".to_string(),
        k => k.to_string(),
    };
    Error::io(
        path,
        std::io::Error::new(
            e.kind(),
            format!("cannot write in folder '{}': {why}", dir.display()),
        ),
    )
}

fn stage(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<Staged> {
    let path = match destination(path)? {
        Destination::InPlace => {
            write_in_place(path, fill)?;
            return Ok(Staged {
                path: path.to_path_buf(),
                tmp: None,
            });
        }
        Destination::Replace(real) => real,
    };
    let path = path.as_path();
    let dir = folder_of(path);
    sweep_stale_temps(dir);
    let prefix = temp_prefix();
    let (mut tmp, live) = LiveTemp::create(|| temp_builder(&prefix).tempfile_in(dir), |t| t.path())
        .map_err(|e| cannot_write(path, dir, &e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w).map_err(|e| Error::io(path, e))?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    set_default_permissions(tmp.as_file(), path)?;
    Ok(Staged {
        path: path.to_path_buf(),
        tmp: Some((tmp, live)),
    })
}

impl Staged {
    fn persist(self) -> Result<()> {
        let Staged { path, tmp } = self;
        let Some((tmp, _live)) = tmp else {
            return Ok(());
        };
        // Looked at again just before the rename: a device or a pipe that
        // appeared at the path since the staging is never renamed over.
        if destination(&path)? != Destination::Replace(path.clone()) {
            return Err(Error::io(
                &path,
                std::io::Error::other(
                    "became a device, a pipe or a link while the output was written: not replaced",
                ),
            ));
        }
        tmp.persist(&path).map_err(|e| Error::io(&path, e.error))?;
        Ok(())
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes to `path` atomically through a writer callback.
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    stage(path, fill)?.persist()
}

/// Outputs of one run that must not mix with another run's: each file is
/// staged (written and synced under a temporary name) as it is added; commit
/// renames them all while holding an exclusive lock on each folder, so two
/// concurrent runs leave all the files of the one that committed last. A
/// failure before commit leaves every old file as it was.
#[derive(Default)]
pub struct AtomicGroup {
    staged: Vec<Staged>,
}

impl AtomicGroup {
    pub fn new() -> AtomicGroup {
        AtomicGroup::default()
    }

    /// Stages `path` with the content `fill` writes.
    pub fn add_with(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
    ) -> Result<()> {
        self.staged.push(stage(path, fill)?);
        Ok(())
    }

    /// Stages `value` as pretty JSON at `path`.
    pub fn add_json<T: Serialize>(&mut self, path: &Path, value: &T) -> Result<()> {
        let text = serde_json::to_string_pretty(value)
            .map_err(|e| Error::format(path, format!("cannot serialise: {e}")))?;
        self.add_with(path, |w| w.write_all(text.as_bytes()))
    }

    /// Where the `i`-th output added is staged until the commit (None for
    /// one written in place, or no such output): what a run reads back is
    /// its own, whatever a concurrent run commits meanwhile.
    pub fn staged_path(&self, i: usize) -> Option<&Path> {
        self.staged.get(i)?.tmp.as_ref().map(|(t, _)| t.path())
    }

    /// Renames every staged file into place under the folders' locks.
    pub fn commit(self) -> Result<()> {
        let mut dirs: Vec<PathBuf> = self
            .staged
            .iter()
            .map(|s| folder_of(&s.path).to_path_buf())
            .collect();
        dirs.sort();
        dirs.dedup();
        // Locks are taken in sorted order (no deadlock between groups) and
        // released when `_locks` drops, after the renames.
        let _locks: Vec<FolderLock> = dirs
            .iter()
            .map(|d| FolderLock::new(d))
            .collect::<Result<_>>()?;
        for s in self.staged {
            s.persist()?;
        }
        Ok(())
    }
}

/// An exclusive advisory lock (flock) on a folder, released on drop.
pub(super) struct FolderLock {
    #[cfg(unix)]
    _file: std::fs::File,
}

impl FolderLock {
    #[cfg(unix)]
    pub(super) fn new(dir: &Path) -> Result<FolderLock> {
        use std::os::fd::AsRawFd;
        extern "C" {
            fn flock(fd: std::ffi::c_int, operation: std::ffi::c_int) -> std::ffi::c_int;
        }
        const LOCK_EX: std::ffi::c_int = 2;
        let file = std::fs::File::open(dir).map_err(|e| Error::io(dir, e))?;
        // SAFETY: flock on a descriptor we own; the lock ends with it.
        if unsafe { flock(file.as_raw_fd(), LOCK_EX) } != 0 {
            return Err(Error::io(dir, std::io::Error::last_os_error()));
        }
        Ok(FolderLock { _file: file })
    }

    #[cfg(not(unix))]
    pub(super) fn new(_dir: &Path) -> Result<FolderLock> {
        Ok(FolderLock {})
    }
}

/// Temporary files are created private (0600); a finished output gets the
/// permissions an ordinary file would: those of the file it replaces, else
/// 0644.
#[cfg(unix)]
fn set_default_permissions(file: &std::fs::File, path: &Path) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(path)
        .map(|m| m.permissions().mode() & 0o7777)
        .unwrap_or(0o644);
    file.set_permissions(std::fs::Permissions::from_mode(mode))
        .map_err(|e| Error::io(path, e))
}

#[cfg(not(unix))]
fn set_default_permissions(_file: &std::fs::File, _path: &Path) -> Result<()> {
    Ok(())
}

/// Serialises `value` as pretty JSON and writes it atomically.
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let mut g = AtomicGroup::new();
    g.add_json(path, value)?;
    g.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let (dir, p) = crate::io::scratch("out.json");
        write_atomic(&p, b"first").unwrap();
        write_atomic(&p, b"second").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "second");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "temporary file left behind");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o644, "outputs are not private temp files");
        }
    }

    #[test]
    fn failed_fill_keeps_old_file() {
        let (_dir, p) = crate::io::scratch("k.json");
        write_atomic(&p, b"good").unwrap();
        let r = write_atomic_with(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "good");
    }
}
