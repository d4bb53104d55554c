//! Clean-up on a terminating signal: the temporary files and staged
//! folders of unfinished writes are removed before the process ends.

use super::temps::{live_temps, remove_registered};
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
                // Held to the end: a swap in progress finishes first, and
                // no temporary is made or swapped in after the removal.
                let mut held = live_temps();
                remove_registered(&mut held, |_| true, &|_| {});
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

/// Ends the process with `code` once no signal clean-up is under way: one
/// that began is not cut short by the exit (it would leave the rest of a
/// staged folder behind); the clean-up ends the process itself, with its
/// own status.
pub fn exit(code: i32) -> ! {
    let _held = wait_for_cleanup();
    std::process::exit(code)
}

/// The lock of the clean-up, once no removal holds it.
fn wait_for_cleanup() -> std::sync::MutexGuard<'static, Vec<std::path::PathBuf>> {
    live_temps()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// An exit waits for a clean-up in progress (here one holding the lock
    /// for a moment), and goes on once it is over.
    #[test]
    fn an_exit_waits_for_the_cleanup() {
        // How long the exit must still be waiting: far longer than taking
        // a free lock, far shorter than the test's patience.
        const STILL_WAITING: Duration = Duration::from_millis(300);
        let _serial = super::super::temps::long_hold();
        let held = live_temps();
        let (tx, rx) = std::sync::mpsc::channel();
        let exiting = std::thread::spawn(move || {
            let _g = wait_for_cleanup();
            tx.send(()).unwrap();
        });
        assert!(
            rx.recv_timeout(STILL_WAITING).is_err(),
            "the exit went on while the clean-up held the lock"
        );
        drop(held);
        rx.recv_timeout(Duration::from_secs(60)).unwrap();
        exiting.join().unwrap();
    }
}
