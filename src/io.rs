//! File output that never leaves a half-written result behind: everything is
//! written to a temporary file in the destination folder, synced, then renamed
//! over the target (rename is atomic on one filesystem).
//!
//! Temporary files (and staged folders) are named `.ssskit-<pid>-<random>.tmp`.
//! Those of an unfinished write are removed when the process is ended by any
//! terminating signal a process can catch (once the binary calls
//! [`remove_temps_on_signals`]; SIGXFSZ, a file size limit, makes the write
//! fail with an error instead); those a killed process (SIGKILL, power loss)
//! left are swept by the next write into the same folder once their process
//! is gone and they are over an hour old.
//!
//! Outputs that belong together (a profile's JSON and CSV) are written as an
//! [`AtomicGroup`]: every file is staged first, then all are renamed under an
//! exclusive lock on their folders, so concurrent runs leave the files of one
//! run, never a mix. A folder of outputs is a [`StagedDir`]: written under a
//! temporary name, then swapped in as a whole.
//!
//! Names are labels, never paths: a file name made from a label (a
//! material's name) goes through [`file_stem`], and [`join_inside`] refuses
//! a name that would leave its folder.
//!
//! Inputs are read with a cap on their size ([`read_text_capped`],
//! [`read_json`]), counted while reading.

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
    /// Creates a temporary file or folder with `make` and registers it
    /// under one hold of the lock the signal thread takes: a signal finds
    /// the temporary either registered or not yet made (and then never
    /// made, since the handler exits holding the lock), never in between.
    fn create<T>(
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
fn remove_temp(p: &Path) {
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

/// The signals whose default action ends the process and that a process
/// may catch (SIGKILL and SIGSTOP cannot be; SIGSEGV, SIGBUS, SIGILL,
/// SIGFPE and SIGTRAP are faults of the process itself, SIGABRT its own
/// abort; SIGPIPE is ignored by Rust programs and a closed output is an
/// error there). SIGXFSZ is caught so that a write beyond the file size
/// limit fails (EFBIG) and is cleaned up like any failed write.
#[cfg(unix)]
pub const CLEANUP_SIGNALS: &[std::ffi::c_int] = {
    use libc::*;
    &[
        SIGHUP,
        SIGINT,
        SIGQUIT,
        SIGTERM,
        SIGUSR1,
        SIGUSR2,
        SIGALRM,
        SIGVTALRM,
        SIGPROF,
        SIGXCPU,
        SIGXFSZ,
        SIGIO,
        #[cfg(any(target_os = "linux", target_os = "android"))]
        SIGPWR,
        #[cfg(any(target_os = "linux", target_os = "android"))]
        SIGSTKFLT,
    ]
};

/// Starts a thread that, on any of [`CLEANUP_SIGNALS`] but SIGXFSZ, removes
/// the temporary files and staged folders of unfinished writes and ends the
/// process with 128 + the signal number (what a shell reports for a
/// process that signal ended). For binaries; a library caller keeps its own
/// signal handling.
#[cfg(unix)]
pub fn remove_temps_on_signals() -> Result<()> {
    use signal_hook::consts::SIGXFSZ;
    let mut signals = signal_hook::iterator::Signals::new(CLEANUP_SIGNALS)
        .map_err(|e| Error::Unsupported(format!("cannot install signal handlers: {e}")))?;
    std::thread::Builder::new()
        .name("ssskit-signals".into())
        .spawn(move || {
            for sig in signals.forever() {
                if sig == SIGXFSZ {
                    // The write that crossed the limit fails with EFBIG.
                    continue;
                }
                let held = live_temps();
                for p in held.iter() {
                    remove_temp(p);
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
                remove_temp(&e.path());
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

/// The builder of every temporary name of this process.
fn temp_builder<'a>(prefix: &'a str) -> tempfile::Builder<'a, 'static> {
    let mut b = tempfile::Builder::new();
    b.prefix(prefix).suffix(TEMP_SUFFIX);
    b
}

fn temp_prefix() -> String {
    format!("{TEMP_PREFIX}{}-", std::process::id())
}

/// Why a file cannot be created in `dir`, for the output `path`: the
/// folder and the reason, without the temporary name (an implementation
/// detail the user never asked for).
fn cannot_write(path: &Path, dir: &Path, e: &std::io::Error) -> Error {
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

/// Checks, before any work, that a file can be written at `path`: its
/// folder exists, is a folder and takes a new file (a temporary one is
/// created and removed: the only honest test of a permission), and `path`
/// is not a folder itself. `what` names the output ("--out", "profile").
pub fn check_output_file(path: &Path, what: &str) -> Result<()> {
    let named = |msg: String| Error::io(path, std::io::Error::other(format!("{what}: {msg}")));
    if path.as_os_str().is_empty() {
        return Err(named("an empty path names no file".into()));
    }
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        return Err(named("is a folder: give a file name".into()));
    }
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
    let prefix = temp_prefix();
    temp_builder(&prefix)
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| cannot_write(path, dir, &e))
}

/// Decodes a PNG within the caps: its size is checked from the header
/// before the pixels are read, and the decoder may not allocate more than
/// [`crate::limits::PNG_DECODE_BYTES`].
pub fn decode_png(path: &Path) -> Result<image::DynamicImage> {
    let open = || -> Result<_> {
        let file = std::io::BufReader::new(open_input(path)?);
        image::ImageReader::new(file)
            .with_guessed_format()
            .map_err(|e| Error::io(path, e))
    };
    let (w, h) = open()?
        .into_dimensions()
        .map_err(|e| Error::format(path, format!("unreadable PNG file: {e}")))?;
    crate::limits::check_image_size(&path.display().to_string(), w as usize, h as usize)?;
    let mut reader = open()?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(crate::limits::PNG_DECODE_BYTES);
    reader.limits(limits);
    reader
        .decode()
        .map_err(|e| Error::format(path, format!("unreadable PNG file: {e}")))
}

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

/// Opens an input for reading without waiting: a named pipe with no writer
/// reads as empty (an error about its content) instead of blocking the open
/// forever; a pipe with a writer (`/dev/stdin` from a shell) reads as usual.
pub fn open_input(path: &Path) -> Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| Error::io(path, e))?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        let fd = file.as_raw_fd();
        // SAFETY: fcntl on a descriptor we own; reads block again from here.
        unsafe {
            let flags = libc::fcntl(fd, libc::F_GETFL);
            if flags >= 0 {
                libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK);
            }
        }
    }
    Ok(file)
}

/// Reads at most `max` bytes of `path`, refusing a longer file: the count
/// is made while reading, so a device or a pipe (no length to check first)
/// is bounded too. `what` names the kind of file in the error ("material
/// TOML").
pub fn read_bytes_capped(path: &Path, max: u64, what: &str) -> Result<Vec<u8>> {
    use std::io::Read;
    let file = open_input(path)?;
    let mut bytes = Vec::new();
    file.take(max.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > max {
        return Err(too_large(path, max, what));
    }
    Ok(bytes)
}

fn too_large(path: &Path, max: u64, what: &str) -> Error {
    Error::format(
        path,
        format!(
            "larger than {} bytes ({:.0} MiB), the most a {what} may have: not read further",
            max,
            max as f64 / 1048576.0
        ),
    )
}

/// [`read_bytes_capped`] as UTF-8 text.
pub fn read_text_capped(path: &Path, max: u64, what: &str) -> Result<String> {
    let bytes = read_bytes_capped(path, max, what)?;
    String::from_utf8(bytes).map_err(|e| {
        Error::format(
            path,
            format!(
                "not UTF-8 text (byte {} of the {what}): not a text file",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// Reads a whole text file with the path in any error, at most
/// [`crate::limits::MAX_JSON_BYTES`].
pub fn read_text(path: &Path) -> Result<String> {
    read_text_capped(path, crate::limits::MAX_JSON_BYTES, "text file")
}

/// A reader that fails once more than `left` bytes were asked of it.
struct Capped<R> {
    inner: R,
    left: u64,
}

impl<R: std::io::Read> std::io::Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.left == 0 {
            // One byte more tells a file of exactly the cap from a longer one.
            let mut probe = [0u8; 1];
            return match self.inner.read(&mut probe)? {
                0 => Ok(0),
                _ => Err(std::io::Error::new(
                    std::io::ErrorKind::FileTooLarge,
                    "over the cap",
                )),
            };
        }
        let n = buf.len().min(self.left.min(usize::MAX as u64) as usize);
        let got = self.inner.read(&mut buf[..n])?;
        self.left -= got as u64;
        Ok(got)
    }
}

/// Parses a JSON file as it is read (a malformed one fails at its first bad
/// byte, without reading the rest), at most
/// [`crate::limits::MAX_JSON_BYTES`]; parse errors carry line and column.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let max = crate::limits::MAX_JSON_BYTES;
    let file = open_input(path)?;
    let reader = std::io::BufReader::with_capacity(
        1 << 16,
        Capped {
            inner: file,
            left: max,
        },
    );
    serde_json::from_reader(reader).map_err(|e| {
        if e.is_io() {
            let over = std::error::Error::source(&e)
                .and_then(|s| s.downcast_ref::<std::io::Error>())
                .is_some_and(|io| io.kind() == std::io::ErrorKind::FileTooLarge);
            if over || e.to_string().contains("over the cap") {
                return too_large(path, max, "JSON file");
            }
        }
        Error::format(path, format!("malformed JSON: {e}"))
    })
}

/// The marker file of a folder [`StagedDir`] wrote: a folder holding it is
/// one ssskit may replace as a whole.
pub const OUTPUT_MARKER: &str = ".ssskit-output";

/// A folder of outputs written under a temporary name next to its
/// destination (`.ssskit-<pid>-<random>.tmp`, removed on a signal or a
/// failure) and swapped in as a whole by [`StagedDir::commit`]: an
/// interrupted run leaves the previous folder as it was, never a mix of two
/// runs. The destination must be absent, empty, or a folder an earlier run
/// wrote (it holds [`OUTPUT_MARKER`]): a folder of other files is refused
/// before any work, since it would be replaced.
pub struct StagedDir {
    target: PathBuf,
    tmp: tempfile::TempDir,
    _live: LiveTemp,
}

impl StagedDir {
    /// Checks the destination and creates the staging folder (and the
    /// destination's parent folders): everything that can fail about the
    /// place fails here, before the work.
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
        let parent = folder_of(target);
        std::fs::create_dir_all(parent).map_err(|e| cannot_write(target, parent, &e))?;
        sweep_stale_temps(parent);
        let prefix = temp_prefix();
        let (tmp, live) =
            LiveTemp::create(|| temp_builder(&prefix).tempdir_in(parent), |t| t.path())
                .map_err(|e| cannot_write(target, parent, &e))?;
        Ok(StagedDir {
            target: target.to_path_buf(),
            tmp,
            _live: live,
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
    /// second rename fails); the old folder is then removed.
    pub fn commit(self) -> Result<()> {
        let StagedDir { target, tmp, _live } = self;
        write_atomic(
            &tmp.path().join(OUTPUT_MARKER),
            b"ssskit output folder: the next run writing here replaces it as a whole\n",
        )?;
        let parent = folder_of(&target).to_path_buf();
        let _lock = FolderLock::new(&parent)?;
        // Checked again under the lock: files may have appeared since.
        check_replaceable(&target)?;
        let staged = tmp.path().to_path_buf();
        let err = |e: std::io::Error| Error::io(&target, e);
        if std::fs::symlink_metadata(&target).is_err() {
            std::fs::rename(&staged, &target).map_err(err)?;
            // The staged path is gone; the TempDir must not remove the result.
            let _ = tmp.keep();
            return Ok(());
        }
        if exchange(&staged, &target).is_ok() {
            // `staged` now holds the old folder: TempDir removes it.
            drop(tmp);
            return Ok(());
        }
        let prefix = temp_prefix();
        let (aside, aside_live) =
            LiveTemp::create(|| temp_builder(&prefix).tempdir_in(&parent), |t| t.path())
                .map_err(|e| cannot_write(&target, &parent, &e))?;
        let aside_path = aside.path().to_path_buf();
        // An empty folder to rename over: rename replaces an empty folder.
        std::fs::rename(&target, &aside_path).map_err(err)?;
        if let Err(e) = std::fs::rename(&staged, &target) {
            let _ = std::fs::rename(&aside_path, &target);
            let _ = aside.keep();
            return Err(err(e));
        }
        let _ = tmp.keep();
        drop(aside);
        drop(aside_live);
        Ok(())
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
        (true, _) | (false, None) => Ok(()),
        (false, Some(f)) => Err(bad(format!(
            "the folder holds files no ssskit run wrote (e.g. '{f}'); the outputs replace the \
             folder as a whole: give a new or empty folder"
        ))),
    }
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

    #[test]
    fn capped_reads_refuse_what_is_over_the_cap() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.toml");
        std::fs::write(&p, "x".repeat(100)).unwrap();
        assert_eq!(read_text_capped(&p, 100, "t").unwrap().len(), 100);
        let e = read_text_capped(&p, 99, "material TOML")
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.toml") && e.contains("material TOML"), "{e}");
        #[cfg(unix)]
        {
            let e = read_text_capped(Path::new("/dev/zero"), 1000, "t")
                .unwrap_err()
                .to_string();
            assert!(e.contains("larger than 1000 bytes"), "{e}");
            let e = read_json::<serde_json::Value>(Path::new("/dev/zero"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("malformed JSON"), "{e}");
        }
        std::fs::write(&p, b"\xff\xfe").unwrap();
        let e = read_text_capped(&p, 100, "t").unwrap_err().to_string();
        assert!(e.contains("not UTF-8"), "{e}");
        // Exactly at the cap reads; one byte over does not.
        let j = dir.path().join("a.json");
        std::fs::write(&j, "[1, 2]").unwrap();
        let r = Capped {
            inner: std::fs::File::open(&j).unwrap(),
            left: 6,
        };
        let v: serde_json::Value = serde_json::from_reader(r).unwrap();
        assert_eq!(v, serde_json::json!([1, 2]));
        let r = Capped {
            inner: std::fs::File::open(&j).unwrap(),
            left: 5,
        };
        assert!(serde_json::from_reader::<_, serde_json::Value>(r).is_err());
    }

    #[test]
    fn staged_folders_replace_only_their_own_kind() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
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

    /// A named pipe nobody writes to is read as empty, not waited for.
    #[cfg(unix)]
    #[test]
    fn a_pipe_without_a_writer_does_not_block() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.json");
        let c = std::ffi::CString::new(p.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = read_json::<serde_json::Value>(&p).unwrap_err().to_string();
        assert!(e.contains("p.json") && e.contains("EOF"), "{e}");
        assert_eq!(read_text_capped(&p, 10, "t").unwrap(), "");
        let e = StagedDir::new(Path::new(".")).err().unwrap().to_string();
        assert!(e.contains("a name, not '.'"), "{e}");
        let cwd = std::env::current_dir().unwrap();
        let e = StagedDir::new(&cwd).err().unwrap().to_string();
        assert!(e.contains("working folder is inside it"), "{e}");
    }

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
