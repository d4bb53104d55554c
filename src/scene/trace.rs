//! One camera path in one channel: the MCML walk (Wang et al. 1995) inside
//! each object, with next-event estimation of the directional lights at
//! every scattering event (and of the point lights, through index-matched
//! boundaries) and the environment picked up by paths that leave.
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

//!
//! The walk is here; the boundary crossings are `boundary`'s, the
//! directional lights' estimate `light`'s (with `beam` for the refracted
//! beam), the directions `frame`'s.

use super::boundary::cross;
use super::camera::Measure;
use super::frame::{cosine_direction, turn};
use super::ray::{Ray, V3};
use super::Scene;
use crate::profile::mc::tracer::{sample_hg_cos, uniform, LayerOptics};
use crate::profile::mc::{
    DEFAULT_EVENT_ROULETTE, DEFAULT_ROULETTE_THRESHOLD, EVENT_ROULETTE_SURVIVAL, ROULETTE_CHANCE,
};
use rand_xoshiro::Xoshiro256PlusPlus;

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
    pub(super) optics: Vec<LayerOptics>,
    pub(super) eta: Vec<f64>,
    pub(super) lights: Vec<(V3, f64)>,
    /// Point lights: position and intensity (irradiance x mm^2).
    pub(super) points: Vec<(V3, f64)>,
    pub(super) env: f64,
    /// Offset of a new ray from the surface it leaves, mm.
    pub(super) eps: f64,
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
            points: scene.points().map(|(p, i)| (p, i[c])).collect(),
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
                    let (a, b) = (uniform(rng), uniform(rng));
                    let omega = cosine_direction(hit.n, a, b);
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
                    // Entering object k from the air.
                    let (next, crossed) = cross(ray.d, p, n, (1.0, self.eta[k]), self.eps, rng);
                    ray = next;
                    if crossed {
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
                        for &(at, i) in &self.points {
                            if i > 0.0 {
                                l += w * a * i * self.direct_point(x, ray.d, at, k);
                            }
                        }
                        w *= a;
                        let cos_t = sample_hg_cos(o, uniform(rng));
                        ray = Ray {
                            o: x,
                            d: turn(ray.d, cos_t, uniform(rng)),
                        };
                    } else {
                        // Leaving object k into the air: the normal facing
                        // the path is -n.
                        let p = ray.at(hit.t);
                        let (next, crossed) =
                            cross(ray.d, p, -hit.n, (self.eta[k], 1.0), self.eps, rng);
                        ray = next;
                        if crossed {
                            inside = None;
                        }
                    }
                }
            }
            stats.events += 1;
            // Wang et al. 1995.
            if w < DEFAULT_ROULETTE_THRESHOLD && !survives(&mut w, ROULETTE_CHANCE, rng) {
                break;
            }
            if stats.events >= next_event_roulette {
                // The event-count roulette of `simulate` (see
                // EVENT_ROULETTE_SURVIVAL): bounds the walks of albedo 1.
                next_event_roulette = next_event_roulette.saturating_mul(2);
                if !survives(&mut w, EVENT_ROULETTE_SURVIVAL, rng) {
                    break;
                }
            }
        }
        l
    }
}

/// Russian roulette: the path survives with probability `chance`, its
/// weight divided by it (unbiased), else ends.
fn survives(w: &mut f64, chance: f64, rng: &mut Xoshiro256PlusPlus) -> bool {
    if uniform(rng) < chance {
        *w /= chance;
        true
    } else {
        false
    }
}
