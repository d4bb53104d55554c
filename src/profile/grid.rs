//! Radial bins for tallies and tabulated profiles.

use crate::error::{finite_positive, Error, Result};
use crate::material::{Channel, Material};
use serde::{Deserialize, Serialize};

/// ln(1e5): the tail factor e^{-kappa r_max} of the automatic grid.
const TAIL_FACTOR: f64 = 11.512_925_464_970_229;
/// Cap of the automatic r_max, in units of the largest MFP.
pub const MAX_MFP_RADIUS: f64 = 2000.0;
/// Cap of the number of uniform bins of the automatic grid.
pub const MAX_AUTO_BINS: usize = 200_000;
/// Freude 2014, table 6.1: bins per smallest mean free path (dr = min MFP / 20).
pub const THESIS_BINS_PER_MFP: f64 = 20.0;
/// Freude 2014, table 6.1: r_max in largest mean free paths (32 max MFP).
pub const THESIS_RADIUS_MFPS: f64 = 32.0;
/// Logarithmic grids: bins per e-fold of r_max / dr, and the fewest and
/// most bins (fine enough near the source, bounded in the tail).
const LOG_BINS_PER_E_FOLD: f64 = 25.0;
const MIN_LOG_BINS: usize = 50;
const MAX_LOG_BINS: usize = 2000;

/// The bin width of Freude 2014, table 6.1, from the smallest mean free path.
pub fn thesis_dr(mfp_min: f64) -> f64 {
    mfp_min / THESIS_BINS_PER_MFP
}

/// Bins of a logarithmic grid from `dr` to `r_max`: [`LOG_BINS_PER_E_FOLD`]
/// per e-fold of r_max / dr, between [`MIN_LOG_BINS`] and [`MAX_LOG_BINS`].
pub fn log_bin_count(dr: f64, r_max: f64) -> usize {
    if dr > 0.0 && r_max > dr {
        (LOG_BINS_PER_E_FOLD * (r_max / dr).ln())
            .ceil()
            .clamp(MIN_LOG_BINS as f64, MAX_LOG_BINS as f64) as usize
    } else {
        MIN_LOG_BINS
    }
}

/// Bin edges from 0 to r_max. Centres follow MCML's convention for uniform
/// grids ((i + 0.5) dr); log grids use the area-weighted centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RadialGrid {
    pub edges: Vec<f64>,
}

/// Narrowest bin and largest radius, mm: tallies divide by bin areas
/// (r_max^2 - ...), which must neither underflow nor overflow.
pub const MIN_BIN_MM: f64 = 1e-12;
pub const MAX_RADIUS_MM: f64 = 1e15;

fn check_range(dr: f64, r_max: f64) -> Result<()> {
    if dr < MIN_BIN_MM {
        return Err(Error::invalid(
            "radial grid",
            "dr",
            dr,
            format!("bins narrower than {MIN_BIN_MM:e} mm have areas too small to divide by"),
        ));
    }
    if r_max > MAX_RADIUS_MM {
        return Err(Error::invalid(
            "radial grid",
            "rmax",
            r_max,
            format!("radii above {MAX_RADIUS_MM:e} mm give bin areas too large to hold"),
        ));
    }
    Ok(())
}

impl RadialGrid {
    /// Refuses edges that are not a grid: fewer than 2, not starting at 0,
    /// not finite and strictly increasing (a given grid is only data).
    pub fn check_edges(&self) -> Result<()> {
        let e = &self.edges;
        let max = crate::limits::MAX_RADIAL_BINS;
        if e.len() > max + 1 {
            return Err(self.edges_error(format!("at most {max} bins")));
        }
        if e.len() < 2 || e[0] != 0.0 || e.windows(2).any(|w| !(w[1] > w[0] && w[1].is_finite())) {
            return Err(self.edges_error(
                "need at least 2 edges, starting at 0, finite and strictly increasing",
            ));
        }
        Ok(())
    }

    /// The error of edges that break `reason` (they are counted, not
    /// listed: a refused grid may hold millions).
    pub(crate) fn edges_error(&self, reason: impl Into<String>) -> Error {
        let n = format!("{} values", self.edges.len());
        Error::invalid("radial grid", "edges", n, reason)
    }

    /// `n = ceil(r_max / dr)` uniform bins of width `dr`.
    pub fn uniform(dr: f64, r_max: f64) -> Result<RadialGrid> {
        finite_positive("radial grid", "dr", dr, "")?;
        if !(r_max.is_finite() && r_max >= dr) {
            return Err(Error::invalid(
                "radial grid",
                "rmax",
                r_max,
                "must be finite and >= dr",
            ));
        }
        check_range(dr, r_max)?;
        let n = (r_max / dr - 1e-9).ceil().max(1.0);
        let max = crate::limits::MAX_RADIAL_BINS;
        if n > max as f64 {
            return Err(Error::invalid(
                "radial grid",
                "dr",
                dr,
                format!(
                    "gives {n:.0} bins up to {r_max} mm, more than {max}: use a wider bin or a \
                     smaller radius"
                ),
            ));
        }
        let n = n as usize;
        Ok(RadialGrid {
            edges: (0..=n).map(|i| i as f64 * dr).collect(),
        })
    }

    /// Bins whose width grows geometrically from `dr_min` at the centre to
    /// r_max, so that both the peak and a long tail are resolved.
    pub fn logarithmic(dr_min: f64, r_max: f64, n: usize) -> Result<RadialGrid> {
        finite_positive("radial grid", "dr", dr_min, "")?;
        if !(r_max.is_finite() && r_max > dr_min) {
            return Err(Error::invalid(
                "radial grid",
                "rmax",
                r_max,
                "must be finite and > dr",
            ));
        }
        check_range(dr_min, r_max)?;
        if n < 2 {
            return Err(Error::invalid(
                "radial grid",
                "bins",
                n,
                "need at least 2 bins",
            ));
        }
        // Edges e_i = dr_min (q^i - 1)/(q - 1): first width dr_min, e_n = r_max.
        let target = r_max / dr_min;
        let f = |q: f64| (q.powi(n as i32) - 1.0) / (q - 1.0) - target;
        let (lo, mut hi) = (1.0 + 1e-12, 2.0f64);
        while f(hi) < 0.0 {
            hi *= 2.0;
        }
        if f(lo) > 0.0 {
            // Even uniform bins overshoot: fall back to uniform spacing.
            return RadialGrid::uniform(r_max / n as f64, r_max);
        }
        let q = crate::numerics::bisect(f, lo, hi, 200);
        let mut edges: Vec<f64> = (0..=n)
            .map(|i| dr_min * (q.powi(i as i32) - 1.0) / (q - 1.0))
            .collect();
        edges[n] = r_max;
        Ok(RadialGrid { edges })
    }

    /// A tally grid sized from the material (Freude 2014, table 6.1 as the starting
    /// point): dr = min MFP / 20 over `channels` and layers, r_max the
    /// largest of 32 max MFP (Freude 2014) and the tail rule below, over channels.
    pub fn for_material(m: &Material, channels: &[Channel]) -> RadialGrid {
        Self::for_material_rule(m, channels, false).0
    }

    /// `for_material` (uniform, or geometric bins with `log_bins`) and a JSON
    /// record of the rule, its numbers and any warning.
    ///
    /// Tail rule: far from the source R_d(r) decays like e^{-kappa r} times a
    /// power of r, with kappa <= sigma_tr in the diffusion regime and kappa <=
    /// sigma_t (uncollided transport) always, so kappa = min(sigma_tr,
    /// sigma_t) over the layers. r_max = ln(1e5) / kappa puts the exponential
    /// factor at 1e-5, ten times below the 1e-4 goal as a margin for the
    /// power-law prefactor (checked against the dipole in the tests). For
    /// sigma_a = 0 (kappa = 0) the tail is a power law and no finite grid
    /// meets the rule: r_max is capped at `MAX_MFP_RADIUS` MFP and a warning
    /// is recorded.
    pub fn for_material_rule(
        m: &Material,
        channels: &[Channel],
        log_bins: bool,
    ) -> (RadialGrid, serde_json::Value) {
        let channels = if channels.is_empty() {
            &Channel::ALL[..]
        } else {
            channels
        };
        let mut mfp_min = f64::INFINITY;
        let mut mfp_max: f64 = 0.0;
        let mut kappa_min = f64::INFINITY;
        let mut warnings = Vec::new();
        for &ch in channels {
            let mut kappa = f64::INFINITY;
            for i in 0..m.layers.len() {
                let md = m.medium(i, ch);
                let mfp = md.mfp();
                mfp_min = mfp_min.min(mfp);
                mfp_max = mfp_max.max(mfp);
                kappa = kappa.min(md.sigma_tr().min(md.sigma_t()));
            }
            if !(kappa > 0.0) {
                warnings.push(format!(
                    "channel {}: sigma_a = 0, R_d has a power-law tail; r_max capped at {} MFP, \
                     see rd_beyond_rmax for the reflectance left outside",
                    ch.name(),
                    MAX_MFP_RADIUS
                ));
            }
            kappa_min = kappa_min.min(kappa);
        }
        let mut dr = thesis_dr(mfp_min);
        let r_002 = THESIS_RADIUS_MFPS * mfp_max;
        let r_tail = TAIL_FACTOR / kappa_min;
        let r_cap = MAX_MFP_RADIUS * mfp_max;
        let r_max = r_002.max(r_tail.min(r_cap));
        if r_max / dr > MAX_AUTO_BINS as f64 {
            dr = r_max / MAX_AUTO_BINS as f64;
            warnings.push(format!(
                "grid: dr widened to {dr:.4e} mm to keep {MAX_AUTO_BINS} bins; \
                 logarithmic bins (`log_bins`) resolve the centre"
            ));
        }
        let (grid, bins) = if log_bins {
            let n = log_bin_count(thesis_dr(mfp_min), r_max);
            let g = RadialGrid::logarithmic(thesis_dr(mfp_min), r_max, n);
            (g, n)
        } else {
            let g = RadialGrid::uniform(dr, r_max);
            let n = g.as_ref().map_or(0, |g| g.len());
            (g, n)
        };
        // The numbers above are finite and positive for a validated material.
        let grid = grid.unwrap_or_else(|_| RadialGrid {
            edges: vec![0.0, r_max.max(1e-9)],
        });
        let rule = serde_json::json!({
            "rule": if log_bins {
                "log bins from dr = min MFP/20 (Freude 2014, table 6.1); r_max = max(32 max MFP, ln(1e5)/min(sigma_tr, sigma_t)) capped at 2000 MFP"
            } else {
                "dr = min MFP/20 (Freude 2014, table 6.1); r_max = max(32 max MFP, ln(1e5)/min(sigma_tr, sigma_t)) capped at 2000 MFP"
            },
            "dr_mm": dr,
            "r_max_mm": grid.r_max(),
            "bins": bins,
            "log_bins": log_bins,
            "tail_rule_met": r_tail <= r_cap,
            "warnings": warnings,
        });
        (grid, rule)
    }

    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn r_max(&self) -> f64 {
        *self.edges.last().unwrap()
    }

    /// Bin centres: (i + 1/2) dr on uniform grids (MCML), midpoints otherwise.
    pub fn centres(&self) -> Vec<f64> {
        self.edges.windows(2).map(|e| 0.5 * (e[0] + e[1])).collect()
    }

    /// Annulus area of each bin, pi (r_o^2 - r_i^2).
    pub fn areas(&self) -> Vec<f64> {
        self.edges
            .windows(2)
            .map(|e| crate::numerics::annulus_area(e[0], e[1]))
            .collect()
    }

    /// The bin holding radius `r`, or None beyond r_max.
    pub fn bin_of(&self, r: f64) -> Option<usize> {
        if !(r >= 0.0) || r >= self.r_max() {
            return None;
        }
        Some(self.edges.partition_point(|&e| e <= r) - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 25 bins per e-fold of r_max / dr, clamped to [50, 2000]; 50 where
    /// the span is empty or dr is no width.
    #[test]
    fn log_bin_count_follows_the_rule() {
        assert_eq!(log_bin_count(1.0, 4f64.exp()), 100);
        assert_eq!(log_bin_count(0.5, 0.5 * 10f64.exp()), 250);
        assert_eq!(log_bin_count(1.0, 1f64.exp()), MIN_LOG_BINS);
        assert_eq!(log_bin_count(1.0, 100f64.exp()), MAX_LOG_BINS);
        assert_eq!(log_bin_count(0.0, 1.0), MIN_LOG_BINS);
        assert_eq!(log_bin_count(2.0, 1.0), MIN_LOG_BINS);
        assert_eq!(thesis_dr(0.4), 0.02);
    }

    #[test]
    fn uniform_grid() {
        let g = RadialGrid::uniform(0.1, 1.0).unwrap();
        assert_eq!(g.len(), 10);
        assert!((g.centres()[0] - 0.05).abs() < 1e-15);
        assert_eq!(g.bin_of(0.15), Some(1));
        assert_eq!(g.bin_of(1.0), None);
        assert!(RadialGrid::uniform(0.0, 1.0).is_err());
        assert!(RadialGrid::uniform(f64::NAN, 1.0).is_err());
    }

    #[test]
    fn material_grid_rules() {
        use crate::material::preset;
        // skin1: dr = MFP_b / 20, r_max from the red channel's diffusion tail.
        let m = preset("skin1").unwrap();
        let (g, rule) = RadialGrid::for_material_rule(&m, &Channel::ALL, false);
        assert!((g.edges[1] - m.top(Channel::B).mfp() / 20.0).abs() < 1e-12);
        let tail = TAIL_FACTOR / m.top(Channel::R).sigma_tr();
        assert!(g.r_max() >= tail && g.r_max() < tail + g.edges[1] * 1.0001);
        assert_eq!(rule["tail_rule_met"], true);
        // Wine barely scatters: the tail is bounded by sigma_t, not sigma_tr.
        let w = preset("wine").unwrap();
        let gw = RadialGrid::for_material(&w, &[Channel::R]);
        let md = w.top(Channel::R);
        assert!(md.sigma_t() < md.sigma_tr());
        assert!(gw.r_max() >= TAIL_FACTOR / md.sigma_t());
        // Albedo 1: capped, with a warning; an empty list means all channels.
        let s = preset("spectralon").unwrap();
        let (gs, rule) = RadialGrid::for_material_rule(&s, &[], false);
        assert_eq!(rule["tail_rule_met"], false);
        assert!(rule["warnings"].to_string().contains("power-law"));
        assert!(gs.r_max() <= MAX_MFP_RADIUS * 1.0001 / 11.6 + gs.edges[1]);
        // Log bins start at dr and end at r_max.
        let (gl, _) = RadialGrid::for_material_rule(&m, &Channel::ALL, true);
        assert!((gl.edges[1] - g.edges[1]).abs() < 1e-9);
        assert!((gl.r_max() - g.r_max()).abs() < g.edges[1]);
        assert!(gl.len() < g.len());
    }

    #[test]
    fn log_grid_spans_range() {
        let g = RadialGrid::logarithmic(0.01, 100.0, 200).unwrap();
        assert_eq!(g.len(), 200);
        assert!((g.edges[1] - 0.01).abs() < 1e-9);
        assert_eq!(g.r_max(), 100.0);
        assert!(g.edges.windows(2).all(|w| w[1] > w[0]));
        let total: f64 = g.areas().iter().sum();
        assert!((total - std::f64::consts::PI * 1e4).abs() < 1e-6);
    }
}
