//! The camera: pixel (x, y) with row 0 at the top, a box pixel filter
//! (positions uniform over the pixel's square), perspective (vertical
//! field of view) or orthographic (millimetres per pixel).

use super::ray::{Ray, V3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    Perspective { fov_y_deg: f64 },
    Orthographic { mm_per_pixel: f64 },
}

/// What a pixel measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Measure {
    /// Radiance toward the camera (a renderer's image).
    Radiance,
    /// The surface's exitance / pi at the point the pixel sees: radiance
    /// averaged over the outgoing hemisphere with the cosine weight, what a
    /// Lambertian exit with the same exitance would show (a sensor for
    /// checks against R_d, not a picture).
    Exitance,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub projection: Projection,
    /// Millimetres.
    pub position: V3,
    /// Unit view direction, and the right and up axes of the image plane
    /// (orthonormal, right-handed with -forward).
    pub forward: V3,
    pub right: V3,
    pub up: V3,
    pub width: usize,
    pub height: usize,
    pub measure: Measure,
}

impl Camera {
    /// An orthonormal frame from a position, a target and an up hint; None
    /// when the target is the position or up is along the view.
    pub fn frame(position: V3, look_at: V3, up: V3) -> Option<(V3, V3, V3)> {
        let f = look_at - position;
        if !(f.norm() > 0.0) {
            return None;
        }
        let f = f.normalize();
        let r = f.cross(&up);
        if !(r.norm() > 1e-9 * up.norm()) {
            return None;
        }
        let r = r.normalize();
        Some((f, r, r.cross(&f)))
    }

    /// tan(fov_y / 2) of a perspective camera.
    pub fn tan_half_fov(&self) -> Option<f64> {
        match self.projection {
            Projection::Perspective { fov_y_deg } => Some((0.5 * fov_y_deg.to_radians()).tan()),
            Projection::Orthographic { .. } => None,
        }
    }

    /// The ray through image position (px, py) in pixels from the top-left
    /// corner (pixel (x, y) covers [x, x + 1) x [y, y + 1)).
    pub fn ray(&self, px: f64, py: f64) -> Ray {
        let (w, h) = (self.width as f64, self.height as f64);
        match self.projection {
            Projection::Perspective { .. } => {
                let t = self.tan_half_fov().unwrap_or(1.0);
                // Square pixels: the horizontal extent follows the aspect.
                let sx = (2.0 * px / w - 1.0) * t * w / h;
                let sy = (1.0 - 2.0 * py / h) * t;
                Ray {
                    o: self.position,
                    d: (self.forward + sx * self.right + sy * self.up).normalize(),
                }
            }
            Projection::Orthographic { mm_per_pixel } => Ray {
                o: self.position
                    + (px - 0.5 * w) * mm_per_pixel * self.right
                    + (0.5 * h - py) * mm_per_pixel * self.up,
                d: self.forward,
            },
        }
    }

    /// Linear view depth of a point (distance along the view axis), mm.
    pub fn depth(&self, p: V3) -> f64 {
        (p - self.position).dot(&self.forward)
    }

    /// Millimetres per pixel on a surface facing the camera at linear depth
    /// `depth_mm`.
    pub fn mm_per_pixel_at(&self, depth_mm: f64) -> f64 {
        match self.projection {
            Projection::Perspective { .. } => {
                2.0 * self.tan_half_fov().unwrap_or(1.0) * depth_mm / self.height as f64
            }
            Projection::Orthographic { mm_per_pixel } => mm_per_pixel,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(projection: Projection) -> Camera {
        let (f, r, u) = Camera::frame(
            V3::new(0.0, 0.0, 150.0),
            V3::zeros(),
            V3::new(0.0, 1.0, 0.0),
        )
        .unwrap();
        Camera {
            projection,
            position: V3::new(0.0, 0.0, 150.0),
            forward: f,
            right: r,
            up: u,
            width: 200,
            height: 100,
            measure: Measure::Radiance,
        }
    }

    #[test]
    fn rows_run_down_and_the_fov_spans_the_height() {
        let c = camera(Projection::Perspective { fov_y_deg: 14.0 });
        // Looking down -z with up +y: right is +x.
        assert!((c.right - V3::x()).norm() < 1e-15 && (c.up - V3::y()).norm() < 1e-15);
        let top = c.ray(100.0, 0.0);
        let t = (7f64).to_radians().tan();
        assert!((top.d.y / -top.d.z - t).abs() < 1e-12, "{:?}", top.d);
        let right = c.ray(200.0, 50.0);
        assert!((right.d.x / -right.d.z - 2.0 * t).abs() < 1e-12);
        // A pixel at depth 150 spans 2 tan(7 deg) 150 / 100 mm.
        assert!((c.mm_per_pixel_at(150.0) - 3.0 * t).abs() < 1e-12);
        assert!((c.depth(V3::new(3.0, -2.0, 10.0)) - 140.0).abs() < 1e-12);
        let o = camera(Projection::Orthographic { mm_per_pixel: 0.5 });
        let r = o.ray(0.0, 0.0);
        assert!((r.o - V3::new(-50.0, 25.0, 150.0)).norm() < 1e-12);
        assert!(Camera::frame(V3::zeros(), V3::zeros(), V3::y()).is_none());
        assert!(Camera::frame(V3::zeros(), V3::y(), V3::y()).is_none());
    }
}
