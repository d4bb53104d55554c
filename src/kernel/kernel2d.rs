//! The discretised 2D ground truth R_d(x, y) = R_d(sqrt(x^2 + y^2)) on an odd
//! square grid centred on the origin (Freude 2014, section 6.1, "simple rotation").
//!
//! Cells hold cell averages (times the cell area), not point samples: the
//! radial profile is supersampled in each cell, more finely where the cell is
//! wide compared with the profile's bins, and the centre cell, where R_d
//! peaks, is integrated exactly in r with the arc length inside the square.
//! Only one octant is computed; the other seven are mirrors, which makes the
//! kernel exactly symmetric under x <-> -x, y <-> -y and x <-> y.

use super::cell_integrals::{cell_integrals, tent_integrals};
use crate::error::{finite_positive, Error, Result};
use crate::material::Channel;
use crate::profile::radius::{default_extent, default_kernel_size};
use crate::profile::Profile;
use crate::profile::RadialInterp;

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

/// Largest share of each channel's light the centre cell of a kernel to
/// fit may hold. Above it in every channel the kernel moves less than 1% of
/// the light off the pixel: any separable fit matches it and reports an
/// error near zero that says nothing about the profile (a grid one cell
/// wide, or an extent so large that the profile fits inside one cell).
pub const MAX_CENTRE_SHARE: f64 = 0.99;

impl Kernel2D {
    /// Refuses a grid that does not resolve its profile (see
    /// [`MAX_CENTRE_SHARE`]), before a fit measures itself against it.
    pub fn check_resolves(&self) -> Result<()> {
        let centre = self.half() * self.size + self.half();
        let share = self
            .data
            .iter()
            .map(|d| d[centre])
            .fold(f64::INFINITY, f64::min);
        if self.size < 3 || !(share <= MAX_CENTRE_SHARE) {
            return Err(Error::invalid(
                "kernel",
                if self.size < 3 { "size" } else { "extent_mm" },
                if self.size < 3 {
                    self.size.to_string()
                } else {
                    format!("{}", crate::numerics::Bounded(self.extent_mm()))
                },
                format!(
                    "a grid of {} cell(s) of {} mm puts {:.1}% of the light in its centre cell \
                     in every channel (at most {:.0}%): it does not resolve the profile, and a \
                     fit to it would claim no error; use at least 3 cells and an extent near \
                     the profile's (the default)",
                    self.size,
                    crate::numerics::Bounded(self.cell_mm),
                    crate::numerics::Bounded(100.0 * share.min(1.0)),
                    100.0 * MAX_CENTRE_SHARE
                ),
            ));
        }
        Ok(())
    }

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
        let mut k = Kernel2D::from_profiles(&[(profile, *spec)])?;
        Ok(k.remove(0))
    }

    /// [`Self::from_profile`] of each (profile, spec), in order. Kernels of
    /// one grid (cells and size) from profiles on one radial grid (a
    /// profile's bootstrap replicates, `report::eval::advise::noise`) are
    /// integrated together, every sample placed among the nodes once
    /// (`cell_integrals`); each kernel is the one `from_profile` makes.
    pub fn from_profiles(items: &[(&Profile, Kernel2DSpec)]) -> Result<Vec<Kernel2D>> {
        let grids: Vec<Grid> = items
            .iter()
            .map(|(p, spec)| Grid::of(p, spec))
            .collect::<Result<_>>()?;
        let interps: Vec<Vec<RadialInterp>> = items
            .iter()
            .zip(&grids)
            .map(|((p, _), g)| g.idx.iter().map(|&c| RadialInterp::new(p, c)).collect())
            .collect();
        let mut integrals: Vec<Option<Vec<Vec<f64>>>> = vec![None; items.len()];
        for i in 0..items.len() {
            if integrals[i].is_some() {
                continue;
            }
            // Every later kernel on this one's grid and nodes joins it.
            let batch: Vec<usize> = (i..items.len())
                .filter(|&j| {
                    integrals[j].is_none()
                        && grids[j].size == grids[i].size
                        && grids[j].cell.to_bits() == grids[i].cell.to_bits()
                        && interps[j][0].same_nodes(&interps[i][0])
                })
                .collect();
            let all: Vec<RadialInterp> = batch
                .iter()
                .flat_map(|&j| interps[j].iter().cloned())
                .collect();
            let mut out = cell_integrals(&all, grids[i].size, grids[i].cell).into_iter();
            for &j in &batch {
                integrals[j] = Some(out.by_ref().take(interps[j].len()).collect());
            }
        }
        items
            .iter()
            .zip(grids)
            .zip(integrals)
            .map(|(((p, _), g), d)| {
                let what = format!("+-{} mm", g.extent);
                normalised(p, &g.idx, g.size, g.cell, &what, d.unwrap_or_default())
            })
            .collect()
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
        finite_positive("kernel", "cell_mm", cell_mm, " (mm)")?;
        let extent = size as f64 * cell_mm / 2.0;
        let integrals = idx
            .iter()
            .map(|&c| tent_integrals(&RadialInterp::new(profile, c), size, cell_mm))
            .collect();
        normalised(
            profile,
            &idx,
            size,
            cell_mm,
            &format!("+-{extent} mm"),
            integrals,
        )
    }
}

/// The grid `from_profile` puts a profile on.
struct Grid {
    idx: [usize; 3],
    extent: f64,
    size: usize,
    cell: f64,
}

impl Grid {
    fn of(profile: &Profile, spec: &Kernel2DSpec) -> Result<Grid> {
        let idx = rgb_indices(profile)?;
        check_profile_values(profile, &idx)?;
        let extent = match spec.extent_mm {
            Some(e) => finite_positive("kernel", "extent_mm", e, " (mm)")?,
            None => default_extent(profile, idx.iter().copied()),
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
        Ok(Grid {
            idx,
            extent,
            size,
            cell: 2.0 * extent / size as f64,
        })
    }
}

/// The kernel of `profile`'s channels `idx` (r, g, b) from their
/// `integrals` (in the order of `idx`) on a grid of `size` cells of `cell`
/// mm (`what` describes it in errors): each channel normalised to sum 1,
/// `captured` the sum over the profile's tabulated total.
fn normalised(
    profile: &Profile,
    idx: &[usize; 3],
    size: usize,
    cell: f64,
    what: &str,
    integrals: Vec<Vec<f64>>,
) -> Result<Kernel2D> {
    let mut data: [Vec<f64>; 3] = Default::default();
    let mut captured = [0.0; 3];
    for ((k, &c), mut d) in idx.iter().enumerate().zip(integrals) {
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
pub(crate) fn check_profile_values(profile: &Profile, idx: &[usize; 3]) -> Result<()> {
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

    /// Kernels made together ([`Kernel2D::from_profiles`]: profiles on one
    /// radial grid, one cell grid, integrated in one sweep) are each the
    /// kernel `from_profile` makes alone, bit for bit; a profile on other
    /// nodes or another grid in the same call too.
    #[test]
    fn kernels_made_together_are_each_made_alone_bit_for_bit() {
        let p = dipole(0.01, 3.0);
        let mut q = p.clone();
        for (c, rd) in q.rd.iter_mut().enumerate() {
            for (i, v) in rd.iter_mut().enumerate() {
                *v *= 1.0 + 0.01 * ((i * 7 + c) % 5) as f64;
            }
        }
        let other = dipole(0.02, 2.0);
        let spec = Kernel2DSpec {
            size: Some(41),
            extent_mm: Some(2.5),
        };
        let wide = Kernel2DSpec {
            size: Some(21),
            ..spec
        };
        let items = [(&p, spec), (&q, spec), (&other, spec), (&p, wide)];
        let together = Kernel2D::from_profiles(&items).unwrap();
        for ((prof, sp), t) in items.iter().zip(&together) {
            let alone = Kernel2D::from_profile(prof, sp).unwrap();
            for c in 0..3 {
                let bits = |k: &Kernel2D| k.data[c].iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(t), bits(&alone));
            }
            assert_eq!(
                t.captured.map(f64::to_bits),
                alone.captured.map(f64::to_bits)
            );
        }
        assert_ne!(together[0].data[0], together[1].data[0]);
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

    /// A grid that holds its profile in one cell is refused for a fit; the
    /// default grid and a coarse but real one are not.
    #[test]
    fn a_grid_that_does_not_resolve_its_profile_is_refused() {
        let p = dipole(0.01, 20.0);
        let k = |size: Option<usize>, extent_mm: Option<f64>| {
            Kernel2D::from_profile(&p, &Kernel2DSpec { size, extent_mm }).unwrap()
        };
        let e = k(Some(1), None).check_resolves().unwrap_err().to_string();
        assert!(e.contains("invalid size = 1"), "{e}");
        let e = k(None, Some(1.8e19))
            .check_resolves()
            .unwrap_err()
            .to_string();
        assert!(e.contains("extent_mm") && e.len() < 400, "{e}");
        k(None, None).check_resolves().unwrap();
        k(Some(3), None).check_resolves().unwrap();
    }
}
