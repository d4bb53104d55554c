//! The thickness table for shaders: per channel, the transmittance of a
//! slab t mm thick lit from behind (`profile::transmission`; its part that
//! scattered, the glow a camera sees, `diffuse`) as a sum of
//! two exponentials, T(t) = a1 e^{-b1 t} + a2 e^{-b2 t}, fitted to the
//! table's significant rows by least squares on the relative error (the
//! slow and the fast mode of the light that diffuses through a slab), and
//! the shader function of the thickness in mm with the fit's error in its
//! header. The function clamps the thickness to the table's range: it is
//! not fitted outside it.

use crate::error::{Error, Result};
use crate::numerics::nelder_mead;
use crate::profile::transmission::ThicknessTable;
use serde::{Deserialize, Serialize};

/// Standard errors a row's T must stand above 0 to enter the fit.
const SIGNIFICANT: f64 = 4.0;
/// The decay rates' range, per mm: e^{-b t} over 0.001 to 1000 mm covers
/// every slab a table holds (`MAX_SLAB_MM`) and the ballistic decay of
/// the densest preset (sigma_t about 15 per mm).
const RATE_RANGE: (f64, f64) = (1e-4, 1e3);

/// A table's fit for shaders.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThicknessFit {
    /// The material of the table.
    pub material: String,
    /// Thinnest and thickest slab of the table, mm: the function clamps to
    /// them.
    pub range_mm: [f64; 2],
    /// Per channel r, g, b: [a1, b1, a2, b2], b in 1/mm.
    pub terms: [[f64; 4]; 3],
    /// Largest and RMS relative error over the table's significant rows.
    pub max_rel_error: [f64; 3],
    pub rms_rel_error: [f64; 3],
    /// Rows fitted per channel.
    pub rows: [usize; 3],
}

impl ThicknessFit {
    /// T of channel `c` through `t_mm` (clamped to the range).
    pub fn eval(&self, c: usize, t_mm: f64) -> f64 {
        let t = t_mm.clamp(self.range_mm[0], self.range_mm[1]);
        let [a1, b1, a2, b2] = self.terms[c];
        a1 * (-b1 * t).exp() + a2 * (-b2 * t).exp()
    }
}

/// Best non-negative (a1, a2) for rates (b1, b2) in the relative least
/// squares over (t, T), and its cost.
fn amplitudes(rows: &[(f64, f64)], b1: f64, b2: f64) -> ([f64; 2], f64) {
    // Columns x_k = e^{-b_k t} / T against the target 1.
    let x = |b: f64, (t, v): (f64, f64)| (-b * t).exp() / v;
    let (mut s11, mut s12, mut s22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &row in rows {
        let (u, w) = (x(b1, row), x(b2, row));
        s11 += u * u;
        s12 += u * w;
        s22 += w * w;
        r1 += u;
        r2 += w;
    }
    let cost = |a: [f64; 2]| -> f64 {
        rows.iter()
            .map(|&row| (a[0] * x(b1, row) + a[1] * x(b2, row) - 1.0).powi(2))
            .sum()
    };
    let det = s11 * s22 - s12 * s12;
    let mut best = ([if s11 > 0.0 { r1 / s11 } else { 0.0 }, 0.0], f64::INFINITY);
    best.1 = cost(best.0);
    let one2 = [0.0, if s22 > 0.0 { r2 / s22 } else { 0.0 }];
    if cost(one2) < best.1 {
        best = (one2, cost(one2));
    }
    if det.abs() > 1e-300 * s11 * s22 {
        let a = [(r1 * s22 - r2 * s12) / det, (r2 * s11 - r1 * s12) / det];
        if a[0] >= 0.0 && a[1] >= 0.0 && cost(a) < best.1 {
            best = (a, cost(a));
        }
    }
    best
}

/// Fits every channel of `table`; refused when a channel has fewer than
/// two significant rows (no decay to fit).
pub fn fit_table(table: &ThicknessTable) -> Result<ThicknessFit> {
    table
        .validate()
        .map_err(|e| Error::Unsupported(format!("transmission table: {e}")))?;
    let ts = table.thicknesses();
    let mut out = ThicknessFit {
        material: table.material.name.clone(),
        range_mm: [ts[0], ts[ts.len() - 1]],
        terms: [[0.0; 4]; 3],
        max_rel_error: [0.0; 3],
        rms_rel_error: [0.0; 3],
        rows: [0; 3],
    };
    for ch in crate::material::Channel::ALL {
        let c = ch.index();
        let i = table.channel_index(ch).ok_or_else(|| {
            Error::Unsupported(format!(
                "the transmission table has no channel {}",
                ch.name()
            ))
        })?;
        let rows: Vec<(f64, f64)> = table
            .rows
            .iter()
            .filter(|r| {
                let (v, s) = (r.diffuse[i], r.diffuse_stderr[i]);
                v > 0.0 && v > SIGNIFICANT * s
            })
            .map(|r| (r.thickness_mm, r.diffuse[i]))
            .collect();
        if rows.len() < 2 {
            return Err(Error::Unsupported(format!(
                "channel {}: {} thickness(es) of the table transmit significant light; a fit \
                 needs two",
                ch.name(),
                rows.len()
            )));
        }
        let (lo, hi) = (RATE_RANGE.0.ln(), RATE_RANGE.1.ln());
        let cost = |x: &[f64]| amplitudes(&rows, x[0].exp(), x[1].exp()).1;
        let grid = 40;
        let at = |k: usize| lo + (hi - lo) * k as f64 / (grid - 1) as f64;
        let mut start = [at(0), at(0)];
        let mut best = f64::INFINITY;
        for k1 in 0..grid {
            for k2 in k1..grid {
                let c0 = cost(&[at(k1), at(k2)]);
                if c0 < best {
                    (best, start) = (c0, [at(k1), at(k2)]);
                }
            }
        }
        let x = nelder_mead(cost, &start, 0.3, (lo, hi), 2000);
        let (b1, b2) = (x[0].exp(), x[1].exp());
        let (a, _) = amplitudes(&rows, b1, b2);
        out.terms[c] = [a[0], b1, a[1], b2];
        let rel: Vec<f64> = rows
            .iter()
            .map(|&(t, v)| out.eval(c, t) / v - 1.0)
            .collect();
        out.max_rel_error[c] = rel.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        out.rms_rel_error[c] = (rel.iter().map(|e| e * e).sum::<f64>() / rel.len() as f64).sqrt();
        out.rows[c] = rows.len();
    }
    Ok(out)
}
