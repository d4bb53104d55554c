//! Clean-up on a terminating signal: the temporary files and staged
//! folders of unfinished writes are removed before the process ends.

use super::temps::{live_temps, remove_temp};
use crate::error::{Error, Result};

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
