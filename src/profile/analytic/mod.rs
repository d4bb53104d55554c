//! Closed-form diffusion profiles: cheap alternatives to simulation.

pub mod dipole;

use super::RadialGrid;

/// Bin averages of a radial function over annuli: int f(r) 2 pi r dr / area,
/// by 8-point Gauss-Legendre per bin. Averages stay finite where f has an
/// integrable singularity at r = 0 because no node sits at r = 0.
pub fn bin_averages(f: impl Fn(f64) -> f64, grid: &RadialGrid) -> Vec<f64> {
    grid.edges
        .windows(2)
        .zip(grid.areas())
        .map(|(e, area)| {
            gauss_legendre(|r| f(r) * 2.0 * std::f64::consts::PI * r, e[0], e[1]) / area
        })
        .collect()
}

/// 8-point Gauss-Legendre quadrature of `f` over [a, b].
pub fn gauss_legendre(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut s = 0.0;
    for k in 0..4 {
        s += W[k] * (f(m - h * X[k]) + f(m + h * X[k]));
    }
    s * h
}

/// 2 pi int_0^inf f(r) r dr for a profile decaying at least like
/// exp(-r / scale): geometric panels from scale * 1e-6 out to 60 scales.
pub fn radial_total(f: impl Fn(f64) -> f64, scale: f64) -> f64 {
    let g = |r: f64| f(r) * 2.0 * std::f64::consts::PI * r;
    let g = &g;
    let mut a = 0.0;
    let mut b = scale * 1e-6;
    let mut s = 0.0;
    while a < 60.0 * scale {
        s += gauss_legendre(g, a, b);
        a = b;
        b = (b * 1.15).max(b + scale * 1e-6);
    }
    s
}
