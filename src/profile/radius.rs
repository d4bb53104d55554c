//! Radii that hold a share of a binned profile's reflectance: the 2D
//! kernel's default extent, plot ranges, the region a Monte Carlo
//! convergence test watches. One definition, so that "r99" means the same
//! everywhere.

use super::Profile;

/// Radius at which the running sum of per-bin `amounts` (bin i spans
/// `edges[i]..edges[i + 1]`) first reaches `goal`, linear in r inside the
/// bin where it crosses; the last edge when it never does.
pub fn radius_reaching(edges: &[f64], amounts: impl IntoIterator<Item = f64>, goal: f64) -> f64 {
    let mut acc = 0.0;
    for (add, e) in amounts.into_iter().zip(edges.windows(2)) {
        if acc + add >= goal {
            let t = if add > 0.0 { (goal - acc) / add } else { 0.0 };
            return e[0] + t * (e[1] - e[0]);
        }
        acc += add;
    }
    edges.last().copied().unwrap_or(0.0)
}

/// Radius inside which `fraction` of the tabulated R_d of channel `c` lies.
pub fn radius_holding(p: &Profile, c: usize, fraction: f64) -> f64 {
    radius_reaching(
        &p.r_edges,
        p.bin_amounts(c),
        fraction * p.tabulated_total(c),
    )
}

/// Fraction of R_d the 2D kernel's default extent holds.
pub const DEFAULT_HOLD: f64 = 0.999;

/// Half-width (mm) of the 2D kernel by default: the largest radius holding
/// [`DEFAULT_HOLD`] of R_d over `channels` (indices into the profile).
pub fn default_extent(p: &Profile, channels: impl IntoIterator<Item = usize>) -> f64 {
    channels
        .into_iter()
        .map(|c| radius_holding(p, c, DEFAULT_HOLD))
        .fold(0.0, f64::max)
}

/// Cells per side of the 2D kernel by default (`kernel::kernel2d`, and the
/// Monte Carlo rule that sizes photons for it): odd, with a cell that
/// resolves the narrowest channel's core (the radius holding 25% of R_d
/// spans at least two cells), between 31 and 401.
pub fn default_kernel_size(p: &Profile, extent: f64) -> usize {
    let core = (0..p.channels.len())
        .filter(|&c| p.tabulated_total(c) > 0.0)
        .map(|c| radius_holding(p, c, 0.25))
        .fold(f64::INFINITY, f64::min)
        .max(extent * 1e-4);
    let n = (2.0 * extent / (core / 2.0)).ceil();
    let n = if n.is_finite() { n as usize } else { 401 };
    (n.clamp(31, 401)) | 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_is_interpolated_inside_its_bin() {
        let edges = [0.0, 1.0, 2.0, 4.0];
        let amounts = [1.0, 1.0, 2.0];
        assert_eq!(radius_reaching(&edges, amounts, 0.5), 0.5);
        assert_eq!(radius_reaching(&edges, amounts, 2.0), 2.0);
        assert_eq!(radius_reaching(&edges, amounts, 3.0), 3.0);
        // Never reached (the goal counts reflectance beyond the grid).
        assert_eq!(radius_reaching(&edges, amounts, 5.0), 4.0);
        // Empty bins before the crossing do not move it.
        assert_eq!(radius_reaching(&edges, [0.0, 0.0, 2.0], 1.0), 3.0);
    }
}
