//! Next-event estimation of the directional lights from a scattering event
//! inside an object: the phase function towards the light times the
//! light's transmittance, straight through index-matched boundaries, or
//! along the refracted beam's entries (`beam`) into a refracting sphere or
//! box; the shadow rays outside cross index-matched objects only.

use super::beam::{box_entries, sphere_entries, Entry};
use super::geometry::Shape;
use super::ray::{Ray, V3};
use super::trace::ChannelScene;
use crate::profile::analytic::pbd::phase_hg;

/// Most boundaries a shadow ray crosses before it is given up as blocked.
const MAX_SHADOW_CROSSINGS: usize = 64;

impl ChannelScene<'_> {
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
    pub(super) fn direct(&self, x: V3, d: V3, toward: V3, k: usize) -> f64 {
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

    /// The light of a point light of unit intensity at `at` scattered at
    /// `x` inside object k towards -d, per unit albedo: p_HG(cos) e^{-tau}
    /// / |at - x|^2, tau the optical depth of the straight segment to the
    /// light through index-matched boundaries (the scene's validation
    /// keeps point lights outside the objects and the objects
    /// index-matched).
    pub(super) fn direct_point(&self, x: V3, d: V3, at: V3, k: usize) -> f64 {
        let to = at - x;
        let dist = to.norm();
        if !(dist > 0.0) {
            return 0.0;
        }
        let toward = to / dist;
        let ray = Ray { o: x, d: toward };
        let Some(h) = self.scene.objects[k].shape.intersect(&ray, dist) else {
            return 0.0;
        };
        let tau = self.optics[k].sigma_t() * h.t;
        let out = self.outside_transmittance_within(
            ray.at(h.t) + self.eps * h.n,
            toward,
            dist - h.t - self.eps,
        );
        phase_hg(d.dot(&toward), self.optics[k].g()) * (-tau).exp() * out / (dist * dist)
    }

    /// Transmittance from `o` outside every object to a light along
    /// `toward`: e^{-sigma_t chord} through each index-matched object in
    /// the way, 0 through a refracting one.
    fn outside_transmittance(&self, o: V3, toward: V3) -> f64 {
        self.outside_transmittance_within(o, toward, f64::INFINITY)
    }

    /// [`Self::outside_transmittance`] to a light at distance `reach`
    /// along `toward` (infinite for a directional light).
    fn outside_transmittance_within(&self, o: V3, toward: V3, reach: f64) -> f64 {
        let mut tau = 0.0f64;
        let mut o = o;
        let mut left = reach;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            let out = Ray { o, d: toward };
            let Some((j, hj)) = self.scene.nearest(&out, left) else {
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
            left -= hj.t + hx.t;
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
