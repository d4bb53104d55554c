//! Temporary files and staged folders of unfinished writes: their names
//! (`.ssskit-<pid>-<random>.tmp`), the registry of the live ones (which the
//! signal clean-up removes), and the sweep of those a killed process left.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files of unfinished writes, removed on a terminating signal.
/// The one lock of the clean-up: the signal thread holds it from the first
/// removal to the end of the process, and every change of what a
/// registered path holds (a staged folder swapped in) is made under it, so
/// a removal never meets a swap half-way.
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

pub(super) fn live_temps() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE_TEMPS.lock().unwrap_or_else(|e| e.into_inner())
}

/// Held by the tests that hold the clean-up's lock for a while (a pause
/// at a dangerous moment), so that one's pause never delays another's.
#[cfg(test)]
pub(super) static LONG_HOLDS: Mutex<()> = Mutex::new(());

#[cfg(test)]
pub(super) fn long_hold() -> std::sync::MutexGuard<'static, ()> {
    LONG_HOLDS.lock().unwrap_or_else(|e| e.into_inner())
}

/// Registers a temporary file for the signal clean-up while it lives.
pub(super) struct LiveTemp(PathBuf);

impl LiveTemp {
    /// Creates a temporary file or folder with `make` and registers it
    /// under one hold of the lock the signal thread takes: a signal finds
    /// the temporary either registered or not yet made (and then never
    /// made, since the handler exits holding the lock), never in between.
    pub(super) fn create<T>(
        make: impl FnOnce() -> std::io::Result<T>,
        path_of: impl Fn(&T) -> &Path,
    ) -> std::io::Result<(T, LiveTemp)> {
        let mut held = live_temps();
        let made = make()?;
        let path = path_of(&made).to_path_buf();
        held.push(path.clone());
        Ok((made, LiveTemp(path)))
    }

    /// Unregisters the temporary under a hold of the lock the caller
    /// already has (its path now names a result, not debris).
    pub(super) fn forget_in(self, held: &mut Vec<PathBuf>) {
        unregister(held, &self.0);
        std::mem::forget(self);
    }
}

fn unregister(held: &mut Vec<PathBuf>, p: &Path) {
    if let Some(i) = held.iter().position(|q| q == p) {
        held.swap_remove(i);
    }
}

impl Drop for LiveTemp {
    fn drop(&mut self) {
        unregister(&mut live_temps(), &self.0);
    }
}

/// Removes every registered temporary that `mine` accepts (the signal
/// thread: all of them), under the caller's hold of the lock.
/// `after_entry` is called after each top-level entry of a folder is
/// removed (tests pause there).
pub(super) fn remove_registered(
    held: &mut [PathBuf],
    mine: impl Fn(&Path) -> bool,
    after_entry: &dyn Fn(&Path),
) {
    for p in held.iter().filter(|p| mine(p)) {
        remove_temp_with(p, after_entry);
    }
}

/// Passes over a staged folder before its removal is given up: the main
/// thread goes on writing into it while the signal thread removes it (a
/// file renamed into place, a subfolder made) and a pass that lists the
/// folder before such an entry appears finds it not empty at the end. New
/// temporary files cannot appear meanwhile (their registration waits for
/// the lock the clean-up holds), so the entries that can are a handful.
const REMOVE_PASSES: usize = 16;

/// Removes a registered temporary file or staged folder.
pub(super) fn remove_temp(p: &Path) {
    remove_temp_with(p, &|_| {});
}

fn remove_temp_with(p: &Path, after_entry: &dyn Fn(&Path)) {
    match std::fs::symlink_metadata(p) {
        Ok(m) if m.is_dir() => {
            for _ in 0..REMOVE_PASSES {
                if remove_folder(p, after_entry).is_ok() {
                    return;
                }
            }
        }
        Ok(_) => {
            let _ = std::fs::remove_file(p);
        }
        Err(_) => {}
    }
}

/// One pass: the entries listed, each removed (a subfolder by
/// `remove_dir_all`, which never follows a link), then the folder.
fn remove_folder(p: &Path, after_entry: &dyn Fn(&Path)) -> std::io::Result<()> {
    let gone = |r: std::io::Result<()>| match r {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    };
    let entries: Vec<std::fs::DirEntry> = match std::fs::read_dir(p) {
        Ok(rd) => rd.flatten().collect(),
        Err(e) => return gone(Err(e)),
    };
    for e in entries {
        let path = e.path();
        if e.file_type().is_ok_and(|t| t.is_dir()) {
            let _ = gone(std::fs::remove_dir_all(&path));
        } else {
            let _ = gone(std::fs::remove_file(&path));
        }
        after_entry(&path);
    }
    gone(std::fs::remove_dir(p))
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

/// The marker file of a folder a staged output wrote: a folder holding it is
/// one ssskit may replace as a whole.
pub const OUTPUT_MARKER: &str = ".ssskit-output";

/// Whether a temporary folder holds a whole output (its marker): written
/// at the commit, so such a folder is a run's finished output or the
/// previous one moved aside, which a process killed (SIGKILL, power loss)
/// between the two renames of a swap without an atomic exchange left
/// while the destination was missing: then it is the only copy, kept.
fn holds_an_output(p: &Path) -> bool {
    p.join(OUTPUT_MARKER).is_file()
}

/// Removes our temporary files in `dir` whose process is gone (no
/// /proc/<pid>) and that are older than an hour (a process on another host
/// sharing the folder finishes its writes long before), except a folder
/// holding a whole output ([`holds_an_output`]). Linux only; errors are
/// ignored: the sweep is a courtesy, never a reason to fail a write.
pub(super) fn sweep_stale_temps(dir: &Path) {
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
            if old && !holds_an_output(&e.path()) {
                remove_temp(&e.path());
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = dir;
}

/// The builder of every temporary name of this process.
pub(super) fn temp_builder<'a>(prefix: &'a str) -> tempfile::Builder<'a, 'static> {
    let mut b = tempfile::Builder::new();
    b.prefix(prefix).suffix(TEMP_SUFFIX);
    b
}

pub(super) fn temp_prefix() -> String {
    format!("{TEMP_PREFIX}{}-", std::process::id())
}
