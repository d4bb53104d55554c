//! The directional dipole of Frisvad et al. 2014 (Dal Corso 2014, ch. 3.3;
//! Dal Corso et al. 2017, appendix): the diffusive part S_d(x_i, w_i; x_o)
//! of the BSSRDF for any points, normals and direction of incidence, and its
//! reduction to a radial profile for normal incidence on a plane, which
//! evaluates the same S_d (one formula).
//!
//! Errata fixed (docs/references.md): in Dal Corso et al. 2017 the last term
//! of S'_d belongs inside C_E(eta)(...); d_v = |x_o - x_v|. Checked against
//! the structure of Dal Corso 2014, eq. 3.13 (where the bracket is right).
//!
//! Conventions: positions in mm, unit normals pointing out of the medium,
//! w_i the unit direction from x_i towards the light (Dal Corso et al.
//! 2017, eq. 6: the light travels along -w_i).
//!
//! At normal incidence on a plane the refracted ray is w_12 = -n, mu_0 = 1,
//! the modified tangent plane is the surface itself (n_i* = n), so with
//! x = x_o - x_i = (r, 0, 0):
//! - real source: x.w = 0, w.n = -1, x.n = 0, and
//!   d_r^2 = r^2 + D (D + 2 d_e r / sqrt(r^2 + d_e^2));
//! - virtual source at height z_v = 2 A d_e with w_v = +n: x.w = x.n = -z_v,
//!   w.n = 1, d_v^2 = r^2 + z_v^2.
//!
//! Integrating the outgoing Fresnel transmission over the hemisphere gives
//! 4 pi C_phi(1/eta), which cancels S_d's 1/(4 C_phi(1/eta)) (Dal Corso
//! 2014, eq. 3.11): R_d(r) = T_entry pi (S'_d(real) - S'_d(virtual)). The
//! real source term then reduces to C_phi phi(r), as in the standard dipole.

use crate::material::Medium;
use crate::profile::fresnel::FresnelMode;
use std::f64::consts::PI;

/// A point or direction, mm.
pub type Vec3 = nalgebra::Vector3<f64>;

/// Where the light enters and leaves: the points, their unit outward
/// normals and the unit direction from x_i towards the light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incidence {
    pub x_i: Vec3,
    pub n_i: Vec3,
    pub w_i: Vec3,
    pub x_o: Vec3,
    pub n_o: Vec3,
}

impl Incidence {
    /// Normal incidence on the plane z = 0 (normal +z), leaving at distance
    /// `r` along x: the geometry of the radial profile.
    pub fn normal(r: f64) -> Incidence {
        Incidence {
            x_i: Vec3::zeros(),
            n_i: Vec3::z(),
            w_i: Vec3::z(),
            x_o: Vec3::new(r, 0.0, 0.0),
            n_o: Vec3::z(),
        }
    }
}

/// The refracted direction w_12 of light arriving from `w_i` (towards the
/// light, n_i.w_i >= 0) through a boundary of relative index `eta` (Frisvad
/// et al. 2014; Dal Corso et al. 2017, appendix). Total internal reflection
/// (eta < 1 beyond the critical angle) gives the grazing direction.
pub fn refracted(w_i: &Vec3, n_i: &Vec3, eta: f64) -> Vec3 {
    let c = w_i.dot(n_i);
    let tangential = (c * n_i - w_i) / eta;
    tangential - n_i * (1.0 - (1.0 - c * c) / (eta * eta)).max(0.0).sqrt()
}

#[derive(Clone, Debug)]
pub struct DirectionalDipole {
    pub d: f64,
    pub sigma_tr: f64,
    /// Extrapolation distance d_e = 2.131 D / sqrt(alpha') (Dal Corso 2014, eq. after 3.15).
    pub d_e: f64,
    pub a: f64,
    pub c_phi: f64,
    pub c_e: f64,
    pub t_entry: f64,
    /// Relative index n_medium / n_outside: the refraction of w_i into w_12.
    pub eta: f64,
    /// Extinction sigma_t (not reduced): a source behind the exit point sits
    /// at 1 / (3 sigma_t) (Frisvad et al. 2014, the case mu_0 <= 0).
    pub sigma_t: f64,
    /// C_phi(1/eta): S_d's exit normalisation 1 / (4 C_phi(1/eta)).
    pub c_phi_exit: f64,
}

impl DirectionalDipole {
    pub fn new(m: &Medium, mode: FresnelMode, t_entry: f64) -> DirectionalDipole {
        let alpha = m.reduced_albedo();
        let d = m.diffusion_coefficient();
        DirectionalDipole {
            d,
            sigma_tr: m.sigma_tr(),
            d_e: 2.131 * d / alpha.sqrt(),
            a: mode.boundary_a(m.eta),
            c_phi: mode.c_phi(m.eta),
            c_e: mode.c_e(m.eta),
            t_entry,
            eta: m.eta,
            sigma_t: m.sigma_t(),
            c_phi_exit: mode.c_phi(1.0 / m.eta),
        }
    }

    /// S'_d of Dal Corso 2014, eq. 3.13 without the 1/(4 C_phi(1/eta)) factor, for the
    /// scalar products x.w, w.n, x.n and distance `dist`.
    fn s_prime(&self, x_w: f64, w_n: f64, x_n: f64, dist: f64) -> f64 {
        let (d, tr) = (self.d, self.sigma_tr);
        let one = 1.0 + tr * dist;
        let r2 = dist * dist;
        let t0 = (-tr * dist).exp() / (4.0 * PI * PI * r2 * dist);
        let t1 = r2 / d + 3.0 * one * x_w;
        let t2 = 3.0 * d * one * w_n;
        let t3 = (one + 3.0 * d * (3.0 * one + (tr * dist).powi(2)) / r2 * x_w) * x_n;
        t0 * (self.c_phi * t1 - self.c_e * (t2 - t3))
    }

    /// Height of the virtual source above the surface, 2 A d_e.
    pub fn z_v(&self) -> f64 {
        2.0 * self.a * self.d_e
    }

    /// S'_d(x_o - x_i, w_12, d_r) - S'_d(x_o - x_v, w_v, d_v) (Frisvad et al.
    /// 2014; Dal Corso et al. 2017, appendix), before the exit
    /// normalisation and the clamp.
    fn source_pair(&self, g: &Incidence) -> f64 {
        let x = g.x_o - g.x_i;
        let r2 = x.norm_squared();
        let w12 = refracted(&g.w_i, &g.n_i, self.eta);
        let x_w = x.dot(&w12);
        let mu0 = -g.n_o.dot(&w12);
        let z_r2 = if mu0 > 0.0 {
            // -d_e cos(beta) = d_e sqrt((r^2 - (x.w)^2) / (r^2 + d_e^2)),
            // written to stay finite as alpha' -> 0, where d_e -> inf, the
            // virtual source leaves and the real one stays (the model does
            // not vanish without scattering).
            let s = (r2 - x_w * x_w).max(0.0).sqrt();
            let de_cos_beta = s / ((r2.sqrt() / self.d_e).powi(2) + 1.0).sqrt();
            let dm = self.d * mu0;
            dm * (dm + 2.0 * de_cos_beta)
        } else {
            (3.0 * self.sigma_t).powi(-2)
        };
        let real = self.s_prime(x_w, w12.dot(&g.n_o), x.dot(&g.n_o), (r2 + z_r2).sqrt());
        let z_v = self.z_v();
        if !z_v.is_finite() {
            return real;
        }
        let n_star = modified_normal(&x, &g.n_i);
        // x_o - x_v, x_v = x_i + 2 A d_e n_i*.
        let xv = x - z_v * n_star;
        let w_v = w12 - 2.0 * w12.dot(&n_star) * n_star;
        real - self.s_prime(xv.dot(&w_v), w_v.dot(&g.n_o), xv.dot(&g.n_o), xv.norm())
    }

    /// S_d(x_i, w_i; x_o) per unit incident flux, mm^-2 sr^-1 (Frisvad et
    /// al. 2014): the Fresnel transmissions at entry and exit are the
    /// caller's (Dal Corso et al. 2017, eq. 2). The flux terms can push the
    /// difference below zero far out; the clamp is Frisvad's (and
    /// appleseed's) too.
    pub fn s_d(&self, g: &Incidence) -> f64 {
        (self.source_pair(g) / (4.0 * self.c_phi_exit)).max(0.0)
    }

    /// R_d(r) at normal incidence on a plane, with the entry transmission:
    /// T_entry 4 pi C_phi(1/eta) S_d = T_entry pi S_d's bracket (module
    /// docs), evaluated on the same S_d.
    pub fn rd(&self, r: f64) -> f64 {
        (self.t_entry * PI * self.source_pair(&Incidence::normal(r))).max(0.0)
    }
}

/// The normal of the modified tangent plane n_i* (Frisvad et al. 2014):
/// the plane through x_i that holds x_o - x_i and is perpendicular to the
/// plane spanned by n_i and x_o - x_i; n_i itself when x_o = x_i (or x_o
/// lies on the normal through x_i, where that plane is undefined).
fn modified_normal(x: &Vec3, n_i: &Vec3) -> Vec3 {
    let v = n_i.cross(x);
    let (r, nv) = (x.norm(), v.norm());
    if r > 0.0 && nv > 0.0 {
        (x / r).cross(&(v / nv))
    } else {
        *n_i
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skin_red() -> DirectionalDipole {
        let m = Medium {
            sigma_a: 0.032,
            sigma_s: 0.74,
            g: 0.0,
            eta: 1.3,
        };
        DirectionalDipole::new(&m, FresnelMode::Exact, 0.98)
    }

    /// A rigid motion of the whole configuration leaves S_d unchanged:
    /// it reads only distances and angles.
    #[test]
    fn s_d_is_invariant_under_rotation_and_translation() {
        let dd = skin_red();
        let w = Vec3::new(-0.5, 0.1, 0.8).normalize();
        let g = Incidence {
            x_i: Vec3::new(0.2, -0.1, 0.0),
            n_i: Vec3::z(),
            w_i: w,
            x_o: Vec3::new(1.3, 0.4, 0.0),
            n_o: Vec3::z(),
        };
        let rot = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let shift = Vec3::new(5.0, -3.0, 7.0);
        let moved = Incidence {
            x_i: rot * g.x_i + shift,
            n_i: rot * g.n_i,
            w_i: rot * g.w_i,
            x_o: rot * g.x_o + shift,
            n_o: rot * g.n_o,
        };
        let (a, b) = (dd.s_d(&g), dd.s_d(&moved));
        assert!(a > 0.0);
        assert!((a - b).abs() <= 1e-12 * a, "{a} {b}");
    }

    /// At normal incidence the radial profile is S_d times the exit
    /// integral 4 pi C_phi(1/eta) and the entry transmission.
    #[test]
    fn radial_profile_is_s_d_times_the_exit_integral() {
        let dd = skin_red();
        for r in [0.0, 0.01, 0.5, 3.0, 20.0] {
            let s = dd.s_d(&Incidence::normal(r));
            let want = dd.t_entry * 4.0 * PI * dd.c_phi_exit * s;
            assert!(
                (dd.rd(r) - want).abs() <= 1e-12 * want.max(1e-300),
                "r = {r}"
            );
        }
    }

    /// The refraction obeys Snell's law and stays in the plane of incidence.
    #[test]
    fn refraction_is_snell() {
        let eta = 1.3;
        for deg in [0.0f64, 30.0, 60.0, 89.0] {
            let t = deg.to_radians();
            let w = Vec3::new(-t.sin(), 0.0, t.cos());
            let w12 = refracted(&w, &Vec3::z(), eta);
            assert!((w12.norm() - 1.0).abs() < 1e-15);
            assert!((w12.x - t.sin() / eta).abs() < 1e-15, "{deg}");
            assert!(w12.z < 0.0 && w12.y == 0.0);
        }
    }
}
