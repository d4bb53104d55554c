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
    /// Adds `x` exactly; false (nothing added) for a value no tally holds:
    /// negative, NaN, infinite or 2^64 and above, or a sum beyond 192 bits.
    #[must_use]
    pub fn add_f64(&mut self, x: f64) -> bool {
        if x == 0.0 {
            return true;
        }
        if !(x > 0.0 && x < 18_446_744_073_709_551_616.0) {
            return false;
        }
        let bits = x.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i32;
        let frac = bits & ((1u64 << 52) - 1);
        let (m, e) = if exp == 0 {
            (frac, -1074)
        } else {
            (frac | (1u64 << 52), exp - 1075)
        };
        // x = m 2^e = m 2^(e + 128) units of 2^-128; x < 2^64 makes
        // s - 64 <= 75 - 53 below.
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
            ExactSum {
                hi: (m as u128) << (s - 64) as u32,
                lo: 0,
            }
        };
        self.add(&part)
    }

    /// Adds `o` exactly; false (self unchanged) when the sum leaves the
    /// 192 bits (never for a run's own sums; a tampered file can ask for it).
    #[must_use]
    pub fn add(&mut self, o: &ExactSum) -> bool {
        let (lo, carry) = self.lo.overflowing_add(o.lo);
        match self
            .hi
            .checked_add(o.hi)
            .and_then(|h| h.checked_add(carry as u128))
        {
            Some(hi) => {
                *self = ExactSum { hi, lo };
                true
            }
            None => false,
        }
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

    #[must_use]
    fn add_chunk(&mut self, b: &BinSums) -> bool {
        let mut ok = true;
        for (a, x) in self.sum.iter_mut().zip(&b.sum) {
            ok &= a.add_f64(*x);
        }
        for (a, x) in self.sum_sq.iter_mut().zip(&b.sum_sq) {
            ok &= a.add_f64(*x);
        }
        ok
    }

    #[must_use]
    fn add(&mut self, o: &ExactBins) -> bool {
        let mut ok = true;
        for (a, x) in self.sum.iter_mut().zip(&o.sum) {
            ok &= a.add(x);
        }
        for (a, x) in self.sum_sq.iter_mut().zip(&o.sum_sq) {
            ok &= a.add(x);
        }
        ok
    }

    /// Adds a chunk's sums, taking their size on first use (a tally kept
    /// only by some runs: the transmittance of a finite stack).
    #[must_use]
    fn add_chunk_sized(&mut self, b: &BinSums) -> bool {
        if b.sum.is_empty() {
            return true;
        }
        if self.sum.is_empty() {
            *self = ExactBins::new(b.sum.len());
        }
        self.sum.len() == b.sum.len() && self.add_chunk(b)
    }

    /// `add` taking the other's size when this one is empty.
    #[must_use]
    fn add_sized(&mut self, o: &ExactBins) -> bool {
        if o.sum.is_empty() {
            return true;
        }
        if self.sum.is_empty() {
            *self = o.clone();
            return true;
        }
        self.sum.len() == o.sum.len() && self.add(o)
    }

    pub fn is_empty(&self) -> bool {
        self.sum.is_empty()
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

    fn same_layout(&self, ra: usize, a: usize, cross: usize) -> bool {
        self.ra.sum.len() == ra
            && self.ra.sum_sq.len() == ra
            && self.a.sum.len() == a
            && self.a.sum_sq.len() == a
            && self.a_cross.len() == cross
    }

    /// Adds a chunk's sums, taking their layout on first use (every chunk
    /// of a run has the same).
    /// False when a sum is not one a tally holds (see `ExactSum::add_f64`)
    /// or the layouts differ.
    #[must_use]
    fn add_chunk(&mut self, e: &ExitSums) -> bool {
        if e.is_empty() {
            return true;
        }
        if self.is_empty() {
            self.ra = ExactBins::new(e.ra.sum.len());
            self.a = ExactBins::new(e.a.sum.len());
            self.a_cross = vec![ExactSum::default(); e.a_cross.len()];
        }
        if !self.same_layout(e.ra.sum.len(), e.a.sum.len(), e.a_cross.len()) {
            return false;
        }
        let mut ok = self.ra.add_chunk(&e.ra);
        ok &= self.a.add_chunk(&e.a);
        for (s, x) in self.a_cross.iter_mut().zip(&e.a_cross) {
            ok &= s.add_f64(*x);
        }
        ok
    }

    #[must_use]
    fn add(&mut self, o: &ExactExit) -> bool {
        if o.is_empty() {
            return true;
        }
        if self.is_empty() {
            *self = o.clone();
            return true;
        }
        if !self.same_layout(o.ra.sum.len(), o.a.sum.len(), o.a_cross.len()) {
            return false;
        }
        let mut ok = self.ra.add(&o.ra);
        ok &= self.a.add(&o.a);
        for (s, x) in self.a_cross.iter_mut().zip(&o.a_cross) {
            ok &= s.add(x);
        }
        ok
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
    /// Transmittance per radial bin, the last entry beyond r_max (finite
    /// stacks only).
    #[serde(default, skip_serializing_if = "ExactBins::is_empty")]
    pub tr_bins: ExactBins,
    /// Exit-angle sums of the transmitted light (angle-resolved runs of a
    /// finite stack only).
    #[serde(default, skip_serializing_if = "ExactExit::is_empty")]
    pub tr_exit: ExactExit,
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

    /// Adds a chunk's f64 sums exactly; an error names what did not fit.
    pub fn add_chunk(&mut self, t: &ChunkTally) -> std::result::Result<(), String> {
        self.add_counts(t.photons, t.events, t.truncated_photons)?;
        let mut ok = true;
        for (a, x) in self.totals.iter_mut().zip(scalars(t)) {
            ok &= a.add_f64(x);
        }
        ok &= self.rd_bins.add_chunk(&t.rd_bins);
        ok &= self.single_bins.add_chunk(&t.single_bins);
        ok &= self.exit.add_chunk(&t.exit);
        ok &= self.tr_bins.add_chunk_sized(&t.tr_bins);
        ok &= self.tr_exit.add_chunk(&t.tr_exit);
        if !ok {
            return Err("a chunk sum is negative, not finite or beyond 2^64".into());
        }
        Ok(())
    }

    /// Adds another tally exactly; an error names the count or sum that
    /// would overflow (a tampered shard), leaving this tally unusable.
    pub fn add(&mut self, o: &ExactTally) -> std::result::Result<(), String> {
        self.add_counts(o.photons, o.events, o.truncated_photons)?;
        let mut ok = true;
        for (a, x) in self.totals.iter_mut().zip(&o.totals) {
            ok &= a.add(x);
        }
        ok &= self.rd_bins.add(&o.rd_bins);
        ok &= self.single_bins.add(&o.single_bins);
        ok &= self.exit.add(&o.exit);
        ok &= self.tr_bins.add_sized(&o.tr_bins);
        ok &= self.tr_exit.add(&o.tr_exit);
        if !ok {
            return Err("an exact sum overflows its 192 bits".into());
        }
        Ok(())
    }

    fn add_counts(
        &mut self,
        photons: u64,
        events: u64,
        truncated: u64,
    ) -> std::result::Result<(), String> {
        let add = |a: u64, b: u64, what: &str| {
            a.checked_add(b)
                .ok_or_else(|| format!("the {what} count overflows 64 bits ({a} + {b})"))
        };
        self.photons = add(self.photons, photons, "photon")?;
        self.events = add(self.events, events, "event")?;
        self.truncated_photons = add(self.truncated_photons, truncated, "truncated photon")?;
        Ok(())
    }

    /// Checks what any honest tally of `photons` packets satisfies, naming
    /// the first field that does not: the energy balance closes (specular +
    /// R_d + T + absorbed + roulette loss - gain + truncated = 1 per photon,
    /// to `balance_tol`), each sum of squares is at least its sum squared
    /// over the photons (Cauchy-Schwarz: a variance is never negative), the
    /// radial bins and the reflectance beyond them add up to R_d, and no
    /// more photons were truncated than traced.
    pub fn verify(&self, balance_tol: f64) -> std::result::Result<(), String> {
        if !self.has_layout(self.rd_bins.sum.len(), !self.single_bins.sum.is_empty()) {
            return Err("the sums do not have the tally's layout".into());
        }
        let n = self.photons;
        if n == 0 {
            return Err("photons = 0".into());
        }
        if self.truncated_photons > n {
            return Err(format!(
                "truncated_photons = {} > photons = {n}",
                self.truncated_photons
            ));
        }
        let v: Vec<f64> = self.totals.iter().map(|x| x.to_f64()).collect();
        let nf = n as f64;
        let balance = (v[0] + v[1] + v[3] + v[5] + v[10] - v[11] + v[12]) / nf;
        // Roulette gains and losses cancel: their size sets the rounding.
        let scale = 1.0 + (v[10] + v[11]) / nf;
        if !((balance - 1.0).abs() <= balance_tol * scale) {
            return Err(format!(
                "energy balance {balance:.12} per photon, not 1 (within {balance_tol:e}): \
                 specular + R_d + T + absorbed + roulette loss - gain + truncated"
            ));
        }
        let moments = |name: &str, sum: f64, sum_sq: f64| {
            // n sum_sq >= sum^2, with room for the rounding of the f64 sums
            // of a chunk before they were added exactly.
            if sum_sq * nf < sum * sum * (1.0 - 1e-9) {
                return Err(format!(
                    "{name}: sum of squares {sum_sq:e} below sum^2 / photons = {:e}: a negative \
                     variance",
                    sum * sum / nf
                ));
            }
            Ok(())
        };
        for (i, name) in [
            (1, "rd"),
            (3, "transmittance"),
            (5, "absorbed"),
            (8, "single"),
        ] {
            moments(name, v[i], v[i + 1])?;
        }
        let mut binned = v[7];
        for (label, b) in [
            ("rd_bins", &self.rd_bins),
            ("single_bins", &self.single_bins),
            ("exit.ra", &self.exit.ra),
            ("exit.a", &self.exit.a),
            ("tr_bins", &self.tr_bins),
            ("tr_exit.ra", &self.tr_exit.ra),
            ("tr_exit.a", &self.tr_exit.a),
        ] {
            for (i, (s, q)) in b.sum.iter().zip(&b.sum_sq).enumerate() {
                moments(&format!("{label}[{i}]"), s.to_f64(), q.to_f64())?;
            }
        }
        binned += self.rd_bins.sum.iter().map(|x| x.to_f64()).sum::<f64>();
        if !((binned - v[1]).abs() <= 1e-9 * v[1].max(f64::MIN_POSITIVE)) {
            return Err(format!(
                "rd_bins and rd beyond r_max sum to {binned:e}, the total rd is {:e}",
                v[1]
            ));
        }
        if !self.tr_bins.is_empty() {
            // The radial bins and the one beyond r_max; the last entry is
            // the scattered part of them.
            let n = self.tr_bins.sum.len().saturating_sub(1);
            let tr: f64 = self.tr_bins.sum[..n].iter().map(|x| x.to_f64()).sum();
            let scattered = self.tr_bins.sum[n].to_f64();
            if !(scattered <= tr * (1.0 + 1e-9)) {
                return Err(format!(
                    "tr_bins: the scattered transmittance {scattered:e} exceeds the whole {tr:e}"
                ));
            }
            if !((tr - v[3]).abs() <= 1e-9 * v[3].max(f64::MIN_POSITIVE)) {
                return Err(format!(
                    "tr_bins sum to {tr:e}, the total transmittance is {:e}",
                    v[3]
                ));
            }
        }
        Ok(())
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
            tr_bins: self.tr_bins.to_f64(),
            tr_exit: self.tr_exit.to_f64(),
            // Not held in exact sums: only `angular::ahead` reads them, from
            // its own chunk tallies.
            ..ChunkTally::default()
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
            assert!(a.add_f64(x));
        }
        let mut b = ExactSum::default();
        for x in xs.iter().rev() {
            assert!(b.add_f64(*x));
        }
        assert_eq!(a, b);
        // Split in two halves added separately, then combined.
        let (mut c, mut d) = (ExactSum::default(), ExactSum::default());
        xs[..3].iter().for_each(|x| assert!(c.add_f64(*x)));
        xs[3..].iter().for_each(|x| assert!(d.add_f64(*x)));
        assert!(d.add(&c));
        assert_eq!(a, d);
        let sum: f64 = xs.iter().sum();
        assert!((a.to_f64() - sum).abs() <= 1e-15 * sum);
        // Representable values come back exactly; hex round-trips.
        for x in [0.75, 1e-20, 12345.678, 2.0f64.powi(-120)] {
            let mut e = ExactSum::default();
            assert!(e.add_f64(x));
            assert_eq!(e.to_f64(), x);
            assert_eq!(ExactSum::from_hex(&e.to_hex()), Some(e));
        }
        assert_eq!(ExactSum::from_hex("zz"), None);
    }

    /// Sums that would wrap are refused and leave the sum as it was; so are
    /// values no tally holds.
    #[test]
    fn overflow_is_refused_not_wrapped() {
        let big = ExactSum {
            hi: u128::MAX,
            lo: u64::MAX,
        };
        let mut a = big;
        assert!(!a.add(&ExactSum { hi: 0, lo: 1 }));
        assert_eq!(a, big);
        let mut b = ExactSum {
            hi: u128::MAX - 1,
            lo: u64::MAX,
        };
        assert!(b.add(&ExactSum { hi: 0, lo: 0 }));
        assert!(!b.add(&ExactSum { hi: 1, lo: 1 }));
        let mut c = ExactSum::default();
        for bad in [f64::NAN, f64::INFINITY, -1.0, 2f64.powi(64)] {
            assert!(!c.add_f64(bad), "{bad}");
        }
        assert!(c.add_f64(2f64.powi(63)));
        assert_eq!(c.to_f64(), 2f64.powi(63));
        let mut t = ExactTally::new(2, false);
        t.photons = u64::MAX;
        let one = ExactTally {
            photons: 1,
            ..ExactTally::new(2, false)
        };
        let e = t.add(&one).unwrap_err();
        assert!(e.contains("photon count overflows"), "{e}");
    }
}
