//! Exact accumulation of chunk tallies: every f64 sum of a chunk is added
//! to a 192-bit fixed-point number, so that the total does not depend on
//! the order in which chunks are added. That makes a run bit-identical for
//! any thread count and any scheduler, and lets disjoint shards of a run,
//! traced on different machines, merge into exactly the single run.

use super::tally::{BinSums, ChunkTally, ExitSums, Moments};
use serde::{Deserialize, Serialize};

/// A non-negative number hi 2^-64 + lo 2^-128, exact for every f64 in
/// [2^-128, 2^64) with all its bits (tallies are sums of weights and squared
/// weights: non-negative, far below 2^64). Parts of an f64 below 2^-128 are
/// dropped, the same way wherever the chunk is traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExactSum {
    hi: u128,
    lo: u64,
}

impl ExactSum {
    pub fn add_f64(&mut self, x: f64) {
        if !(x > 0.0) {
            return;
        }
        let bits = x.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i32;
        let frac = bits & ((1u64 << 52) - 1);
        let (m, e) = if exp == 0 {
            (frac, -1074)
        } else {
            (frac | (1u64 << 52), exp - 1075)
        };
        // x = m 2^e = m 2^(e + 128) units of 2^-128.
        let s = e + 128;
        let part = if s < 0 {
            ExactSum {
                hi: 0,
                lo: if s <= -64 { 0 } else { m >> (-s) },
            }
        } else if s < 64 {
            let full = (m as u128) << s;
            ExactSum {
                hi: full >> 64,
                lo: full as u64,
            }
        } else {
            // s - 64 <= 75 for x < 2^64; saturate beyond (never reached).
            let sh = (s - 64) as u32;
            ExactSum {
                hi: if sh >= 75 {
                    u128::MAX >> 1
                } else {
                    (m as u128) << sh
                },
                lo: 0,
            }
        };
        self.add(&part);
    }

    pub fn add(&mut self, o: &ExactSum) {
        let (lo, carry) = self.lo.overflowing_add(o.lo);
        self.lo = lo;
        self.hi = self.hi.wrapping_add(o.hi).wrapping_add(carry as u128);
    }

    /// The nearest f64 of the high part plus the low part: a function of the
    /// exact value only, hence the same for every order of accumulation.
    pub fn to_f64(self) -> f64 {
        const TWO_M64: f64 = 1.0 / 18_446_744_073_709_551_616.0;
        self.hi as f64 * TWO_M64 + self.lo as f64 * TWO_M64 * TWO_M64
    }

    fn to_hex(self) -> String {
        if self.lo == 0 {
            format!("{:x}", self.hi)
        } else {
            format!("{:x}:{:x}", self.hi, self.lo)
        }
    }

    fn from_hex(s: &str) -> Option<ExactSum> {
        let (h, l) = s.split_once(':').unwrap_or((s, "0"));
        Some(ExactSum {
            hi: u128::from_str_radix(h, 16).ok()?,
            lo: u64::from_str_radix(l, 16).ok()?,
        })
    }
}

impl Serialize for ExactSum {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_hex())
    }
}

impl<'de> Deserialize<'de> for ExactSum {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        ExactSum::from_hex(&s).ok_or_else(|| {
            serde::de::Error::custom(format!("'{s}' is not an exact sum (hex 'hi' or 'hi:lo')"))
        })
    }
}

/// Per-bin exact sums and sums of squares.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExactBins {
    pub sum: Vec<ExactSum>,
    pub sum_sq: Vec<ExactSum>,
}

impl ExactBins {
    fn new(n: usize) -> ExactBins {
        ExactBins {
            sum: vec![ExactSum::default(); n],
            sum_sq: vec![ExactSum::default(); n],
        }
    }

    fn add_chunk(&mut self, b: &BinSums) {
        for (a, x) in self.sum.iter_mut().zip(&b.sum) {
            a.add_f64(*x);
        }
        for (a, x) in self.sum_sq.iter_mut().zip(&b.sum_sq) {
            a.add_f64(*x);
        }
    }

    fn add(&mut self, o: &ExactBins) {
        for (a, x) in self.sum.iter_mut().zip(&o.sum) {
            a.add(x);
        }
        for (a, x) in self.sum_sq.iter_mut().zip(&o.sum_sq) {
            a.add(x);
        }
    }

    fn to_f64(&self) -> BinSums {
        BinSums {
            sum: self.sum.iter().map(|x| x.to_f64()).collect(),
            sum_sq: self.sum_sq.iter().map(|x| x.to_f64()).collect(),
        }
    }
}

/// Exact exit-angle sums (`ExitSums`); empty when not tallied.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExactExit {
    pub ra: ExactBins,
    pub a: ExactBins,
    pub a_cross: Vec<ExactSum>,
}

impl ExactExit {
    pub fn is_empty(&self) -> bool {
        self.a.sum.is_empty()
    }

    /// Adds a chunk's sums, taking their layout on first use (every chunk
    /// of a run has the same).
    fn add_chunk(&mut self, e: &ExitSums) {
        if e.is_empty() {
            return;
        }
        if self.is_empty() {
            self.ra = ExactBins::new(e.ra.sum.len());
            self.a = ExactBins::new(e.a.sum.len());
            self.a_cross = vec![ExactSum::default(); e.a_cross.len()];
        }
        self.ra.add_chunk(&e.ra);
        self.a.add_chunk(&e.a);
        for (s, x) in self.a_cross.iter_mut().zip(&e.a_cross) {
            s.add_f64(*x);
        }
    }

    fn add(&mut self, o: &ExactExit) {
        if o.is_empty() {
            return;
        }
        if self.is_empty() {
            *self = o.clone();
            return;
        }
        self.ra.add(&o.ra);
        self.a.add(&o.a);
        for (s, x) in self.a_cross.iter_mut().zip(&o.a_cross) {
            s.add(x);
        }
    }

    pub fn to_f64(&self) -> ExitSums {
        ExitSums {
            ra: self.ra.to_f64(),
            a: self.a.to_f64(),
            a_cross: self.a_cross.iter().map(|x| x.to_f64()).collect(),
        }
    }
}

/// Number of f64 totals of a `ChunkTally` (see `scalars`).
const SCALARS: usize = 13;

/// The f64 totals of a chunk tally, in a fixed order.
fn scalars(t: &ChunkTally) -> [f64; SCALARS] {
    [
        t.specular,
        t.rd.sum,
        t.rd.sum_sq,
        t.transmittance.sum,
        t.transmittance.sum_sq,
        t.absorbed.sum,
        t.absorbed.sum_sq,
        t.rd_beyond,
        t.single.sum,
        t.single.sum_sq,
        t.roulette_loss,
        t.roulette_gain,
        t.truncated,
    ]
}

/// Everything a set of chunks scored, exactly.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExactTally {
    pub photons: u64,
    pub events: u64,
    pub truncated_photons: u64,
    /// specular, rd, rd^2, T, T^2, absorbed, absorbed^2, beyond r_max,
    /// single, single^2, roulette loss, roulette gain, truncated.
    pub totals: Vec<ExactSum>,
    pub rd_bins: ExactBins,
    pub single_bins: ExactBins,
    /// Exit-angle sums (angle-resolved runs only).
    #[serde(default, skip_serializing_if = "ExactExit::is_empty")]
    pub exit: ExactExit,
}

impl ExactTally {
    pub fn new(bins: usize, single_scatter: bool) -> ExactTally {
        ExactTally {
            totals: vec![ExactSum::default(); SCALARS],
            rd_bins: ExactBins::new(bins),
            single_bins: ExactBins::new(if single_scatter { bins } else { 0 }),
            ..Default::default()
        }
    }

    /// Whether this tally has the layout of `new(bins, single)`.
    pub fn has_layout(&self, bins: usize, single_scatter: bool) -> bool {
        let sb = if single_scatter { bins } else { 0 };
        self.totals.len() == SCALARS
            && self.rd_bins.sum.len() == bins
            && self.rd_bins.sum_sq.len() == bins
            && self.single_bins.sum.len() == sb
            && self.single_bins.sum_sq.len() == sb
    }

    pub fn add_chunk(&mut self, t: &ChunkTally) {
        self.photons += t.photons;
        self.events += t.events;
        self.truncated_photons += t.truncated_photons;
        for (a, x) in self.totals.iter_mut().zip(scalars(t)) {
            a.add_f64(x);
        }
        self.rd_bins.add_chunk(&t.rd_bins);
        self.single_bins.add_chunk(&t.single_bins);
        self.exit.add_chunk(&t.exit);
    }

    pub fn add(&mut self, o: &ExactTally) {
        self.photons += o.photons;
        self.events += o.events;
        self.truncated_photons += o.truncated_photons;
        for (a, x) in self.totals.iter_mut().zip(&o.totals) {
            a.add(x);
        }
        self.rd_bins.add(&o.rd_bins);
        self.single_bins.add(&o.single_bins);
        self.exit.add(&o.exit);
    }

    /// The totals rounded to f64, as one chunk tally.
    pub fn to_f64(&self) -> ChunkTally {
        let v: Vec<f64> = self.totals.iter().map(|x| x.to_f64()).collect();
        let m = |i: usize| Moments {
            sum: v[i],
            sum_sq: v[i + 1],
        };
        ChunkTally {
            photons: self.photons,
            events: self.events,
            specular: v[0],
            rd: m(1),
            transmittance: m(3),
            absorbed: m(5),
            rd_bins: self.rd_bins.to_f64(),
            rd_beyond: v[7],
            single: m(8),
            single_bins: self.single_bins.to_f64(),
            roulette_loss: v[10],
            roulette_gain: v[11],
            truncated: v[12],
            truncated_photons: self.truncated_photons,
            exit: self.exit.to_f64(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_are_exact_and_order_free() {
        let xs = [
            1.0,
            1e-17,
            3.5e-9,
            0.1,
            7.25e3,
            1e-30,
            0.3,
            2.0f64.powi(-100),
        ];
        let mut a = ExactSum::default();
        for x in xs {
            a.add_f64(x);
        }
        let mut b = ExactSum::default();
        for x in xs.iter().rev() {
            b.add_f64(*x);
        }
        assert_eq!(a, b);
        // Split in two halves added separately, then combined.
        let (mut c, mut d) = (ExactSum::default(), ExactSum::default());
        xs[..3].iter().for_each(|x| c.add_f64(*x));
        xs[3..].iter().for_each(|x| d.add_f64(*x));
        d.add(&c);
        assert_eq!(a, d);
        let sum: f64 = xs.iter().sum();
        assert!((a.to_f64() - sum).abs() <= 1e-15 * sum);
        // Representable values come back exactly; hex round-trips.
        for x in [0.75, 1e-20, 12345.678, 2.0f64.powi(-120)] {
            let mut e = ExactSum::default();
            e.add_f64(x);
            assert_eq!(e.to_f64(), x);
            assert_eq!(ExactSum::from_hex(&e.to_hex()), Some(e));
        }
        assert_eq!(ExactSum::from_hex("zz"), None);
    }
}
