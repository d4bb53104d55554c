//! Rays and the analytic closed shapes in f64: sphere, axis-aligned box
//! and capped cylinder, and the shape enum that also holds closed triangle
//! meshes (`mesh`; heightfields become meshes). Every shape answers one
//! question, the nearest crossing of its surface along a ray and the
//! outward normal there, whether the ray starts outside (it enters) or
//! inside (it leaves); the tracer knows which from the medium it is in.

use super::frame::frame;
use super::mesh::Mesh;
use super::ray::{Hit, Ray, V3};

/// A closed surface bounding one homogeneous medium.
#[derive(Clone, Debug)]
pub enum Shape {
    Sphere {
        centre: V3,
        radius: f64,
    },
    /// Axis-aligned.
    Cuboid {
        min: V3,
        max: V3,
    },
    Cylinder(Cylinder),
    Mesh(Mesh),
}

impl Shape {
    /// The nearest crossing at a distance in (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        match self {
            Shape::Sphere { centre, radius } => sphere_hit(*centre, *radius, ray, t_max),
            Shape::Cuboid { min, max } => cuboid_hit(*min, *max, ray, t_max),
            Shape::Cylinder(c) => c.intersect(ray, t_max),
            Shape::Mesh(m) => m.intersect(ray, t_max),
        }
    }

    /// Axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (V3, V3) {
        match self {
            Shape::Sphere { centre, radius } => {
                let r = V3::repeat(*radius);
                (centre - r, centre + r)
            }
            Shape::Cuboid { min, max } => (*min, *max),
            Shape::Cylinder(c) => c.bounds(),
            Shape::Mesh(m) => (m.min, m.max),
        }
    }

    /// Whether `p` is inside (for tests and checks; the tracer tracks its
    /// medium instead).
    pub fn contains(&self, p: V3) -> bool {
        match self {
            Shape::Sphere { centre, radius } => (p - centre).norm_squared() < radius * radius,
            Shape::Cuboid { min, max } => (0..3).all(|i| p[i] > min[i] && p[i] < max[i]),
            Shape::Cylinder(c) => c.contains(p),
            Shape::Mesh(m) => m.contains(p),
        }
    }
}

fn sphere_hit(c: V3, r: f64, ray: &Ray, t_max: f64) -> Option<Hit> {
    let oc = ray.o - c;
    let b = oc.dot(&ray.d);
    let cc = oc.norm_squared() - r * r;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    // The two roots without cancellation: q = -b - sign(b) sqrt(disc),
    // t = q and cc / q (a = 1 for a unit direction).
    let q = -b - b.signum() * disc.sqrt();
    let (mut t0, mut t1) = (q, if q != 0.0 { cc / q } else { 0.0 });
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    let t = if t0 > 0.0 { t0 } else { t1 };
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    let n = (ray.at(t) - c) / r;
    Some(Hit {
        t,
        n: n.normalize(),
    })
}

fn cuboid_hit(min: V3, max: V3, ray: &Ray, t_max: f64) -> Option<Hit> {
    let (mut t_near, mut t_far) = (f64::NEG_INFINITY, f64::INFINITY);
    let (mut near_axis, mut far_axis) = (0, 0);
    for i in 0..3 {
        let (o, d) = (ray.o[i], ray.d[i]);
        if d == 0.0 {
            if o <= min[i] || o >= max[i] {
                return None;
            }
            continue;
        }
        let (a, b) = ((min[i] - o) / d, (max[i] - o) / d);
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        if lo > t_near {
            t_near = lo;
            near_axis = i;
        }
        if hi < t_far {
            t_far = hi;
            far_axis = i;
        }
    }
    if t_near > t_far {
        return None;
    }
    let (t, axis, sign) = if t_near > 0.0 {
        (t_near, near_axis, -ray.d[near_axis].signum())
    } else {
        (t_far, far_axis, ray.d[far_axis].signum())
    };
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    let mut n = V3::zeros();
    n[axis] = sign;
    Some(Hit { t, n })
}

/// A capped cylinder around `axis` (unit) through `centre`, from
/// -half_height to +half_height along it; (u, v, axis) is an orthonormal
/// frame.
#[derive(Clone, Debug)]
pub struct Cylinder {
    pub centre: V3,
    pub axis: V3,
    pub u: V3,
    pub v: V3,
    pub radius: f64,
    pub half_height: f64,
}

impl Cylinder {
    /// The cylinder of unit `axis`, its frame completed by [`frame`].
    pub fn new(centre: V3, axis: V3, radius: f64, half_height: f64) -> Cylinder {
        let (u, v) = frame(axis);
        Cylinder {
            centre,
            axis,
            u,
            v,
            radius,
            half_height,
        }
    }

    /// Axis-aligned bounds (min, max).
    fn bounds(&self) -> (V3, V3) {
        let (axis, radius, half_height) = (self.axis, self.radius, self.half_height);
        // Per coordinate: the caps' discs reach r sqrt(1 - a_i^2).
        let ext = V3::from_fn(|i, _| {
            half_height * axis[i].abs() + radius * (1.0 - axis[i] * axis[i]).max(0.0).sqrt()
        });
        (self.centre - ext, self.centre + ext)
    }

    fn contains(&self, p: V3) -> bool {
        let (axis, radius) = (self.axis, self.radius);
        let q = p - self.centre;
        let h = q.dot(&axis);
        h.abs() < self.half_height && (q - h * axis).norm_squared() < radius * radius
    }

    /// The nearest crossing in (0, t_max), solved in the frame (u, v, axis).
    fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let (c, r, hh) = (self.centre, self.radius, self.half_height);
        let frame = [self.u, self.v, self.axis];
        let q = ray.o - c;
        let o = V3::new(q.dot(&frame[0]), q.dot(&frame[1]), q.dot(&frame[2]));
        let d = V3::new(
            ray.d.dot(&frame[0]),
            ray.d.dot(&frame[1]),
            ray.d.dot(&frame[2]),
        );
        let mut best: Option<(f64, V3)> = None;
        let mut consider = |t: f64, n: V3| {
            if t > 0.0 && t < t_max && best.is_none_or(|(b, _)| t < b) {
                best = Some((t, n));
            }
        };
        // The side x^2 + y^2 = r^2 within |z| <= hh.
        let a = d.x * d.x + d.y * d.y;
        if a > 0.0 {
            let b = o.x * d.x + o.y * d.y;
            let cc = o.x * o.x + o.y * o.y - r * r;
            let disc = b * b - a * cc;
            if disc >= 0.0 {
                let qq = -b - b.signum() * disc.sqrt();
                for t in [qq / a, if qq != 0.0 { cc / qq } else { -1.0 }] {
                    let p = o + t * d;
                    if p.z.abs() <= hh {
                        consider(t, V3::new(p.x, p.y, 0.0) / r);
                    }
                }
            }
        }
        // The caps z = +-hh within the disc.
        if d.z != 0.0 {
            for s in [-1.0, 1.0] {
                let t = (s * hh - o.z) / d.z;
                let p = o + t * d;
                if p.x * p.x + p.y * p.y <= r * r {
                    consider(t, V3::new(0.0, 0.0, s));
                }
            }
        }
        best.map(|(t, n)| Hit {
            t,
            n: (n.x * frame[0] + n.y * frame[1] + n.z * frame[2]).normalize(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first hit of `shape` along `ray(o, d)`, as far as any scene reaches.
    fn hit(shape: &Shape, o: [f64; 3], d: [f64; 3]) -> Option<Hit> {
        shape.intersect(&ray(o, d), 1e9)
    }

    fn ray(o: [f64; 3], d: [f64; 3]) -> Ray {
        Ray {
            o: V3::from(o),
            d: V3::from(d).normalize(),
        }
    }

    /// A unit cube as a mesh of 12 triangles, wound `ccw` or not.
    fn cube(ccw: bool) -> Mesh {
        let p: Vec<V3> = (0..8)
            .map(|i| V3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut t = Vec::new();
        for q in quads {
            let (a, b) = ([q[0], q[1], q[2]], [q[0], q[2], q[3]]);
            if ccw {
                t.push(a);
                t.push(b);
            } else {
                t.push([a[0], a[2], a[1]]);
                t.push([b[0], b[2], b[1]]);
            }
        }
        Mesh::new(&p, &t).unwrap()
    }

    /// Every shape agrees with a cube or sphere of the same extent: from
    /// outside it enters, from inside it leaves, normals point out.
    #[test]
    fn shapes_enter_and_leave_with_outward_normals() {
        let cuboid = Shape::Cuboid {
            min: V3::zeros(),
            max: V3::repeat(1.0),
        };
        for mesh in [cube(true), cube(false)] {
            let m = Shape::Mesh(mesh);
            for (o, d) in [
                ([0.5, 0.5, -2.0], [0.0, 0.0, 1.0]),
                ([0.3, 0.6, 0.5], [1.0, 0.2, -0.1]),
                ([-1.0, -1.0, -1.0], [1.0, 1.1, 1.2]),
                ([0.2, 0.2, 0.2], [-0.3, 1.0, 0.4]),
            ] {
                let r = ray(o, d);
                let (a, b) = (cuboid.intersect(&r, 1e9), m.intersect(&r, 1e9));
                let (a, b) = (a.unwrap(), b.unwrap());
                assert!((a.t - b.t).abs() < 1e-12, "{o:?}: {} vs {}", a.t, b.t);
                assert!((a.n - b.n).norm() < 1e-12, "{o:?}: {} vs {}", a.n, b.n);
                let inside = cuboid.contains(r.o);
                assert_eq!(inside, m.contains(r.o));
                // Entering: against the normal; leaving: along it.
                assert_eq!(r.d.dot(&a.n) > 0.0, inside, "{o:?}");
            }
        }
        let s = Shape::Sphere {
            centre: V3::new(1.0, 2.0, 3.0),
            radius: 2.0,
        };
        let h = hit(&s, [1.0, 2.0, -10.0], [0.0, 0.0, 1.0]).unwrap();
        assert!((h.t - 11.0).abs() < 1e-12 && (h.n.z + 1.0).abs() < 1e-12);
        let h = hit(&s, [1.0, 2.0, 3.5], [0.0, 0.0, 1.0]).unwrap();
        assert!((h.t - 1.5).abs() < 1e-12 && (h.n.z - 1.0).abs() < 1e-12);
        assert!(s
            .intersect(&ray([1.0, 2.0, 3.5], [0.0, 0.0, 1.0]), 1.0)
            .is_none());
        assert!(hit(&s, [5.0, 2.0, -10.0], [0.0, 0.0, 1.0]).is_none());
    }

    #[test]
    fn cylinder_side_and_caps() {
        let c = Shape::Cylinder(Cylinder::new(V3::zeros(), V3::y(), 1.0, 2.0));
        // Side, from outside along x.
        let h = hit(&c, [-5.0, 0.5, 0.0], [1.0, 0.0, 0.0]).unwrap();
        assert!((h.t - 4.0).abs() < 1e-12 && (h.n.x + 1.0).abs() < 1e-12);
        // Cap, from inside along the axis.
        let h = hit(&c, [0.2, 0.0, 0.3], [0.0, 1.0, 0.0]).unwrap();
        assert!((h.t - 2.0).abs() < 1e-12 && (h.n.y - 1.0).abs() < 1e-12);
        // Passing above the top cap misses.
        assert!(hit(&c, [-5.0, 2.5, 0.0], [1.0, 0.0, 0.0]).is_none());
        let (lo, hi) = c.bounds();
        assert!((lo - V3::new(-1.0, -2.0, -1.0)).norm() < 1e-12);
        assert!((hi - V3::new(1.0, 2.0, 1.0)).norm() < 1e-12);
    }
}
