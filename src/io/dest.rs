//! What sits at an output path decides how it is written: nothing or a
//! regular file is replaced atomically (a temporary file renamed over it);
//! a character device or a named pipe (`/dev/stdout`, `/dev/null`, a
//! `mkfifo` pipe, or a symbolic link to one) is written in place, never
//! renamed over; a folder, a socket, a block device or a link to nothing is
//! refused. A symbolic link to a regular file is written through: the file
//! it names is replaced atomically and the link stays a link.

use super::read::open_without_waiting;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// How an output path is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Destination {
    /// Replaced atomically: a temporary file in this path's folder is
    /// renamed over it (the path itself, or the regular file a symbolic
    /// link resolves to).
    Replace(PathBuf),
    /// Opened for writing as it is (no temporary, no rename, no
    /// truncation): a character device or a named pipe.
    InPlace,
}

fn refuse(path: &Path, msg: &str) -> Error {
    Error::io(path, std::io::Error::other(msg.to_string()))
}

/// Looks at what exists at `path` (the link itself, then what it names).
pub(super) fn destination(path: &Path) -> Result<Destination> {
    let own = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok(Destination::Replace(path.to_path_buf()))
        }
        Err(e) => return Err(Error::io(path, e)),
    };
    let link = own.file_type().is_symlink();
    let meta = if link {
        std::fs::metadata(path).map_err(|_| {
            refuse(
                path,
                "is a symbolic link to nothing: give the file it should name, or remove the link",
            )
        })?
    } else {
        own
    };
    let ft = meta.file_type();
    if ft.is_dir() {
        return Err(refuse(path, "is a folder: give a file name"));
    }
    if ft.is_file() {
        // A link into /proc (`/dev/stdout` redirected to a file) names a
        // descriptor the shell opened: written in place, as `>` asked.
        if link && through_proc(path) {
            return Ok(Destination::InPlace);
        }
        return Ok(Destination::Replace(if link {
            path.canonicalize().map_err(|e| Error::io(path, e))?
        } else {
            path.to_path_buf()
        }));
    }
    special(path, &ft)
}

/// Whether an output at `path` would be written in place (a device or a
/// named pipe, or a link to one): such an output cannot be read back, nor
/// have a record beside it.
pub fn writes_in_place(path: &Path) -> bool {
    matches!(destination(path), Ok(Destination::InPlace))
}

#[cfg(unix)]
fn special(path: &Path, ft: &std::fs::FileType) -> Result<Destination> {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_char_device() || ft.is_fifo() {
        Ok(Destination::InPlace)
    } else if ft.is_socket() {
        Err(refuse(
            path,
            "is a socket: outputs go to files, character devices or named pipes",
        ))
    } else {
        Err(refuse(
            path,
            "is a block device: outputs go to files, character devices or named pipes",
        ))
    }
}

#[cfg(not(unix))]
fn special(path: &Path, _ft: &std::fs::FileType) -> Result<Destination> {
    Err(refuse(path, "is not a regular file: give a file name"))
}

/// Whether the chain of symbolic links from `path` passes through /proc.
fn through_proc(path: &Path) -> bool {
    // Links are followed at most this many times (Linux's own limit).
    const MAX_LINKS: usize = 40;
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let Ok(next) = std::fs::read_link(&p) else {
            return false;
        };
        let next = match p.parent() {
            Some(dir) if next.is_relative() => dir.join(next),
            _ => next,
        };
        if next.starts_with("/proc") {
            return true;
        }
        p = next;
    }
    false
}

/// Opens the device or pipe at `path` for writing without waiting: a named
/// pipe that no program has open for reading is refused at once (as an
/// input pipe with no writer reads as empty), so no call ever waits,
/// unbounded and uninterruptible, for a reader that may never come.
fn open_in_place(path: &Path) -> Result<std::fs::File> {
    open_without_waiting(std::fs::OpenOptions::new().write(true), path).map_err(|e| {
        #[cfg(unix)]
        if e.raw_os_error() == Some(libc::ENXIO) {
            return refuse(
                path,
                "is a named pipe that no program reads: start its reader first (an output \
                 is written to a pipe only while it is read, never waited for)",
            );
        }
        Error::io(path, e)
    })
}

/// Writes `fill`'s output into the device or pipe at `path` as it is:
/// first into an unnamed temporary file (writers such as OpenEXR's seek
/// back, which a pipe cannot), then copied; the device is opened only
/// once the whole output exists, so a failed fill sends it nothing.
pub(super) fn write_in_place(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<()> {
    use std::io::{Seek, Write};
    let io = |e| Error::io(path, e);
    let mut staged = tempfile::tempfile().map_err(io)?;
    {
        let mut w = std::io::BufWriter::new(&mut staged);
        fill(&mut w).map_err(io)?;
        w.flush().map_err(io)?;
    }
    staged.rewind().map_err(io)?;
    let mut file = open_in_place(path)?;
    std::io::copy(&mut staged, &mut file).map_err(io)?;
    file.flush().map_err(io)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn what_sits_at_the_path_decides() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let file = d.join("a.json");
        assert_eq!(
            destination(&file).unwrap(),
            Destination::Replace(file.clone())
        );
        std::fs::write(&file, "x").unwrap();
        assert_eq!(
            destination(&file).unwrap(),
            Destination::Replace(file.clone())
        );
        let link = d.join("l.json");
        std::os::unix::fs::symlink(&file, &link).unwrap();
        assert_eq!(
            destination(&link).unwrap(),
            Destination::Replace(file.canonicalize().unwrap())
        );
        assert_eq!(
            destination(Path::new("/dev/null")).unwrap(),
            Destination::InPlace
        );
        let e = destination(d).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        let dangling = d.join("gone.json");
        std::os::unix::fs::symlink(d.join("nothing"), &dangling).unwrap();
        let e = destination(&dangling).unwrap_err().to_string();
        assert!(e.contains("link to nothing"), "{e}");
        let sock = d.join("s.json");
        let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
        let e = destination(&sock).unwrap_err().to_string();
        assert!(e.contains("is a socket"), "{e}");
    }

    /// A named pipe with no reader is refused at once, not waited for
    /// (the write runs on a thread, so a wait fails the test instead of
    /// hanging it); with a reader, the output goes through the pipe.
    #[test]
    fn a_pipe_without_a_reader_is_refused_not_waited_for() {
        use std::io::{Read, Write};
        use std::os::unix::fs::OpenOptionsExt;
        // Far longer than a refused open takes, on any machine.
        const NO_WAIT: std::time::Duration = std::time::Duration::from_secs(10);
        let (_dir, fifo) = crate::io::scratch("out.json");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let (tx, rx) = std::sync::mpsc::channel();
        let p = fifo.clone();
        std::thread::spawn(move || {
            let r = write_in_place(&p, |w| w.write_all(b"{}"));
            let _ = tx.send(r.map_err(|e| e.to_string()));
        });
        let e = rx
            .recv_timeout(NO_WAIT)
            .expect("the write waited for a reader")
            .unwrap_err();
        assert!(
            e.contains("out.json") && e.contains("no program reads"),
            "{e}"
        );
        let mut reader = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(&fifo)
            .unwrap();
        write_in_place(&fifo, |w| w.write_all(b"{\"a\": 1}")).unwrap();
        let mut got = String::new();
        reader.read_to_string(&mut got).unwrap();
        assert_eq!(got, "{\"a\": 1}");
    }
}
