//! The discretised 2D ground truth R_d(x, y) = R_d(sqrt(x^2 + y^2)) on an odd
//! square grid centred on the origin (Freude 2014, section 6.1, "simple rotation").
//!
//! Cells hold cell averages (times the cell area), not point samples: the
//! radial profile is supersampled in each cell, more finely where the cell is
//! wide compared with the profile's bins, and the centre cell, where R_d
//! peaks, is integrated exactly in r with the arc length inside the square.
//! Only one octant is computed; the other seven are mirrors, which makes the
//! kernel exactly symmetric under x <-> -x, y <-> -y and x <-> y.

use crate::error::{Error, Result};
use crate::material::Channel;
use crate::numerics::{gauss_legendre, gauss_legendre_sqrt_start};
use crate::profile::Profile;
use crate::profile::{radius_holding, RadialInterp};
use rayon::prelude::*;

/// How to discretise: both optional, chosen from the profile when absent.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Kernel2DSpec {
    /// Cells per side (odd).
    pub size: Option<usize>,
    /// Half-width in mm of the covered square (to the outer cell edge).
    pub extent_mm: Option<f64>,
}

/// Cell averages of a radial profile, each channel normalised to sum 1, with
/// the total diffuse reflectance kept apart as a colour factor.
#[derive(Clone, Debug, PartialEq)]
pub struct Kernel2D {
    pub size: usize,
    /// Width of one cell in mm.
    pub cell_mm: f64,
    /// `data[c][iy * size + ix]`, cell (ix, iy) centred at
    /// ((ix - size/2) cell_mm, (iy - size/2) cell_mm).
    pub data: [Vec<f64>; 3],
    /// Total diffuse reflectance per channel (the profile's, whole plane).
    pub total_rd: [f64; 3],
    /// Fraction of each channel's tabulated R_d that falls inside the grid.
    pub captured: [f64; 3],
}

/// Most of the tabulated R_d a kernel grid may hold (`Kernel2D::captured`
/// is a fraction; see `from_profile`).
pub const MAX_CAPTURED: f64 = 1.1;

/// How errors about a profile name it: by its material.
fn profile_context(profile: &Profile) -> String {
    format!("profile of '{}'", profile.material.name)
}

/// Largest kernel accepted (cells per side); 4001^2 cells x 3 channels is
/// about 384 MB of f64.
pub const MAX_SIZE: usize = 4001;

/// Fraction of R_d the default extent holds.
pub const DEFAULT_HOLD: f64 = 0.999;

impl Kernel2D {
    pub fn half(&self) -> usize {
        self.size / 2
    }

    /// Half-width in mm to the outer cell edge.
    pub fn extent_mm(&self) -> f64 {
        0.5 * self.size as f64 * self.cell_mm
    }

    /// Offset in mm of cell index `i` along one axis.
    pub fn offset(&self, i: usize) -> f64 {
        (i as f64 - self.half() as f64) * self.cell_mm
    }

    /// Cell centre offsets in mm along one axis.
    pub fn offsets(&self) -> Vec<f64> {
        (0..self.size).map(|i| self.offset(i)).collect()
    }

    pub fn at(&self, c: usize, ix: usize, iy: usize) -> f64 {
        self.data[c][iy * self.size + ix]
    }

    /// The quadrant x, y >= 0 of channel `c`, (half + 1)^2 row-major:
    /// `q[my * (half + 1) + mx]` = R at (mx, my) cells from the centre. The
    /// kernel is even in x and y, so the quadrant and `multiplicity` hold all
    /// of it.
    pub fn quadrant(&self, c: usize) -> Vec<f64> {
        let h = self.half();
        let mut q = Vec::with_capacity((h + 1) * (h + 1));
        for my in 0..=h {
            let row = (h + my) * self.size + h;
            q.extend_from_slice(&self.data[c][row..row + h + 1]);
        }
        q
    }

    /// Discretises `profile` (which must hold r, g and b).
    pub fn from_profile(profile: &Profile, spec: &Kernel2DSpec) -> Result<Kernel2D> {
        let idx = rgb_indices(profile)?;
        check_profile_values(profile, &idx)?;
        let extent = match spec.extent_mm {
            Some(e) if e.is_finite() && e > 0.0 => e,
            Some(e) => {
                return Err(Error::invalid(
                    "kernel",
                    "extent_mm",
                    e,
                    "must be finite and > 0 (mm)",
                ))
            }
            None => idx
                .iter()
                .map(|&c| radius_holding(profile, c, DEFAULT_HOLD))
                .fold(0.0, f64::max),
        };
        if !(extent > 0.0) {
            return Err(Error::invalid(
                "kernel",
                "extent_mm",
                "none",
                "the profile holds its reflectance at r = 0 only: give the extent",
            ));
        }
        let size = match spec.size {
            Some(n) if n % 2 == 1 && n <= MAX_SIZE => n,
            Some(n) => {
                return Err(Error::invalid(
                    "kernel",
                    "size",
                    n,
                    format!("must be odd and at most {MAX_SIZE}"),
                ))
            }
            None => default_size(profile, extent),
        };
        let cell = 2.0 * extent / size as f64;
        let mut data: [Vec<f64>; 3] = Default::default();
        let mut captured = [0.0; 3];
        for (k, &c) in idx.iter().enumerate() {
            let interp = RadialInterp::new(profile, c);
            let mut d = cell_integrals(&interp, size, cell);
            let sum: f64 = d.iter().sum();
            let tab = profile.tabulated_total(c);
            captured[k] = sum / tab;
            let name = profile.channels[c].name();
            if !(sum > 0.0) || !sum.is_finite() {
                return Err(Error::Unsupported(format!(
                    "{}: kernel grid ({size} cells over +-{extent} mm) holds no reflectance of \
                     channel '{name}'",
                    profile_context(profile)
                )));
            }
            // A fraction: the grid holds at most the tabulated R_d, up to
            // the difference between the reconstruction between bin centres
            // and the bin averages (a few percent at most on real profiles).
            if !(captured[k] <= MAX_CAPTURED) {
                return Err(Error::invalid(
                    profile_context(profile),
                    format!("rd[{name}]"),
                    format!(
                        "{:.4e} in [0, {:.4e}] mm",
                        profile.rd[c][0], profile.r_edges[1]
                    ),
                    format!(
                        "the kernel grid would hold {:.3e} times the profile's tabulated \
                         reflectance (at most {MAX_CAPTURED}): its bins do not describe R_d \
                         (a degenerate first bin, or values that jump between bins)",
                        captured[k]
                    ),
                ));
            }
            d.iter_mut().for_each(|v| *v /= sum);
            data[k] = d;
        }
        let total_rd = [
            profile.total_rd[idx[0]],
            profile.total_rd[idx[1]],
            profile.total_rd[idx[2]],
        ];
        Ok(Kernel2D {
            size,
            cell_mm: cell,
            data,
            total_rd,
            captured,
        })
    }
}

/// Cells at distance m from the centre along one axis: 1 for the centre, 2
/// for the mirrored pair.
pub fn multiplicity(m: usize) -> f64 {
    if m == 0 {
        1.0
    } else {
        2.0
    }
}

/// Positions of r, g, b in the profile's channel list.
pub fn rgb_indices(profile: &Profile) -> Result<[usize; 3]> {
    let mut idx = [0; 3];
    for (k, ch) in Channel::ALL.iter().enumerate() {
        idx[k] = profile.channel_index(*ch).ok_or_else(|| {
            Error::Unsupported(format!(
                "{}: a kernel needs a profile with channels r, g and b (it has {})",
                profile_context(profile),
                profile
                    .channels
                    .iter()
                    .map(|c| c.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
        })?;
    }
    Ok(idx)
}

/// Rejects what a profile file's own validation may let through when the
/// profile was built in memory: NaN, negative or all-zero channels.
fn check_profile_values(profile: &Profile, idx: &[usize; 3]) -> Result<()> {
    let n = profile.r.len();
    if n == 0 || profile.r_edges.len() != n + 1 {
        return Err(Error::Unsupported(format!(
            "{}: no radial bins (or r_edges does not match r)",
            profile_context(profile)
        )));
    }
    for &c in idx {
        let name = profile.channels[c].name();
        if profile.rd.get(c).map(|v| v.len()) != Some(n) {
            return Err(Error::Unsupported(format!(
                "{}: channel '{name}' does not have {n} bins",
                profile_context(profile)
            )));
        }
        if let Some((i, x)) = profile.rd[c]
            .iter()
            .enumerate()
            .find(|(_, x)| !x.is_finite() || **x < 0.0)
        {
            return Err(Error::invalid(
                profile_context(profile),
                format!("rd[{name}][{i}]"),
                x,
                "must be finite and >= 0",
            ));
        }
        if !(profile.tabulated_total(c) > 0.0) {
            return Err(Error::Unsupported(format!(
                "{}: channel '{name}' is zero everywhere (no diffuse reflectance comes back): no \
                 kernel can be normalised",
                profile_context(profile)
            )));
        }
        match profile.total_rd.get(c) {
            Some(t) if t.is_finite() && *t >= 0.0 => {}
            t => {
                return Err(Error::invalid(
                    profile_context(profile),
                    format!("total_rd[{name}]"),
                    format!("{t:?}"),
                    "must be finite and >= 0",
                ))
            }
        }
    }
    Ok(())
}

/// Supersampling factor for a cell whose nearest point to the origin is at
/// radius `r_near`: enough samples per profile bin and per cell near the peak.
fn supersampling(cell: f64, r_near: f64, ring: usize, bin_width: f64) -> usize {
    let by_bins = (2.0 * cell / bin_width).ceil() as usize;
    let by_peak = match ring {
        0..=1 => 24,
        2..=4 => 12,
        5..=12 => 6,
        _ => 3,
    };
    // Far from the peak a wide cell sees a slowly varying profile.
    let by_bins = if r_near > 20.0 * bin_width {
        by_bins.min(8)
    } else {
        by_bins
    };
    by_bins.max(by_peak).clamp(3, 64)
}

/// Integral of the reconstruction over the centre cell [-a, a]^2 as
/// int R(r) L(r) dr, with L(r) the length of the circle of radius r inside
/// the square: 2 pi r up to a, then r (2 pi - 8 acos(a / r)) up to the
/// corner a sqrt 2. The peak of R_d sits in this cell: supersampling it
/// undersamples a peak much narrower than the cell (a pixel wider than the
/// kernel), and misses a profile that ends inside the first sample spacing.
fn centre_cell_integral(interp: &RadialInterp, a: f64) -> f64 {
    use std::f64::consts::{PI, SQRT_2};
    let arc = |r: f64| {
        if r <= a {
            2.0 * PI * r
        } else {
            r * (2.0 * PI - 8.0 * (a / r).min(1.0).acos())
        }
    };
    let g = |r: f64| interp.eval(r) * arc(r);
    let end = (a * SQRT_2).min(interp.r_max());
    let mut cuts: Vec<f64> = std::iter::once(0.0)
        .chain(interp.nodes().iter().copied())
        .chain([a, end])
        .filter(|&r| r <= end)
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    cuts.windows(2)
        .map(|w| {
            if w[0] == a {
                // L(r) has a square-root corner at r = a.
                gauss_legendre_sqrt_start(&g, w[0], w[1])
            } else {
                gauss_legendre(g, w[0], w[1])
            }
        })
        .sum()
}

/// Integrals of the reconstruction over each cell (octant, then mirrored).
fn cell_integrals(interp: &RadialInterp, size: usize, cell: f64) -> Vec<f64> {
    let half = size / 2;
    // Narrowest bin: the resolution the supersampling must follow.
    let bin_width = interp
        .nodes()
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min)
        .max(cell * 1e-3);
    // Octant 0 <= dy <= dx <= half.
    let octant: Vec<(usize, usize, f64)> = (0..=half)
        .into_par_iter()
        .flat_map_iter(|dx| {
            (0..=dx).map(move |dy| {
                let x0 = (dx as f64 - 0.5) * cell;
                let y0 = (dy as f64 - 0.5) * cell;
                let r_near = ((x0.max(0.0)).powi(2) + (y0.max(0.0)).powi(2)).sqrt();
                if r_near > interp.r_max() {
                    return (dx, dy, 0.0);
                }
                if dx == 0 {
                    return (0, 0, centre_cell_integral(interp, cell / 2.0));
                }
                let ss = supersampling(cell, r_near, dx, bin_width);
                let h = cell / ss as f64;
                let mut s = 0.0;
                for sy in 0..ss {
                    let y = y0 + (sy as f64 + 0.5) * h;
                    for sx in 0..ss {
                        let x = x0 + (sx as f64 + 0.5) * h;
                        s += interp.eval((x * x + y * y).sqrt());
                    }
                }
                (dx, dy, s * h * h)
            })
        })
        .collect();
    let mut d = vec![0.0; size * size];
    for (dx, dy, v) in octant {
        for (a, b) in [(dx, dy), (dy, dx)] {
            for sx in [half - a, half + a] {
                for sy in [half - b, half + b] {
                    d[sy * size + sx] = v;
                }
            }
        }
    }
    d
}

/// Odd size whose cell resolves the narrowest channel's core (the radius
/// holding 25% of R_d spans at least two cells), between 31 and 401.
pub fn default_size(p: &Profile, extent: f64) -> usize {
    let core = (0..p.channels.len())
        .filter(|&c| p.tabulated_total(c) > 0.0)
        .map(|c| radius_holding(p, c, 0.25))
        .fold(f64::INFINITY, f64::min)
        .max(extent * 1e-4);
    let n = (2.0 * extent / (core / 2.0)).ceil();
    let n = if n.is_finite() { n as usize } else { 401 };
    (n.clamp(31, 401)) | 1
}
