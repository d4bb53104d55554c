//! Progress reporting without tying the library to a terminal: long
//! computations call a `Progress`; the CLI passes an indicatif bar on a
//! terminal and prints one line per stage elsewhere, tests pass
//! `NoProgress`.

pub trait Progress: Sync {
    /// Announces the amount of work (e.g. photons) and what it is.
    fn start(&self, _total: u64, _what: &str) {}
    /// Reports `n` more units done.
    fn advance(&self, _n: u64) {}
    /// The work of the stage is now `total` units in all (done ones
    /// included): a run that stops at a target error announces the work it
    /// can see (its first round) and then what each round projects, so that
    /// an ETA comes from the work to do, not from a cap it will not reach.
    fn set_total(&self, _total: u64) {}
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

/// CPU seconds the process has spent so far, every thread, user and
/// system (0 where the platform does not say): with the wall seconds, what
/// a stage of a job cost and how well it kept the cores busy.
pub fn process_cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `t` is a valid timespec for the call to fill.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) } == 0 {
            return t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9;
        }
    }
    0.0
}

/// Wall and process CPU seconds since it started ([`process_cpu_seconds`]).
#[derive(Clone, Copy, Debug)]
pub struct Clock {
    wall: std::time::Instant,
    cpu: f64,
}

impl Clock {
    pub fn start() -> Clock {
        Clock {
            wall: std::time::Instant::now(),
            cpu: process_cpu_seconds(),
        }
    }

    /// (wall seconds, CPU seconds) since the start.
    pub fn elapsed(&self) -> (f64, f64) {
        (
            self.wall.elapsed().as_secs_f64(),
            process_cpu_seconds() - self.cpu,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A busy loop spends CPU time the clock sees (no upper bound: the
    /// other tests' threads count in the process's CPU time too).
    #[test]
    fn the_clock_counts_cpu_seconds() {
        let c = Clock::start();
        let mut x = 0u64;
        while c.elapsed().0 < 0.05 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let (wall, cpu) = c.elapsed();
        assert!(cpu > 0.0 && wall >= 0.05, "{cpu} {wall}");
    }
}
