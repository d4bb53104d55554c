//! Path-traced scenes: the ground truth beyond the flat plane.
//!
//! A scene (TOML, [`parse_scene_toml`]) holds closed objects (sphere, box,
//! cylinder, a heightfield from an image, triangle meshes from OBJ), each
//! filled with one homogeneous material, lights (directional, uniform
//! environment) and a camera (perspective or orthographic). [`render`]
//! traces it with the physics of `simulate` (Wang et al. 1995): per RGB
//! channel, free flights -ln(xi)/sigma_t, implicit absorption,
//! Henyey-Greenstein scattering, Fresnel boundaries with MCML's all-or-none
//! choice (any eta, total internal reflection), the same roulettes. Paths
//! start at the camera (backward); at every scattering event a directional
//! light is reached by next-event estimation through the index-matched
//! boundary (Lafortune and Willems 1996), and a path that leaves the
//! objects picks up the environment's radiance.
//!
//! Alongside the radiance, the render returns what a renderer's G-buffer
//! gives a screen-space pass from the same camera: linear view depth,
//! normals, coverage and the diffuse irradiance E / pi x R_d, where R_d is
//! the material's total diffuse reflectance from `simulate` (the input
//! convention of `ssskit apply`: kernels have unit sum, so the filtered
//! image is the exitance / pi of a Lambertian exit).
//!
//! Reproducible: sample s of pixel p in channel c draws from its own
//! Xoshiro256++ stream keyed by (seed, c, p, s), and each pixel's sums are
//! taken in sample order by one thread, so the image is bit-identical for
//! any thread count. A target-error run adds rounds of samples per pixel
//! whose length depends only on the sums so far.

mod beam;
mod boundary;
mod camera;
mod file;
mod frame;
mod gbuffer;
pub mod geometry;
mod heightfield;
mod light;
mod light_map;
mod mesh;
mod ray;
mod render;
mod rounds;
mod samples;
mod sphere;
pub mod thickness;
mod trace;

pub use camera::{Camera, Measure, Projection};
pub use file::{parse_scene_toml, CONTEXT};
pub use frame::frame;
pub use gbuffer::{GBuffer, ENV_RAYS};
pub use geometry::Shape;
pub use light_map::{
    check_light, light_map, surface_points, LightMap, LightSource, SurfacePoints,
    CONTEXT as LIGHT_SPACE,
};
pub use ray::V3;
pub use render::{
    channel_names, material_profiles, render, Render, RenderConfig, RenderConfigRecord, RenderInfo,
    DEFAULT_GBUFFER_SIDE, DEFAULT_MAX_SPP, DEFAULT_MAX_WORK, DEFAULT_SCENE_ERROR, RENDER_SCHEMA,
};
pub use samples::{SampleBudget, FIRST_ROUND_SPP};
pub use sphere::{
    lit_sphere, CAMERA_DISTANCE_MM, FOV_Y_DEG, LIGHT_FROM_VIEW_DEG, SPHERE_RADIUS_MM,
};

use crate::error::Result;
use crate::material::Material;
use std::path::Path;

/// The length unit of a scene file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unit {
    Mm,
    Cm,
    M,
}

impl Unit {
    /// Millimetres per scene unit.
    pub fn mm(self) -> f64 {
        match self {
            Unit::Mm => 1.0,
            Unit::Cm => 10.0,
            Unit::M => 1000.0,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Unit::Mm => "mm",
            Unit::Cm => "cm",
            Unit::M => "m",
        }
    }
}

/// A light. Directions are unit vectors towards the light.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Collimated: `irradiance` on a surface facing it, per channel.
    Directional { toward: V3, irradiance: [f64; 3] },
    /// Uniform radiance from every direction, per channel.
    Environment { radiance: [f64; 3] },
    /// A point at `position` (mm) of radiant `intensity` per channel, in
    /// irradiance times mm^2: a surface facing it at distance d mm gets
    /// intensity / d^2. Outside every object, and only with index-matched
    /// objects (the scene's validation).
    Point { position: V3, intensity: [f64; 3] },
}

/// One closed object filled with a homogeneous medium.
#[derive(Clone, Debug)]
pub struct Object {
    /// "object[i]" or the name given in the file.
    pub name: String,
    /// In millimetres.
    pub shape: Shape,
    /// One semi-infinite layer: its coefficients fill the object; its index
    /// is relative to the ambient air.
    pub material: Material,
}

impl Object {
    /// The medium's index relative to the air around the objects.
    pub fn eta(&self) -> f64 {
        self.material.layers[0].eta / self.material.eta_above
    }
}

/// A validated scene; every length in millimetres.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The unit the file states (depths are reported in it).
    pub unit: Unit,
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub objects: Vec<Object>,
    /// Where the scene came from (file name), for messages.
    pub origin: String,
}

impl Scene {
    /// Reads and validates a scene file; relative paths inside it (material
    /// files, meshes, heightfield images) are taken from its folder.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = crate::io::read_text(path)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        parse_scene_toml(&text, &path.display().to_string(), dir)
    }

    /// The nearest object surface along `ray` within `t_max`, from outside
    /// every object.
    pub fn nearest(&self, ray: &ray::Ray, t_max: f64) -> Option<(usize, ray::Hit)> {
        let mut best: Option<(usize, ray::Hit)> = None;
        let mut limit = t_max;
        for (i, o) in self.objects.iter().enumerate() {
            if let Some(h) = o.shape.intersect(ray, limit) {
                limit = h.t;
                best = Some((i, h));
            }
        }
        best
    }

    /// Bounds of all objects (min, max), mm.
    pub fn bounds(&self) -> (V3, V3) {
        self.objects.iter().fold(
            (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY)),
            |(lo, hi), o| {
                let (a, b) = o.shape.bounds();
                (lo.inf(&a), hi.sup(&b))
            },
        )
    }

    /// The largest distance from the camera to a corner of the objects'
    /// bounds, mm: the scale of the scene as the camera sees it.
    pub fn reach(&self) -> f64 {
        let (lo, hi) = self.bounds();
        let mut r = 0.0f64;
        for k in 0..8 {
            let c = V3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            r = r.max((c - self.camera.position).norm());
        }
        r
    }

    /// The directional lights (direction, irradiance per channel).
    pub fn directional(&self) -> impl Iterator<Item = (V3, [f64; 3])> + '_ {
        self.lights.iter().filter_map(|l| match l {
            Light::Directional { toward, irradiance } => Some((*toward, *irradiance)),
            _ => None,
        })
    }

    /// The point lights (position, intensity per channel).
    pub fn points(&self) -> impl Iterator<Item = (V3, [f64; 3])> + '_ {
        self.lights.iter().filter_map(|l| match l {
            Light::Point {
                position,
                intensity,
            } => Some((*position, *intensity)),
            _ => None,
        })
    }

    /// The environment's radiance per channel (0 without one).
    pub fn environment(&self) -> [f64; 3] {
        let mut e = [0.0; 3];
        for l in &self.lights {
            if let Light::Environment { radiance } = l {
                for c in 0..3 {
                    e[c] += radiance[c];
                }
            }
        }
        e
    }
}
