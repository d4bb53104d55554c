//! The rounds of a render: each round traces a number of samples per pixel
//! in every channel still short of its target, a rayon task per tile of
//! pixels and channel; the per-pixel sums grow in sample order, so the
//! image does not depend on the thread count. Between rounds each channel's
//! noise decides the next round's length or that the channel is done.

use super::samples::{sample_key, SampleBudget, CONTEXT, FIRST_ROUND_SPP};
use super::trace::ChannelScene;
use crate::error::{Error, Result};
use crate::material::Channel;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Tile side in pixels (one rayon task per tile and channel).
pub(super) const TILE: usize = 16;

/// Per channel, per pixel: sums of the samples and of their squares.
struct Sums {
    sum: Vec<f64>,
    sum_sq: Vec<f64>,
}

/// One round's work on a tile of one channel.
pub(super) struct TileRound {
    pub c: usize,
    /// The tile's top-left pixel.
    pub origin: (usize, usize),
    /// Per pixel, row by row: (sum, sum of squares) of the round's samples.
    pub values: Vec<(f64, f64)>,
    pub events: u64,
    /// Paths ended by round-off.
    pub lost: u64,
}

/// The pixels of the tile at `(x0, y0)` in an image `w` x `h`, row by row.
fn tile_pixels(
    (x0, y0): (usize, usize),
    (w, h): (usize, usize),
) -> impl Iterator<Item = (usize, usize)> {
    (y0..(y0 + TILE).min(h)).flat_map(move |y| (x0..(x0 + TILE).min(w)).map(move |x| (x, y)))
}

/// Samples `first..first + len` of every pixel of one tile in channel `c`,
/// each from its own stream (`sample_key`).
pub(super) fn trace_tile(
    cs: &ChannelScene,
    c: usize,
    origin: (usize, usize),
    (first, len): (u64, u64),
    seed: u64,
    size: (usize, usize),
) -> TileRound {
    let mut out = TileRound {
        c,
        origin,
        values: Vec::with_capacity(TILE * TILE),
        events: 0,
        lost: 0,
    };
    for (x, y) in tile_pixels(origin, size) {
        let p = (y * size.0 + x) as u64;
        let (mut s, mut s2) = (0.0, 0.0);
        for k in first..first + len {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(sample_key(seed, c as u64, p, k));
            let (v, st) = cs.sample(x, y, &mut rng);
            s += v;
            s2 += v * v;
            out.events += st.events;
            out.lost += st.lost as u64;
        }
        out.values.push((s, s2));
    }
    out
}

/// The noise of the target-error rule for one channel after `n` samples.
fn noise(s: &Sums, n: u64, coverage: &[f64]) -> f64 {
    let nf = n as f64;
    let seen: Vec<usize> = (0..coverage.len()).filter(|&i| coverage[i] > 0.0).collect();
    let pixels: Vec<usize> = if seen.is_empty() {
        (0..coverage.len()).collect()
    } else {
        seen
    };
    let mut means: Vec<f64> = pixels.iter().map(|&i| s.sum[i] / nf).collect();
    let var: f64 = pixels
        .iter()
        .map(|&i| {
            let m = s.sum[i] / nf;
            if n < 2 {
                return f64::INFINITY;
            }
            ((s.sum_sq[i] / nf - m * m).max(0.0) / (nf - 1.0)).max(0.0)
        })
        .sum::<f64>()
        / pixels.len() as f64;
    means.sort_by(f64::total_cmp);
    let peak = crate::numerics::nearest_rank(&means, 0.99);
    if !(peak > 0.0) {
        // A black image is exact once its samples say so.
        return if var == 0.0 { 0.0 } else { f64::INFINITY };
    }
    var.sqrt() / peak
}

/// Samples per pixel of the next round, from the totals only: the first
/// round, then what error ~ N^-1/2 predicts is missing (plus 10%), at
/// least one and at most as many as done (a fixed budget doubles).
fn round_len(done: u64, ratio: f64, left: u64) -> u64 {
    let n = if done == 0 {
        FIRST_ROUND_SPP
    } else if !ratio.is_finite() {
        done
    } else {
        ((done as f64 * (1.1 * ratio * ratio - 1.0)).ceil().max(1.0) as u64).min(done)
    };
    n.min(left)
}

/// Where each channel's rounds stand.
pub(super) struct Rounds {
    sums: Vec<Sums>,
    /// Samples per pixel done.
    pub spp: [u64; 3],
    pub events: [u64; 3],
    pub lost: [u64; 3],
    /// Noise over target after the last round.
    ratio: [f64; 3],
    active: [bool; 3],
    pub noise: [f64; 3],
    /// A channel stopped at the work cap.
    pub work_capped: bool,
    /// The cap on samples per pixel, and the noise target of a
    /// target-error budget.
    max_spp: u64,
    target: Option<f64>,
    max_work: u64,
}

impl Rounds {
    pub fn new(pixels: usize, budget: SampleBudget, max_work: u64) -> Rounds {
        let (max_spp, target) = match budget {
            SampleBudget::Fixed(n) => (n, None),
            SampleBudget::TargetError { rel, max_spp } => (max_spp, Some(rel)),
        };
        Rounds {
            sums: (0..3)
                .map(|_| Sums {
                    sum: vec![0.0; pixels],
                    sum_sq: vec![0.0; pixels],
                })
                .collect(),
            spp: [0; 3],
            events: [0; 3],
            lost: [0; 3],
            ratio: [f64::INFINITY; 3],
            active: [true; 3],
            noise: [f64::INFINITY; 3],
            work_capped: false,
            max_spp,
            target,
            max_work,
        }
    }

    /// Samples per pixel of the next round per channel (0: done).
    pub fn next_lens(&self) -> [u64; 3] {
        std::array::from_fn(|c| {
            if self.active[c] {
                round_len(self.spp[c], self.ratio[c], self.max_spp - self.spp[c])
            } else {
                0
            }
        })
    }

    /// Adds a round's tiles to the sums, in the order given.
    pub fn add(&mut self, parts: Vec<TileRound>, size: (usize, usize)) {
        for t in parts {
            let sums = &mut self.sums[t.c];
            for ((x, y), (s, s2)) in tile_pixels(t.origin, size).zip(t.values) {
                sums.sum[y * size.0 + x] += s;
                sums.sum_sq[y * size.0 + x] += s2;
            }
            self.events[t.c] += t.events;
            self.lost[t.c] += t.lost;
        }
    }

    /// Closes a round of `lens` samples per pixel: each channel's noise,
    /// and whether it goes on. A fixed budget whose first round predicts
    /// more events than the work cap is refused.
    pub fn close(&mut self, lens: [u64; 3], coverage: &[f64]) -> Result<()> {
        for (c, &len) in lens.iter().enumerate() {
            if len == 0 {
                continue;
            }
            let first = self.spp[c] == 0;
            self.spp[c] += len;
            self.noise[c] = noise(&self.sums[c], self.spp[c], coverage);
            match self.target {
                Some(rel) => {
                    self.ratio[c] = self.noise[c] / rel;
                    if self.noise[c] <= rel || self.spp[c] >= self.max_spp {
                        self.active[c] = false;
                        continue;
                    }
                    if first {
                        self.check_projected_work(c, self.target_spp(c))?;
                    }
                }
                None => {
                    if first && self.spp[c] < self.max_spp {
                        self.check_projected_work(c, self.max_spp)?;
                    }
                    if self.spp[c] >= self.max_spp {
                        self.active[c] = false;
                        continue;
                    }
                }
            }
            if self.events[c] >= self.max_work {
                self.active[c] = false;
                self.work_capped = true;
            }
        }
        Ok(())
    }

    /// The samples per pixel a target-error budget will run channel `c`
    /// to, from its first round: noise ~ N^-1/2 (the law `round_len`
    /// follows) reaches `rel` at N = n (noise / rel)^2, or stops at the cap.
    fn target_spp(&self, c: usize) -> u64 {
        let needed = self.spp[c] as f64 * self.ratio[c] * self.ratio[c];
        // `as` saturates an infinite or huge projection at u64::MAX.
        (needed.ceil() as u64).min(self.max_spp)
    }

    /// The events of `spp` samples per pixel (a fixed budget's, or what a
    /// target error needs), projected from channel `c`'s first round,
    /// within the work cap: work the cap would stop is refused after one
    /// round, not run until the cap.
    fn check_projected_work(&self, c: usize, spp_to: u64) -> Result<()> {
        let (spp, events) = (self.spp[c], self.events[c]);
        let projected = events as f64 / spp as f64 * spp_to as f64;
        if projected > self.max_work as f64 {
            let (field, value, why) = match self.target {
                None => ("spp", spp_to.to_string(), String::new()),
                Some(rel) => (
                    "target_error",
                    rel.to_string(),
                    format!(
                        " (noise {:.2e} after them: the target needs about {spp_to} samples \
                         per pixel, at most `max_spp`)",
                        self.noise[c]
                    ),
                ),
            };
            return Err(Error::invalid(
                CONTEXT,
                field,
                value,
                format!(
                    "channel {}: the first {spp} samples per pixel took {events} events{why}: \
                     {spp_to} would take about {projected:.2e}, above the work \
                     cap of {} events per channel (`max_work`)",
                    Channel::ALL[c].name(),
                    self.max_work
                ),
            ));
        }
        Ok(())
    }

    /// Every channel met its target (a fixed budget: ran to its end).
    pub fn converged(&self) -> bool {
        match self.target {
            Some(rel) => self.noise.iter().all(|&e| e <= rel),
            None => self.spp.iter().all(|&n| n == self.max_spp),
        }
    }

    /// Per channel, the pixels' means and the standard errors of the means.
    pub fn estimates(&self) -> ([Vec<f64>; 3], [Vec<f64>; 3]) {
        let mut radiance: [Vec<f64>; 3] = Default::default();
        let mut stderr: [Vec<f64>; 3] = Default::default();
        for c in 0..3 {
            let (sums, spp) = (&self.sums[c], self.spp[c]);
            let n = spp as f64;
            radiance[c] = sums.sum.iter().map(|s| s / n).collect();
            stderr[c] = sums
                .sum
                .iter()
                .zip(&sums.sum_sq)
                .map(|(s, s2)| {
                    if spp < 2 {
                        return 0.0;
                    }
                    let m = s / n;
                    ((s2 / n - m * m).max(0.0) / (n - 1.0)).sqrt()
                })
                .collect();
        }
        (radiance, stderr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sums of a round give each pixel's sample mean and the standard
    /// error of the mean, sqrt(s^2 / n) with the unbiased sample variance
    /// s^2, computed here from the samples themselves; the noise is that
    /// error over the covered pixels' peak.
    #[test]
    fn rounds_give_the_mean_and_its_standard_error() {
        let samples = [[1.0, 2.0, 3.0, 4.0], [0.5, 0.5, 0.5, 0.5]];
        let mut rounds = Rounds::new(2, SampleBudget::Fixed(4), u64::MAX);
        assert_eq!(rounds.next_lens(), [4; 3]);
        let values: Vec<(f64, f64)> = samples
            .iter()
            .map(|s| (s.iter().sum(), s.iter().map(|v| v * v).sum()))
            .collect();
        let parts = (0..3)
            .map(|c| TileRound {
                c,
                origin: (0, 0),
                values: values.clone(),
                events: 10,
                lost: 0,
            })
            .collect();
        rounds.add(parts, (2, 1));
        rounds.close([4; 3], &[1.0, 0.0]).unwrap();
        assert!(rounds.converged() && rounds.next_lens() == [0; 3]);
        let (mean, stderr) = rounds.estimates();
        for (p, s) in samples.iter().enumerate() {
            let m = s.iter().sum::<f64>() / 4.0;
            let var = s.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / 3.0;
            for c in 0..3 {
                assert!((mean[c][p] - m).abs() < 1e-15);
                assert!((stderr[c][p] - (var / 4.0).sqrt()).abs() < 1e-15);
            }
        }
        // Only pixel 0 is covered: its error over its mean.
        let expect = (5.0f64 / 12.0).sqrt() / 2.5;
        assert!(
            (rounds.noise[0] - expect).abs() < 1e-15,
            "{}",
            rounds.noise[0]
        );
    }

    /// Round lengths: the first round, then what the N^-1/2 law asks
    /// (plus 10%), never more than doubling, never past the cap.
    #[test]
    fn round_lengths_follow_the_error_law() {
        assert_eq!(round_len(0, f64::INFINITY, 1000), FIRST_ROUND_SPP);
        assert_eq!(round_len(0, f64::INFINITY, 5), 5);
        // Noise 1.2 x target after 100: 100 (1.1 x 1.44 - 1) = 58.4 more.
        assert_eq!(round_len(100, 1.2, 1000), 59);
        assert_eq!(round_len(100, 3.0, 1000), 100);
        assert_eq!(round_len(100, 0.5, 1000), 1);
        assert_eq!(round_len(100, f64::INFINITY, 30), 30);
    }

    /// A target error the work cap would stop is refused after the first
    /// round, as a fixed budget is; one the cap allows goes on.
    #[test]
    fn a_target_beyond_the_work_cap_is_refused_after_one_round() {
        // Two pixels, samples alternating 0 and 2: mean 1, standard error
        // of the mean about 0.26 after the 16 samples of the first round;
        // two events per sample and pixel.
        let run = |rel: f64| {
            let budget = SampleBudget::TargetError {
                rel,
                max_spp: 1_000_000_000_000,
            };
            let mut rounds = Rounds::new(2, budget, 1_000_000_000);
            let lens = rounds.next_lens();
            let n = lens[0];
            let (s, s2) = (n as f64, 2.0 * n as f64);
            let parts = (0..3)
                .map(|c| TileRound {
                    c,
                    origin: (0, 0),
                    values: vec![(s, s2); 2],
                    events: 4 * n,
                    lost: 0,
                })
                .collect();
            rounds.add(parts, (2, 1));
            rounds.close(lens, &[1.0, 1.0])
        };
        let e = run(1e-9).unwrap_err().to_string();
        assert!(e.contains("target_error") && e.contains("max_work"), "{e}");
        // 0.1 needs about 16 x 2.6^2 = 110 samples: far below the cap.
        assert!(run(0.1).is_ok());
    }
}
