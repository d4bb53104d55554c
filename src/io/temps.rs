//! Temporary files and staged folders of unfinished writes: their names
//! (`.ssskit-<pid>-<random>.tmp`), the registry of the live ones (which the
//! signal clean-up removes), and the sweep of those a killed process left.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files of unfinished writes, removed on a terminating signal.
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

pub(super) fn live_temps() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE_TEMPS.lock().unwrap_or_else(|e| e.into_inner())
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
}

impl Drop for LiveTemp {
    fn drop(&mut self) {
        let mut l = live_temps();
        if let Some(i) = l.iter().position(|p| *p == self.0) {
            l.swap_remove(i);
        }
    }
}

/// Removes a registered temporary file or staged folder.
pub(super) fn remove_temp(p: &Path) {
    match std::fs::symlink_metadata(p) {
        Ok(m) if m.is_dir() => {
            let _ = std::fs::remove_dir_all(p);
        }
        Ok(_) => {
            let _ = std::fs::remove_file(p);
        }
        Err(_) => {}
    }
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
            if old {
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
