//! Convergence of the light-space directional method
//! (`filter::light_space`, Dal Corso et al. 2017) to the integral it
//! estimates, eq. 7: the scattered radiosity of a flat lit surface with a
//! straight shadow edge, from an independent quadrature.
//!
//! The scene: a skin1 box whose top face z = 0 (24 x 24 mm) is lit by a
//! directional light at normal incidence and at 60 degrees from either
//! side of the edge (the beam running into the shadow or away from it),
//! and by a point light 20 mm above it (index-matched: point lights need
//! eta = 1); the light map's texels off the top face or at x < 0 are
//! darkened (the shadow edge along y). An orthographic camera looks
//! straight down at x = -1, 0 and 1 mm.
//!
//! The quadrature shares no code with the method: the directional dipole,
//! the Fresnel reflectance and its moments are typed again below from the
//! papers (Frisvad et al. 2014 as Dal Corso et al. 2017, appendix, with
//! the bracket of Dal Corso 2014, eq. 3.13; the clamp at 0 of Dal Corso
//! 2014, listing B.1), and eq. 7 is integrated in polar coordinates about
//! x_o over the lit rectangle.

mod common;

use common::scenes;
use ssskit::filter::light_space::{light_space_cpu, LightSpaceInput, LightSpaceSetup};
use ssskit::numerics::gauss_legendre;
use std::f64::consts::PI;

type V = nalgebra::Vector3<f64>;

/// Light-map side: texels of 0.034 mm on the 17.4 mm bounding radius.
const MAP_SIDE: usize = 1024;
/// Seeds of the method, and samples per pixel and channel of each: the
/// spread of the seeds' means gives the standard error.
const SEEDS: u64 = 16;
const SAMPLES: usize = 8000;
/// The method looks up the nearest texel, so it integrates eq. 7 by the
/// midpoint rule on the texels' footprints: an error of order
/// (h^2 / 24) |f'' / f| with h = 0.034 mm / cos(theta) (0.068 mm at 60
/// degrees) and S_d varying on the scale of D (0.22 to 0.43 mm for
/// skin1), about 2e-3 where the peak dominates; the bound is that with
/// room, relative to the quadrature.
const MAP_BIAS: f64 = 5e-3;

/// skin1's coefficients (mm^-1) per channel: sigma_a, sigma_s (g = 0).
const SKIN1: [(f64, f64); 3] = [(0.032, 0.74), (0.17, 0.88), (0.48, 1.01)];

/// Unpolarised Fresnel reflectance from a medium of index n_i into one of
/// n_t at incidence cosine `c` (1 under total internal reflection).
fn fresnel(c: f64, n_i: f64, n_t: f64) -> f64 {
    let s2 = (n_i / n_t).powi(2) * (1.0 - c * c);
    if s2 >= 1.0 {
        return 1.0;
    }
    let t = (1.0 - s2).sqrt();
    let rs = (n_i * c - n_t * t) / (n_i * c + n_t * t);
    let rp = (n_i * t - n_t * c) / (n_i * t + n_t * c);
    0.5 * (rs * rs + rp * rp)
}

/// int_0^1 R(mu) mu^n dmu for light in a medium of index `n_in` meeting
/// one of `n_out` (d'Eon and Irving 2011's C_1, C_2), split at the
/// critical cosine, 400 Gauss-Legendre panels.
fn moment(n: i32, n_in: f64, n_out: f64) -> f64 {
    let crit = if n_in > n_out {
        (1.0 - (n_out / n_in).powi(2)).sqrt()
    } else {
        0.0
    };
    let f = |mu: f64| fresnel(mu, n_in, n_out) * mu.powi(n);
    let panels = |a: f64, b: f64| -> f64 {
        (0..400)
            .map(|k| {
                let (lo, hi) = (
                    a + (b - a) * k as f64 / 400.0,
                    a + (b - a) * (k + 1) as f64 / 400.0,
                );
                gauss_legendre(f, lo, hi)
            })
            .sum()
    };
    panels(0.0, crit) + panels(crit, 1.0)
}

/// The directional dipole's constants for one channel.
struct Dipole {
    d: f64,
    tr: f64,
    de: f64,
    a: f64,
    c_phi: f64,
    c_e: f64,
    c_phi_out: f64,
    sigma_t: f64,
    eta: f64,
}

impl Dipole {
    fn new(sigma_a: f64, sigma_s: f64, eta: f64) -> Dipole {
        let st = sigma_a + sigma_s;
        let d = 1.0 / (3.0 * st);
        let c_phi = 0.25 * (1.0 - 2.0 * moment(1, eta, 1.0));
        let c_e = 0.5 * (1.0 - 3.0 * moment(2, eta, 1.0));
        Dipole {
            d,
            tr: (sigma_a / d).sqrt(),
            de: 2.131 * d / (sigma_s / st).sqrt(),
            a: (1.0 - c_e) / (2.0 * c_phi),
            c_phi,
            c_e,
            c_phi_out: 0.25 * (1.0 - 2.0 * moment(1, 1.0, eta)),
            sigma_t: st,
            eta,
        }
    }

    /// S'_d(x, w, r) of Dal Corso 2014, eq. 3.13.
    fn sp(&self, x: V, w: V, no: V, r: f64) -> f64 {
        let (d, tr) = (self.d, self.tr);
        let (xw, xn) = (x.dot(&w), x.dot(&no));
        let k = 1.0 + tr * r;
        (-tr * r).exp() / (4.0 * self.c_phi_out * 4.0 * PI * PI * r.powi(3))
            * (self.c_phi * (r * r / d + 3.0 * k * xw)
                - self.c_e
                    * (3.0 * d * k * w.dot(&no)
                        - (k + 3.0 * d * (3.0 * k + (tr * r).powi(2)) / (r * r) * xw) * xn))
    }

    /// S_d(x_i, w_i; x_o), Dal Corso et al. 2017, appendix.
    fn s_d(&self, xi: V, ni: V, wi: V, xo: V, no: V) -> f64 {
        let c = wi.dot(&ni);
        let w12 =
            ((c * ni - wi) / self.eta) - ni * (1.0 - (1.0 - c * c) / (self.eta * self.eta)).sqrt();
        let x = xo - xi;
        let r2 = x.norm_squared();
        let mu0 = -no.dot(&w12);
        let dr2 = if mu0 > 0.0 {
            let cos_beta = -((r2 - x.dot(&w12).powi(2)) / (r2 + self.de * self.de)).sqrt();
            r2 + self.d * mu0 * (self.d * mu0 - 2.0 * self.de * cos_beta)
        } else {
            r2 + 1.0 / (3.0 * self.sigma_t).powi(2)
        };
        let n_star = if r2 > 0.0 && ni.cross(&x).norm() > 0.0 {
            (x / r2.sqrt()).cross(&ni.cross(&x).normalize())
        } else {
            ni
        };
        let xv = xi + 2.0 * self.a * self.de * n_star;
        let wv = w12 - 2.0 * w12.dot(&n_star) * n_star;
        let s = self.sp(x, w12, no, dr2.sqrt()) - self.sp(xo - xv, wv, no, (xo - xv).norm());
        s.max(0.0)
    }
}

/// The light of one case: towards it (directional) or its position.
#[derive(Clone, Copy)]
enum Lit {
    Toward(V),
    Point(V),
}

/// L_o = F_t(w_o) B / pi at x_o = (x0, 0, 0) seen from straight above,
/// B from eq. 7 over the lit rectangle edge <= x <= 12, |y| <= 12 (z = 0,
/// unit irradiance or intensity).
fn quadrature(dp: &Dipole, lit: Lit, x0: f64, edge: f64) -> f64 {
    let z = V::z();
    let xo = V::new(x0, 0.0, 0.0);
    let integrand = |xi: V| {
        let (wi, e) = match lit {
            Lit::Toward(t) => (t, 1.0),
            Lit::Point(p) => {
                let to = p - xi;
                (to.normalize(), 1.0 / to.norm_squared())
            }
        };
        let cos = wi.dot(&z);
        dp.s_d(xi, z, wi, xo, z) * e * cos * (1.0 - fresnel(cos, 1.0, dp.eta))
    };
    // The ray from x_o at angle phi inside the rectangle: [rho_in, rho_out].
    let clip = |phi: f64| -> Option<(f64, f64)> {
        let d = (phi.cos(), phi.sin());
        let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
        for (o, dir, a, b) in [(x0, d.0, edge, 12.0), (0.0, d.1, -12.0, 12.0)] {
            if dir.abs() < 1e-300 {
                if o < a || o > b {
                    return None;
                }
                continue;
            }
            let (t1, t2) = ((a - o) / dir, (b - o) / dir);
            lo = lo.max(t1.min(t2));
            hi = hi.min(t1.max(t2));
        }
        (hi > lo).then_some((lo, hi))
    };
    let n_phi = 1440;
    let mut b = 0.0;
    for k in 0..n_phi {
        let phi = (k as f64 + 0.5) * 2.0 * PI / n_phi as f64;
        let Some((lo, hi)) = clip(phi) else { continue };
        let u = V::new(phi.cos(), phi.sin(), 0.0);
        let start = 1e-5;
        let mut edges = vec![lo];
        edges.extend((0..=64).map(|i| lo + start * ((hi - lo) / start).powf(i as f64 / 64.0)));
        let line: f64 = edges
            .windows(2)
            .map(|e| gauss_legendre(|rho| rho * integrand(xo + rho * u), e[0], e[1]))
            .sum();
        b += line * 2.0 * PI / n_phi as f64;
    }
    // B = pi L int ...; L_o = F_t(w_o) B / pi.
    (1.0 - fresnel(1.0, 1.0, dp.eta)) * b
}

/// A flat skin1 slab (24 x 24 x 8 mm, top face at z = 0) under `light`,
/// seen from above by a 3 x 1 pixel orthographic camera.
fn scene(light: &str, eta: f64) -> ssskit::scene::Scene {
    let camera = "type = \"orthographic\"\nposition = [0, 0, 50]\nlook_at = [0, 0, 0]\n\
                  up = [0, 1, 0]\nmm_per_pixel = 1\nsize = [3, 1]";
    let slab = "shape = \"box\"\ncenter = [0, 0, -4]\nsize = [24, 24, 8]";
    let text = scenes::toml(camera, light, &scenes::object(slab, "skin1", eta));
    ssskit::scene::parse_scene_toml(&text, "flat", std::path::Path::new(".")).unwrap()
}

/// Where the shadow edge falls: a map resolves an edge only at its texel
/// boundaries, so the edge is the boundary line nearest x = 0 on the top
/// face, taken from the map's frame (its texel columns run along y in
/// every case here: the light lies in the x-z plane).
fn edge_of(map: &ssskit::scene::LightMap) -> f64 {
    assert!(
        map.v.x.abs() < 1e-12 && map.u.y.abs() < 1e-12,
        "{:?} {:?}",
        map.u,
        map.v
    );
    let h = 2.0 * map.half / map.side as f64;
    match map.source {
        ssskit::scene::LightSource::Directional { .. } => {
            // u.(p - centre) at p = (x, 0, 0) is u.x x - u.centre.
            let at0 = -map.u.dot(&map.centre);
            let k = (at0 / h).round();
            (k * h - at0) / map.u.x
        }
        ssskit::scene::LightSource::Point { position, .. } => {
            // The middle column's boundary, straight below the light.
            assert!(position.x == 0.0 && map.centre.x == 0.0 && map.side.is_multiple_of(2));
            0.0
        }
    }
}

/// The method with the shadow edge: its mean over [`SEEDS`] seeds and the
/// standard error of that mean, per pixel and channel, and the edge.
fn method(scene: &ssskit::scene::Scene) -> (Vec<[(f64, f64); 3]>, f64) {
    let mut input = LightSpaceInput::new(scene, MAP_SIDE, 1, SAMPLES).unwrap();
    assert!(input.warnings.is_empty(), "{:?}", input.warnings);
    let map = &mut input.maps[0];
    let edge = edge_of(map);
    assert!(edge.abs() < 0.1, "{edge}");
    for t in 0..map.object.len() {
        if map.position[t].x < edge || map.normal[t].z < 0.5 {
            for c in 0..3 {
                map.transmitted[c][t] = 0.0;
            }
        }
    }
    let runs: Vec<_> = (0..SEEDS)
        .map(|seed| {
            let setup = LightSpaceSetup {
                samples: SAMPLES,
                seed,
            };
            light_space_cpu(&input, &setup).unwrap()
        })
        .collect();
    let stats = (0..3)
        .map(|p| {
            std::array::from_fn(|c| {
                let v: Vec<f64> = runs.iter().map(|r| r.rgb[c][p]).collect();
                let n = v.len() as f64;
                let m = v.iter().sum::<f64>() / n;
                let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
                (m, (var / n).sqrt())
            })
        })
        .collect();
    (stats, edge)
}

/// Every case, pixel and channel: the method within 4 standard errors plus
/// [`MAP_BIAS`] of the quadrature.
fn agree(light: &str, lit: Lit, eta: f64) {
    let (got, edge) = method(&scene(light, eta));
    for c in 0..3 {
        let dp = Dipole::new(SKIN1[c].0, SKIN1[c].1, eta);
        for (p, x0) in [-1.0, 0.0, 1.0].into_iter().enumerate() {
            let want = quadrature(&dp, lit, x0, edge);
            let (m, se) = got[p][c];
            eprintln!(
                "{light} channel {c} x = {x0}: method {m:.6e} +- {se:.1e}, quadrature {want:.6e} \
                 ({:+.2} sigma, {:+.2e} relative)",
                (m - want) / se,
                m / want - 1.0
            );
            assert!(want > 0.0 && se > 0.0);
            assert!(
                (m - want).abs() <= 4.0 * se + MAP_BIAS * want,
                "{light}, channel {c}, x = {x0}: method {m:e} +- {se:e}, quadrature {want:e}"
            );
        }
    }
}

#[test]
fn normal_incidence() {
    let t = V::z();
    agree(
        "type = \"directional\"\ntoward = [0, 0, 1]\nirradiance = 1",
        Lit::Toward(t),
        1.3,
    );
}

/// 60 degrees from the normal, on the side of `sign` x.
fn oblique(sign: f64) {
    let t = V::new(
        sign * 60f64.to_radians().sin(),
        0.0,
        60f64.to_radians().cos(),
    );
    agree(
        &format!(
            "type = \"directional\"\ntoward = [{}, 0, {}]\nirradiance = 1",
            t.x, t.z
        ),
        Lit::Toward(t),
        1.3,
    );
}

/// The light over the lit side: the beam runs into the shadow.
#[test]
fn oblique_into_the_shadow() {
    oblique(1.0);
}

/// The light over the shadow: the beam runs away from it.
#[test]
fn oblique_away_from_the_shadow() {
    oblique(-1.0);
}

/// A point light 20 mm above the edge (index-matched box).
#[test]
fn point_light() {
    agree(
        "type = \"point\"\nposition = [0, 0, 20]\nintensity = 1",
        Lit::Point(V::new(0.0, 0.0, 20.0)),
        1.0,
    );
}
