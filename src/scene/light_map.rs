//! The light-space G-buffer of the directional method (Dal Corso et al.
//! 2017, section 3.2, first step; a translucent shadow map, Dachsbacher
//! and Stamminger 2003): the scene seen from a light, per texel the first
//! surface point x_i, its normal n_i, the object and the light's
//! transmitted irradiance there, E F_t(theta) cos(theta) (the factor of
//! S_d in Dal Corso et al. 2017, eq. 7). A directional light sees the
//! scene through an orthographic view along the light; a point light
//! through a perspective one from its position (section 3.3), which holds
//! the objects only when the light is outside their bounding sphere (a
//! light the objects surround needs an omnidirectional map, which ssskit
//! does not build: refused).
//!
//! Texels are cast rays, not rasterised triangles: the same first hits a
//! rasteriser's depth test keeps, at the texel centres. Every object is
//! opaque to the map (a shadow map), so an object in front shadows what
//! lies behind it.

use super::frame::frame;
use super::ray::{Ray, V3};
use super::{Light, Scene};
use crate::error::{Error, Result};
use crate::profile::fresnel::fresnel_dielectric;
use rayon::prelude::*;

/// Errors' context.
pub const CONTEXT: &str = "light-space method";

/// Where the light comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightSource {
    /// Collimated along -toward; irradiance on a surface facing it.
    Directional { toward: V3, irradiance: [f64; 3] },
    /// A point at `position` (mm), intensity in irradiance x mm^2.
    Point { position: V3, intensity: [f64; 3] },
}

impl LightSource {
    /// The unit direction from `x` towards the light and the irradiance
    /// per channel on a surface at `x` facing it.
    pub fn at(&self, x: V3) -> (V3, [f64; 3]) {
        match *self {
            LightSource::Directional { toward, irradiance } => (toward, irradiance),
            LightSource::Point {
                position,
                intensity,
            } => {
                let to = position - x;
                let d2 = to.norm_squared();
                (to / d2.sqrt(), intensity.map(|i| i / d2))
            }
        }
    }
}

/// One light's map, row-major, row 0 at the top of the light's view.
#[derive(Clone, Debug, PartialEq)]
pub struct LightMap {
    pub source: LightSource,
    pub side: usize,
    /// The view's centre (the objects' bounding sphere's), its axis from
    /// the light into the scene, and the axes of its image plane (u to the
    /// right of a texel row, v up).
    pub centre: V3,
    pub forward: V3,
    pub u: V3,
    pub v: V3,
    /// Orthographic: half the view's side, mm. Perspective: tan of half
    /// its field of view.
    pub half: f64,
    /// Per texel: the first surface point and its outward unit normal
    /// (zeros where no object is seen), the object (-1: none) and the
    /// transmitted irradiance per channel.
    pub position: Vec<V3>,
    pub normal: Vec<V3>,
    pub object: Vec<i32>,
    pub transmitted: [Vec<f64>; 3],
}

impl LightMap {
    /// Texel coordinates (column, row, continuous: texel (i, j) spans
    /// [i, i + 1) x [j, j + 1)) of point `p`; None behind a point light.
    pub fn coordinates(&self, p: V3) -> Option<(f64, f64)> {
        let s = self.side as f64;
        match self.source {
            LightSource::Directional { .. } => {
                let q = p - self.centre;
                Some((
                    (0.5 + q.dot(&self.u) / (2.0 * self.half)) * s,
                    (0.5 - q.dot(&self.v) / (2.0 * self.half)) * s,
                ))
            }
            LightSource::Point { position, .. } => {
                let q = p - position;
                let z = q.dot(&self.forward);
                (z > 0.0).then(|| {
                    (
                        (0.5 + q.dot(&self.u) / (2.0 * z * self.half)) * s,
                        (0.5 - q.dot(&self.v) / (2.0 * z * self.half)) * s,
                    )
                })
            }
        }
    }

    /// The texel holding point `p` (nearest lookup), None outside the map.
    pub fn texel(&self, p: V3) -> Option<usize> {
        let (x, y) = self.coordinates(p)?;
        let s = self.side as f64;
        (x >= 0.0 && x < s && y >= 0.0 && y < s).then(|| y as usize * self.side + x as usize)
    }

    /// The ray of texel (i, j) through its centre, from the light's side
    /// of the scene.
    fn ray(&self, i: usize, j: usize) -> Ray {
        let s = self.side as f64;
        let a = 2.0 * (i as f64 + 0.5) / s - 1.0;
        let b = 1.0 - 2.0 * (j as f64 + 0.5) / s;
        match self.source {
            LightSource::Directional { .. } => Ray {
                o: self.centre + self.half * (a * self.u + b * self.v)
                    - 2.0 * self.half * self.forward,
                d: self.forward,
            },
            LightSource::Point { position, .. } => Ray {
                o: position,
                d: (self.forward + self.half * (a * self.u + b * self.v)).normalize(),
            },
        }
    }
}

/// The scene's light `index` as a light-map source, or why the method
/// cannot use it (an environment light).
fn source_of(scene: &Scene, index: usize) -> Result<LightSource> {
    match scene.lights.get(index) {
        Some(Light::Directional { toward, irradiance }) => Ok(LightSource::Directional {
            toward: *toward,
            irradiance: *irradiance,
        }),
        Some(Light::Point {
            position,
            intensity,
        }) => Ok(LightSource::Point {
            position: *position,
            intensity: *intensity,
        }),
        Some(Light::Environment { .. }) => Err(Error::Unsupported(format!(
            "{}: light[{index}] is an environment light: the light-space method takes \
             directional and point lights (Dal Corso et al. 2017, section 4, samples an \
             environment into directional lights; ssskit does not)",
            scene.origin
        ))),
        None => Err(Error::invalid(CONTEXT, "light", index, "no such light")),
    }
}

/// The view that holds every object: orthographic along a directional
/// light, covering the bounding sphere; perspective from a point light
/// outside it. Returns (centre, forward, u, v, half).
fn view_of(scene: &Scene, source: &LightSource) -> Result<(V3, V3, V3, V3, f64)> {
    let (lo, hi) = scene.bounds();
    let centre = 0.5 * (lo + hi);
    // A hair beyond the sphere, so that its silhouette's texels see it.
    let radius = 0.5 * (hi - lo).norm() * (1.0 + 1e-9);
    let (forward, half) = match *source {
        LightSource::Directional { toward, .. } => (-toward, radius),
        LightSource::Point { position, .. } => {
            let to = centre - position;
            let dist = to.norm();
            if !(dist > radius) {
                return Err(Error::Unsupported(format!(
                    "{}: the point light at {:?} mm is within the objects' bounding sphere \
                     (centre {:?}, radius {radius:.4} mm): one perspective light map cannot \
                     hold every object, and an omnidirectional one (Dal Corso et al. 2017, \
                     section 3.3) is not built: move the light out",
                    scene.origin,
                    position.as_slice(),
                    centre.as_slice()
                )));
            }
            (to / dist, radius / (dist * dist - radius * radius).sqrt())
        }
    };
    let (u, v) = frame(forward);
    Ok((centre, forward, u, v, half))
}

/// Why the scene's light `index` cannot have a light map (an environment
/// light, a point light the objects' bounding sphere holds), before any
/// work.
pub fn check_light(scene: &Scene, index: usize) -> Result<()> {
    view_of(scene, &source_of(scene, index)?).map(drop)
}

/// What a texel's ray meets: the object, the point, its normal and the
/// transmitted irradiance.
type Texel = (usize, V3, V3, [f64; 3]);

/// Builds the map of the scene's light `index` at `side` x `side` texels.
/// The caller checks `side` against `limits::check_light_space` first.
pub fn light_map(scene: &Scene, index: usize, side: usize) -> Result<LightMap> {
    crate::limits::check_light_space(CONTEXT, side, 1, 1, 1)?;
    let source = source_of(scene, index)?;
    let (centre, forward, u, v, half) = view_of(scene, &source)?;
    let mut map = LightMap {
        source,
        side,
        centre,
        forward,
        u,
        v,
        half,
        position: Vec::new(),
        normal: Vec::new(),
        object: Vec::new(),
        transmitted: Default::default(),
    };
    let texels: Vec<Option<Texel>> = (0..side * side)
        .into_par_iter()
        .map(|t| {
            let ray = map.ray(t % side, t / side);
            let (k, hit) = scene.nearest(&ray, f64::INFINITY)?;
            let x = ray.at(hit.t);
            let (toward, e) = source.at(x);
            let cos = hit.n.dot(&toward).max(0.0);
            // Dal Corso et al. 2017, eq. 7: L F_t(-w_l) cos(theta_l).
            let t_in = 1.0 - fresnel_dielectric(cos, scene.objects[k].eta());
            Some((k, x, hit.n, e.map(|e| e * t_in * cos)))
        })
        .collect();
    for t in texels {
        let (k, x, n, e) = t.unwrap_or((usize::MAX, V3::zeros(), V3::zeros(), [0.0; 3]));
        map.object.push(if k == usize::MAX { -1 } else { k as i32 });
        map.position.push(x);
        map.normal.push(n);
        for (plane, v) in map.transmitted.iter_mut().zip(e) {
            plane.push(v);
        }
    }
    Ok(map)
}

/// What the camera sees, for the light-space method: `side` x `side`
/// stratified positions per pixel (the box filter of the render and its
/// G-buffer), each the first surface point, its outward normal, the
/// object (-1: none) and the unit direction towards the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfacePoints {
    pub width: usize,
    pub height: usize,
    pub side: usize,
    /// Pixel p's positions are p side^2 .. (p + 1) side^2, row by row.
    pub position: Vec<V3>,
    pub normal: Vec<V3>,
    pub object: Vec<i32>,
    pub view: Vec<V3>,
}

/// The camera's surface points at `side` x `side` positions per pixel.
pub fn surface_points(scene: &Scene, side: usize) -> Result<SurfacePoints> {
    super::gbuffer::check_side(CONTEXT, side)?;
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let per = side * side;
    let points: Vec<(i32, V3, V3, V3)> = (0..w * h * per)
        .into_par_iter()
        .map(|q| {
            let (p, s) = (q / per, q % per);
            let px = (p % w) as f64 + ((s % side) as f64 + 0.5) / side as f64;
            let py = (p / w) as f64 + ((s / side) as f64 + 0.5) / side as f64;
            let ray = cam.ray(px, py);
            match scene.nearest(&ray, f64::INFINITY) {
                Some((k, hit)) => (k as i32, ray.at(hit.t), hit.n, -ray.d),
                None => (-1, V3::zeros(), V3::zeros(), -ray.d),
            }
        })
        .collect();
    let mut out = SurfacePoints {
        width: w,
        height: h,
        side,
        position: Vec::with_capacity(points.len()),
        normal: Vec::with_capacity(points.len()),
        object: Vec::with_capacity(points.len()),
        view: Vec::with_capacity(points.len()),
    };
    for (k, x, n, v) in points {
        out.object.push(k);
        out.position.push(x);
        out.normal.push(n);
        out.view.push(v);
    }
    Ok(out)
}
