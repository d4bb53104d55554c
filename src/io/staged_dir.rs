//! A folder of outputs written under a temporary name and swapped in as a
//! whole ([`StagedDir`]).

use super::atomic::{cannot_write, folder_of, write_atomic, FolderLock};
use super::temps::{
    live_temps, sweep_stale_temps, temp_builder, temp_prefix, LiveTemp, OUTPUT_MARKER,
};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// A folder of outputs written under a temporary name
/// (`.ssskit-<pid>-<random>.tmp`, removed on a signal or a failure) and
/// swapped in as a whole by [`StagedDir::commit`]: an interrupted run
/// leaves the previous folder as it was, never a mix of two runs. The
/// destination must be absent, empty, or a folder an earlier run wrote (it
/// holds [`OUTPUT_MARKER`]): a folder of other files is refused before any
/// work, since it would be replaced. Missing parent folders of the
/// destination are made at the commit only: the staging folder waits in the
/// nearest folder that exists, so a run that fails makes none.
pub struct StagedDir {
    target: PathBuf,
    tmp: tempfile::TempDir,
    live: LiveTemp,
}

impl StagedDir {
    /// Checks the destination and creates the staging folder: everything
    /// that can fail about the place fails here, before the work.
    pub fn new(target: &Path) -> Result<StagedDir> {
        use std::path::Component;
        let bad = |msg: &str| Error::io(target, std::io::Error::other(msg.to_string()));
        if !matches!(target.components().next_back(), Some(Component::Normal(_))) {
            return Err(bad(
                "give the outputs a folder of their own (a name, not '.', '..' or '/'): it is \
                 replaced as a whole",
            ));
        }
        let inside = std::env::current_dir()
            .and_then(|cwd| cwd.canonicalize())
            .ok()
            .zip(target.canonicalize().ok())
            .is_some_and(|(cwd, t)| cwd.starts_with(t));
        if inside {
            return Err(bad(
                "the working folder is inside it, and the outputs replace it as a whole: give \
                 another folder",
            ));
        }
        check_replaceable(target)?;
        let home = nearest_folder(target)?;
        sweep_stale_temps(&home);
        let prefix = temp_prefix();
        let (tmp, live) =
            LiveTemp::create(|| temp_builder(&prefix).tempdir_in(&home), |t| t.path())
                .map_err(|e| cannot_write(target, &home, &e))?;
        Ok(StagedDir {
            target: target.to_path_buf(),
            tmp,
            live,
        })
    }

    /// Where the outputs are written until the commit.
    pub fn path(&self) -> &Path {
        self.tmp.path()
    }

    /// The destination.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Marks the staged folder as ssskit's and swaps it in for the
    /// destination (atomically where the system can exchange two names;
    /// otherwise the old folder is moved aside first and restored if the
    /// second rename fails); the old folder is then removed. The swap and
    /// the registry of temporaries change together under the lock the
    /// signal clean-up takes: a signal during the swap waits for it, then
    /// removes the old folder only.
    pub fn commit(self) -> Result<()> {
        let StagedDir { target, tmp, live } = self;
        write_atomic(
            &tmp.path().join(OUTPUT_MARKER),
            b"ssskit output folder: the next run writing here replaces it as a whole\n",
        )?;
        let parent = folder_of(&target).to_path_buf();
        let home = folder_of(tmp.path()).to_path_buf();
        let _lock = FolderLock::new(&home)?;
        // Checked again under the lock: files may have appeared since.
        check_replaceable(&target)?;
        let err = |e: std::io::Error| Error::io(&target, e);
        // An empty folder to move the old one into where there is no
        // exchange (made now: its registration takes the lock held below).
        let aside = match std::fs::symlink_metadata(&target) {
            Ok(_) => Some(
                LiveTemp::create(
                    || temp_builder(&temp_prefix()).tempdir_in(&parent),
                    |t| t.path(),
                )
                .map_err(|e| cannot_write(&target, &parent, &e))?,
            ),
            Err(_) => None,
        };
        hooks::at(hooks::Point::Swapping);
        let mut held = live_temps();
        let swapped = swap(
            tmp.path(),
            &target,
            &parent,
            aside.as_ref().map(|a| a.0.path()),
        );
        let how = swapped.map_err(err)?;
        if how != Swap::Exchanged {
            // The staged folder is the destination now: no longer debris.
            live.forget_in(&mut held);
        }
        drop(held);
        // The old folder is removed (at the staged path after an exchange,
        // in `aside` after two renames), then unregistered.
        match how {
            Swap::Exchanged => drop(tmp),
            _ => {
                let _ = tmp.keep();
            }
        }
        drop(aside);
        Ok(())
    }
}

/// How [`swap`] put the staged folder in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Swap {
    /// Renamed to the destination, which did not exist.
    Renamed,
    /// Exchanged with the old folder, now at the staged path.
    Exchanged,
    /// Renamed after the old folder was moved aside.
    MovedAside,
}

/// Puts `staged` at `target`: a rename (making the missing parent folders)
/// where nothing is there, else an atomic exchange, else the old folder
/// renamed to `aside` (an empty folder) and the staged one to `target`,
/// the old folder put back if that fails. The caller holds the clean-up's
/// lock: a signal cannot fall between the two renames.
fn swap(
    staged: &Path,
    target: &Path,
    parent: &Path,
    aside: Option<&Path>,
) -> std::io::Result<Swap> {
    let Some(aside) = aside else {
        std::fs::create_dir_all(parent)?;
        std::fs::rename(staged, target)?;
        return Ok(Swap::Renamed);
    };
    if !hooks::no_exchange() && exchange(staged, target).is_ok() {
        return Ok(Swap::Exchanged);
    }
    std::fs::rename(target, aside)?;
    hooks::at(hooks::Point::BetweenRenames);
    if let Err(e) = std::fs::rename(staged, target) {
        let _ = std::fs::rename(aside, target);
        return Err(e);
    }
    Ok(Swap::MovedAside)
}

/// The folder the staging folder of `target` is made in: its parent, or
/// the nearest of the parent's ancestors that exists (the missing ones are
/// made at the commit); refused when that is not a folder.
fn nearest_folder(target: &Path) -> Result<PathBuf> {
    let parent = folder_of(target);
    let found = parent
        .ancestors()
        .map(|a| {
            if a.as_os_str().is_empty() {
                Path::new(".")
            } else {
                a
            }
        })
        .find_map(|a| std::fs::metadata(a).ok().map(|m| (a, m)));
    match found {
        Some((a, m)) if m.is_dir() => Ok(a.to_path_buf()),
        Some((a, _)) => Err(Error::io(
            target,
            std::io::Error::other(format!(
                "cannot write in folder '{}': '{}' is not a folder",
                parent.display(),
                a.display()
            )),
        )),
        None => Err(cannot_write(
            target,
            parent,
            &std::io::Error::from(std::io::ErrorKind::NotFound),
        )),
    }
}

/// Pauses of the commit that tests hold at the dangerous moments
/// (`staged_dir_tests.rs`); nothing outside test builds.
pub(super) mod hooks {
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Point {
        /// Before the clean-up's lock is taken for the swap.
        Swapping,
        /// Without an exchange: the old folder moved aside, the staged
        /// one not yet in place.
        BetweenRenames,
    }

    /// What a test runs at each point.
    #[cfg(test)]
    pub type Hook = Box<dyn Fn(Point)>;

    #[cfg(test)]
    thread_local! {
        pub static ON: std::cell::RefCell<Option<Hook>> =
            const { std::cell::RefCell::new(None) };
        pub static NO_EXCHANGE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }

    pub fn at(p: Point) {
        #[cfg(test)]
        ON.with(|h| {
            if let Some(f) = &*h.borrow() {
                f(p)
            }
        });
        let _ = p;
    }

    /// Whether the commit is to go without the atomic exchange (the
    /// systems and filesystems that lack it).
    pub fn no_exchange() -> bool {
        #[cfg(test)]
        return NO_EXCHANGE.with(|n| n.get());
        #[cfg(not(test))]
        false
    }
}

/// Refuses a destination folder that is a file, or a folder of files that
/// no ssskit run wrote.
fn check_replaceable(target: &Path) -> Result<()> {
    let bad = |msg: String| Error::io(target, std::io::Error::other(msg));
    let meta = match std::fs::symlink_metadata(target) {
        Ok(m) => m,
        Err(_) => return Ok(()),
    };
    if !meta.is_dir() {
        return Err(bad(
            "exists and is not a folder: give a new folder for the outputs".into(),
        ));
    }
    let entries = std::fs::read_dir(target).map_err(|e| Error::io(target, e))?;
    let mut first_other = None;
    let mut ours = false;
    for e in entries.flatten() {
        let name = e.file_name();
        if name == OUTPUT_MARKER {
            ours = true;
        } else if first_other.is_none() {
            first_other = Some(name.to_string_lossy().into_owned());
        }
    }
    match (ours, first_other) {
        (true, _) => no_special_files(target, 0),
        (false, None) => Ok(()),
        (false, Some(f)) => Err(bad(format!(
            "the folder holds files no ssskit run wrote (e.g. '{f}'); the outputs replace the \
             folder as a whole: give a new or empty folder"
        ))),
    }
}

/// Refuses a folder to be replaced that holds a device, a named pipe or a
/// socket anywhere below it (no ssskit run writes one; someone put it
/// there, and the swap would remove it).
fn no_special_files(dir: &Path, depth: usize) -> Result<()> {
    // Folders ssskit writes are at most two deep (`kernels/`); deeper ones
    // are looked at a little further, then trusted.
    const MAX_DEPTH: usize = 8;
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    for e in entries.flatten() {
        let Ok(ft) = e.file_type() else { continue };
        if ft.is_dir() {
            if depth < MAX_DEPTH {
                no_special_files(&e.path(), depth + 1)?;
            }
        } else if !ft.is_file() && !ft.is_symlink() {
            return Err(Error::io(
                e.path(),
                std::io::Error::other(
                    "a device, named pipe or socket in an output folder that would be replaced \
                     as a whole: move it, or give another folder",
                ),
            ));
        }
    }
    Ok(())
}

/// Exchanges two paths atomically (Linux renameat2 RENAME_EXCHANGE).
#[cfg(any(target_os = "linux", target_os = "android"))]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| {
        std::ffi::CString::new(p.as_os_str().as_bytes())
            .map_err(|_| std::io::Error::from(std::io::ErrorKind::InvalidInput))
    };
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: two NUL-terminated paths that live across the call.
    let r = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

#[cfg(not(any(target_os = "linux", target_os = "android")))]
fn exchange(_a: &Path, _b: &Path) -> std::io::Result<()> {
    Err(std::io::Error::from(std::io::ErrorKind::Unsupported))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staged_folders_replace_only_their_own_kind() {
        let (dir, out) = crate::io::scratch("run");
        let s = StagedDir::new(&out).unwrap();
        write_atomic(&s.path().join("a.txt"), b"1").unwrap();
        assert!(!out.exists(), "nothing is in place before the commit");
        s.commit().unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a.txt")).unwrap(), "1");
        assert!(out.join(OUTPUT_MARKER).exists());
        // A second run replaces the folder as a whole: a.txt goes.
        let s = StagedDir::new(&out).unwrap();
        write_atomic(&s.path().join("b.txt"), b"2").unwrap();
        s.commit().unwrap();
        assert!(!out.join("a.txt").exists() && out.join("b.txt").exists());
        // A failed run (dropped before the commit) leaves the last one.
        let s = StagedDir::new(&out).unwrap();
        write_atomic(&s.path().join("c.txt"), b"3").unwrap();
        drop(s);
        assert!(out.join("b.txt").exists() && !out.join("c.txt").exists());
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "staging folders left behind");
        // Someone else's folder, or a file, is refused before any work.
        let theirs = dir.path().join("theirs");
        std::fs::create_dir(&theirs).unwrap();
        std::fs::write(theirs.join("notes.txt"), "keep").unwrap();
        let e = StagedDir::new(&theirs).err().unwrap().to_string();
        assert!(
            e.contains("notes.txt") && e.contains("new or empty folder"),
            "{e}"
        );
        let e = StagedDir::new(&theirs.join("notes.txt"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("not a folder"), "{e}");
        // An empty folder is taken.
        let empty = dir.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        StagedDir::new(&empty).unwrap().commit().unwrap();
        assert!(empty.join(OUTPUT_MARKER).exists());
    }
}

#[cfg(test)]
#[path = "staged_dir_tests.rs"]
mod race_tests;
