//! How a temporal filter accumulates the frames of a stochastic pass (the
//! disk kernels' rotations), as weights on the frames: the plain mean, or
//! an exponential moving average h_1 = f_1, h_k = (1 - a) h_{k-1} + a f_k
//! with a stated weight a (the form of a TAA history blend). Both sets of
//! weights sum to 1, so the bias is the one of a single frame; the noise
//! of K frames whose errors are independent with standard deviation s is
//! s sqrt(sum of the squared weights) ([`Accumulate::noise_factor`]): for
//! the mean 1 / sqrt(K); for the EMA
//! sqrt((1 - a)^(2 (K - 1)) + a^2 (1 - (1 - a)^(2 (K - 1))) / (1 - (1 - a)^2)),
//! which tends to sqrt(a / (2 - a)) as K grows, the floor a history of
//! weight a never goes below.

use crate::error::{Error, Result};

/// How frames are accumulated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Accumulate {
    /// The plain mean of the frames.
    Mean,
    /// Exponential moving average with this weight on the newest frame,
    /// in (0, 1].
    Ema(f64),
}

impl Accumulate {
    /// Parses `mean` or `ema:W` (W in (0, 1]).
    pub fn parse(s: &str) -> Result<Accumulate> {
        let bad = |reason: &str| Error::invalid("accumulate", "accumulate", s, reason);
        if s == "mean" {
            return Ok(Accumulate::Mean);
        }
        let w = s
            .strip_prefix("ema:")
            .ok_or_else(|| bad("must be `mean` or `ema:W` with W in (0, 1]"))?;
        let w: f64 = w
            .parse()
            .map_err(|_| bad("the EMA weight must be a number in (0, 1]"))?;
        if !(w > 0.0 && w <= 1.0) {
            return Err(bad("the EMA weight must be in (0, 1]"));
        }
        Ok(Accumulate::Ema(w))
    }

    /// The weight of frame k (0-based, oldest first) of `frames`.
    pub fn weights(self, frames: u32) -> Vec<f64> {
        let k = frames.max(1) as usize;
        match self {
            Accumulate::Mean => vec![1.0 / k as f64; k],
            Accumulate::Ema(a) => {
                // Frame 0 starts the history; each later frame scales it
                // by (1 - a) and adds itself with weight a.
                let mut w = vec![0.0; k];
                w[0] = (1.0 - a).powi(k as i32 - 1);
                for (j, wj) in w.iter_mut().enumerate().skip(1) {
                    *wj = a * (1.0 - a).powi((k - 1 - j) as i32);
                }
                w
            }
        }
    }

    /// The noise of `frames` accumulated frames over the noise of one, for
    /// frames with independent errors: sqrt(sum of the squared weights),
    /// in closed form (module comment).
    pub fn noise_factor(self, frames: u32) -> f64 {
        let k = frames.max(1) as f64;
        match self {
            Accumulate::Mean => 1.0 / k.sqrt(),
            Accumulate::Ema(a) => {
                let q = (1.0 - a) * (1.0 - a);
                let first = q.powf(k - 1.0);
                if q == 0.0 {
                    // a = 1: the newest frame alone.
                    return 1.0;
                }
                (first + a * a * (1.0 - first) / (1.0 - q)).sqrt()
            }
        }
    }

    /// `mean` or `ema:W`.
    pub fn name(self) -> String {
        match self {
            Accumulate::Mean => "mean".into(),
            Accumulate::Ema(a) => format!("ema:{a}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weights sum to 1 (the bias stays that of one frame), and the
    /// closed form is their root sum of squares.
    #[test]
    fn weights_and_closed_form_agree() {
        for acc in [Accumulate::Mean, Accumulate::Ema(0.1), Accumulate::Ema(0.5)] {
            for k in [1, 2, 8, 40] {
                let w = acc.weights(k);
                let sum: f64 = w.iter().sum();
                assert!((sum - 1.0).abs() < 1e-12, "{acc:?} {k}: {sum}");
                let rss = w.iter().map(|x| x * x).sum::<f64>().sqrt();
                let f = acc.noise_factor(k);
                assert!((rss - f).abs() < 1e-12, "{acc:?} {k}: {rss} vs {f}");
            }
        }
        // The EMA's floor sqrt(a / (2 - a)).
        let f = Accumulate::Ema(0.1).noise_factor(10_000);
        assert!((f - (0.1f64 / 1.9).sqrt()).abs() < 1e-12, "{f}");
    }

    #[test]
    fn parse_refuses_bad_weights() {
        assert_eq!(Accumulate::parse("mean").unwrap(), Accumulate::Mean);
        assert_eq!(Accumulate::parse("ema:0.1").unwrap(), Accumulate::Ema(0.1));
        for bad in ["ema:0", "ema:1.5", "ema:nan", "ema:", "median", "ema:-0.1"] {
            assert!(Accumulate::parse(bad).is_err(), "{bad}");
        }
    }
}
