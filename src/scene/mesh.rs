//! Closed triangle meshes (OBJ files and heightfields become them): the
//! closedness and orientation checks of a mesh that bounds a medium, its
//! bounding volume hierarchy, and the nearest triangle crossed along a ray
//! (Möller and Trumbore 1997 inside the hierarchy's slab tests).

use super::ray::{Hit, Ray, V3};
use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::{Bvh, BvhNode};
use nalgebra::Point3;

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

/// One child of an inner node.
#[derive(Clone, Copy, Debug)]
enum Child {
    Left,
    Right,
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
        let flip = signed_volume(positions, triangles, scale)? < 0.0;
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
        let nodes = hierarchy(&tris, 1e-9 * scale);
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

    /// One vertex of the surface (a point on it, for containment tests).
    pub fn vertex(&self) -> V3 {
        self.tris[0][0]
    }

    /// Whether `f` holds for a triangle whose box meets the box (lo, hi):
    /// the hierarchy prunes the others, so a query near a small part of a
    /// large mesh visits few triangles.
    pub fn any_near(&self, lo: V3, hi: V3, mut f: impl FnMut(&[V3; 3]) -> bool) -> bool {
        let meets = |b: &(V3, V3)| (0..3).all(|i| b.0[i] <= hi[i] && lo[i] <= b.1[i]);
        if !meets(&(self.min, self.max)) {
            return false;
        }
        self.walk(
            |k| f(&self.tris[k]),
            |l, r| {
                [
                    meets(r).then_some(Child::Right),
                    meets(l).then_some(Child::Left),
                ]
            },
        )
    }

    /// Depth first through the hierarchy from its root: `leaf(k)` at each
    /// leaf reached (true ends the walk, which then returns true), and at
    /// an inner node `order(left_box, right_box)` names the children to
    /// visit, in the order to visit them.
    fn walk(
        &self,
        mut leaf: impl FnMut(usize) -> bool,
        mut order: impl FnMut(&(V3, V3), &(V3, V3)) -> [Option<Child>; 2],
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack: Vec<usize> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            match &self.nodes[i] {
                Node::Leaf(k) => {
                    if leaf(*k) {
                        return true;
                    }
                }
                Node::Inner {
                    left,
                    left_box,
                    right,
                    right_box,
                } => {
                    // Pushed last, popped first.
                    for c in order(left_box, right_box).iter().rev().flatten() {
                        stack.push(match c {
                            Child::Left => *left,
                            Child::Right => *right,
                        });
                    }
                }
            }
        }
        false
    }

    /// Every triangle, in order.
    pub fn tris(&self) -> &[[V3; 3]] {
        &self.tris
    }

    /// Whether `p` is inside: the parity of the crossings along one ray.
    pub fn contains(&self, p: V3) -> bool {
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
        while let Some(h) = self.intersect(&probe, f64::INFINITY) {
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

    /// The nearest triangle crossed in (0, t_max), either side.
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        let inv = V3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
        let best = std::cell::Cell::new(t_max);
        let mut hit = None;
        self.walk(
            |k| {
                if let Some(t) = triangle_hit(&self.tris[k], ray, best.get()) {
                    best.set(t);
                    hit = Some(k);
                }
                false
            },
            |l, r| {
                let l = box_entry(l, ray, &inv, best.get());
                let r = box_entry(r, ray, &inv, best.get());
                // The nearer child first.
                match (l, r) {
                    (Some(a), Some(b)) if a <= b => [Some(Child::Left), Some(Child::Right)],
                    (Some(_), Some(_)) => [Some(Child::Right), Some(Child::Left)],
                    (Some(_), None) => [Some(Child::Left), None],
                    (None, Some(_)) => [Some(Child::Right), None],
                    (None, None) => [None, None],
                }
            },
        );
        let best = best.get();
        hit.map(|k| Hit {
            t: best,
            n: self.normals[k],
        })
    }
}

/// The signed volume of a closed mesh (negative: wound clockwise), or how
/// it fails to be one: a triangle without area, an edge not used once in
/// each direction, no volume.
fn signed_volume(
    positions: &[V3],
    triangles: &[[usize; 3]],
    scale: f64,
) -> Result<f64, MeshDefect> {
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
    Ok(volume)
}

/// The hierarchy of `tris` (the `bvh` crate's SAH build), flattened, each
/// triangle's box padded by `pad`.
fn hierarchy(tris: &[[V3; 3]], pad: f64) -> Vec<Node> {
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
    bvh.nodes
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
        .collect()
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
