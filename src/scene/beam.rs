//! The refracted beam of a directional light inside a sphere or a box:
//! every way an unscattered collimated beam, refracted where it enters,
//! reaches a point inside, with its irradiance there (Fresnel
//! transmittance times the beam's compression). Next-event estimation
//! through a refracting boundary needs these entries, since a backward
//! path cannot hit a delta light through a smooth boundary that bends it.

use super::boundary::refract;
use super::frame::frame;
use super::ray::V3;
use crate::profile::fresnel::fresnel_dielectric;

/// One way of a refracted collimated beam to a point inside an object.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Entry {
    /// Where the beam entered, and the outward normal there.
    pub point: V3,
    pub normal: V3,
    /// The beam's direction inside.
    pub dir: V3,
    /// Length inside, entry to the point.
    pub path: f64,
    /// The beam's irradiance perpendicular to `dir` at the point, per unit
    /// irradiance outside: Fresnel transmittance times the compression of
    /// the beam's cross-section.
    pub irradiance: f64,
}

/// The refracted beam in a box: through each face turned to the light
/// (normal n, cos_i = n.toward > 0) the beam goes along the refracted
/// direction t; it reaches x from the face point x - s t if that lies on
/// the face. A plane keeps the beam parallel: its cross-section grows by
/// cos_t / cos_i (irradiance T cos_i / cos_t).
pub(crate) fn box_entries(x: V3, min: V3, max: V3, toward: V3, eta: f64) -> Vec<Entry> {
    let mut out = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut n = V3::zeros();
            n[axis] = sign;
            let cos_i = n.dot(&toward);
            if !(cos_i > 0.0) {
                continue;
            }
            let Some(t) = refract(-toward, n, 1.0 / eta) else {
                continue;
            };
            let plane = if sign > 0.0 { max[axis] } else { min[axis] };
            let s = (x[axis] - plane) / t[axis];
            if !(s > 0.0) {
                continue;
            }
            let p = x - s * t;
            let on_face = (0..3)
                .filter(|&i| i != axis)
                .all(|i| p[i] >= min[i] && p[i] <= max[i]);
            if !on_face {
                continue;
            }
            let cos_t = -t.dot(&n);
            out.push(Entry {
                point: p,
                normal: n,
                dir: t,
                path: s,
                irradiance: (1.0 - fresnel_dielectric(cos_i, eta)) * cos_i / cos_t,
            });
        }
    }
    out
}

/// Largest index of a sphere under a directional light: the range
/// `sphere_entries_find_every_ray` checks.
pub const SPHERE_MAX_ETA: f64 = 2.0;

/// Cells of the scan for the entry points of `sphere_entries`, uniform in
/// the incidence angle over (-pi/2, pi/2).
const SPHERE_SCAN: usize = 32;

/// The refracted beam in a sphere of radius r centred at the origin, at
/// `q` inside, for eta in (1, SPHERE_MAX_ETA]. In the plane of the light's
/// axis (u = toward) and q, the beam entering at incidence angle theta
/// (point r (cos theta, sin theta); q at distance b >= 0 from the axis on
/// the side theta > 0) refracts along t(theta); an entry solves f(theta) =
/// cross(q - P(theta), t(theta)) = 0 on (-pi/2, pi/2). Near the back of
/// the ball more than one ray reaches q: one entering near grazing
/// incidence on q's side (the two meet on the caustic of the refracted
/// beam), and above eta = sqrt(2) one from the other side of the axis,
/// which such rays cross inside the ball. Every sign change of f on a scan
/// of [`SPHERE_SCAN`] cells is refined by the Illinois variant of false
/// position (Dowell and Jarratt 1971); two rays closer than a cell (a point
/// within a cell's width of the caustic) are missed together.
/// Power in a tube of rays is conserved: the beam's cross-section element
/// h dh dpsi (h = r |sin theta|) becomes w dtheta b dpsi at q, w the width
/// of the ray family across the ray, |cross(dP/dtheta + s dt/dtheta, t)|.
pub(crate) fn sphere_entries(q: V3, r: f64, toward: V3, eta: f64) -> Vec<Entry> {
    let a = q.dot(&toward);
    let perp = q - a * toward;
    let b = perp.norm().max(1e-9 * r);
    let e2 = if perp.norm() > 1e-9 * r {
        perp / perp.norm()
    } else {
        frame(toward).0
    };
    let inv = 1.0 / eta;
    // (P, t) in the plane, coordinates along (toward, e2), from the sine
    // and cosine of the incidence angle.
    let ray_sc = |(s, c): (f64, f64)| -> ((f64, f64), (f64, f64)) {
        let sin_t = s * inv;
        let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
        let k = inv * c - cos_t;
        ((r * c, r * s), (-inv + k * c, k * s))
    };
    let ray = |th: f64| ray_sc(th.sin_cos());
    let f_sc = |sc: (f64, f64)| -> f64 {
        let ((px, py), (tx, ty)) = ray_sc(sc);
        (a - px) * ty - (b - py) * tx
    };
    let f = |th: f64| f_sc(th.sin_cos());
    let nodes = scan_nodes();
    let mut out = Vec::new();
    let (mut lo, s, c) = nodes[0];
    let mut f_lo = f_sc((s, c));
    for &(hi, s, c) in &nodes[1..] {
        let f_hi = f_sc((s, c));
        if (f_lo < 0.0) != (f_hi < 0.0) {
            let th = illinois(&f, (lo, f_lo), (hi, f_hi), 1e-13 * r);
            if let Some(e) = sphere_ray(th, q, r, a, b, toward, e2, eta, &ray) {
                out.push(e);
            }
        }
        (lo, f_lo) = (hi, f_hi);
    }
    out
}

/// The scan's nodes of `sphere_entries`: each incidence angle with its
/// sine and cosine, the same for every point, radius and index (computed
/// once: the sines and cosines were most of a refracting sphere's render).
fn scan_nodes() -> &'static [(f64, f64, f64); SPHERE_SCAN + 1] {
    static NODES: std::sync::OnceLock<[(f64, f64, f64); SPHERE_SCAN + 1]> =
        std::sync::OnceLock::new();
    NODES.get_or_init(|| {
        let top = std::f64::consts::FRAC_PI_2 * (1.0 - 1e-12);
        std::array::from_fn(|i| {
            let th = if i == 0 {
                -top
            } else {
                top * (2.0 * i as f64 / SPHERE_SCAN as f64 - 1.0)
            };
            let (s, c) = th.sin_cos();
            (th, s, c)
        })
    })
}

/// The root of `f` in a bracket [(x0, f0), (x1, f1)] of opposite signs
/// (Illinois false position; Dowell and Jarratt 1971).
fn illinois(
    f: &dyn Fn(f64) -> f64,
    (mut ax, mut af): (f64, f64),
    (mut bx, mut bf): (f64, f64),
    tol: f64,
) -> f64 {
    let mut x = 0.5 * (ax + bx);
    for _ in 0..100 {
        let mut c = bx - bf * (bx - ax) / (bf - af);
        if !(c > ax.min(bx) && c < ax.max(bx)) {
            c = 0.5 * (ax + bx);
        }
        let fc = f(c);
        x = c;
        if fc.abs() <= tol || (bx - ax).abs() < 1e-15 {
            break;
        }
        if (fc < 0.0) != (bf < 0.0) {
            (ax, af) = (bx, bf);
        } else {
            af *= 0.5;
        }
        (bx, bf) = (c, fc);
    }
    x
}

/// The entry of the ray of incidence angle `th` that reaches q (see
/// `sphere_entries`), with its irradiance at q.
#[allow(clippy::too_many_arguments)]
fn sphere_ray(
    th: f64,
    q: V3,
    r: f64,
    a: f64,
    b: f64,
    toward: V3,
    e2: V3,
    eta: f64,
    ray: &dyn Fn(f64) -> ((f64, f64), (f64, f64)),
) -> Option<Entry> {
    let ((px, py), (tx, ty)) = ray(th);
    let s = (a - px) * tx + (b - py) * ty;
    if !(s > 0.0) {
        return None;
    }
    // d/dtheta of t by central differences (t is smooth away from grazing
    // incidence, which the scan stops short of).
    let hstep = 1e-6;
    let ((_, _), (tx1, ty1)) = ray(th + hstep);
    let ((_, _), (tx0, ty0)) = ray(th - hstep);
    let (dtx, dty) = ((tx1 - tx0) / (2.0 * hstep), (ty1 - ty0) / (2.0 * hstep));
    let (dpx, dpy) = (-r * th.sin(), r * th.cos());
    let (wx, wy) = (dpx + s * dtx, dpy + s * dty);
    let width = (wx * ty - wy * tx).abs();
    let (sin_i, cos_i) = th.sin_cos();
    let area_in = r * r * sin_i.abs() * cos_i;
    if !(width > 0.0) {
        return None;
    }
    let point = px * toward + py * e2;
    debug_assert!((point + s * (tx * toward + ty * e2) - q).norm() < 1e-6 * r);
    Some(Entry {
        point,
        normal: point / r,
        dir: tx * toward + ty * e2,
        path: s,
        irradiance: (1.0 - fresnel_dielectric(cos_i, eta)) * area_in / (width * b),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::ray::Ray;

    /// Every refracted ray of a collimated beam that reaches a point inside
    /// a ball is found, against a fine scan of the whole lit half circle
    /// with the 3D refraction; only two rays closer than a scan cell (a
    /// point next to the caustic) may be missed, together.
    #[test]
    fn sphere_entries_find_every_ray() {
        let toward = V3::new(0.48, 0.6, 0.64);
        let (u1, _) = frame(toward);
        let cell = std::f64::consts::PI / SPHERE_SCAN as f64;
        let mut pairs = 0;
        for eta in [1.05, 1.3, 1.5, 2.0] {
            for k in 1..300 {
                // Points spread over the ball, many near its surface.
                let f = k as f64 / 300.0;
                let rr = (0.999 * (f * 7.3).fract()).sqrt();
                let ang = std::f64::consts::TAU * (f * 13.7).fract();
                let q = rr * (ang.cos() * toward + ang.sin() * u1);
                let a = q.dot(&toward);
                let perp = q - a * toward;
                let e2 = perp / perp.norm();
                let ray = |th: f64| {
                    let p = th.cos() * toward + th.sin() * e2;
                    (p, refract(-toward, p, 1.0 / eta).unwrap())
                };
                let cross = |th: f64| {
                    let (p, t) = ray(th);
                    (q - p).cross(&t).dot(&toward.cross(&e2))
                };
                let n = 20_000;
                let edge = std::f64::consts::FRAC_PI_2 * (1.0 - 1e-9);
                let mut roots = Vec::new();
                let mut prev = cross(-edge);
                for i in 1..=n {
                    let th = edge * (2.0 * i as f64 / n as f64 - 1.0);
                    let cur = cross(th);
                    if (cur < 0.0) != (prev < 0.0) {
                        let (p, t) = ray(th);
                        if (q - p).dot(&t) > 0.0 {
                            roots.push(th);
                        }
                    }
                    prev = cur;
                }
                let found: Vec<f64> = sphere_entries(q, 1.0, toward, eta)
                    .iter()
                    .map(|e| {
                        // The refracted ray from the entry runs through q.
                        assert!((e.point + e.path * e.dir - q).norm() < 1e-9);
                        e.point.dot(&e2).atan2(e.point.dot(&toward))
                    })
                    .collect();
                for &t in &roots {
                    let hit = found.iter().any(|&g| (g - t).abs() < 1e-3);
                    let partner = roots.iter().any(|&o| o != t && (o - t).abs() < cell);
                    assert!(hit || partner, "eta {eta}, {q:?}: {roots:?} vs {found:?}");
                    pairs += (!hit) as usize;
                }
                assert!(found.len() <= roots.len(), "eta {eta}, {q:?}: {found:?}");
            }
        }
        eprintln!("rays missed in pairs next to the caustic: {pairs}");
    }

    /// The beam's irradiance at a point inside a ball, against a ray tube
    /// traced through it: parallel rays a small square apart, refracted
    /// by the sphere, cut by the plane across the beam at the point; the
    /// power the square carries (times the Fresnel transmittance) over the
    /// cut's area.
    #[test]
    fn sphere_entry_conserves_power_in_a_ray_tube() {
        use crate::scene::geometry::Shape;
        let ball = Shape::Sphere {
            centre: V3::zeros(),
            radius: 1.0,
        };
        let toward = V3::new(0.0, 0.6, 0.8);
        let (a, b) = frame(toward);
        for eta in [1.0 + 1e-9, 1.3, 1.7] {
            let mut checked = 0;
            for q in [
                V3::new(0.2, 0.1, 0.3),
                V3::new(-0.5, 0.3, -0.2),
                V3::new(0.7, -0.4, 0.1),
                V3::new(0.05, 0.02, -0.6),
                V3::new(0.3, -0.5, -0.7),
            ] {
                for e in sphere_entries(q, 1.0, toward, eta) {
                    let h = 1e-6;
                    // The beam's ray through the entry, and its neighbours.
                    let base = e.point - e.point.dot(&toward) * toward + 3.0 * toward;
                    let cut = |o: V3| -> V3 {
                        let ray = Ray { o, d: -toward };
                        let hit = ball.intersect(&ray, 1e9).unwrap();
                        let p = ray.at(hit.t);
                        let t = refract(-toward, hit.n, 1.0 / eta).unwrap();
                        // Where the refracted ray meets the plane through q
                        // across e.dir.
                        let s = (q - p).dot(&e.dir) / t.dot(&e.dir);
                        p + s * t
                    };
                    // Central differences: the h x h square maps to the
                    // parallelogram of the half-differences (error O(h^2)).
                    let da = cut(base + h * a) - cut(base - h * a);
                    let db = cut(base + h * b) - cut(base - h * b);
                    let area = 0.25 * da.cross(&db).norm();
                    let cos_i = e.normal.dot(&toward);
                    let tube = (1.0 - fresnel_dielectric(cos_i, eta)) * h * h / area;
                    assert!(
                        (tube - e.irradiance).abs() < 1e-5 * tube,
                        "eta {eta}, {q:?}: tube {tube}, entry {}",
                        e.irradiance
                    );
                    checked += 1;
                }
            }
            assert!(checked >= 2, "eta {eta}: {checked} entries");
        }
    }

    /// The planar entry: through the face turned to the light, at the
    /// point x - s t, compressed by cos_i / cos_t.
    #[test]
    fn box_entry_through_the_lit_faces() {
        let toward = V3::new(0.6, 0.0, 0.8);
        let x = V3::new(-3.0, -1.0, -0.5);
        let es = box_entries(x, V3::new(-5.0, -5.0, -5.0), V3::zeros(), toward, 1.5);
        assert_eq!(es.len(), 1, "{es:?}");
        let e = es[0];
        assert!((e.point.z).abs() < 1e-15 && (e.normal - V3::z()).norm() == 0.0);
        assert!((e.point + e.path * e.dir - x).norm() < 1e-12);
        let cos_t = (1.0 - (0.6f64 / 1.5).powi(2)).sqrt();
        let t = 1.0 - fresnel_dielectric(0.8, 1.5);
        assert!((e.irradiance - t * 0.8 / cos_t).abs() < 1e-12);
        // Both +x and +z faces see a light along (1, 0, 1)/sqrt(2); a
        // point near the +x face is reached through both.
        let diag = V3::new(1.0, 0.0, 1.0).normalize();
        let es = box_entries(
            V3::new(-0.1, 0.0, -0.1),
            V3::repeat(-5.0),
            V3::zeros(),
            diag,
            1.5,
        );
        assert_eq!(es.len(), 2);
    }
}
