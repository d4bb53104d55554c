//! Standard output that never panics. `println!` panics when stdout fails:
//! `ssskit materials | head -1` (the reader closed the pipe) or `> /dev/full`
//! (the disk is full). Subcommands print with [`outln!`] / [`out!`], which
//! return an error instead: a closed pipe ends the process quietly with
//! status [`BROKEN_PIPE_EXIT`] (141, what a shell reports for a tool that
//! SIGPIPE ended, so `set -o pipefail` scripts see the usual status), any
//! other failure is an error naming standard output (status 2).
//!
//! Usage: `use super::out::outln;` then `outln!("{x} {y}")?;` in a function
//! returning `anyhow::Result`.

use std::io::Write;

/// Exit status when the reader of standard output has gone: 128 + SIGPIPE.
pub const BROKEN_PIPE_EXIT: i32 = 141;

/// The reader of standard output closed it: not an error worth a message.
#[derive(Debug)]
pub struct StdoutClosed;

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output was closed by its reader")
    }
}

impl std::error::Error for StdoutClosed {}

pub fn map_err(e: std::io::Error) -> anyhow::Error {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        anyhow::Error::new(StdoutClosed)
    } else {
        anyhow::anyhow!("writing to standard output: {e}")
    }
}

/// Writes `args` to standard output (what [`outln!`] and [`out!`] call).
pub fn write_fmt(args: std::fmt::Arguments) -> anyhow::Result<()> {
    std::io::stdout().lock().write_fmt(args).map_err(map_err)
}

/// Flushes standard output: a full disk can surface only here.
pub fn flush() -> anyhow::Result<()> {
    std::io::stdout().lock().flush().map_err(map_err)
}

/// The exit status for an error that ended a subcommand, or None when the
/// error is an ordinary one (print it, exit 2).
pub fn quiet_exit(e: &anyhow::Error) -> Option<i32> {
    e.downcast_ref::<StdoutClosed>().map(|_| BROKEN_PIPE_EXIT)
}

/// Last resort for a `println!`/`eprintln!` left somewhere: their panic on
/// a failed write becomes the same quiet exit or one-line error, never a
/// backtrace.
pub fn install_panic_hook() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if let Some(rest) = msg.strip_prefix("failed printing to ") {
            if rest.contains("Broken pipe") {
                std::process::exit(BROKEN_PIPE_EXIT);
            }
            if rest.starts_with("stdout") {
                let _ = writeln!(
                    std::io::stderr(),
                    "error: writing to standard output: {}",
                    rest.trim_start_matches("stdout: ")
                );
            }
            std::process::exit(2);
        }
        default(info)
    }));
}

/// `println!` to standard output, returning `anyhow::Result<()>`.
macro_rules! outln {
    () => {
        $crate::cli::out::write_fmt(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::cli::out::write_fmt(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` to standard output, returning `anyhow::Result<()>`.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::out::write_fmt(format_args!($($arg)*))
    };
}

pub(crate) use {out, outln};
