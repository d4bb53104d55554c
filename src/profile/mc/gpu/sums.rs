//! The GPU tally: the word layout of the buffer the shader's atomics add
//! into (64-bit sums in 2 words, 96-bit sums of squares in 3, least
//! significant first), and the host's exact u128 sums of its batches.

use super::super::exact::ExactTally;
use super::super::tally::{BinSums, ChunkTally, Moments};
use crate::error::{Error, Result};

/// Fixed point of the tallies: per-packet values are integers in units of
/// 2^-24.
pub const TALLY_RESOLUTION: f64 = 1.0 / (1u64 << 24) as f64;

// Word layout of the tally buffer, given to mc_trace.wgsl by
// `shader::shader_consts`.
/// Words of a 64-bit sum; a sum of squares follows its sum at this offset.
pub(super) const SUM_WORDS: usize = 2;
/// Words of a sum with its 96-bit sum of squares (a moment, a bin).
pub(super) const MOMENT_WORDS: usize = SUM_WORDS + 3;
/// Reflectance: sum at 0..2, squares at 2..5 (likewise T_TR, T_ABS).
pub(super) const T_RD: usize = 0;
pub(super) const T_TR: usize = 5;
pub(super) const T_ABS: usize = 10;
/// Sums only (likewise T_LOSS to T_EVENTS).
pub(super) const T_BEYOND: usize = 15;
pub(super) const T_LOSS: usize = 17;
pub(super) const T_GAIN: usize = 19;
pub(super) const T_TRUNC: usize = 21;
/// Packet count.
pub(super) const T_TRUNC_N: usize = 23;
pub(super) const T_EVENTS: usize = 25;
/// One word: a value beyond the fixed-point range was met.
pub(super) const T_SATURATED: usize = 27;
/// The next packet to trace (the shared work counter).
pub(super) const WORK: usize = 28;
/// Packets whose walk stopped with weight left (a driver's loop limit), and
/// packets traced: both checked by the host.
pub(super) const INCOMPLETE: usize = 29;
pub(super) const TRACED: usize = 30;
/// Per bin from here: sum (2 words), sum of squares (3 words).
pub(super) const BINS: usize = 32;

/// Words of the tally buffer of `n_bins` bins.
pub(super) fn tally_words(n_bins: usize) -> usize {
    BINS + MOMENT_WORDS * n_bins
}

/// Exact integer tallies of a channel, in units of `TALLY_RESOLUTION`
/// (squares in its square).
pub(super) struct Sums {
    pub(super) photons: u64,
    rd: [u128; 2],
    tr: [u128; 2],
    absorbed: [u128; 2],
    beyond: u128,
    loss: u128,
    gain: u128,
    truncated: u128,
    truncated_photons: u128,
    pub(super) events: u128,
    bins: Vec<[u128; 2]>,
    pub(super) saturated: bool,
}

impl Sums {
    pub(super) fn new(n_bins: usize) -> Sums {
        Sums {
            photons: 0,
            rd: [0; 2],
            tr: [0; 2],
            absorbed: [0; 2],
            beyond: 0,
            loss: 0,
            gain: 0,
            truncated: 0,
            truncated_photons: 0,
            events: 0,
            bins: vec![[0; 2]; n_bins],
            saturated: false,
        }
    }

    /// Adds one batch's words.
    pub(super) fn add(&mut self, w: &[u32], photons: u64) {
        let wide =
            |i: usize, n: usize| -> u128 { (0..n).map(|k| (w[i + k] as u128) << (32 * k)).sum() };
        let moments = |m: &mut [u128; 2], i: usize| {
            m[0] += wide(i, SUM_WORDS);
            m[1] += wide(i + SUM_WORDS, MOMENT_WORDS - SUM_WORDS);
        };
        self.photons += photons;
        moments(&mut self.rd, T_RD);
        moments(&mut self.tr, T_TR);
        moments(&mut self.absorbed, T_ABS);
        self.beyond += wide(T_BEYOND, SUM_WORDS);
        self.loss += wide(T_LOSS, SUM_WORDS);
        self.gain += wide(T_GAIN, SUM_WORDS);
        self.truncated += wide(T_TRUNC, SUM_WORDS);
        self.truncated_photons += wide(T_TRUNC_N, SUM_WORDS);
        self.events += wide(T_EVENTS, SUM_WORDS);
        self.saturated |= w[T_SATURATED] != 0;
        for (i, b) in self.bins.iter_mut().enumerate() {
            moments(b, BINS + MOMENT_WORDS * i);
        }
    }

    pub(super) fn tally(&self, specular: f64) -> ChunkTally {
        let v = |x: u128| x as f64 * TALLY_RESOLUTION;
        let m = |x: &[u128; 2]| Moments {
            sum: v(x[0]),
            sum_sq: x[1] as f64 * TALLY_RESOLUTION * TALLY_RESOLUTION,
        };
        let bins = self.bins.iter().map(m);
        let (sum, sum_sq) = bins.map(|b| (b.sum, b.sum_sq)).unzip();
        ChunkTally {
            photons: self.photons,
            events: self.events as u64,
            specular: specular * self.photons as f64,
            rd: m(&self.rd),
            transmittance: m(&self.tr),
            absorbed: m(&self.absorbed),
            rd_bins: BinSums { sum, sum_sq },
            rd_beyond: v(self.beyond),
            roulette_loss: v(self.loss),
            roulette_gain: v(self.gain),
            truncated: v(self.truncated),
            truncated_photons: self.truncated_photons as u64,
            ..ChunkTally::new(0, false)
        }
    }
}

/// The GPU's per-channel sums as the exact tally `build_profile` reads.
pub(super) fn exact_tally(t: &ChunkTally, bins: usize) -> Result<ExactTally> {
    let mut e = ExactTally::new(bins, false);
    e.add_chunk(t)
        .map_err(|e| Error::Unsupported(format!("the GPU tally: {e}")))?;
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wide_sums_carry_across_words() {
        let mut s = Sums::new(1);
        let mut w = vec![0u32; tally_words(1)];
        w[T_RD] = u32::MAX;
        w[T_RD + 1] = 2;
        w[T_RD + 4] = 1;
        s.add(&w, 3);
        s.add(&w, 3);
        assert_eq!(s.rd[0], 2 * ((2u128 << 32) + u32::MAX as u128));
        assert_eq!(s.rd[1], 2u128 << 64);
        assert_eq!(s.photons, 6);
    }
}
