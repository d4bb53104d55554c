//! Rank-N separable approximation by singular value decomposition (002 5.1):
//! R = U S V^T, a_i = u_i sqrt(sigma_i), A_N = sum_{i<=N} a_i a_i^T, the best
//! rank-N approximation in the Frobenius norm (Eckart-Young, 002 eq. 5.6).

use super::model::Factors;
use super::Kernel2D;
use crate::error::{Error, Result};
use nalgebra::DMatrix;
use serde_json::json;

/// Singular values kept in the report (the spectrum decays fast).
const SPECTRUM_SHOWN: usize = 32;

/// SVD factors of every channel. `renormalize` scales the kernel to the
/// ground truth's 1-norm afterwards (002 eq. 5.12).
pub fn svd(k: &Kernel2D, rank: usize, renormalize: bool) -> Result<(Factors, serde_json::Value)> {
    if rank == 0 || rank > k.size {
        return Err(Error::invalid(
            "svd",
            "--rank",
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
        // 002 eq. 5.12: A~ = A ||R||_1 / ||A||_1; a factor scales by the root.
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

fn channel_svd(r: &[f64], n: usize, rank: usize) -> Result<ChannelSvd> {
    // Row-major data into nalgebra's column-major matrix: transposed, which
    // for a symmetric kernel is the same matrix.
    let m = DMatrix::from_column_slice(n, n, r).transpose();
    let svd = nalgebra::SVD::try_new(m, true, true, f64::EPSILON, 0)
        .ok_or_else(|| Error::Unsupported("SVD did not converge".into()))?;
    let (u, vt) = match (&svd.u, &svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return Err(Error::Unsupported("SVD returned no vectors".into())),
    };
    let s = &svd.singular_values;
    let total: f64 = s.iter().map(|x| x * x).sum();
    let mut factors = Vec::new();
    let mut skipped = Vec::new();
    let mut kept = 0.0;
    for i in 0..rank.min(s.len()) {
        let ui = u.column(i);
        let vi = vt.row(i);
        let same: f64 = ui.iter().zip(vi.iter()).map(|(a, b)| a * b).sum();
        kept += s[i] * s[i];
        if same < 0.0 {
            skipped.push(i);
            continue;
        }
        // Sign convention: positive centre (u and -u are both singular vectors).
        let centre = ui[n / 2];
        let sign = if centre < 0.0 { -1.0 } else { 1.0 };
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
