//! Kernel-space quality of a separable model against its ground truth
//! (Freude 2014, table 6.3): every metric compares the model's kernel
//! A = sum_i a_i a_i^T exactly as produced (no renormalisation) with the
//! ground truth R normalised to sum 1 per channel.

use super::factors::Factors;
use super::Kernel2D;

/// The 2D kernel of channel `c`, row-major.
pub fn reconstruct(f: &Factors, n: usize, c: usize) -> Vec<f64> {
    let mut a = vec![0.0; n * n];
    for term in f {
        let t = &term[c];
        for (iy, row) in a.chunks_mut(n).enumerate() {
            let ty = t[iy];
            if ty != 0.0 {
                row.iter_mut().zip(t).for_each(|(v, tx)| *v += tx * ty);
            }
        }
    }
    a
}

/// ||A||_1 per channel, from the factors (sum_i (sum a_i)^2 would hide
/// negative entries, so this sums |A| cell by cell).
pub fn norm1(f: &Factors) -> [f64; 3] {
    let n = f.first().map(|t| t[0].len()).unwrap_or(0);
    std::array::from_fn(|c| reconstruct(f, n, c).iter().map(|v| v.abs()).sum())
}

/// RMS over the cells of R - A.
pub fn kernel_rms(r: &[f64], a: &[f64]) -> f64 {
    let s: f64 = r.iter().zip(a).map(|(r, a)| (r - a) * (r - a)).sum();
    (s / r.len() as f64).sqrt()
}

/// (||A||_1 - ||R||_1) / ||R||_1 (signed).
pub fn norm1_error(r: &[f64], a: &[f64]) -> f64 {
    let nr: f64 = r.iter().map(|v| v.abs()).sum();
    let na: f64 = a.iter().map(|v| v.abs()).sum();
    (na - nr) / nr
}

/// Radial asymmetry: a radially symmetric kernel has the same value at
/// distance d along the axis and along the diagonal. With diagonal cells
/// (m, m) at d_m = m sqrt(2) cell and the axis slice A(j, 0) interpolated
/// linearly in d, asymmetry = ||A_diag(d_m) - A_axis(d_m)||_2 /
/// ||A_axis(d_m)||_2 over m = 0 .. floor(half / sqrt 2). 0 for a radial
/// kernel (up to discretisation: the same number for R is reported apart).
pub fn asymmetry(a: &[f64], n: usize) -> f64 {
    let h = n / 2;
    let axis = |d: f64| -> f64 {
        let j = d.floor() as usize;
        let t = d - j as f64;
        let v = |j: usize| a[h * n + h + j];
        if j >= h {
            v(h)
        } else {
            v(j) * (1.0 - t) + v(j + 1) * t
        }
    };
    let mmax = (h as f64 / std::f64::consts::SQRT_2).floor() as usize;
    let (mut num, mut den) = (0.0, 0.0);
    for m in 0..=mmax {
        let d = m as f64 * std::f64::consts::SQRT_2;
        let ax = axis(d);
        let dg = a[(h + m) * n + h + m];
        num += (dg - ax) * (dg - ax);
        den += ax * ax;
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        0.0
    }
}

/// All per-channel metrics of a model on kernel `k`.
pub struct ChannelMetrics {
    pub kernel_rms: [f64; 3],
    pub norm1_error: [f64; 3],
    pub asymmetry: [f64; 3],
    pub truth_asymmetry: [f64; 3],
    pub max_abs_error: [f64; 3],
}

pub fn measure(k: &Kernel2D, f: &Factors) -> ChannelMetrics {
    let n = k.size;
    let mut m = ChannelMetrics {
        kernel_rms: [0.0; 3],
        norm1_error: [0.0; 3],
        asymmetry: [0.0; 3],
        truth_asymmetry: [0.0; 3],
        max_abs_error: [0.0; 3],
    };
    for c in 0..3 {
        let a = reconstruct(f, n, c);
        let r = &k.data[c];
        m.kernel_rms[c] = kernel_rms(r, &a);
        m.norm1_error[c] = norm1_error(r, &a);
        m.asymmetry[c] = asymmetry(&a, n);
        m.truth_asymmetry[c] = asymmetry(r, n);
        m.max_abs_error[c] = r
            .iter()
            .zip(&a)
            .map(|(r, a)| (r - a).abs())
            .fold(0.0, f64::max);
    }
    m
}
