//! One camera path in one channel: the MCML walk (Wang et al. 1995) inside
//! each object, with next-event estimation of the directional lights at
//! every scattering event and the environment picked up by paths that
//! leave.
//!
//! The estimator, per path: the weight w starts at 1; at a boundary the
//! path is reflected with probability R (unpolarised Fresnel; 1 under
//! total internal reflection) and transmitted otherwise, as MCML's
//! all-or-none choice; inside, a flight of optical depth -ln(xi) ends at
//! a scattering event where a directional light of irradiance E adds
//! w a p_HG(cos) E T (a = sigma_s / sigma_t, T the transmittance to the
//! light through index-matched boundaries), then w becomes w a and a new
//! direction is drawn from p_HG; a path leaving every object adds w L_env.
//! Collision estimation with implicit absorption is unbiased for the
//! radiance transport equation (Lafortune and Willems 1996); the
//! roulettes of `simulate` keep it so.

use super::camera::Measure;
use super::geometry::{frame, Ray, Shape, V3};
use super::Scene;
use crate::profile::analytic::pbd::phase_hg;
use crate::profile::fresnel::fresnel_dielectric;
use crate::profile::mc::tracer::{sample_hg_cos, LayerOptics};
use crate::profile::mc::{
    DEFAULT_EVENT_ROULETTE, DEFAULT_ROULETTE_THRESHOLD, EVENT_ROULETTE_SURVIVAL, ROULETTE_CHANCE,
};
use rand_core::RngCore;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Most boundaries a shadow ray crosses before it is given up as blocked.
const MAX_SHADOW_CROSSINGS: usize = 64;

/// Uniform in [0, 1) with 53 random bits.
#[inline(always)]
pub(crate) fn uniform(rng: &mut Xoshiro256PlusPlus) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// What one path did.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PathStats {
    /// Scattering events and boundary crossings.
    pub events: u64,
    /// The path inside an object found no boundary ahead (round-off at a
    /// grazing crossing): it ends, and is counted.
    pub lost: bool,
}

/// The scene as one channel sees it.
pub(crate) struct ChannelScene<'a> {
    pub scene: &'a Scene,
    optics: Vec<LayerOptics>,
    eta: Vec<f64>,
    lights: Vec<(V3, f64)>,
    env: f64,
    /// Offset of a new ray from the surface it leaves, mm.
    eps: f64,
}

impl<'a> ChannelScene<'a> {
    pub fn new(scene: &'a Scene, c: usize) -> ChannelScene<'a> {
        let optics = scene
            .objects
            .iter()
            .map(|o| {
                let l = &o.material.layers[0];
                LayerOptics::unbounded(l.sigma_a[c], l.sigma_s[c], l.g[c], o.eta())
            })
            .collect();
        ChannelScene {
            scene,
            optics,
            eta: scene.objects.iter().map(|o| o.eta()).collect(),
            lights: scene.directional().map(|(d, e)| (d, e[c])).collect(),
            env: scene.environment()[c],
            eps: 1e-9 * (1.0 + scene.reach()),
        }
    }

    /// One sample of pixel (x, y): box filter over the pixel.
    pub fn sample(&self, x: usize, y: usize, rng: &mut Xoshiro256PlusPlus) -> (f64, PathStats) {
        let cam = &self.scene.camera;
        let px = x as f64 + uniform(rng);
        let py = y as f64 + uniform(rng);
        let ray = cam.ray(px, py);
        let mut stats = PathStats::default();
        let l = match cam.measure {
            Measure::Radiance => self.radiance(ray, None, rng, &mut stats),
            Measure::Exitance => match self.scene.nearest(&ray, f64::INFINITY) {
                None => self.env,
                Some((k, hit)) => {
                    // The radiance leaving along a cosine-distributed
                    // direction: its mean is the exitance / pi.
                    let (u, v) = frame(hit.n);
                    let (a, b) = (uniform(rng), uniform(rng));
                    let (s, c) = (std::f64::consts::TAU * b).sin_cos();
                    let r = a.sqrt();
                    let omega = r * c * u + r * s * v + (1.0 - a).max(0.0).sqrt() * hit.n;
                    let at = Ray {
                        o: ray.at(hit.t),
                        d: -omega,
                    };
                    self.radiance(at, Some((k, hit.n)), rng, &mut stats)
                }
            },
        };
        (l, stats)
    }

    /// Radiance arriving along `ray` (towards its origin). `at` marks a ray
    /// whose origin is on object k's surface with normal n, about to cross.
    fn radiance(
        &self,
        mut ray: Ray,
        at: Option<(usize, V3)>,
        rng: &mut Xoshiro256PlusPlus,
        stats: &mut PathStats,
    ) -> f64 {
        let mut w = 1.0;
        let mut l = 0.0;
        let mut inside: Option<usize> = None;
        let mut pending = at;
        let mut next_event_roulette = DEFAULT_EVENT_ROULETTE;
        loop {
            match inside {
                None => {
                    let (k, p, n) = match pending.take() {
                        Some((k, n)) => (k, ray.o, n),
                        None => match self.scene.nearest(&ray, f64::INFINITY) {
                            None => {
                                l += w * self.env;
                                break;
                            }
                            Some((k, hit)) => (k, ray.at(hit.t), hit.n),
                        },
                    };
                    // Entering object k through its boundary (cos_i > 0).
                    let cos_i = -ray.d.dot(&n);
                    let eta = self.eta[k];
                    let r = fresnel_dielectric(cos_i, eta);
                    if r > 0.0 && (r >= 1.0 || uniform(rng) < r) {
                        ray = Ray {
                            o: p + self.eps * n,
                            d: reflect(ray.d, n),
                        };
                    } else {
                        ray = Ray {
                            o: p - self.eps * n,
                            d: refract(ray.d, n, 1.0 / eta).unwrap_or(ray.d),
                        };
                        inside = Some(k);
                    }
                }
                Some(k) => {
                    let o = &self.optics[k];
                    let Some(hit) = self.scene.objects[k].shape.intersect(&ray, f64::INFINITY)
                    else {
                        stats.lost = true;
                        break;
                    };
                    // s = -ln(xi) / sigma_t, xi in (0, 1] (Wang et al. 1995).
                    let s = -(1.0 - uniform(rng)).ln() / o.sigma_t();
                    if s < hit.t {
                        let x = ray.at(s);
                        let a = o.albedo();
                        for &(toward, e) in &self.lights {
                            if e > 0.0 {
                                l += w * a * e * self.direct(x, ray.d, toward, k);
                            }
                        }
                        w *= a;
                        let cos_t = sample_hg_cos(o, uniform(rng));
                        ray = Ray {
                            o: x,
                            d: turn(ray.d, cos_t, uniform(rng)),
                        };
                    } else {
                        let p = ray.at(hit.t);
                        let n = hit.n;
                        let eta = self.eta[k];
                        // Leaving: from index eta to 1, cos_i = d.n > 0.
                        let cos_i = ray.d.dot(&n);
                        let r = fresnel_dielectric(cos_i, 1.0 / eta);
                        if r > 0.0 && (r >= 1.0 || uniform(rng) < r) {
                            ray = Ray {
                                o: p - self.eps * n,
                                d: reflect(ray.d, n),
                            };
                        } else {
                            ray = Ray {
                                o: p + self.eps * n,
                                d: refract(ray.d, -n, eta).unwrap_or(ray.d),
                            };
                            inside = None;
                        }
                    }
                }
            }
            stats.events += 1;
            if w < DEFAULT_ROULETTE_THRESHOLD {
                // Wang et al. 1995.
                if uniform(rng) < ROULETTE_CHANCE {
                    w /= ROULETTE_CHANCE;
                } else {
                    break;
                }
            }
            if stats.events >= next_event_roulette {
                // The event-count roulette of `simulate` (see
                // EVENT_ROULETTE_SURVIVAL): bounds the walks of albedo 1.
                next_event_roulette = next_event_roulette.saturating_mul(2);
                if uniform(rng) < EVENT_ROULETTE_SURVIVAL {
                    w /= EVENT_ROULETTE_SURVIVAL;
                } else {
                    break;
                }
            }
        }
        l
    }

    /// The light of a directional light of unit irradiance along `toward`
    /// scattered at `x` inside object k towards -d, per unit albedo: the
    /// sum over the unscattered beam's ways to x of p_HG(cos) E_x e^{-sigma_t
    /// s}, E_x the beam's irradiance (perpendicular to it) where it entered
    /// times the Fresnel transmittance and the beam's compression, s the
    /// path inside, over eta^2. Through an index-matched boundary the beam goes
    /// straight (any shape); through a refracting one its entry point is
    /// solved for on a sphere or a box face (the scene's validation refuses
    /// other shapes). Light reflected inside before it first scatters is
    /// left out: a share below R e^{-sigma_t chord} of the beam.
    fn direct(&self, x: V3, d: V3, toward: V3, k: usize) -> f64 {
        let o = &self.optics[k];
        let eta = self.eta[k];
        if eta == 1.0 {
            // Light travels along -toward and leaves along -d: the
            // scattering cosine is d.toward.
            let t = self.transmittance(x, toward, k);
            return if t > 0.0 {
                phase_hg(d.dot(&toward), o.g()) * t
            } else {
                0.0
            };
        }
        // The beam's irradiance is power per area inside; radiance over
        // n^2 is what a boundary keeps (the n^2 law), so the radiance the
        // camera path carries out is the inside one over eta^2 (paths from
        // the environment gain eta^2 on the way in and lose it on the way
        // out).
        let mut sum = 0.0;
        for entry in self.entries(x, toward, k) {
            let shadow = self.outside_transmittance(entry.point + self.eps * entry.normal, toward);
            if shadow > 0.0 {
                // The beam travels along `dir` inside: cosine -dir.d.
                sum += phase_hg(-entry.dir.dot(&d), o.g())
                    * entry.irradiance
                    * (-o.sigma_t() * entry.path).exp()
                    * shadow;
            }
        }
        sum / (eta * eta)
    }

    /// Where the refracted beam of a unit-irradiance directional light
    /// along `toward` that reaches `x` (inside object k) entered.
    fn entries(&self, x: V3, toward: V3, k: usize) -> Vec<Entry> {
        let eta = self.eta[k];
        match &self.scene.objects[k].shape {
            Shape::Sphere { centre, radius } => sphere_entries(x - centre, *radius, toward, eta)
                .into_iter()
                .map(|e| Entry {
                    point: e.point + centre,
                    ..e
                })
                .collect(),
            Shape::Cuboid { min, max } => box_entries(x, *min, *max, toward, eta),
            _ => Vec::new(),
        }
    }

    /// Transmittance from `o` outside every object to a light along
    /// `toward`: e^{-sigma_t chord} through each index-matched object in
    /// the way, 0 through a refracting one.
    fn outside_transmittance(&self, o: V3, toward: V3) -> f64 {
        let mut tau = 0.0f64;
        let mut o = o;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            let out = Ray { o, d: toward };
            let Some((j, hj)) = self.scene.nearest(&out, f64::INFINITY) else {
                return (-tau).exp();
            };
            if self.eta[j] != 1.0 {
                return 0.0;
            }
            let inner = Ray {
                o: out.at(hj.t) - self.eps * hj.n,
                d: toward,
            };
            let Some(hx) = self.scene.objects[j].shape.intersect(&inner, f64::INFINITY) else {
                return 0.0;
            };
            tau += self.optics[j].sigma_t() * hx.t;
            if tau > 745.0 {
                return 0.0;
            }
            o = inner.at(hx.t) + self.eps * hx.n;
        }
        0.0
    }

    /// Transmittance from `x` inside object k to a light along `toward`,
    /// through the index-matched boundaries of the objects in the way
    /// (e^{-sigma_t chord} each). Refracting objects in the way block it
    /// (the scene's validation keeps them out of scenes with directional
    /// lights).
    pub(crate) fn transmittance(&self, x: V3, toward: V3, k: usize) -> f64 {
        let ray = Ray { o: x, d: toward };
        let Some(h) = self.scene.objects[k].shape.intersect(&ray, f64::INFINITY) else {
            return 0.0;
        };
        let tau = self.optics[k].sigma_t() * h.t;
        (-tau).exp() * self.outside_transmittance(ray.at(h.t) + self.eps * h.n, toward)
    }
}

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
    // (P, t) in the plane, coordinates along (toward, e2).
    let ray = |th: f64| -> ((f64, f64), (f64, f64)) {
        let (s, c) = th.sin_cos();
        let sin_t = s * inv;
        let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
        let k = inv * c - cos_t;
        ((r * c, r * s), (-inv + k * c, k * s))
    };
    let f = |th: f64| -> f64 {
        let ((px, py), (tx, ty)) = ray(th);
        (a - px) * ty - (b - py) * tx
    };
    let top = std::f64::consts::FRAC_PI_2 * (1.0 - 1e-12);
    let mut out = Vec::new();
    let mut lo = -top;
    let mut f_lo = f(lo);
    for i in 1..=SPHERE_SCAN {
        let hi = top * (2.0 * i as f64 / SPHERE_SCAN as f64 - 1.0);
        let f_hi = f(hi);
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

/// `d` turned by polar cosine `cos_t` and azimuth 2 pi `u` around itself.
pub(crate) fn turn(d: V3, cos_t: f64, u: f64) -> V3 {
    let (a, b) = frame(d);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (s, c) = (std::f64::consts::TAU * u).sin_cos();
    (sin_t * c * a + sin_t * s * b + cos_t * d).normalize()
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
}
