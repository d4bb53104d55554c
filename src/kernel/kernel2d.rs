//! The discretised 2D ground truth R_d(x, y) = R_d(sqrt(x^2 + y^2)) on an odd
//! square grid centred on the origin (002 section 6.1, "simple rotation").

use crate::error::{Error, Result};
use crate::material::Channel;
use crate::profile::Profile;

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

/// Largest kernel accepted (cells per side); 4001^2 cells x 3 channels is
/// about 384 MB of f64.
pub const MAX_SIZE: usize = 4001;

impl Kernel2D {
    pub fn half(&self) -> usize {
        self.size / 2
    }

    /// Offset in mm of cell index `i` along one axis.
    pub fn offset(&self, i: usize) -> f64 {
        (i as f64 - self.half() as f64) * self.cell_mm
    }

    pub fn at(&self, c: usize, ix: usize, iy: usize) -> f64 {
        self.data[c][iy * self.size + ix]
    }

    /// Discretises `profile` (which must hold r, g and b).
    pub fn from_profile(profile: &Profile, spec: &Kernel2DSpec) -> Result<Kernel2D> {
        let idx: Vec<usize> = Channel::ALL
            .iter()
            .map(|&c| profile.channel_index(c))
            .collect::<Option<_>>()
            .ok_or_else(|| {
                Error::Unsupported("a kernel needs a profile with channels r, g and b".into())
            })?;
        for &c in &idx {
            if profile.tabulated_total(c) <= 0.0 {
                return Err(Error::Unsupported(format!(
                    "profile channel '{}' is zero everywhere: no kernel can be normalised",
                    profile.channels[c].name()
                )));
            }
        }
        let extent = match spec.extent_mm {
            Some(e) if e.is_finite() && e > 0.0 => e,
            Some(e) => {
                return Err(Error::invalid(
                    "kernel",
                    "extent",
                    e,
                    "must be finite and > 0",
                ))
            }
            None => idx
                .iter()
                .map(|&c| radius_holding(profile, c, 0.999))
                .fold(0.0, f64::max),
        };
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
        let half = size / 2;
        let mut data: [Vec<f64>; 3] = Default::default();
        for (k, &c) in idx.iter().enumerate() {
            let mut d = vec![0.0; size * size];
            for iy in 0..size {
                for ix in 0..size {
                    let (dx, dy) = (ix.abs_diff(half), iy.abs_diff(half));
                    // Supersample more finely near the peak, where R_d varies fastest.
                    let ss = if dx.max(dy) <= 2 {
                        16
                    } else if dx.max(dy) <= 8 {
                        6
                    } else {
                        3
                    };
                    let x0 = (ix as f64 - half as f64 - 0.5) * cell;
                    let y0 = (iy as f64 - half as f64 - 0.5) * cell;
                    let mut s = 0.0;
                    for sy in 0..ss {
                        for sx in 0..ss {
                            let x = x0 + (sx as f64 + 0.5) * cell / ss as f64;
                            let y = y0 + (sy as f64 + 0.5) * cell / ss as f64;
                            s += profile.eval(c, (x * x + y * y).sqrt());
                        }
                    }
                    d[iy * size + ix] = s / (ss * ss) as f64 * cell * cell;
                }
            }
            data[k] = d;
        }
        let mut captured = [0.0; 3];
        for (k, &c) in idx.iter().enumerate() {
            let sum: f64 = data[k].iter().sum();
            captured[k] = sum / profile.tabulated_total(c);
            if !(sum > 0.0) {
                return Err(Error::Unsupported(
                    "kernel grid holds no reflectance".into(),
                ));
            }
            data[k].iter_mut().for_each(|v| *v /= sum);
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

/// Radius inside which `fraction` of the tabulated R_d of channel `c` lies.
pub fn radius_holding(p: &Profile, c: usize, fraction: f64) -> f64 {
    let total = p.tabulated_total(c);
    let mut acc = 0.0;
    for (i, e) in p.r_edges.windows(2).enumerate() {
        let add = p.rd[c][i] * std::f64::consts::PI * (e[1] * e[1] - e[0] * e[0]);
        if acc + add >= fraction * total {
            let t = if add > 0.0 {
                (fraction * total - acc) / add
            } else {
                0.0
            };
            return e[0] + t * (e[1] - e[0]);
        }
        acc += add;
    }
    *p.r_edges.last().unwrap()
}

/// Odd size whose cell resolves the narrowest channel's core (the radius
/// holding 25% of R_d spans at least two cells), between 31 and 401.
fn default_size(p: &Profile, extent: f64) -> usize {
    let core = (0..p.channels.len())
        .map(|c| radius_holding(p, c, 0.25))
        .fold(f64::INFINITY, f64::min)
        .max(extent * 1e-4);
    let n = (2.0 * extent / (core / 2.0)).ceil() as usize;
    (n.clamp(31, 401)) | 1
}
