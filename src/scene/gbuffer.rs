//! What a renderer's G-buffer hands a screen-space pass, from the scene's
//! camera: per pixel, box-filtered over `side` x `side` stratified
//! positions, the coverage (fraction of positions that see an object), the
//! linear view depth and the normal (means over the covered positions),
//! and the diffuse irradiance / pi x R_d (mean over all positions, 0 where
//! nothing is seen).
//!
//! Irradiance as a rasteriser computes it: a directional light gives
//! E max(0, N.L) where the shadow ray towards it meets no object (shadow
//! maps treat every object as opaque), a point light of intensity I at
//! distance d gives I max(0, N.L) / d^2 where the segment to it meets no
//! object; the environment gives pi L times the
//! cosine-weighted fraction of the hemisphere no object hides, estimated
//! with [`ENV_RAYS`] rays per position.

use super::frame::cosine_direction;
use super::ray::{Ray, V3};
use super::Scene;
use crate::error::{Error, Result};
use crate::profile::mc::tracer::uniform;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// Cosine-distributed visibility rays per position for the environment.
pub const ENV_RAYS: usize = 16;

/// Most positions per pixel side (16 x 16 per pixel), for the render's
/// G-buffer and the light-space method's surface points alike.
pub const MAX_SIDE: usize = 16;

/// Refuses `side` positions per pixel side outside 1..=[`MAX_SIDE`];
/// `context` names the caller in the error.
pub fn check_side(context: &str, side: usize) -> Result<()> {
    if (1..=MAX_SIDE).contains(&side) {
        return Ok(());
    }
    let reason = format!("must be in 1..={MAX_SIDE} (positions per pixel side)");
    Err(Error::invalid(context, "gbuffer_side", side, reason))
}

/// The G-buffer planes, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct GBuffer {
    /// Diffuse irradiance / pi x R_d per channel: `ssskit apply`'s input.
    pub irradiance: [Vec<f64>; 3],
    /// Linear view depth in scene units; `far` where nothing is seen.
    pub depth: Vec<f64>,
    /// World-space unit normal (x, y, z); 0 where nothing is seen.
    pub normal: [Vec<f64>; 3],
    /// Fraction of the pixel that sees an object.
    pub coverage: Vec<f64>,
}

/// Computes the G-buffer. `rd[k]` is object k's total diffuse reflectance
/// per channel; `far` (scene units) is the depth written where nothing is
/// seen; `side` x `side` positions per pixel.
pub(crate) fn gbuffer(scene: &Scene, rd: &[[f64; 3]], far: f64, side: usize, seed: u64) -> GBuffer {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let eps = 1e-9 * (1.0 + scene.reach());
    let light = Lighting {
        scene,
        env: scene.environment(),
        lights: scene.directional().collect(),
        points: scene.points().collect(),
    };
    let unit = scene.unit.mm();
    let per_pixel: Vec<([f64; 3], f64, V3, f64)> = (0..w * h)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % w, p / w);
            let mut rng =
                Xoshiro256PlusPlus::seed_from_u64(super::samples::sample_key(seed, 3, p as u64, 0));
            let mut irr = [0.0; 3];
            let (mut depth, mut normal, mut hits) = (0.0, V3::zeros(), 0usize);
            for j in 0..side {
                for i in 0..side {
                    let px = x as f64 + (i as f64 + 0.5) / side as f64;
                    let py = y as f64 + (j as f64 + 0.5) / side as f64;
                    let ray = cam.ray(px, py);
                    let Some((k, hit)) = scene.nearest(&ray, f64::INFINITY) else {
                        continue;
                    };
                    hits += 1;
                    let q = ray.at(hit.t);
                    depth += cam.depth(q) / unit;
                    normal += hit.n;
                    let e = light.at(hit.n, q + eps * hit.n, &mut rng);
                    for c in 0..3 {
                        irr[c] += e[c] / std::f64::consts::PI * rd[k][c];
                    }
                }
            }
            let n2 = (side * side) as f64;
            if hits == 0 {
                return ([0.0; 3], far, V3::zeros(), 0.0);
            }
            let nn = normal.norm();
            (
                irr.map(|v| v / n2),
                depth / hits as f64,
                if nn > 0.0 { normal / nn } else { V3::zeros() },
                hits as f64 / n2,
            )
        })
        .collect();
    let mut g = GBuffer {
        irradiance: Default::default(),
        depth: Vec::with_capacity(w * h),
        normal: Default::default(),
        coverage: Vec::with_capacity(w * h),
    };
    for (irr, d, n, cov) in per_pixel {
        for c in 0..3 {
            g.irradiance[c].push(irr[c]);
            g.normal[c].push(n[c]);
        }
        g.depth.push(d);
        g.coverage.push(cov);
    }
    g
}

/// The lights a position sees, as a rasteriser lights it.
struct Lighting<'a> {
    scene: &'a Scene,
    env: [f64; 3],
    lights: Vec<(V3, [f64; 3])>,
    points: Vec<(V3, [f64; 3])>,
}

impl Lighting<'_> {
    /// Whether no object meets the ray from `o` along `d` before `t_max`.
    fn open(&self, o: V3, d: V3, t_max: f64) -> bool {
        self.scene.nearest(&Ray { o, d }, t_max).is_none()
    }

    /// The irradiance at a point of normal `n`, with `lifted` the point
    /// moved off its surface for shadow rays: the unshadowed directional
    /// and point lights, and the environment through the open part of the
    /// hemisphere ([`ENV_RAYS`] rays from `rng`).
    fn at(&self, n: V3, lifted: V3, rng: &mut Xoshiro256PlusPlus) -> [f64; 3] {
        let mut e = [0.0; 3];
        for (toward, ir) in &self.lights {
            let cos = n.dot(toward);
            if cos > 0.0 && self.open(lifted, *toward, f64::INFINITY) {
                for c in 0..3 {
                    e[c] += ir[c] * cos;
                }
            }
        }
        for (at, intensity) in &self.points {
            let to = at - lifted;
            let dist = to.norm();
            let cos = n.dot(&to) / dist;
            if cos > 0.0 && self.open(lifted, to / dist, dist) {
                for c in 0..3 {
                    e[c] += intensity[c] * cos / (dist * dist);
                }
            }
        }
        if self.env.iter().any(|&v| v > 0.0) {
            let mut open = 0usize;
            for _ in 0..ENV_RAYS {
                let (a, b) = (uniform(rng), uniform(rng));
                let d = cosine_direction(n, a, b);
                if self.open(lifted, d, f64::INFINITY) {
                    open += 1;
                }
            }
            let f = open as f64 / ENV_RAYS as f64;
            for (e, l) in e.iter_mut().zip(self.env) {
                *e += std::f64::consts::PI * l * f;
            }
        }
        e
    }
}
