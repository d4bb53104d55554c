//! The vector type, rays and surface crossings: a leaf that the shapes,
//! meshes, frames and tracers share.

/// A point or direction in scene units, f64.
pub type V3 = nalgebra::Vector3<f64>;

/// A ray with a unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: V3,
    pub d: V3,
}

impl Ray {
    pub fn at(&self, t: f64) -> V3 {
        self.o + t * self.d
    }
}

/// A crossing of a surface: distance along the ray and the unit outward
/// normal.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f64,
    pub n: V3,
}
