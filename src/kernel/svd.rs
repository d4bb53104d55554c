//! Rank-N separable approximation by singular value decomposition (Freude 2014, sec. 5.1):
//! R = U S V^T, a_i = u_i sqrt(sigma_i), A_N = sum_{i<=N} a_i a_i^T, the best
//! rank-N approximation in the Frobenius norm (Eckart and Young 1936; Freude 2014,
//! eq. 5.6).

use super::factors::Factors;
use super::kernel2d::multiplicity;
use super::Kernel2D;
use crate::error::{Error, Result};
use nalgebra::DMatrix;
use serde_json::json;

/// Singular values kept in the report (the spectrum decays fast).
const SPECTRUM_SHOWN: usize = 32;

/// SVD factors of every channel. `renormalize` scales the kernel to the
/// ground truth's 1-norm afterwards (Freude 2014, eq. 5.12).
pub fn svd(k: &Kernel2D, rank: usize, renormalize: bool) -> Result<(Factors, serde_json::Value)> {
    if rank == 0 || rank > k.size {
        return Err(Error::invalid(
            "svd",
            "rank",
            rank,
            format!("must be between 1 and the kernel size {}", k.size),
        ));
    }
    let n = k.size;
    let per_channel: Vec<ChannelSvd> = (0..3)
        .map(|c| channel_svd(&k.data[c], n, rank))
        .collect::<Result<_>>()?;
    let terms = per_channel
        .iter()
        .map(|p| p.factors.len())
        .max()
        .unwrap_or(0);
    let mut factors: Factors = (0..terms)
        .map(|i| {
            std::array::from_fn(|c| {
                per_channel[c]
                    .factors
                    .get(i)
                    .cloned()
                    .unwrap_or_else(|| vec![0.0; n])
            })
        })
        .collect();
    let norm1_before = super::metrics::norm1(&factors);
    if renormalize {
        // Freude 2014, eq. 5.12: A~ = A ||R||_1 / ||A||_1; a factor scales by the root.
        for c in 0..3 {
            let target: f64 = k.data[c].iter().map(|v| v.abs()).sum();
            let s = (target / norm1_before[c]).sqrt();
            if s.is_finite() {
                factors
                    .iter_mut()
                    .for_each(|f| f[c].iter_mut().for_each(|v| *v *= s));
            }
        }
    }
    let extra = json!({
        "singular_values": per_channel.iter().map(|p| &p.spectrum).collect::<Vec<_>>(),
        "energy_captured": per_channel.iter().map(|p| p.energy).collect::<Vec<_>>(),
        "skipped_negative": per_channel.iter().map(|p| &p.skipped).collect::<Vec<_>>(),
        "norm1_before_renormalize": norm1_before,
    });
    Ok((factors, extra))
}

struct ChannelSvd {
    factors: Vec<Vec<f64>>,
    spectrum: Vec<f64>,
    /// Fraction of ||R||_F^2 held by the kept singular values.
    energy: f64,
    /// Indices of kept components with u_i . v_i < 0 (A holds -sigma u u^T
    /// there), which one symmetric factor cannot express; left out.
    skipped: Vec<usize>,
}

/// Whether R(x, y) = R(-x, y) = R(x, -y) (to rounding): then R is zero on
/// odd vectors and its SVD lives in the even block.
fn is_even(r: &[f64], n: usize) -> bool {
    let peak = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    (0..n).all(|iy| {
        (0..n).all(|ix| {
            let v = r[iy * n + ix];
            (v - r[iy * n + (n - 1 - ix)]).abs() <= 1e-13 * peak
                && (v - r[(n - 1 - iy) * n + ix]).abs() <= 1e-13 * peak
        })
    })
}

fn channel_svd(r: &[f64], n: usize, rank: usize) -> Result<ChannelSvd> {
    if n > 1 && is_even(r, n) {
        even_block_svd(r, n, rank)
    } else {
        full_svd(r, n, rank)
    }
}

/// For an R even in x and in y, the odd vectors (d_{h+m} - d_{h-m})/sqrt 2
/// span its null space and the even ones e_0 = d_h, e_m = (d_{h+m} +
/// d_{h-m})/sqrt 2 an invariant block E = D Q D, Q the quadrant, D =
/// diag(1, sqrt 2, ...): the same singular values with an (h+1)^2 matrix,
/// about 8 times less work.
fn even_block_svd(r: &[f64], n: usize, rank: usize) -> Result<ChannelSvd> {
    let h = n / 2;
    let d = |m: usize| multiplicity(m).sqrt();
    let e = DMatrix::from_fn(h + 1, h + 1, |i, j| d(i) * d(j) * r[(h + i) * n + h + j]);
    let svd = nalgebra::SVD::try_new(e, true, true, f64::EPSILON, 0)
        .ok_or_else(|| Error::Unsupported("SVD did not converge".into()))?;
    let (u, vt) = match (&svd.u, &svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return Err(Error::Unsupported("SVD returned no vectors".into())),
    };
    let expand = |col: Vec<f64>| -> Vec<f64> {
        (0..n)
            .map(|i| {
                let m = i.abs_diff(h);
                col[m] / d(m)
            })
            .collect()
    };
    assemble(&svd.singular_values, rank, |i| {
        let ui: Vec<f64> = u.column(i).iter().copied().collect();
        let same: f64 = ui.iter().zip(vt.row(i).iter()).map(|(a, b)| a * b).sum();
        (expand(ui), same)
    })
}

fn full_svd(r: &[f64], n: usize, rank: usize) -> Result<ChannelSvd> {
    // Row-major data into nalgebra's column-major matrix: transposed, which
    // for a symmetric kernel is the same matrix.
    let m = DMatrix::from_column_slice(n, n, r).transpose();
    let svd = nalgebra::SVD::try_new(m, true, true, f64::EPSILON, 0)
        .ok_or_else(|| Error::Unsupported("SVD did not converge".into()))?;
    let (u, vt) = match (&svd.u, &svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return Err(Error::Unsupported("SVD returned no vectors".into())),
    };
    assemble(&svd.singular_values, rank, |i| {
        let ui: Vec<f64> = u.column(i).iter().copied().collect();
        let same: f64 = ui.iter().zip(vt.row(i).iter()).map(|(a, b)| a * b).sum();
        (ui, same)
    })
}

/// Factors a_i = u_i sqrt(sigma_i) of the first `rank` components; `vec(i)`
/// gives u_i on the full grid and u_i . v_i (its sign tells whether the
/// component is +sigma u u^T or -sigma u u^T).
fn assemble(
    s: &nalgebra::DVector<f64>,
    rank: usize,
    vec: impl Fn(usize) -> (Vec<f64>, f64),
) -> Result<ChannelSvd> {
    let total: f64 = s.iter().map(|x| x * x).sum();
    let mut factors = Vec::new();
    let mut skipped = Vec::new();
    let mut kept = 0.0;
    for i in 0..rank.min(s.len()) {
        let (ui, same) = vec(i);
        kept += s[i] * s[i];
        if same < 0.0 {
            skipped.push(i);
            continue;
        }
        // Sign convention: each factor sums to a positive value (u and -u
        // are both singular vectors and a_i a_i^T is the same), so that a
        // term's taps are mostly positive where the kernel's mass is.
        let sum: f64 = ui.iter().sum();
        let sign = if sum < 0.0 { -1.0 } else { 1.0 };
        let root = s[i].sqrt();
        factors.push(ui.iter().map(|x| sign * root * x).collect());
    }
    Ok(ChannelSvd {
        factors,
        spectrum: s.iter().take(SPECTRUM_SHOWN).copied().collect(),
        energy: if total > 0.0 { kept / total } else { 0.0 },
        skipped,
    })
}
