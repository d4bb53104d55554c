//! Scores of a chunk of photons: sums and sums of squares of per-photon
//! contributions, so every bin and total carries a standard error from the
//! per-photon second moment (Wang et al. 1995), and the exact bookkeeping
//! that closes the energy balance.

use crate::profile::RadialGrid;

/// Sum and sum of squares of one per-photon quantity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    pub sum: f64,
    pub sum_sq: f64,
}

impl Moments {
    #[inline(always)]
    pub fn add(&mut self, x: f64) {
        self.sum += x;
        self.sum_sq += x * x;
    }

    pub fn merge(&mut self, o: &Moments) {
        self.sum += o.sum;
        self.sum_sq += o.sum_sq;
    }

    /// Mean per photon over `n` photons.
    pub fn mean(&self, n: u64) -> f64 {
        if n == 0 {
            0.0
        } else {
            self.sum / n as f64
        }
    }

    /// Standard error of the mean: sqrt((<x^2> - <x>^2) / (n - 1)).
    pub fn stderr(&self, n: u64) -> f64 {
        if n < 2 {
            return 0.0;
        }
        let nf = n as f64;
        let m = self.sum / nf;
        ((self.sum_sq / nf - m * m).max(0.0) / (nf - 1.0)).sqrt()
    }
}

/// Radius to bin, with a fast path for uniform grids.
#[derive(Clone, Debug)]
pub struct BinIndex {
    edges: Vec<f64>,
    r_max: f64,
    /// 1 / dr when the grid is uniform.
    inv_dr: Option<f64>,
}

impl BinIndex {
    pub fn new(grid: &RadialGrid) -> BinIndex {
        let n = grid.len();
        let dr = grid.edges[1] - grid.edges[0];
        let uniform = grid
            .edges
            .iter()
            .enumerate()
            .all(|(i, &e)| (e - i as f64 * dr).abs() <= 1e-9 * dr.max(e));
        BinIndex {
            edges: grid.edges.clone(),
            r_max: grid.r_max(),
            inv_dr: uniform.then_some(n as f64 / grid.r_max()),
        }
    }

    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }

    #[inline(always)]
    pub fn bin(&self, r: f64) -> Option<usize> {
        if !(r < self.r_max) {
            return None;
        }
        match self.inv_dr {
            Some(k) => Some(((r * k) as usize).min(self.len() - 1)),
            None => Some(self.edges.partition_point(|&e| e <= r) - 1),
        }
    }
}

/// Per-bin sums of a radial tally.
#[derive(Clone, Debug, Default)]
pub struct BinSums {
    pub sum: Vec<f64>,
    pub sum_sq: Vec<f64>,
}

impl BinSums {
    /// Adds one packet's total `v` in bin `i` and its square.
    #[inline(always)]
    fn add_square(&mut self, i: usize, v: f64) {
        self.sum[i] += v;
        self.sum_sq[i] += v * v;
    }

    pub(super) fn new(n: usize) -> BinSums {
        BinSums {
            sum: vec![0.0; n],
            sum_sq: vec![0.0; n],
        }
    }
}

/// Everything a chunk of photons scored.
#[derive(Clone, Debug, Default)]
pub struct ChunkTally {
    pub photons: u64,
    /// Interactions and boundary hits.
    pub events: u64,
    pub specular: f64,
    pub rd: Moments,
    /// Diffuse reflectance that left at x > 0, ahead of the entry point
    /// along the plane of incidence, and the sum over packets of its
    /// product with the packet's R_d (the covariance of the ahead share).
    pub rd_ahead: Moments,
    pub rd_ahead_cross: f64,
    pub transmittance: Moments,
    pub absorbed: Moments,
    /// Diffuse reflectance per radial bin (weights, not densities).
    pub rd_bins: BinSums,
    /// Reflectance that left beyond r_max (counted in `rd`).
    pub rd_beyond: f64,
    /// Reflectance of packets scattered exactly once (optional tally).
    pub single: Moments,
    pub single_bins: BinSums,
    pub roulette_loss: f64,
    pub roulette_gain: f64,
    pub truncated: f64,
    pub truncated_photons: u64,
    /// Exit-angle tallies (empty unless `WalkSettings::angular`).
    pub exit: ExitSums,
    /// Transmittance per radial bin at the bottom surface, then the
    /// entry for exits beyond r_max, then the part of all of it that
    /// scattered at least once (empty for a semi-infinite stack).
    pub tr_bins: BinSums,
    /// Exit-angle tallies of the transmitted light (empty unless the stack
    /// is finite and the walk tallies angles).
    pub tr_exit: ExitSums,
}

impl ChunkTally {
    pub fn new(bins: usize, single_scatter: bool) -> ChunkTally {
        ChunkTally {
            rd_bins: BinSums::new(bins),
            single_bins: BinSums::new(if single_scatter { bins } else { 0 }),
            ..Default::default()
        }
    }

    /// Zeroes every score, keeping the bin layout (reused per chunk).
    pub fn reset(&mut self) {
        let rd_bins = std::mem::take(&mut self.rd_bins);
        let single_bins = std::mem::take(&mut self.single_bins);
        let mut exit = std::mem::take(&mut self.exit);
        exit.fill_zero();
        let tr_bins = std::mem::take(&mut self.tr_bins);
        let mut tr_exit = std::mem::take(&mut self.tr_exit);
        tr_exit.fill_zero();
        *self = ChunkTally {
            rd_bins,
            single_bins,
            exit,
            tr_bins,
            tr_exit,
            ..Default::default()
        };
        for v in [
            &mut self.rd_bins.sum,
            &mut self.rd_bins.sum_sq,
            &mut self.single_bins.sum,
            &mut self.single_bins.sum_sq,
            &mut self.tr_bins.sum,
            &mut self.tr_bins.sum_sq,
        ] {
            v.fill(0.0);
        }
    }

    /// Roulette losses minus gains plus truncated weight: the part of the
    /// launched energy not in specular, R_d, T or absorption.
    pub fn residual(&self) -> f64 {
        self.roulette_loss - self.roulette_gain + self.truncated
    }
}

/// How exits are binned by angle: `angle_bins` bins uniform in the polar
/// angle of the escaping direction in the ambient medium, over [0, 90]
/// degrees (MCML's `na`, da = pi / (2 na)), crossed with the radial bins
/// plus one row for exits beyond r_max (`radial` rows in all; 0: no
/// radius-angle table, only the angle bins).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AngleLayout {
    pub angle_bins: usize,
    pub radial: usize,
}

impl AngleLayout {
    /// The bin of an exit with cosine `cos_out` (in the ambient medium) in
    /// [0, 1]: floor(theta / da), the last bin for theta = 90 degrees, as
    /// MCML's RecordR.
    #[inline(always)]
    pub fn angle_bin(&self, cos_out: f64) -> usize {
        let theta = cos_out.clamp(0.0, 1.0).acos();
        let k = (theta * (2.0 * self.angle_bins as f64 / std::f64::consts::PI)) as usize;
        k.min(self.angle_bins - 1)
    }
}

/// Sums of the exit-angle tallies: `ra[ir * angle_bins + ia]` (radius row
/// `ir`, the last row beyond r_max) and `a[ia]` over the whole plane with
/// `a_cross`, the sum over photons of (weight in bin ia) x (photon's whole
/// R_d), for the standard error of each bin's share of R_d.
#[derive(Clone, Debug, Default)]
pub struct ExitSums {
    pub ra: BinSums,
    pub a: BinSums,
    pub a_cross: Vec<f64>,
}

impl ExitSums {
    pub fn new(l: AngleLayout) -> ExitSums {
        ExitSums {
            ra: BinSums::new(l.radial * l.angle_bins),
            a: BinSums::new(l.angle_bins),
            a_cross: vec![0.0; l.angle_bins],
        }
    }

    pub fn is_empty(&self) -> bool {
        self.a.sum.is_empty()
    }

    fn fill_zero(&mut self) {
        for v in [
            &mut self.ra.sum,
            &mut self.ra.sum_sq,
            &mut self.a.sum,
            &mut self.a.sum_sq,
            &mut self.a_cross,
        ] {
            v.fill(0.0);
        }
    }
}

/// One packet's exit-angle scores before they are squared (see
/// `PhotonScratch`).
#[derive(Clone, Debug, Default)]
pub struct ExitScratch {
    ra: Vec<f64>,
    touched_ra: Vec<u32>,
    a: Vec<f64>,
    touched_a: Vec<u32>,
}

impl ExitScratch {
    pub fn new(l: AngleLayout) -> ExitScratch {
        ExitScratch {
            ra: vec![0.0; l.radial * l.angle_bins],
            touched_ra: Vec::new(),
            a: vec![0.0; l.angle_bins],
            touched_a: Vec::new(),
        }
    }

    /// Scores weight `w` leaving through angle bin `ia` at radius row `ir`
    /// (ignored when the layout has no radius-angle table).
    #[inline(always)]
    pub fn score(&mut self, l: AngleLayout, ir: usize, ia: usize, w: f64) {
        add_sparse(&mut self.a, &mut self.touched_a, ia, w);
        if l.radial > 0 {
            let i = ir.min(l.radial - 1) * l.angle_bins + ia;
            add_sparse(&mut self.ra, &mut self.touched_ra, i, w);
        }
    }

    /// Adds the packet's per-bin totals, their squares and their products
    /// with the packet's R_d `rd` to `t`.
    pub fn flush(&mut self, t: &mut ExitSums, rd: f64) {
        drain_sparse(&mut self.a, &mut self.touched_a, |i, v| {
            t.a.add_square(i, v);
            t.a_cross[i] += v * rd;
        });
        drain_sparse(&mut self.ra, &mut self.touched_ra, |i, v| {
            t.ra.add_square(i, v)
        });
    }
}

/// One packet's radial scores before they are squared: a packet may leave
/// weight in the same bin several times (splitting), and the second moment
/// must be of its total per bin.
pub struct PhotonScratch {
    cur: Vec<f64>,
    touched: Vec<u32>,
    cur_single: Vec<f64>,
    touched_single: Vec<u32>,
    beyond: f64,
    single: f64,
    /// Exit-angle scores (empty unless the walk tallies them).
    pub exit: ExitScratch,
    /// Transmittance per radial bin and beyond (empty for a semi-infinite
    /// stack), and its exit-angle scores.
    cur_tr: Vec<f64>,
    touched_tr: Vec<u32>,
    pub tr_exit: ExitScratch,
}

impl PhotonScratch {
    pub fn new(bins: usize, single_scatter: bool) -> PhotonScratch {
        PhotonScratch {
            cur: vec![0.0; bins],
            touched: Vec::with_capacity(64),
            cur_single: vec![0.0; if single_scatter { bins } else { 0 }],
            touched_single: Vec::new(),
            beyond: 0.0,
            single: 0.0,
            exit: ExitScratch::default(),
            cur_tr: Vec::new(),
            touched_tr: Vec::new(),
            tr_exit: ExitScratch::default(),
        }
    }

    /// Makes room for the transmittance tally of `bins` radial bins (plus
    /// the one beyond r_max) in this scratch and in `t`, and for its angle
    /// bins when `angles` is given (a finite stack's walk).
    pub fn transmitting(&mut self, t: &mut ChunkTally, bins: usize, angles: Option<AngleLayout>) {
        if self.cur_tr.len() != bins + 2 {
            self.cur_tr = vec![0.0; bins + 2];
            self.touched_tr.clear();
        }
        if t.tr_bins.sum.len() != bins + 2 {
            t.tr_bins = BinSums::new(bins + 2);
        }
        if let Some(l) = angles {
            if t.tr_exit.a.sum.len() != l.angle_bins
                || t.tr_exit.ra.sum.len() != l.radial * l.angle_bins
            {
                t.tr_exit = ExitSums::new(l);
                self.tr_exit = ExitScratch::new(l);
            }
        }
    }

    /// Scores weight `w` transmitted through the bottom at radius `r`
    /// (the entry after the bins beyond r_max), and in the last entry too
    /// when the packet scattered on its way.
    #[inline(always)]
    pub fn score_transmittance(&mut self, bins: &BinIndex, r: f64, w: f64, scatters: u32) {
        let i = bins.bin(r).unwrap_or(bins.len());
        add_sparse(&mut self.cur_tr, &mut self.touched_tr, i, w);
        if scatters > 0 {
            add_sparse(&mut self.cur_tr, &mut self.touched_tr, bins.len() + 1, w);
        }
    }

    #[inline(always)]
    pub fn score_reflectance(&mut self, bins: &BinIndex, r: f64, w: f64, scatters: u32) {
        let bin = bins.bin(r);
        match bin {
            Some(i) => add_sparse(&mut self.cur, &mut self.touched, i, w),
            None => self.beyond += w,
        }
        if scatters == 1 && !self.cur_single.is_empty() {
            self.single += w;
            if let Some(i) = bin {
                add_sparse(&mut self.cur_single, &mut self.touched_single, i, w);
            }
        }
    }

    /// Adds the packet's per-bin totals and their squares to the tally.
    pub fn flush(&mut self, t: &mut ChunkTally, single_scatter: bool) {
        drain_sparse(&mut self.cur, &mut self.touched, |i, v| {
            t.rd_bins.add_square(i, v)
        });
        t.rd_beyond += std::mem::take(&mut self.beyond);
        if !self.touched_tr.is_empty() {
            drain_sparse(&mut self.cur_tr, &mut self.touched_tr, |i, v| {
                t.tr_bins.add_square(i, v)
            });
        }
        if single_scatter {
            drain_sparse(&mut self.cur_single, &mut self.touched_single, |i, v| {
                t.single_bins.add_square(i, v)
            });
            t.single.add(std::mem::take(&mut self.single));
        }
    }
}

/// Adds `w` to entry `i` of a packet's sparse scores `v`, noting in
/// `touched` each entry it makes nonzero, so that the flush visits only
/// those.
#[inline(always)]
fn add_sparse(v: &mut [f64], touched: &mut Vec<u32>, i: usize, w: f64) {
    if v[i] == 0.0 {
        touched.push(i as u32);
    }
    v[i] += w;
}

/// Hands each touched entry of `v` (the packet's total there) to `add`,
/// leaving `v` zero and `touched` empty for the next packet.
#[inline(always)]
fn drain_sparse(v: &mut [f64], touched: &mut Vec<u32>, mut add: impl FnMut(usize, f64)) {
    for &i in touched.iter() {
        add(i as usize, std::mem::take(&mut v[i as usize]));
    }
    touched.clear();
}

/// R_d per bin (mm^-2) of a tally.
pub(super) fn densities(sum: &[f64], n: u64, areas: &[f64]) -> Vec<f64> {
    let nf = n.max(1) as f64;
    sum.iter().zip(areas).map(|(s, a)| s / (nf * a)).collect()
}

/// `convergence` of any radial tally: its total's moments and its bins'
/// sums over `n` photons (R_d, or the transmittance of a finite stack).
pub(super) fn convergence_of(
    total_m: &Moments,
    bins: &BinSums,
    n: u64,
    grid: &RadialGrid,
) -> (f64, f64, f64) {
    let total = total_m.mean(n);
    if total <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let rel_total = total_m.stderr(n) / total;
    let goal = 0.99 * total_m.sum;
    let mut acc = 0.0;
    let mut err = 0.0;
    for i in 0..grid.len() {
        let m = Moments {
            sum: bins.sum[i],
            sum_sq: bins.sum_sq[i],
        };
        acc += bins.sum[i];
        err += m.stderr(n) * n as f64;
        if acc >= goal {
            break;
        }
    }
    let r99 = crate::profile::radius::radius_reaching(&grid.edges, bins.sum.iter().copied(), goal);
    let rel_profile = if acc > 0.0 { err / acc } else { 0.0 };
    (rel_total, rel_profile, r99)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stderr_of_constant_is_zero_and_of_coin_is_known() {
        let mut m = Moments::default();
        for _ in 0..10 {
            m.add(0.5);
        }
        assert!(m.stderr(10) < 1e-12);
        let mut c = Moments::default();
        for i in 0..1000 {
            c.add((i % 2) as f64);
        }
        // Bernoulli(1/2): sd 0.5, stderr 0.5 sqrt(n/(n-1))/sqrt(n).
        let expect = 0.5 / (999.0f64).sqrt();
        assert!((c.stderr(1000) - expect).abs() < 1e-12);
    }

    #[test]
    fn bin_index_matches_grid() {
        for g in [
            RadialGrid::uniform(0.1, 1.0).unwrap(),
            RadialGrid::logarithmic(0.01, 5.0, 40).unwrap(),
        ] {
            let b = BinIndex::new(&g);
            for k in 0..1000 {
                let r = k as f64 * 0.00613;
                let want = g.bin_of(r);
                let got = b.bin(r);
                // The fast path may differ only exactly on an edge.
                if want != got {
                    let i = want.or(got).unwrap();
                    assert!((g.edges[i] - r).abs() < 1e-12 || (g.edges[i + 1] - r).abs() < 1e-12);
                }
            }
        }
    }
}
