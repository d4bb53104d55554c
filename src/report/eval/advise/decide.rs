//! What advise may spend and how it decides: the budget a candidate must
//! fit, when a score misses the target (by more than its uncertainty), and
//! which candidate wins (the cheapest that meets the target; where none
//! does, the most accurate, ties within the uncertainty going to the
//! cheaper).

use serde::{Deserialize, Serialize};
use std::cmp::Ordering;
use std::collections::BTreeMap;

/// A candidate fails a signal only when its score is over the target by
/// more than this many standard deviations of the score: a kernel exactly
/// at the target then looks failed by noise alone 2.3% of the time (one
/// sided, normal), where at k = 0 it would half the time; the same factor
/// makes two worst cases tie.
pub const NOISE_K: f64 = 2.0;

/// One-dimensional passes allowed by default: one horizontal and one
/// vertical pass of a rank-1 separable kernel, what every engine in
/// `ssskit engine` runs.
pub const DEFAULT_MAX_PASSES: usize = 2;

/// What a candidate may cost. None: unbounded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Budget {
    /// One-dimensional passes (a rank-r separable kernel runs 2r).
    pub max_passes: Option<usize>,
    /// Samples per pixel over all passes.
    pub max_samples: Option<usize>,
    /// Taps per pass (full factors: the pixels a pass spans).
    pub max_taps: Option<usize>,
}

impl Default for Budget {
    fn default() -> Budget {
        Budget {
            max_passes: Some(DEFAULT_MAX_PASSES),
            max_samples: None,
            max_taps: None,
        }
    }
}

impl Budget {
    /// No limit at all.
    pub const UNBOUNDED: Budget = Budget {
        max_passes: None,
        max_samples: None,
        max_taps: None,
    };

    /// Whether a kernel of `passes` one-dimensional passes of `taps` taps
    /// each (`samples` in all) fits.
    pub fn allows(&self, passes: usize, taps: usize, samples: usize) -> bool {
        let within = |limit: Option<usize>, v: usize| limit.is_none_or(|m| v <= m);
        within(self.max_passes, passes)
            && within(self.max_taps, taps)
            && within(self.max_samples, samples)
    }

    /// "2 passes, any samples, any taps".
    pub fn describe(&self) -> String {
        let f = |v: Option<usize>, what: &str| match v {
            Some(n) => format!("at most {n} {what}"),
            None => format!("any {what}"),
        };
        format!(
            "{}, {}, {}",
            f(self.max_passes, "passes"),
            f(self.max_samples, "samples per pixel"),
            f(self.max_taps, "taps per pass")
        )
    }
}

/// A candidate's scores on every signal it was filtered on, and the
/// decision on them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// Per signal, the largest relative RMS over channels.
    pub per_signal: BTreeMap<String, f64>,
    /// Per signal, that score's standard deviation (bootstrap).
    pub per_signal_sigma: BTreeMap<String, f64>,
    /// Largest score over the signals filtered on.
    pub rel_rms: f64,
    /// Its standard deviation.
    pub rel_rms_sigma: f64,
    /// Signal of the worst case.
    pub worst_signal: String,
    /// The signal that decides: the largest score less [`NOISE_K`] of its
    /// standard deviations (the one a failing candidate misses by most,
    /// the one a passing candidate comes closest to missing).
    pub deciding_signal: String,
    /// Its score less NOISE_K standard deviations: the candidate meets a
    /// target at or above this.
    pub decided_at: f64,
    pub meets: bool,
    /// Filtered on every signal; otherwise the search stopped once it
    /// could neither meet the target nor be its model's most accurate,
    /// and `rel_rms` is a lower bound.
    pub complete: bool,
}

impl Verdict {
    /// The verdict on `scores` (signal, score, standard deviation) at
    /// `target`, complete when every signal is there.
    pub fn new(scores: &[(String, f64, f64)], target: f64, complete: bool) -> Verdict {
        let mut v = Verdict {
            per_signal: BTreeMap::new(),
            per_signal_sigma: BTreeMap::new(),
            rel_rms: 0.0,
            rel_rms_sigma: 0.0,
            worst_signal: String::new(),
            deciding_signal: String::new(),
            decided_at: f64::NEG_INFINITY,
            meets: false,
            complete,
        };
        for (name, s, sigma) in scores {
            v.per_signal.insert(name.clone(), *s);
            v.per_signal_sigma.insert(name.clone(), *sigma);
            if *s > v.rel_rms || v.worst_signal.is_empty() {
                (v.rel_rms, v.rel_rms_sigma, v.worst_signal) = (*s, *sigma, name.clone());
            }
            let at = s - NOISE_K * sigma;
            if at > v.decided_at {
                (v.decided_at, v.deciding_signal) = (at, name.clone());
            }
        }
        v.meets = complete && v.decided_at <= target;
        v
    }

    /// Whether a signal already misses the target by more than its margin.
    pub fn failed(&self, target: f64) -> bool {
        self.decided_at > target
    }

    /// Whether this worst case and `other` lie within [`NOISE_K`] combined
    /// standard deviations of each other.
    pub fn ties(&self, other: &Verdict) -> bool {
        (self.rel_rms - other.rel_rms).abs()
            <= NOISE_K * self.rel_rms_sigma.hypot(other.rel_rms_sigma)
    }
}

/// What a candidate costs, cheapest first: samples per pixel (the GPU's
/// work), then passes (each a full-screen read and write).
pub trait Cost {
    fn samples(&self) -> usize;
    fn passes(&self) -> usize;
    fn verdict(&self) -> &Verdict;
    fn cost_order(&self, other: &Self) -> Ordering {
        self.samples()
            .cmp(&other.samples())
            .then(self.passes().cmp(&other.passes()))
    }
}

/// The winner among `cands` (complete ones only): the cheapest that meets
/// the target (the most accurate among equally cheap); where none does,
/// the cheapest of those whose worst case ties the smallest worst case.
pub fn choose<C: Cost>(cands: &[C]) -> Option<usize> {
    let complete = || {
        cands
            .iter()
            .enumerate()
            .filter(|(_, c)| c.verdict().complete)
    };
    let by_cost = |a: &(usize, &C), b: &(usize, &C)| {
        a.1.cost_order(b.1)
            .then(a.1.verdict().rel_rms.total_cmp(&b.1.verdict().rel_rms))
    };
    if let Some((i, _)) = complete()
        .filter(|(_, c)| c.verdict().meets)
        .min_by(by_cost)
    {
        return Some(i);
    }
    let (_, best) = complete().min_by(|a, b| {
        a.1.verdict()
            .rel_rms
            .total_cmp(&b.1.verdict().rel_rms)
            .then(a.1.cost_order(b.1))
    })?;
    complete()
        .filter(|(_, c)| c.verdict().ties(best.verdict()))
        .min_by(by_cost)
        .map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct C(usize, usize, Verdict);
    impl Cost for C {
        fn samples(&self) -> usize {
            self.0
        }
        fn passes(&self) -> usize {
            self.1
        }
        fn verdict(&self) -> &Verdict {
            &self.2
        }
    }

    fn v(score: f64, sigma: f64) -> Verdict {
        Verdict::new(&[("checker2px".into(), score, sigma)], 0.05, true)
    }

    /// A miss smaller than NOISE_K standard deviations is no miss; a
    /// larger one is (at k = 0 both would fail).
    #[test]
    fn a_miss_within_the_noise_meets() {
        assert!(v(0.0501, 0.0001).meets);
        assert!(!v(0.0503, 0.0001).meets);
        assert!(!v(0.0501, 0.0).meets);
    }

    /// The budget counts passes, taps and samples; None is no limit.
    #[test]
    fn budget_limits_each_cost() {
        let b = Budget::default();
        assert!(b.allows(2, 33, 66));
        assert!(!b.allows(6, 21, 126));
        let t = Budget {
            max_taps: Some(17),
            max_samples: Some(40),
            ..Budget::UNBOUNDED
        };
        assert!(t.allows(2, 17, 34));
        assert!(!t.allows(2, 21, 42));
        // Over on taps alone (19 > 17; 38 samples within 40).
        assert!(!t.allows(2, 19, 38));
        assert!(!t.allows(4, 11, 44));
        assert!(Budget::UNBOUNDED.allows(12, 255, 100_000));
    }

    /// Where none meets the target, worst cases within the noise tie and
    /// the cheaper wins; a clearly better one wins whatever it costs.
    #[test]
    fn ties_go_to_the_cheaper() {
        let tied = [C(126, 6, v(0.060, 0.002)), C(26, 2, v(0.062, 0.002))];
        assert_eq!(choose(&tied), Some(1));
        let clear = [C(126, 6, v(0.060, 0.0005)), C(26, 2, v(0.062, 0.0005))];
        assert_eq!(choose(&clear), Some(0));
        let meets = [
            C(126, 6, v(0.04, 0.0)),
            C(26, 2, v(0.045, 0.0)),
            C(10, 2, v(0.2, 0.0)),
        ];
        assert_eq!(choose(&meets), Some(1));
    }
}
