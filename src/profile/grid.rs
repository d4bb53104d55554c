//! Radial bins for tallies and tabulated profiles.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Bin edges from 0 to r_max. Centres follow MCML's convention for uniform
/// grids ((i + 0.5) dr); log grids use the area-weighted centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RadialGrid {
    pub edges: Vec<f64>,
}

impl RadialGrid {
    /// `n = ceil(r_max / dr)` uniform bins of width `dr`.
    pub fn uniform(dr: f64, r_max: f64) -> Result<RadialGrid> {
        if !(dr.is_finite() && dr > 0.0) {
            return Err(Error::invalid(
                "radial grid",
                "dr",
                dr,
                "must be finite and > 0",
            ));
        }
        if !(r_max.is_finite() && r_max >= dr) {
            return Err(Error::invalid(
                "radial grid",
                "rmax",
                r_max,
                "must be finite and >= dr",
            ));
        }
        let n = (r_max / dr - 1e-9).ceil().max(1.0) as usize;
        if n > 10_000_000 {
            return Err(Error::invalid(
                "radial grid",
                "rmax/dr",
                n,
                "more than 10^7 bins; use a larger --dr or --log-bins",
            ));
        }
        Ok(RadialGrid {
            edges: (0..=n).map(|i| i as f64 * dr).collect(),
        })
    }

    /// Bins whose width grows geometrically from `dr_min` at the centre to
    /// r_max, so that both the peak and a long tail are resolved.
    pub fn logarithmic(dr_min: f64, r_max: f64, n: usize) -> Result<RadialGrid> {
        if !(dr_min.is_finite() && dr_min > 0.0) {
            return Err(Error::invalid(
                "radial grid",
                "dr",
                dr_min,
                "must be finite and > 0",
            ));
        }
        if !(r_max.is_finite() && r_max > dr_min) {
            return Err(Error::invalid(
                "radial grid",
                "rmax",
                r_max,
                "must be finite and > dr",
            ));
        }
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
        let (mut lo, mut hi) = (1.0 + 1e-12, 2.0f64);
        while f(hi) < 0.0 {
            hi *= 2.0;
        }
        if f(lo) > 0.0 {
            // Even uniform bins overshoot: fall back to uniform spacing.
            return RadialGrid::uniform(r_max / n as f64, r_max);
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if f(mid) > 0.0 {
                hi = mid
            } else {
                lo = mid
            }
        }
        let q = 0.5 * (lo + hi);
        let mut edges: Vec<f64> = (0..=n)
            .map(|i| dr_min * (q.powi(i as i32) - 1.0) / (q - 1.0))
            .collect();
        edges[n] = r_max;
        Ok(RadialGrid { edges })
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
            .map(|e| std::f64::consts::PI * (e[1] * e[1] - e[0] * e[0]))
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
