//! Bounded reads of inputs: a cap on the bytes, counted while reading (a
//! device or a pipe has no length to check first), and opens that never
//! wait on a pipe without a writer.

use crate::error::{Error, Result};
use serde::de::DeserializeOwned;
use std::path::Path;

/// Opens an input for reading without waiting: a named pipe with no writer
/// reads as empty (an error about its content) instead of blocking the open
/// forever; a pipe with a writer (`/dev/stdin` from a shell) reads as usual.
pub fn open_input(path: &Path) -> Result<std::fs::File> {
    open_without_waiting(std::fs::OpenOptions::new().read(true), path)
        .map_err(|e| Error::io(path, e))
}

/// Opens `path` with `options` and O_NONBLOCK, then clears O_NONBLOCK:
/// the open itself never waits on a named pipe (for its writer, or for its
/// reader: then it fails with ENXIO), and reads and writes block again as
/// usual. Elsewhere than Unix, a plain open.
pub(super) fn open_without_waiting(
    options: &mut std::fs::OpenOptions,
    path: &Path,
) -> std::io::Result<std::fs::File> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path)?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        let fd = file.as_raw_fd();
        // SAFETY: fcntl on a descriptor we own; reads and writes block
        // again from here.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::StagedDir;

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
}
