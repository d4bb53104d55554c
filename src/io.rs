//! File output that never leaves a half-written result behind: everything is
//! written to a temporary file in the destination folder, synced, then renamed
//! over the target (rename is atomic on one filesystem).
//!
//! Temporary files are named `.ssskit-<pid>-<random>.tmp`. Those of an
//! unfinished write are removed when the process is ended by SIGINT, SIGTERM
//! or SIGHUP (once the binary calls [`remove_temps_on_signals`]); those a
//! killed process (SIGKILL, power loss) left are swept by the next write into
//! the same folder once their process is gone and they are over an hour old.
//!
//! Outputs that belong together (a profile's JSON and CSV) are written as an
//! [`AtomicGroup`]: every file is staged first, then all are renamed under an
//! exclusive lock on their folders, so concurrent runs leave the files of one
//! run, never a mix.

use crate::error::{Error, Result};
use serde::{de::DeserializeOwned, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files of unfinished writes, removed on a terminating signal.
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live_temps() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE_TEMPS.lock().unwrap_or_else(|e| e.into_inner())
}

/// Registers a temporary file for the signal clean-up while it lives.
struct LiveTemp(PathBuf);

impl LiveTemp {
    fn new(path: &Path) -> LiveTemp {
        live_temps().push(path.to_path_buf());
        LiveTemp(path.to_path_buf())
    }
}

impl Drop for LiveTemp {
    fn drop(&mut self) {
        let mut l = live_temps();
        if let Some(i) = l.iter().position(|p| *p == self.0) {
            l.swap_remove(i);
        }
    }
}

/// Starts a thread that, on SIGINT, SIGTERM or SIGHUP, removes the temporary
/// files of unfinished writes and ends the process with 128 + the signal
/// number (what a shell reports for a process that signal ended). For
/// binaries; a library caller keeps its own signal handling.
#[cfg(unix)]
pub fn remove_temps_on_signals() -> Result<()> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
        .map_err(|e| Error::Unsupported(format!("cannot install signal handlers: {e}")))?;
    std::thread::Builder::new()
        .name("ssskit-signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let held = live_temps();
                for p in held.iter() {
                    let _ = std::fs::remove_file(p);
                }
                std::process::exit(128 + sig);
            }
        })
        .map_err(|e| Error::Unsupported(format!("cannot start the signal thread: {e}")))?;
    Ok(())
}

#[cfg(not(unix))]
pub fn remove_temps_on_signals() -> Result<()> {
    Ok(())
}

const TEMP_PREFIX: &str = ".ssskit-";
const TEMP_SUFFIX: &str = ".tmp";
/// Age after which a temporary file of a process that is gone is debris.
const STALE_AFTER: std::time::Duration = std::time::Duration::from_secs(3600);

/// The pid in a temporary file name of ours, `.ssskit-<pid>-<random>.tmp`.
fn temp_owner(name: &str) -> Option<u32> {
    let rest = name.strip_prefix(TEMP_PREFIX)?.strip_suffix(TEMP_SUFFIX)?;
    rest.split_once('-')?.0.parse().ok()
}

/// Removes our temporary files in `dir` whose process is gone (no
/// /proc/<pid>) and that are older than an hour (a process on another host
/// sharing the folder finishes its writes long before). Linux only; errors
/// are ignored: the sweep is a courtesy, never a reason to fail a write.
fn sweep_stale_temps(dir: &Path) {
    #[cfg(target_os = "linux")]
    {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let name = e.file_name();
            let Some(pid) = name.to_str().and_then(temp_owner) else {
                continue;
            };
            if Path::new(&format!("/proc/{pid}")).exists() {
                continue;
            }
            let old = e
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|age| age > STALE_AFTER);
            if old {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = dir;
}

/// A file written to its temporary name, synced, waiting to be renamed.
struct Staged {
    path: PathBuf,
    tmp: tempfile::NamedTempFile,
    _live: LiveTemp,
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn stage(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<Staged> {
    let dir = folder_of(path);
    sweep_stale_temps(dir);
    let mut tmp = tempfile::Builder::new()
        .prefix(&format!("{TEMP_PREFIX}{}-", std::process::id()))
        .suffix(TEMP_SUFFIX)
        .tempfile_in(dir)
        .map_err(|e| Error::io(dir, e))?;
    let live = LiveTemp::new(tmp.path());
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w).map_err(|e| Error::io(path, e))?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    set_default_permissions(tmp.as_file(), path)?;
    Ok(Staged {
        path: path.to_path_buf(),
        tmp,
        _live: live,
    })
}

impl Staged {
    fn persist(self) -> Result<()> {
        let Staged { path, tmp, _live } = self;
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
struct FolderLock {
    #[cfg(unix)]
    _file: std::fs::File,
}

impl FolderLock {
    #[cfg(unix)]
    fn new(dir: &Path) -> Result<FolderLock> {
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
    fn new(_dir: &Path) -> Result<FolderLock> {
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

/// Refuses an output path whose extension is not one of `allowed` (lower
/// case, without the dot): the format written is the one the name says, so
/// that ssskit and other tools read back what they expect. `what` names the
/// output in the error ("unknown image type").
pub fn check_extension(path: &Path, allowed: &[&str], what: &str) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if ext.as_deref().is_some_and(|e| allowed.contains(&e)) {
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

/// Serialises `value` as pretty JSON and writes it atomically.
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let mut g = AtomicGroup::new();
    g.add_json(path, value)?;
    g.commit()
}

/// Decodes a PNG within the caps: its size is checked from the header
/// before the pixels are read, and the decoder may not allocate more than
/// [`crate::limits::PNG_DECODE_BYTES`].
pub fn decode_png(path: &Path) -> Result<image::DynamicImage> {
    let reader = image::ImageReader::open(path).map_err(|e| Error::io(path, e))?;
    let reader = reader
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?;
    let (w, h) = reader
        .into_dimensions()
        .map_err(|e| Error::format(path, format!("unreadable PNG file: {e}")))?;
    crate::limits::check_image_size(&path.display().to_string(), w as usize, h as usize)?;
    let mut reader = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| Error::io(path, e))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(crate::limits::PNG_DECODE_BYTES);
    reader.limits(limits);
    reader
        .decode()
        .map_err(|e| Error::format(path, format!("unreadable PNG file: {e}")))
}

/// Reads a whole text file with the path in any error.
pub fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

/// Reads and parses a JSON file; parse errors carry line and column.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let text = read_text(path)?;
    serde_json::from_str(&text).map_err(|e| Error::format(path, format!("malformed JSON: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
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
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("k.json");
        write_atomic(&p, b"good").unwrap();
        let r = write_atomic_with(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "good");
    }
}
