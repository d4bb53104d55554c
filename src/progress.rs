//! Progress reporting without tying the library to a terminal: long
//! computations call a `Progress`; the CLI passes an indicatif bar that stays
//! quiet when stderr is not a terminal, tests pass `NoProgress`.

pub trait Progress: Sync {
    /// Announces the amount of work (e.g. photons) and what it is.
    fn start(&self, _total: u64, _what: &str) {}
    /// Reports `n` more units done.
    fn advance(&self, _n: u64) {}
    /// Work is over.
    fn finish(&self) {}
    /// Whether the caller asked the work to stop (Ctrl-C in the Python
    /// binding); the Monte Carlo rounds check it before each chunk and
    /// then fail with [`INTERRUPTED`].
    fn cancelled(&self) -> bool {
        false
    }
}

/// The message of work stopped because [`Progress::cancelled`] said so.
pub const INTERRUPTED: &str = "interrupted by the caller";

/// Discards all progress.
pub struct NoProgress;
impl Progress for NoProgress {}
