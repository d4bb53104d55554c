//! Rays and closed shapes in f64: sphere, axis-aligned box, capped
//! cylinder and closed triangle meshes (heightfields become meshes). Every
//! shape answers one question, the nearest crossing of its surface along a
//! ray and the outward normal there, whether the ray starts outside (it
//! enters) or inside (it leaves); the tracer knows which from the medium it
//! is in.

use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::{Bvh, BvhNode};
use nalgebra::Point3;

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
    /// Capped, around `axis` (unit) through `centre`, from -half_height to
    /// +half_height along it; (u, v, axis) is an orthonormal frame.
    Cylinder {
        centre: V3,
        axis: V3,
        u: V3,
        v: V3,
        radius: f64,
        half_height: f64,
    },
    Mesh(Mesh),
}

impl Shape {
    /// The nearest crossing at a distance in (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        match self {
            Shape::Sphere { centre, radius } => sphere_hit(*centre, *radius, ray, t_max),
            Shape::Cuboid { min, max } => cuboid_hit(*min, *max, ray, t_max),
            Shape::Cylinder {
                centre,
                axis,
                u,
                v,
                radius,
                half_height,
            } => cylinder_hit(*centre, [*u, *v, *axis], *radius, *half_height, ray, t_max),
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
            Shape::Cylinder {
                centre,
                axis,
                radius,
                half_height,
                ..
            } => {
                // Per coordinate: the caps' discs reach r sqrt(1 - a_i^2).
                let ext = V3::from_fn(|i, _| {
                    half_height * axis[i].abs() + radius * (1.0 - axis[i] * axis[i]).max(0.0).sqrt()
                });
                (centre - ext, centre + ext)
            }
            Shape::Mesh(m) => (m.min, m.max),
        }
    }

    /// Whether `p` is inside (for tests and checks; the tracer tracks its
    /// medium instead).
    pub fn contains(&self, p: V3) -> bool {
        match self {
            Shape::Sphere { centre, radius } => (p - centre).norm_squared() < radius * radius,
            Shape::Cuboid { min, max } => (0..3).all(|i| p[i] > min[i] && p[i] < max[i]),
            Shape::Cylinder {
                centre,
                axis,
                radius,
                half_height,
                ..
            } => {
                let q = p - centre;
                let h = q.dot(axis);
                h.abs() < *half_height && (q - h * axis).norm_squared() < radius * radius
            }
            // Parity of the crossings along one ray.
            Shape::Mesh(m) => {
                let ray = Ray {
                    o: p,
                    d: V3::new(
                        0.267_261_241_912_424_4,
                        0.534_522_483_824_848_8,
                        0.801_783_725_737_273_2,
                    ),
                };
                let mut n = 0;
                let mut from = 0.0;
                let mut probe = ray;
                while let Some(h) = m.intersect(&probe, f64::INFINITY) {
                    n += 1;
                    from += h.t;
                    probe.o = ray.at(from + 1e-9 * (1.0 + from));
                    from += 1e-9 * (1.0 + from);
                    if n > 1_000_000 {
                        break;
                    }
                }
                n % 2 == 1
            }
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

fn cylinder_hit(c: V3, frame: [V3; 3], r: f64, hh: f64, ray: &Ray, t_max: f64) -> Option<Hit> {
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

/// An orthonormal pair (u, v) completing the unit vector `w` to a
/// right-handed frame (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited").
pub fn frame(w: V3) -> (V3, V3) {
    let s = if w.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + w.z);
    let b = w.x * w.y * a;
    (
        V3::new(1.0 + s * w.x * w.x * a, s * b, -s * w.x),
        V3::new(b, s + w.y * w.y * a, -w.y),
    )
}

/// A triangle as the hierarchy stores it.
#[derive(Clone, Debug)]
struct TriRef {
    index: usize,
    min: V3,
    max: V3,
    node: usize,
}

impl Bounded<f64, 3> for TriRef {
    fn aabb(&self) -> Aabb<f64, 3> {
        Aabb::with_bounds(Point3::from(self.min), Point3::from(self.max))
    }
}

impl BHShape<f64, 3> for TriRef {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// A closed, consistently oriented triangle mesh (outward normals) with a
/// bounding volume hierarchy (the `bvh` crate's SAH build; traversal here,
/// with the nearest hit so far pruning the boxes).
#[derive(Clone, Debug)]
pub struct Mesh {
    /// Vertices of each triangle, counter-clockwise seen from outside.
    tris: Vec<[V3; 3]>,
    /// Unit outward normal of each triangle.
    normals: Vec<V3>,
    /// The hierarchy's nodes, with each child's box padded.
    nodes: Vec<Node>,
    pub min: V3,
    pub max: V3,
}

/// A flattened hierarchy node: an inner node with two children's boxes,
/// or a leaf with one triangle.
#[derive(Clone, Debug)]
enum Node {
    Inner {
        left: usize,
        left_box: (V3, V3),
        right: usize,
        right_box: (V3, V3),
    },
    Leaf(usize),
}

/// How a mesh's triangles fail to bound a volume.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshDefect {
    Empty,
    /// A triangle with (nearly) no area, by index.
    Degenerate(usize),
    /// An edge (vertex indices) not shared by exactly two triangles with
    /// opposite directions.
    OpenEdge(usize, usize),
    /// The enclosed volume is not positive after orientation.
    NoVolume,
}

impl Mesh {
    /// Builds a mesh from indexed triangles. It must be closed: every edge
    /// used once in each direction (a watertight, consistently wound
    /// surface); a mesh wound clockwise (negative signed volume) is turned.
    pub fn new(positions: &[V3], triangles: &[[usize; 3]]) -> Result<Mesh, MeshDefect> {
        if triangles.is_empty() {
            return Err(MeshDefect::Empty);
        }
        let scale = positions
            .iter()
            .fold(0.0f64, |m, p| m.max(p.amax()))
            .max(f64::MIN_POSITIVE);
        let mut edges: std::collections::HashMap<(usize, usize), i32> =
            std::collections::HashMap::with_capacity(3 * triangles.len());
        let mut volume = 0.0;
        for (k, t) in triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| positions[i]);
            let area2 = (b - a).cross(&(c - a)).norm();
            if !(area2 > 1e-14 * scale * scale) {
                return Err(MeshDefect::Degenerate(k));
            }
            for (i, j) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((i, j)).or_insert(0) += 1;
            }
            // Divergence theorem: sum of signed tetrahedra from the origin.
            volume += a.dot(&b.cross(&c)) / 6.0;
        }
        for (&(i, j), &n) in &edges {
            if n != 1 || edges.get(&(j, i)) != Some(&1) {
                return Err(MeshDefect::OpenEdge(i, j));
            }
        }
        if volume.abs() <= 1e-12 * scale * scale * scale {
            return Err(MeshDefect::NoVolume);
        }
        let flip = volume < 0.0;
        let tris: Vec<[V3; 3]> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i]);
                if flip {
                    [a, c, b]
                } else {
                    [a, b, c]
                }
            })
            .collect();
        let normals = tris
            .iter()
            .map(|[a, b, c]| (b - a).cross(&(c - a)).normalize())
            .collect();
        let pad = 1e-9 * scale;
        let mut refs: Vec<TriRef> = tris
            .iter()
            .enumerate()
            .map(|(index, t)| {
                let min = t[0].inf(&t[1]).inf(&t[2]) - V3::repeat(pad);
                let max = t[0].sup(&t[1]).sup(&t[2]) + V3::repeat(pad);
                TriRef {
                    index,
                    min,
                    max,
                    node: 0,
                }
            })
            .collect();
        let bvh = Bvh::build(&mut refs);
        let to_box = |b: &Aabb<f64, 3>| {
            (
                V3::new(b.min.x, b.min.y, b.min.z),
                V3::new(b.max.x, b.max.y, b.max.z),
            )
        };
        let nodes = bvh
            .nodes
            .iter()
            .map(|n| match n {
                BvhNode::Leaf { shape_index, .. } => Node::Leaf(refs[*shape_index].index),
                BvhNode::Node {
                    child_l_index,
                    child_l_aabb,
                    child_r_index,
                    child_r_aabb,
                    ..
                } => Node::Inner {
                    left: *child_l_index,
                    left_box: to_box(child_l_aabb),
                    right: *child_r_index,
                    right_box: to_box(child_r_aabb),
                },
            })
            .collect();
        let min = positions
            .iter()
            .fold(V3::repeat(f64::INFINITY), |m, p| m.inf(p));
        let max = positions
            .iter()
            .fold(V3::repeat(f64::NEG_INFINITY), |m, p| m.sup(p));
        Ok(Mesh {
            tris,
            normals,
            nodes,
            min,
            max,
        })
    }

    pub fn triangles(&self) -> usize {
        self.tris.len()
    }

    /// The nearest triangle crossed in (0, t_max), either side.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let inv = V3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
        let mut best = t_max;
        let mut hit = None;
        let mut stack: Vec<usize> = Vec::with_capacity(64);
        if self.nodes.is_empty() {
            return None;
        }
        stack.push(0);
        while let Some(i) = stack.pop() {
            match &self.nodes[i] {
                Node::Leaf(k) => {
                    if let Some(t) = triangle_hit(&self.tris[*k], ray, best) {
                        best = t;
                        hit = Some(*k);
                    }
                }
                Node::Inner {
                    left,
                    left_box,
                    right,
                    right_box,
                } => {
                    let l = box_entry(left_box, ray, &inv, best);
                    let r = box_entry(right_box, ray, &inv, best);
                    // Nearer child last, so that it is popped first.
                    match (l, r) {
                        (Some(a), Some(b)) if a <= b => {
                            stack.push(*right);
                            stack.push(*left);
                        }
                        (Some(_), Some(_)) => {
                            stack.push(*left);
                            stack.push(*right);
                        }
                        (Some(_), None) => stack.push(*left),
                        (None, Some(_)) => stack.push(*right),
                        (None, None) => {}
                    }
                }
            }
        }
        hit.map(|k| Hit {
            t: best,
            n: self.normals[k],
        })
    }
}

/// Where the ray enters the box, if it meets it before `t_max` (slab test;
/// a zero direction component gives infinite slabs, handled by the
/// comparisons with NaN excluded).
fn box_entry(b: &(V3, V3), ray: &Ray, inv: &V3, t_max: f64) -> Option<f64> {
    let (mut lo, mut hi) = (0.0f64, t_max);
    for i in 0..3 {
        let (t1, t2) = ((b.0[i] - ray.o[i]) * inv[i], (b.1[i] - ray.o[i]) * inv[i]);
        let (a, c) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
        if a.is_nan() || c.is_nan() {
            // 0 x inf: the origin lies on a slab plane of a flat direction;
            // keep the box (conservative).
            continue;
        }
        lo = lo.max(a);
        hi = hi.min(c);
        if lo > hi {
            return None;
        }
    }
    Some(lo)
}

/// Möller and Trumbore 1997 ("Fast, Minimum Storage Ray/Triangle
/// Intersection"), both faces: the distance in (0, t_max).
fn triangle_hit(t: &[V3; 3], ray: &Ray, t_max: f64) -> Option<f64> {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let p = ray.d.cross(&e2);
    let det = e1.dot(&p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.o - t[0];
    let u = s.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(&e1);
    let v = ray.d.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let d = e2.dot(&q) * inv;
    (d > 0.0 && d < t_max).then_some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let h = s
            .intersect(&ray([1.0, 2.0, -10.0], [0.0, 0.0, 1.0]), 1e9)
            .unwrap();
        assert!((h.t - 11.0).abs() < 1e-12 && (h.n.z + 1.0).abs() < 1e-12);
        let h = s
            .intersect(&ray([1.0, 2.0, 3.5], [0.0, 0.0, 1.0]), 1e9)
            .unwrap();
        assert!((h.t - 1.5).abs() < 1e-12 && (h.n.z - 1.0).abs() < 1e-12);
        assert!(s
            .intersect(&ray([1.0, 2.0, 3.5], [0.0, 0.0, 1.0]), 1.0)
            .is_none());
        assert!(s
            .intersect(&ray([5.0, 2.0, -10.0], [0.0, 0.0, 1.0]), 1e9)
            .is_none());
    }

    #[test]
    fn cylinder_side_and_caps() {
        let axis = V3::new(0.0, 1.0, 0.0);
        let (u, v) = frame(axis);
        let c = Shape::Cylinder {
            centre: V3::zeros(),
            axis,
            u,
            v,
            radius: 1.0,
            half_height: 2.0,
        };
        // Side, from outside along x.
        let h = c
            .intersect(&ray([-5.0, 0.5, 0.0], [1.0, 0.0, 0.0]), 1e9)
            .unwrap();
        assert!((h.t - 4.0).abs() < 1e-12 && (h.n.x + 1.0).abs() < 1e-12);
        // Cap, from inside along the axis.
        let h = c
            .intersect(&ray([0.2, 0.0, 0.3], [0.0, 1.0, 0.0]), 1e9)
            .unwrap();
        assert!((h.t - 2.0).abs() < 1e-12 && (h.n.y - 1.0).abs() < 1e-12);
        // Passing above the top cap misses.
        assert!(c
            .intersect(&ray([-5.0, 2.5, 0.0], [1.0, 0.0, 0.0]), 1e9)
            .is_none());
        let (lo, hi) = c.bounds();
        assert!((lo - V3::new(-1.0, -2.0, -1.0)).norm() < 1e-12);
        assert!((hi - V3::new(1.0, 2.0, 1.0)).norm() < 1e-12);
        for w in [
            V3::z(),
            -V3::z(),
            V3::new(0.6, 0.0, 0.8),
            V3::new(-0.48, 0.6, -0.64),
        ] {
            let (a, b) = frame(w);
            assert!(a.dot(&b).abs() < 1e-15 && a.dot(&w).abs() < 1e-15);
            assert!((a.cross(&b) - w).norm() < 1e-15);
        }
    }

    #[test]
    fn open_or_flat_meshes_are_refused() {
        let p = [V3::zeros(), V3::x(), V3::y(), V3::z()];
        // A tetrahedron missing a face.
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2]];
        assert!(matches!(Mesh::new(&p, &t), Err(MeshDefect::OpenEdge(..))));
        let closed = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        assert_eq!(Mesh::new(&p, &closed).unwrap().triangles(), 4);
        // The same face twice in one direction.
        let twice = [[0, 2, 1], [0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        assert!(Mesh::new(&p, &twice).is_err());
        let flat = [V3::zeros(), V3::x(), V3::y(), V3::x() + V3::y()];
        assert!(matches!(
            Mesh::new(&flat, &[[0, 1, 2], [0, 2, 1]]),
            Err(MeshDefect::NoVolume)
        ));
        assert_eq!(Mesh::new(&p, &[]).unwrap_err(), MeshDefect::Empty);
        let line = [V3::zeros(), V3::x(), 2.0 * V3::x()];
        assert_eq!(
            Mesh::new(&line, &[[0, 1, 2]]).unwrap_err(),
            MeshDefect::Degenerate(0)
        );
    }
}
