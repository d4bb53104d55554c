//! The thickness a real-time engine reads for each pixel of a scene lit
//! from behind, from the scene's geometry at the pixel's centre:
//!
//! - through the light's shadow map (Unreal, Godot): the depth difference
//!   along the light between the pixel and the surface nearest the light
//!   on that line, i.e. the distance from the pixel to the last surface
//!   the line toward the light crosses (air gaps of a folded object
//!   included, as a shadow map has them);
//! - through a baked thickness map (HDRP): the object's thickness through
//!   its surface, the chord from the pixel along -N to where it leaves the
//!   object.
//!
//! With each pixel's N.L and dot(-L, V), the engines' view terms.

use super::ray::{Ray, V3};
use super::Scene;

/// Most surfaces the line toward the light may cross.
const MAX_CROSSINGS: usize = 64;

/// Per pixel (row-major, row 0 at the top) of a scene's camera.
#[derive(Clone, Debug)]
pub struct PixelThickness {
    pub width: usize,
    pub height: usize,
    /// Whether the pixel's centre sees an object.
    pub seen: Vec<bool>,
    /// Shadow-map thickness, mm (0 where nothing is seen).
    pub shadow_map_mm: Vec<f64>,
    /// Thickness-map thickness, mm.
    pub thickness_map_mm: Vec<f64>,
    /// The seen surface's N.L and dot(-L, V).
    pub n_dot_l: Vec<f64>,
    pub back_cos: Vec<f64>,
}

/// The thicknesses of every pixel of `scene` for a directional light along
/// `toward` (unit, towards the light).
pub fn pixel_thickness(scene: &Scene, toward: V3) -> PixelThickness {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let eps = 1e-9 * (1.0 + scene.reach());
    let mut out = PixelThickness {
        width: w,
        height: h,
        seen: vec![false; w * h],
        shadow_map_mm: vec![0.0; w * h],
        thickness_map_mm: vec![0.0; w * h],
        n_dot_l: vec![0.0; w * h],
        back_cos: vec![0.0; w * h],
    };
    for i in 0..w * h {
        let ray = cam.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        let Some((k, hit)) = scene.nearest(&ray, f64::INFINITY) else {
            continue;
        };
        let p = ray.at(hit.t);
        let n = hit.n;
        out.seen[i] = true;
        out.n_dot_l[i] = n.dot(&toward);
        out.back_cos[i] = toward.dot(&ray.d);
        out.shadow_map_mm[i] = to_last_surface(scene, k, p - eps * n, toward, eps);
        let inward = Ray {
            o: p - eps * n,
            d: -n,
        };
        out.thickness_map_mm[i] = scene.objects[k]
            .shape
            .intersect(&inward, f64::INFINITY)
            .map_or(0.0, |x| x.t);
    }
    out
}

/// The distance from `o` (inside object k) along `d` to the last surface
/// of the scene that line crosses.
fn to_last_surface(scene: &Scene, k: usize, o: V3, d: V3, eps: f64) -> f64 {
    let (mut o, mut inside, mut travelled, mut last) = (o, Some(k), 0.0, 0.0);
    for _ in 0..MAX_CROSSINGS {
        let ray = Ray { o, d };
        match inside {
            Some(j) => {
                let Some(x) = scene.objects[j].shape.intersect(&ray, f64::INFINITY) else {
                    break;
                };
                travelled += x.t;
                last = travelled;
                o = ray.at(x.t) + eps * x.n;
                inside = None;
            }
            None => {
                let Some((j, x)) = scene.nearest(&ray, f64::INFINITY) else {
                    break;
                };
                travelled += x.t;
                o = ray.at(x.t) - eps * x.n;
                inside = Some(j);
            }
        }
    }
    last
}
