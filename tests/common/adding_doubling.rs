//! Total reflectance and transmittance of a homogeneous slab under a
//! normally incident collimated beam by the adding-doubling method (van de
//! Hulst 1980; as Prahl 1995 sets it up): the azimuthally averaged
//! Henyey-Greenstein redistribution on Gauss-Radau quadrature in mu (the
//! node mu = 1 carries the collimated beam), a layer of optical thickness
//! tau / 2^24 initialised from the radiative transfer equation to first
//! order, then doubled 24 times:
//! R2 = R + T (I - R R)^-1 R T, T2 = T (I - R R)^-1 T.
//! Index-matched boundaries (n = 1 inside and out). Independent of ssskit:
//! written from the radiative transfer equation; it reproduces van de
//! Hulst's tabulated R = 0.09739 and T = 0.66096 (albedo 0.9, tau 2,
//! g 0.75) within `AD_TABLE_TOLERANCE` (tests/mc_transmission.rs).

use std::f64::consts::PI;

/// Quadrature nodes in mu (Gauss-Radau, mu = 1 included).
const NODES: usize = 32;
/// Azimuth samples of the redistribution integral (trapezoid on a periodic
/// smooth integrand: spectrally accurate).
const AZIMUTHS: usize = 512;
/// Doublings from the thin starting layer: tau / 2^24, whose first-order
/// error (tau times its thickness) is below 1e-6.
const DOUBLINGS: i32 = 24;

/// Legendre P_{n-1}(x) and P_n(x).
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (0.0, 1.0);
    }
    for k in 2..=n {
        let k = k as f64;
        (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
    }
    (p0, p1)
}

/// Gauss-Radau nodes and weights in mu on (0, 1], mu = 1 the first node:
/// on [-1, 1] with x = -1 fixed, the other nodes are the roots of
/// P_{n-1} + P_n and the weights (1 - x) / (n P_{n-1}(x))^2 (2 / n^2 at
/// x = -1); mu = (1 - x) / 2 halves them.
pub fn radau(n: usize) -> (Vec<f64>, Vec<f64>) {
    let nf = n as f64;
    let mut mu = vec![1.0];
    let mut w = vec![1.0 / (nf * nf)];
    for k in 1..n {
        let mut x = -(2.0 * PI * k as f64 / (2.0 * nf - 1.0)).cos();
        for _ in 0..100 {
            let (a, b) = legendre(n, x);
            let f = a + b;
            // d/dx (P_{n-1} + P_n) from P'_m = m (x P_m - P_{m-1}) / (x^2 - 1).
            let (c, _) = legendre(n - 1, x);
            let da = (nf - 1.0) * (x * a - c) / (x * x - 1.0);
            let db = nf * (x * b - a) / (x * x - 1.0);
            let dx = f / (da + db);
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let (a, _) = legendre(n, x);
        mu.push((1.0 - x) / 2.0);
        w.push(0.5 * (1.0 - x) / (nf * a).powi(2));
    }
    (mu, w)
}

/// The Henyey-Greenstein phase function (normalised over the sphere)
/// integrated over the azimuth between directions of cosines `a` and `b`.
fn redistribution(g: f64, a: f64, b: f64) -> f64 {
    let s = ((1.0 - a * a) * (1.0 - b * b)).max(0.0).sqrt();
    let dphi = 2.0 * PI / AZIMUTHS as f64;
    (0..AZIMUTHS)
        .map(|k| {
            let c = a * b + s * (k as f64 * dphi).cos();
            (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
        })
        .sum::<f64>()
        * dphi
}

type Mat = Vec<Vec<f64>>;

fn mul(a: &Mat, b: &Mat) -> Mat {
    let n = a.len();
    (0..n)
        .map(|i| {
            (0..n)
                .map(|j| (0..n).map(|k| a[i][k] * b[k][j]).sum())
                .collect()
        })
        .collect()
}

/// (I - m)^-1 by Gauss-Jordan elimination with partial pivoting.
fn inverse_of_identity_minus(m: &Mat) -> Mat {
    let n = m.len();
    let mut a: Mat = (0..n)
        .map(|i| (0..n).map(|j| f64::from(i == j) - m[i][j]).collect())
        .collect();
    let mut inv: Mat = (0..n)
        .map(|i| (0..n).map(|j| f64::from(i == j)).collect())
        .collect();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap();
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for r in 0..n {
            if r != c && a[r][c] != 0.0 {
                let f = a[r][c];
                for j in 0..n {
                    a[r][j] -= f * a[c][j];
                    inv[r][j] -= f * inv[c][j];
                }
            }
        }
    }
    inv
}

/// (total diffuse reflectance, total transmittance including the
/// unscattered beam) of a slab of single-scattering albedo `albedo`,
/// optical thickness `tau` and HG anisotropy `g`, index-matched, under a
/// normal collimated beam of unit flux.
pub fn slab_totals(albedo: f64, tau: f64, g: f64) -> (f64, f64) {
    let (mu, w) = radau(NODES);
    let n = mu.len();
    // h(mu_i, +-mu_j), each row renormalised so that a scattering keeps
    // its energy on the quadrature (Prahl 1995).
    let mut hpp: Mat = vec![vec![0.0; n]; n];
    let mut hpm: Mat = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            hpp[i][j] = redistribution(g, mu[i], mu[j]);
            hpm[i][j] = redistribution(g, mu[i], -mu[j]);
        }
        let total: f64 = (0..n).map(|j| w[j] * (hpp[i][j] + hpm[i][j])).sum();
        for j in 0..n {
            hpp[i][j] /= total;
            hpm[i][j] /= total;
        }
    }
    let d = tau / 2f64.powi(DOUBLINGS);
    let mut r: Mat = vec![vec![0.0; n]; n];
    let mut t: Mat = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            r[i][j] = d / mu[i] * albedo * hpm[i][j] * w[j];
            t[i][j] = d / mu[i] * albedo * hpp[i][j] * w[j];
        }
        t[i][i] += 1.0 - d / mu[i];
    }
    for _ in 0..DOUBLINGS {
        let rr = mul(&r, &r);
        let g_inv = inverse_of_identity_minus(&rr);
        let tg = mul(&t, &g_inv);
        let r2 = {
            let x = mul(&mul(&tg, &r), &t);
            (0..n)
                .map(|i| (0..n).map(|j| r[i][j] + x[i][j]).collect())
                .collect()
        };
        t = mul(&tg, &t);
        r = r2;
    }
    // The beam on node 0 (mu = 1) with unit flux: I = 1 / (2 pi mu w);
    // the flux out is 2 pi sum mu_i w_i I_i.
    let k = 0;
    let flux = |m: &Mat| (0..n).map(|i| mu[i] * w[i] * m[i][k]).sum::<f64>() / (mu[k] * w[k]);
    (flux(&r), flux(&t))
}
