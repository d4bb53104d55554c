//! Progress on stderr. On a terminal, an indicatif bar whose ETA is the
//! time the work left takes at the rate of the work done so far (units
//! done over seconds spent: no guess before the first unit is done).
//! Elsewhere (stderr piped or redirected to a file) no bar is drawn and
//! each stage, from `start` to `finish`, prints one line when it ends: what
//! it did, how many units and in how many seconds.

use indicatif::{ProgressBar, ProgressState, ProgressStyle};
use ssskit::progress::Progress;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

pub struct Bar {
    bar: ProgressBar,
    /// Between `start` and `finish`.
    running: AtomicBool,
    /// Whether stderr is a terminal (the bar draws) or not (one line per
    /// stage).
    terminal: bool,
}

impl Bar {
    pub fn new() -> Bar {
        Bar {
            bar: ProgressBar::hidden(),
            running: AtomicBool::new(false),
            terminal: std::io::stderr().is_terminal(),
        }
    }
}

/// Seconds the work left takes at the rate of the work done so far: None
/// before any is done (a rate from nothing would be a guess).
pub fn eta_seconds(done: u64, total: u64, elapsed: Duration) -> Option<f64> {
    (done > 0).then(|| elapsed.as_secs_f64() * total.saturating_sub(done) as f64 / done as f64)
}

/// "1h02m", "3m05s", "12s", "0.4s".
fn short_duration(s: f64) -> String {
    let whole = s.round() as u64;
    if s < 9.95 {
        format!("{s:.1}s")
    } else if whole < 60 {
        format!("{whole}s")
    } else if whole < 3600 {
        format!("{}m{:02}s", whole / 60, whole % 60)
    } else {
        format!("{}h{:02}m", whole / 3600, (whole % 3600) / 60)
    }
}

/// The line a stage prints when stderr is not a terminal: "skin1 photons:
/// 974848 in 0.4 s", with "of N" where it stopped short of the work it
/// announced.
pub fn stage_line(what: &str, done: u64, total: u64, elapsed: Duration) -> String {
    let of = if done == total {
        String::new()
    } else {
        format!(" of {total}")
    };
    format!("{what}: {done}{of} in {:.1} s", elapsed.as_secs_f64())
}

impl Progress for Bar {
    fn start(&self, total: u64, what: &str) {
        self.bar.reset();
        self.bar.set_length(total);
        self.bar.set_message(what.to_string());
        self.running.store(true, Ordering::Relaxed);
        if !self.terminal {
            return;
        }
        self.bar
            .set_draw_target(indicatif::ProgressDrawTarget::stderr());
        self.bar.set_style(
            ProgressStyle::with_template(
                "{msg} [{bar:40}] {human_pos}/{human_len} ({per_sec}, eta {eta_work})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .with_key(
                "eta_work",
                |s: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let eta = eta_seconds(s.pos(), s.len().unwrap_or(0), s.elapsed());
                    let _ = match eta {
                        Some(t) => write!(w, "{}", short_duration(t)),
                        None => write!(w, "?"),
                    };
                },
            )
            .progress_chars("=> "),
        );
    }
    fn advance(&self, n: u64) {
        self.bar.inc(n);
    }
    fn set_total(&self, total: u64) {
        self.bar.set_length(total);
    }
    fn finish(&self) {
        if !self.running.swap(false, Ordering::Relaxed) {
            return;
        }
        if self.terminal {
            self.bar.finish_and_clear();
            return;
        }
        eprintln!(
            "{}",
            stage_line(
                &self.bar.message(),
                self.bar.position(),
                self.bar.length().unwrap_or(0),
                self.bar.elapsed()
            )
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ETA is the work left at the rate of the work done: a quarter
    /// done in 1 s leaves 3 s; nothing done, no ETA; all done, none left.
    #[test]
    fn eta_from_the_work_done() {
        let s = Duration::from_secs(1);
        assert_eq!(eta_seconds(25, 100, s), Some(3.0));
        assert_eq!(eta_seconds(0, 100, s), None);
        assert_eq!(eta_seconds(100, 100, s), Some(0.0));
        assert_eq!(short_duration(0.44), "0.4s");
        assert_eq!(short_duration(185.0), "3m05s");
        assert_eq!(short_duration(3725.0), "1h02m");
    }

    #[test]
    fn stage_lines() {
        let t = Duration::from_millis(420);
        assert_eq!(
            stage_line("skin1 photons", 9, 9, t),
            "skin1 photons: 9 in 0.4 s"
        );
        assert_eq!(stage_line("models", 3, 5, t), "models: 3 of 5 in 0.4 s");
    }
}
