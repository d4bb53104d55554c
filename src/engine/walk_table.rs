//! A unit Random Walk tabulated for fitting: its exits counted by radius
//! and number of scatterings, so that any alpha (each exit weighted by the
//! alphas of its scatterings) and any extinction (the exit profile scales
//! as sigma_t^2 R(sigma_t r)) is read without another pass over the exits;
//! the per-channel fit of Cycles' Base Color and extinction from it.

use super::cycles_walk::{self, UnitWalk, MAX_BOUNCES};
use super::model::Target;
use super::priority::Priority;
use crate::numerics::minimise_log;
use crate::profile::Profile;
use std::f64::consts::PI;

/// The fine radial table of the fit: log-spaced edges in mean free paths
/// from TABLE_MIN to TABLE_MIN x 10^TABLE_DECADES, TABLE_PER_DECADE a
/// decade (a bin 2.9% wide; linear interpolation of the cumulative mass
/// inside it).
const TABLE_MIN: f64 = 1e-3;
const TABLE_DECADES: usize = 6;
const TABLE_PER_DECADE: usize = 80;
/// The Base Color searched (the remap's whole useful range).
pub const COLOUR_RANGE: (f64, f64) = (1e-3, 1.0);
/// Extinctions searched, in units of 1 / r99 of the profile: a walk's r99
/// lies between a tenth of a mean free path (alpha at MIN_ALPHA) and a few
/// hundred (alpha near 1, the flight cap).
const SIGMA_T_RANGE_R99: (f64, f64) = (1e-3, 1e4);
const SCAN: usize = 15;
/// Bisection steps of the colour that reflects a total: the colour's
/// interval shrinks by 2^-60, far below the 4 printed digits.
const BISECTIONS: usize = 60;

/// The table's edges in mean free paths (also the grid of the printed
/// values' profile for scripts/engine-cycles).
pub fn table_edges() -> Vec<f64> {
    let n = TABLE_DECADES * TABLE_PER_DECADE;
    std::iter::once(0.0)
        .chain((0..=n).map(|k| TABLE_MIN * 10f64.powf(k as f64 / TABLE_PER_DECADE as f64)))
        .collect()
}

/// A unit walk's exits counted by table bin and scatterings, per walk:
/// the cumulative weight for any alpha without a pass over the exits.
pub struct Table {
    edges: Vec<f64>,
    /// counts[row * MAX_BOUNCES + n], per walk.
    counts: Vec<f64>,
    pub walk: UnitWalk,
}

impl Table {
    pub fn new(walk: UnitWalk) -> Table {
        let edges = table_edges();
        // Row j < edges.len() holds the exits in [e_{j-1}, e_j); the last
        // row those beyond the table.
        let bins = edges.len() + 1;
        let mut counts = vec![0.0; bins * MAX_BOUNCES];
        let per_walk = 1.0 / walk.walks as f64;
        for &(r, n) in &walk.exits {
            let k = edges.partition_point(|e| *e <= r);
            counts[k * MAX_BOUNCES + n as usize] += per_walk;
        }
        Table {
            edges,
            counts,
            walk,
        }
    }

    /// The cumulative exit weight by radius of a channel walking `alpha`.
    pub fn cumulative(&self, alpha: f64) -> Cumulative<'_> {
        let w: Vec<f64> = (0..MAX_BOUNCES)
            .map(|n| self.walk.weight(n as u16, alpha))
            .collect();
        let mut acc = 0.0;
        let mut inside: Vec<f64> = self
            .counts
            .chunks(MAX_BOUNCES)
            .map(|row| {
                acc += row.iter().zip(&w).map(|(c, w)| c * w).sum::<f64>();
                acc
            })
            .collect();
        // The last row is the exits beyond the table: in the total only.
        let total = inside.pop().unwrap_or(0.0);
        Cumulative {
            edges: &self.edges,
            inside,
            total,
        }
    }

    /// What a channel of Base Color `colour` reflects in total (the
    /// throughput of the remap's clamp included).
    pub fn total_for(&self, colour: f64, g: f64) -> f64 {
        let ch = cycles_walk::channel(colour, 1.0, g);
        ch.throughput * self.cumulative(ch.alpha).total
    }
}

/// Cumulative exit weight of a unit walk by radius, for one alpha.
pub struct Cumulative<'a> {
    edges: &'a [f64],
    /// Weight inside each edge, per walk.
    inside: Vec<f64>,
    pub total: f64,
}

impl Cumulative<'_> {
    /// Weight inside radius u (mean free paths).
    pub fn at(&self, u: f64) -> f64 {
        let e = self.edges;
        if u >= e[e.len() - 1] {
            return self.total;
        }
        if u < e[1] {
            // Uniform per area inside the first edge.
            return self.inside[1] * (u / e[1]).powi(2);
        }
        let k = e.partition_point(|x| *x <= u);
        let t = (u.ln() - e[k - 1].ln()) / (e[k].ln() - e[k - 1].ln());
        self.inside[k - 1] + t * (self.inside[k] - self.inside[k - 1])
    }

    /// R_d per mm^2 on the annuli `edges` (mm) for extinction `sigma_t`
    /// (1/mm) and throughput `k`.
    pub fn bins(&self, edges: &[f64], sigma_t: f64, k: f64) -> Vec<f64> {
        edges
            .windows(2)
            .map(|e| {
                let m = self.at(e[1] * sigma_t) - self.at(e[0] * sigma_t);
                k * m / (PI * (e[1].powi(2) - e[0].powi(2)))
            })
            .collect()
    }
}

/// The residual of r R_d for extinction `sigma_t` and throughput `k`.
fn residual(t: &Target, edges: &[f64], c: &Cumulative, sigma_t: f64, k: f64) -> f64 {
    let rd = c.bins(&edges[..=t.bins], sigma_t, k);
    (0..t.bins)
        .map(|i| t.weight[i] * (rd[i] - t.value[i]).powi(2))
        .sum()
}

/// The Base Color whose walk reflects `total`, by bisection (the walk's
/// total grows with the colour through the remap); the ends of
/// [`COLOUR_RANGE`] where it lies beyond them.
pub fn colour_for_total(table: &Table, g: f64, total: f64) -> f64 {
    let (mut lo, mut hi) = COLOUR_RANGE;
    if table.total_for(hi, g) <= total {
        return hi;
    }
    if table.total_for(lo, g) >= total {
        return lo;
    }
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if table.total_for(mid, g) < total {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The best Base Color and extinction (1/mm) of channel `c` read from
/// `table`: with `Priority::Colour` the colour that reflects the
/// profile's total and the extinction that fits the shape for it; with
/// `Priority::Shape` both by least squares on r R_d.
pub fn fit_channel(p: &Profile, c: usize, g: f64, table: &Table, priority: Priority) -> (f64, f64) {
    let t = Target::new(p, c);
    let r99 = crate::profile::radius_holding(p, c, crate::profile::metrics::SHAPE_HOLD);
    let (lo, hi) = SIGMA_T_RANGE_R99;
    let best_sigma_t = |colour: f64| {
        let ch = cycles_walk::channel(colour, 1.0, g);
        let cum = table.cumulative(ch.alpha);
        let cost = |s: f64| residual(&t, &p.r_edges, &cum, s, ch.throughput);
        let s = minimise_log(cost, lo / r99, hi / r99, SCAN);
        (s, cost(s))
    };
    let colour = match priority {
        Priority::Colour => colour_for_total(table, g, p.total_rd[c]),
        Priority::Shape => {
            let (clo, chi) = COLOUR_RANGE;
            minimise_log(|b| best_sigma_t(b).1, clo, chi, SCAN)
        }
    };
    (colour, best_sigma_t(colour).0)
}
