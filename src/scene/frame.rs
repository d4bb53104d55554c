//! Orthonormal frames and the directions built in them: the frame around a
//! unit vector, a direction at a given polar angle and azimuth about an
//! axis, and the two uses of it, turning a path's direction by a sampled
//! scattering angle and drawing a cosine-distributed direction about a
//! surface normal.

use super::ray::V3;

/// An orthonormal pair (u, v) completing the unit vector `w` to a
/// right-handed frame (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited").
pub fn frame(w: V3) -> (V3, V3) {
    let s = if w.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + w.z);
    let b = w.x * w.y * a;
    (
        V3::new(1.0 + s * w.x * w.x * a, s * b, -s * w.x),
        V3::new(b, s + w.y * w.y * a, -w.y),
    )
}

/// The direction of polar cosine `cos_t` (and sine `sin_t`) about the unit
/// axis `w`, at azimuth 2 pi `u` in `frame(w)`.
fn about(w: V3, cos_t: f64, sin_t: f64, u: f64) -> V3 {
    let (a, b) = frame(w);
    let (s, c) = (std::f64::consts::TAU * u).sin_cos();
    sin_t * c * a + sin_t * s * b + cos_t * w
}

/// `d` turned by polar cosine `cos_t` and azimuth 2 pi `u` around itself.
pub(crate) fn turn(d: V3, cos_t: f64, u: f64) -> V3 {
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    about(d, cos_t, sin_t, u).normalize()
}

/// A direction about the unit normal `n` with density cos(theta) / pi
/// (Malley's method: a uniform point of the unit disc, radius sqrt(a) and
/// azimuth 2 pi b, lifted onto the hemisphere).
pub(crate) fn cosine_direction(n: V3, a: f64, b: f64) -> V3 {
    about(n, (1.0 - a).max(0.0).sqrt(), a.sqrt(), b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_right_handed() {
        for w in [
            V3::z(),
            -V3::z(),
            V3::new(0.6, 0.0, 0.8),
            V3::new(-0.48, 0.6, -0.64),
        ] {
            let (a, b) = frame(w);
            assert!(a.dot(&b).abs() < 1e-15 && a.dot(&w).abs() < 1e-15);
            assert!((a.cross(&b) - w).norm() < 1e-15);
        }
    }

    #[test]
    fn turn_keeps_the_polar_angle() {
        let d = V3::new(0.48, -0.6, 0.64);
        for k in 0..50 {
            let c = -1.0 + k as f64 / 25.0;
            let t = turn(d, c.clamp(-1.0, 1.0), k as f64 / 50.0);
            assert!((t.norm() - 1.0).abs() < 1e-14);
            assert!((t.dot(&d) - c.clamp(-1.0, 1.0)).abs() < 1e-12);
        }
    }

    /// Malley's method against its closed forms: a unit vector whose
    /// cosine with the normal is sqrt(1 - a) and whose azimuth in the
    /// frame is 2 pi b.
    #[test]
    fn cosine_directions_have_the_disc_radius_and_azimuth() {
        let n = V3::new(-0.48, 0.6, -0.64);
        let (u, v) = frame(n);
        for k in 0..40 {
            let (a, b) = (k as f64 / 40.0, (k as f64 * 0.37).fract());
            let d = cosine_direction(n, a, b);
            assert!((d.norm() - 1.0).abs() < 1e-14);
            assert!((d.dot(&n) - (1.0 - a).sqrt()).abs() < 1e-14);
            let (s, c) = (std::f64::consts::TAU * b).sin_cos();
            assert!((d.dot(&u) - a.sqrt() * c).abs() < 1e-14);
            assert!((d.dot(&v) - a.sqrt() * s).abs() < 1e-14);
        }
    }
}
