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

mod atomic;
mod check;
mod dest;
mod names;
mod read;
mod signals;
mod staged_dir;
mod temps;

pub use atomic::{write_atomic, write_atomic_with, write_json_atomic, AtomicGroup};
pub use check::{check_extension, check_output_file};
pub use dest::writes_in_place;
pub use names::{file_stem, join_inside};
pub use read::{
    decode_png, open_input, open_seekable_input, read_bytes_capped, read_json, read_text,
    read_text_capped, Input,
};
#[cfg(unix)]
pub use signals::CLEANUP_SIGNALS;
pub use signals::{exit, remove_temps_on_signals};
pub use staged_dir::StagedDir;
pub use temps::OUTPUT_MARKER;

/// A temporary folder and the path `name` inside it (not made): where a
/// unit test writes; the folder goes when the returned guard is dropped.
#[cfg(test)]
pub(crate) fn scratch(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    (dir, path)
}
