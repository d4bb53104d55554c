//! Bounded reads of inputs: a cap on the bytes, counted while reading (a
//! device or a pipe has no length to check first), and opens that never
//! wait on a pipe without a writer.

use crate::error::{Error, Result};
use serde::de::DeserializeOwned;
use std::path::Path;

/// An input opened by [`open_input`]: a file, with the byte a probe of a
/// pipe read first given back before the rest.
pub struct Input {
    file: std::fs::File,
    first: Option<u8>,
}

impl std::io::Read for Input {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match (self.first.take(), buf.is_empty()) {
            (Some(b), false) => {
                buf[0] = b;
                Ok(1)
            }
            (first, _) => {
                self.first = first;
                self.file.read(buf)
            }
        }
    }
}

impl std::io::Seek for Input {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        if self.first.is_some() {
            return Err(std::io::Error::other("a pipe cannot seek"));
        }
        self.file.seek(pos)
    }
}

fn refuse(path: &Path, msg: &str) -> Error {
    Error::io(path, std::io::Error::other(msg.to_string()))
}

/// Refuses, by what it is, an input that is not a regular file and cannot
/// be read as one (as outputs are refused by what sits at their path): a
/// folder, a device, a socket; and, where `seekable` (images are read
/// twice, their headers first), a pipe.
fn check_input_kind(path: &Path, seekable: bool) -> Result<()> {
    let Ok(meta) = std::fs::metadata(path) else {
        // The open says why.
        return Ok(());
    };
    let ft = meta.file_type();
    if ft.is_file() {
        return Ok(());
    }
    if ft.is_dir() {
        return Err(refuse(path, "is a folder: give a file"));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return if seekable {
                Err(refuse(
                    path,
                    "is a pipe: an image is read twice (its headers, then its pixels), so it \
                     must be a regular file",
                ))
            } else {
                Ok(())
            };
        }
        let what = if ft.is_socket() {
            "a socket"
        } else if ft.is_block_device() {
            "a block device"
        } else {
            "a device (a terminal, /dev/null, /dev/zero, ...)"
        };
        return Err(refuse(
            path,
            &format!("is {what}, not a file: give a regular file (or a pipe with a writer)"),
        ));
    }
    #[allow(unreachable_code)]
    Ok(())
}

/// Opens an input for reading without waiting: a named pipe with no writer
/// is refused as such (it would read as empty) instead of blocking the open
/// forever; a pipe with a writer (`/dev/stdin` from a shell) reads as usual.
/// Folders, devices and sockets are refused by what they are.
pub fn open_input(path: &Path) -> Result<Input> {
    open_checked(path, false)
}

/// [`open_input`] for a file read with seeks (an image): a regular file
/// only.
pub fn open_seekable_input(path: &Path) -> Result<Input> {
    open_checked(path, true)
}

fn open_checked(path: &Path, seekable: bool) -> Result<Input> {
    check_input_kind(path, seekable)?;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| Error::io(path, e))?;
    #[allow(unused_mut)]
    let mut input = Input { file, first: None };
    #[cfg(unix)]
    {
        use std::io::Read;
        use std::os::fd::AsRawFd;
        let is_pipe = input
            .file
            .metadata()
            .is_ok_and(|m| std::os::unix::fs::FileTypeExt::is_fifo(&m.file_type()));
        if is_pipe {
            // Without a writer a non-blocking read ends at once (0 bytes);
            // with one it has a byte or would wait.
            let mut b = [0u8; 1];
            match input.file.read(&mut b) {
                Ok(0) => {
                    return Err(refuse(
                        path,
                        "is a pipe that nothing writes to (and nothing is in it): give a regular \
                         file, or start the writer first",
                    ))
                }
                Ok(_) => input.first = Some(b[0]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                Err(e) => return Err(Error::io(path, e)),
            }
        }
        clear_nonblock(input.file.as_raw_fd());
    }
    Ok(input)
}

/// Clears O_NONBLOCK on a descriptor opened with it: reads and writes block
/// again as usual.
#[cfg(unix)]
fn clear_nonblock(fd: std::os::fd::RawFd) {
    // SAFETY: fcntl on a descriptor the caller owns.
    unsafe {
        let flags = libc::fcntl(fd, libc::F_GETFL);
        if flags >= 0 {
            libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK);
        }
    }
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
    clear_nonblock(std::os::fd::AsRawFd::as_raw_fd(&file));
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
    serde_json::from_reader(capped_json(open_input(path)?)).map_err(|e| {
        if e.is_io() {
            let over = std::error::Error::source(&e)
                .and_then(|s| s.downcast_ref::<std::io::Error>())
                .is_some_and(|io| io.kind() == std::io::ErrorKind::FileTooLarge);
            if over || e.to_string().contains("over the cap") {
                return too_large(path, max, "JSON file");
            }
        }
        // serde_json says "trailing characters" both after the document
        // and in an array longer than the field it fills; the document
        // read again without a type (nothing kept) tells them apart.
        let well_formed = || {
            open_input(path).is_ok_and(|f| {
                serde_json::from_reader::<_, serde::de::IgnoredAny>(capped_json(f)).is_ok()
            })
        };
        if e.to_string().starts_with("trailing characters") && well_formed() {
            return Error::format(
                path,
                format!(
                    "line {} column {}: this array has more entries than its field takes (a \
                     row of 4 numbers where [r, g, b] takes 3?)",
                    e.line(),
                    e.column()
                ),
            );
        }
        Error::format(path, format!("malformed JSON: {e}"))
    })
}

/// A JSON input read through a buffer, failing past
/// [`crate::limits::MAX_JSON_BYTES`].
fn capped_json(file: Input) -> std::io::BufReader<Capped<Input>> {
    std::io::BufReader::with_capacity(
        1 << 16,
        Capped {
            inner: file,
            left: crate::limits::MAX_JSON_BYTES,
        },
    )
}

/// Decodes a PNG within the caps: its size is checked from the header
/// before the pixels are read, and the decoder may not allocate more than
/// [`crate::limits::PNG_DECODE_BYTES`].
pub fn decode_png(path: &Path) -> Result<image::DynamicImage> {
    let open = || -> Result<_> {
        let file = std::io::BufReader::new(open_seekable_input(path)?);
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
        let (dir, p) = crate::io::scratch("m.toml");
        std::fs::write(&p, "x".repeat(100)).unwrap();
        assert_eq!(read_text_capped(&p, 100, "t").unwrap().len(), 100);
        let e = read_text_capped(&p, 99, "material TOML")
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.toml") && e.contains("material TOML"), "{e}");
        #[cfg(unix)]
        {
            // A device is refused by what it is (it would read forever, or
            // as empty); a folder too.
            for dev in ["/dev/zero", "/dev/null"] {
                let e = read_text_capped(Path::new(dev), 1000, "t")
                    .unwrap_err()
                    .to_string();
                assert!(e.contains(dev) && e.contains("is a device"), "{e}");
            }
            let e = read_json::<serde_json::Value>(dir.path())
                .unwrap_err()
                .to_string();
            assert!(e.contains("is a folder"), "{e}");
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

    /// A named pipe nobody writes to is refused as such, not waited for
    /// nor read as empty; one with a writer is read whole, its first byte
    /// (read to see whether there is a writer) included; an image from a
    /// pipe is refused (it is read twice).
    #[cfg(unix)]
    #[test]
    fn a_pipe_without_a_writer_does_not_block() {
        let (_dir, p) = crate::io::scratch("p.json");
        let c = std::ffi::CString::new(p.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = read_json::<serde_json::Value>(&p).unwrap_err().to_string();
        assert!(
            e.contains("p.json") && e.contains("nothing writes to"),
            "{e}"
        );
        let e = read_text_capped(&p, 10, "t").unwrap_err().to_string();
        assert!(e.contains("nothing writes to"), "{e}");
        let e = decode_png(&p).unwrap_err().to_string();
        assert!(e.contains("p.json") && e.contains("regular file"), "{e}");
        let writer = {
            let p = p.clone();
            // A reader that gave up between the writer's open and its
            // write makes the write fail (a broken pipe): write again.
            std::thread::spawn(move || while std::fs::write(&p, "[1, 2]").is_err() {})
        };
        // The writer's open waits for a reader: keep trying until it is in.
        let start = std::time::Instant::now();
        let v = loop {
            match read_json::<serde_json::Value>(&p) {
                Ok(v) => break v,
                Err(_) if start.elapsed() < std::time::Duration::from_secs(60) => {
                    std::thread::sleep(std::time::Duration::from_millis(5))
                }
                Err(e) => panic!("{e}"),
            }
        };
        writer.join().unwrap();
        assert_eq!(v, serde_json::json!([1, 2]));
        let e = StagedDir::new(Path::new(".")).err().unwrap().to_string();
        assert!(e.contains("a name, not '.'"), "{e}");
        let cwd = std::env::current_dir().unwrap();
        let e = StagedDir::new(&cwd).err().unwrap().to_string();
        assert!(e.contains("working folder is inside it"), "{e}");
    }
}
