//! Smooth dielectric boundaries: mirror reflection, Snell refraction, and
//! MCML's all-or-none crossing (Wang et al. 1995): reflect with the
//! unpolarised Fresnel reflectance (1 under total internal reflection),
//! else transmit.

use super::ray::{Ray, V3};
use crate::profile::fresnel::fresnel_dielectric;
use crate::profile::mc::tracer::uniform;
use rand_xoshiro::Xoshiro256PlusPlus;

/// A path along `d` meeting at `p` a boundary whose unit normal `m` faces
/// it (d.m < 0), from index `n_i` into `n_t`: reflected with probability
/// R (Fresnel), else refracted; the new ray starts `eps` off the surface
/// on its side. Returns the ray and whether it crossed.
pub(crate) fn cross(
    d: V3,
    p: V3,
    m: V3,
    (n_i, n_t): (f64, f64),
    eps: f64,
    rng: &mut Xoshiro256PlusPlus,
) -> (Ray, bool) {
    let r = fresnel_dielectric(-d.dot(&m), n_t / n_i);
    if r > 0.0 && (r >= 1.0 || uniform(rng) < r) {
        let ray = Ray {
            o: p + eps * m,
            d: reflect(d, m),
        };
        (ray, false)
    } else {
        let ray = Ray {
            o: p - eps * m,
            d: refract(d, m, n_i / n_t).unwrap_or(d),
        };
        (ray, true)
    }
}

/// Mirror reflection of `d` about the plane of normal `n`.
pub(crate) fn reflect(d: V3, n: V3) -> V3 {
    d - 2.0 * d.dot(&n) * n
}

/// Snell's law: `d` crossing a boundary whose normal `n` faces against it
/// (d.n < 0), from index n1 into n2 with `ratio` = n1 / n2; None under
/// total internal reflection.
pub(crate) fn refract(d: V3, n: V3, ratio: f64) -> Option<V3> {
    let cos_i = -d.dot(&n);
    let sin2_t = ratio * ratio * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((ratio * d + (ratio * cos_i - cos_t) * n).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snell_and_mirror() {
        let n = V3::new(0.0, 0.0, 1.0);
        let d = V3::new(0.6, 0.0, -0.8);
        let r = reflect(d, n);
        assert!((r - V3::new(0.6, 0.0, 0.8)).norm() < 1e-15);
        // Into glass: sin_t = sin_i / 1.5.
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        assert!((t.x - 0.6 / 1.5).abs() < 1e-15 && t.z < 0.0);
        assert!((t.norm() - 1.0).abs() < 1e-15);
        // Out of glass at sin 0.8 > 1/1.5: total internal reflection.
        assert!(refract(V3::new(0.8, 0.0, -0.6), n, 1.5).is_none());
        assert!(refract(d, n, 1.5).is_some());
        // Index-matched: straight on.
        assert!((refract(d, n, 1.0).unwrap() - d).norm() < 1e-15);
    }
}
