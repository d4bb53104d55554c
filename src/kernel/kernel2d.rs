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
use crate::profile::radius::{default_kernel_size, DEFAULT_HOLD};
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
            None => default_kernel_size(profile, extent),
        };
        let cell = 2.0 * extent / size as f64;
        normalised(profile, &idx, size, cell, &format!("+-{extent} mm"), |f| {
            cell_integrals(f, size, cell)
        })
    }

    /// The kernel whose convolution with an image of pixel values gives the
    /// exact convolution of the piecewise-constant image with R_d *averaged
    /// over each output pixel* (what a camera with a box pixel filter
    /// records), instead of sampled at the pixel centres as `from_profile`'s
    /// cell integrals give: entry (i, j) = int R_d(u) w(u_x / p - i) w(u_y /
    /// p - j) du with the tent w(z) = max(0, 1 - |z|), the autocorrelation
    /// of the pixel box. `size` (odd) cells of `cell_mm`. Each channel sums to
    /// 1 (the tents are a partition of unity), `captured` as in
    /// `from_profile`. The shifted cells cover the square of half-width
    /// size / 2 cells, so the outermost entries keep the inner half of their
    /// tent: a grid one cell wider than `from_profile`'s holds the same
    /// square.
    ///
    /// Exact in the geometry: the tent is bilinear on each cell of the grid
    /// shifted by half a cell (corners at multiples of p), so every entry is
    /// a combination of four moments of R_d (against 1, s, t, s t) on the
    /// four shifted cells meeting at its centre; the shifted cells near the
    /// origin, where R_d peaks, are integrated exactly in r
    /// (`polar_cell_moments`), the others supersampled as in
    /// `from_profile`.
    pub fn pixel_averaged(profile: &Profile, size: usize, cell_mm: f64) -> Result<Kernel2D> {
        let idx = rgb_indices(profile)?;
        check_profile_values(profile, &idx)?;
        if size.is_multiple_of(2) || !(3..=MAX_SIZE).contains(&size) {
            return Err(Error::invalid(
                "kernel",
                "size",
                size,
                format!("must be odd, at least 3 and at most {MAX_SIZE}"),
            ));
        }
        if !(cell_mm.is_finite() && cell_mm > 0.0) {
            return Err(Error::invalid(
                "kernel",
                "cell_mm",
                cell_mm,
                "must be finite and > 0 (mm)",
            ));
        }
        let extent = size as f64 * cell_mm / 2.0;
        normalised(
            profile,
            &idx,
            size,
            cell_mm,
            &format!("+-{extent} mm"),
            |f| tent_integrals(f, size, cell_mm),
        )
    }
}

/// The kernel of `profile`'s channels `idx` (r, g, b) from the integrals
/// `integrate` gives on a grid of `size` cells of `cell` mm (`what`
/// describes it in errors): each channel normalised to sum 1, `captured` the
/// sum over the profile's tabulated total.
fn normalised(
    profile: &Profile,
    idx: &[usize; 3],
    size: usize,
    cell: f64,
    what: &str,
    integrate: impl Fn(&RadialInterp) -> Vec<f64>,
) -> Result<Kernel2D> {
    let mut data: [Vec<f64>; 3] = Default::default();
    let mut captured = [0.0; 3];
    for (k, &c) in idx.iter().enumerate() {
        let mut d = integrate(&RadialInterp::new(profile, c));
        let sum: f64 = d.iter().sum();
        captured[k] = sum / profile.tabulated_total(c);
        let name = profile.channels[c].name();
        if !(sum > 0.0) || !sum.is_finite() {
            return Err(Error::Unsupported(format!(
                "{}: kernel grid ({size} cells over {what}) holds no reflectance of channel \
                 '{name}'",
                profile_context(profile)
            )));
        }
        // A fraction: the grid holds at most the tabulated R_d, up to the
        // difference between the reconstruction between bin centres and the
        // bin averages (a few percent at most on real profiles).
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
    Ok(Kernel2D {
        size,
        cell_mm: cell,
        data,
        total_rd: idx.map(|c| profile.total_rd[c]),
        captured,
    })
}

/// Integrals of R_d over a cell of the shifted grid against 1, s, t and
/// s t, (s, t) in [0, 1]^2 the cell's own coordinates rising with x and y.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct CellMoments {
    m00: f64,
    m10: f64,
    m01: f64,
    m11: f64,
}

impl CellMoments {
    /// The moments of the mirror image across x (s -> 1 - s).
    fn mirror_x(self) -> CellMoments {
        CellMoments {
            m00: self.m00,
            m10: self.m00 - self.m10,
            m01: self.m01,
            m11: self.m01 - self.m11,
        }
    }

    fn transpose(self) -> CellMoments {
        CellMoments {
            m10: self.m01,
            m01: self.m10,
            ..self
        }
    }
}

/// Shifted cells up to this many cells from the origin are integrated
/// exactly in r (`polar_cell_moments`): R_d is steepest there, and a pixel
/// wide compared with the profile puts most of it in them.
const POLAR_RINGS: usize = 6;

/// The moments of the shifted cell [a p, (a+1) p] x [b p, (b+1) p] (a, b >=
/// 0) as int R(r) r A(r) dr: the arc of radius r inside the cell is the one
/// interval phi0 <= phi <= phi1 of the first quadrant with x = r cos phi in
/// [x0, x1] and y = r sin phi in [y0, y1], and the angular integrals of 1,
/// s = (x - x0)/p, t = (y - y0)/p and s t over it are closed forms. The arc
/// has square-root corners where r crosses x0, x1, y0 or y1 (each piece
/// starting there is integrated by r = start + h u^2) and kinks at the
/// corners' radii, all of them cuts, with the profile's nodes.
fn polar_cell_moments(interp: &RadialInterp, a: usize, b: usize, p: f64) -> CellMoments {
    let (x0, y0) = (a as f64 * p, b as f64 * p);
    let (x1, y1) = (x0 + p, y0 + p);
    let arc = |r: f64| -> Option<(f64, f64)> {
        let ac = |x: f64| (x / r).min(1.0).acos();
        let as_ = |y: f64| (y / r).min(1.0).asin();
        let lo = ac(x1).max(as_(y0));
        let hi = ac(x0).min(as_(y1));
        (hi > lo).then_some((lo, hi))
    };
    // The integrand of each moment at radius r: R(r) r times the angular
    // integral of 1, s, t, s t over the arc.
    let parts = |r: f64| -> [f64; 4] {
        let Some((f0, f1)) = arc(r) else {
            return [0.0; 4];
        };
        let (s0, c0) = f0.sin_cos();
        let (s1, c1) = f1.sin_cos();
        let d = f1 - f0;
        let ic = s1 - s0; // int cos
        let is = c0 - c1; // int sin
        let isc = 0.5 * (s1 * s1 - s0 * s0); // int sin cos
        let k = interp.eval(r) * r;
        [
            k * d,
            k * (r * ic - x0 * d) / p,
            k * (r * is - y0 * d) / p,
            k * (r * r * isc - r * y0 * ic - r * x0 * is + x0 * y0 * d) / (p * p),
        ]
    };
    let corners = [x0.hypot(y0), x1.hypot(y0), x0.hypot(y1), x1.hypot(y1)];
    let (r_lo, r_hi) = (corners[0], corners[3].min(interp.r_max()));
    if !(r_hi > r_lo) {
        return CellMoments::default();
    }
    let sqrt_at = [x0, x1, y0, y1];
    let mut cuts: Vec<f64> = [r_lo, r_hi]
        .into_iter()
        .chain(corners)
        .chain(sqrt_at)
        .chain(interp.nodes().iter().copied())
        .filter(|&r| r >= r_lo && r <= r_hi)
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut m = [0.0; 4];
    for w in cuts.windows(2) {
        for (k, mk) in m.iter_mut().enumerate() {
            let g = |r: f64| parts(r)[k];
            *mk += if sqrt_at.contains(&w[0]) {
                gauss_legendre_sqrt_start(&g, w[0], w[1])
            } else {
                gauss_legendre(g, w[0], w[1])
            };
        }
    }
    CellMoments {
        m00: m[0],
        m10: m[1],
        m01: m[2],
        m11: m[3],
    }
}

/// The moments of the shifted cell [a p, (a+1) p] x [b p, (b+1) p], a and b
/// >= 0, not the origin's, by midpoint supersampling.
fn shifted_cell_moments(
    interp: &RadialInterp,
    a: usize,
    b: usize,
    p: f64,
    bin_width: f64,
) -> CellMoments {
    let (x0, y0) = (a as f64 * p, b as f64 * p);
    let r_near = x0.hypot(y0);
    if r_near > interp.r_max() {
        return CellMoments::default();
    }
    let ss = supersampling(p, r_near, a.max(b), bin_width);
    let h = 1.0 / ss as f64;
    let mut m = CellMoments::default();
    for iy in 0..ss {
        let t = (iy as f64 + 0.5) * h;
        for ix in 0..ss {
            let s = (ix as f64 + 0.5) * h;
            let v = interp.eval((x0 + s * p).hypot(y0 + t * p));
            m.m00 += v;
            m.m10 += v * s;
            m.m01 += v * t;
            m.m11 += v * s * t;
        }
    }
    let area = p * p * h * h;
    CellMoments {
        m00: m.m00 * area,
        m10: m.m10 * area,
        m01: m.m01 * area,
        m11: m.m11 * area,
    }
}

/// The tent-weighted integrals of `Kernel2D::pixel_averaged` (before
/// normalisation), row-major, `size` x `size`.
fn tent_integrals(interp: &RadialInterp, size: usize, p: f64) -> Vec<f64> {
    let half = size / 2;
    // Shifted cells [a, a+1] x [b, b+1] (in cells) for 0 <= a, b < half:
    // together the square the tents of the entries up to `half` reach.
    let n = half;
    let bin_width = interp
        .nodes()
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min)
        .max(p * 1e-3);
    let octant: Vec<(usize, usize, CellMoments)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|a| {
            (0..=a).map(move |b| {
                let m = if a <= POLAR_RINGS {
                    polar_cell_moments(interp, a, b, p)
                } else {
                    shifted_cell_moments(interp, a, b, p, bin_width)
                };
                (a, b, m)
            })
        })
        .collect();
    let mut quad = vec![CellMoments::default(); n * n];
    for (a, b, m) in octant {
        quad[a * n + b] = m;
        quad[b * n + a] = m.transpose();
    }
    // Any shifted cell, by mirror symmetry: cell a < 0 is cell -a-1
    // mirrored (s -> 1 - s); outside the square nothing.
    let cell = |a: i64, b: i64| -> CellMoments {
        let (ua, ub) = (
            if a < 0 { -a - 1 } else { a },
            if b < 0 { -b - 1 } else { b },
        );
        if ua >= n as i64 || ub >= n as i64 {
            return CellMoments::default();
        }
        let mut m = quad[ua as usize * n + ub as usize];
        if a < 0 {
            m = m.mirror_x();
        }
        if b < 0 {
            m = m.transpose().mirror_x().transpose();
        }
        m
    };
    let mut d = vec![0.0; size * size];
    // The octant 0 <= j <= i, mirrored: exactly symmetric, as `from_profile`.
    for j in 0..=half {
        for i in j..=half {
            let (i, j) = (i as i64, j as i64);
            // The tent rises over the cell left of (below) its centre (s,
            // t) and falls over the one right of (above) it (1 - s, 1 - t).
            let ll = cell(i - 1, j - 1).m11;
            let lr = {
                let m = cell(i, j - 1);
                m.m01 - m.m11
            };
            let ul = {
                let m = cell(i - 1, j);
                m.m10 - m.m11
            };
            let ur = {
                let m = cell(i, j);
                m.m00 - m.m10 - m.m01 + m.m11
            };
            let v = ll + lr + ul + ur;
            let h = half as i64;
            for (a, b) in [(i, j), (j, i)] {
                for sx in [h - a, h + a] {
                    for sy in [h - b, h + b] {
                        d[sy as usize * size + sx as usize] = v;
                    }
                }
            }
        }
    }
    d
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::RadialGrid;

    fn dipole(dr: f64, r_max: f64) -> Profile {
        let m = crate::material::preset("skin1").unwrap();
        crate::kernel::reference::dipole_profile(&m, &RadialGrid::uniform(dr, r_max).unwrap())
            .unwrap()
    }

    /// Entries of the pixel-averaged kernel against brute force: the tent
    /// weights times R_d summed on a fine midpoint grid over the tent's
    /// support, for entries on and off the axes, near the peak (polar
    /// moments: 2e-7, the brute force's own resolution; 3e-8 measured) and
    /// beyond it (the midpoint supersampling of `from_profile`'s cells:
    /// 1e-4; 1.8e-5 measured on an entry holding 1e-4 of the kernel).
    #[test]
    fn pixel_averaged_entries_are_tent_integrals() {
        let p = dipole(0.01, 3.0);
        let cell = 0.2;
        let size = 33;
        let k = Kernel2D::pixel_averaged(&p, size, cell).unwrap();
        let interp = RadialInterp::new(&p, 0);
        let tent = |z: f64| (1.0 - z.abs()).max(0.0);
        let brute = |i: i64, j: i64, n: usize| -> f64 {
            let h = 2.0 / n as f64;
            let mut s = 0.0;
            for a in 0..n {
                let zx = -1.0 + (a as f64 + 0.5) * h;
                for b in 0..n {
                    let zy = -1.0 + (b as f64 + 0.5) * h;
                    let (x, y) = ((i as f64 + zx) * cell, (j as f64 + zy) * cell);
                    s += interp.eval(x.hypot(y)) * tent(zx) * tent(zy);
                }
            }
            s * h * h * cell * cell
        };
        let unnormalised: f64 = tent_integrals(&interp, size, cell).iter().sum();
        let half = (size / 2) as i64;
        for (i, j, n, tol) in [
            (2, 1, 800, 2e-7),
            (6, 0, 800, 2e-7),
            (5, 4, 400, 2e-7),
            (1, 1, 2000, 2e-7),
            (0, 0, 4000, 2e-7),
            (12, 3, 400, 1e-4),
        ] {
            let got = k.at(0, (half + i) as usize, (half + j) as usize) * unnormalised;
            let want = brute(i, j, n);
            assert!(
                (got - want).abs() <= tol * want,
                "({i}, {j}): {got} vs {want} ({:.1e})",
                (got - want) / want
            );
            // Symmetric under x <-> -x, y <-> -y and x <-> y.
            for (a, b) in [(-i, j), (i, -j), (j, i), (-j, -i)] {
                assert_eq!(
                    k.at(0, (half + a) as usize, (half + b) as usize),
                    k.at(0, (half + i) as usize, (half + j) as usize)
                );
            }
        }
        for c in 0..3 {
            let s: f64 = k.data[c].iter().sum();
            assert!((s - 1.0).abs() < 1e-12);
        }
    }

    /// A pixel much wider than the kernel: R_d is a delta at the centre of
    /// the pixel, where every tent but the centre's is 0.
    #[test]
    fn pixel_averaged_kernel_of_a_narrow_profile_is_the_delta() {
        let p = dipole(0.001, 0.3);
        let k = Kernel2D::pixel_averaged(&p, 5, 1000.0).unwrap();
        for c in 0..3 {
            assert!((k.at(c, 2, 2) - 1.0).abs() < 1e-3, "{}", k.at(c, 2, 2));
        }
        assert!(Kernel2D::pixel_averaged(&p, 4, 0.1).is_err());
        assert!(Kernel2D::pixel_averaged(&p, 5, 0.0).is_err());
    }
}
