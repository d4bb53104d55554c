//! Objects must not intersect (docs/scene.md): the tracer keeps one medium
//! per point, so two solids that share volume would be rendered as
//! whichever boundary a path met last. Each pair whose boxes meet is tested
//! exactly: sphere to sphere, box or cylinder by the distance from the
//! centre to the solid; a sphere to a mesh by the distance from its centre
//! to each nearby triangle (Ericson 2005, section 5.1.5) and whether the
//! mesh holds the centre; two meshes (a box counts as its twelve triangles)
//! by triangle-triangle crossings (an edge of one through the other,
//! Möller and Trumbore 1997) and, failing those, whether one holds a vertex
//! of the other (the ray-parity test of `Mesh::contains`). Surfaces that
//! only touch (equal distances, shared faces) do not intersect. A cylinder
//! against a mesh (or a box as its triangles): each nearby triangle is
//! clipped to the cylinder's slab |h| <= half height (Sutherland and
//! Hodgman 1974) and the clipped polygon, projected along the axis, is
//! measured against the radius (a polygon lying in a cap's plane only
//! touches); failing those, whether the mesh holds the cylinder's centre.
//! Two cylinders are not checked against each other.
//!
//! Work: the box test runs over every pair, at most `MAX_OBJECTS`^2 / 2
//! = 32640 pairs; an exact test visits only the triangles whose boxes meet
//! the other object's box (the mesh's hierarchy prunes the rest).

use super::check::Check;
use crate::error::Result;
use crate::scene::geometry::Cylinder;
use crate::scene::mesh::Mesh;
use crate::scene::{Object, Shape, V3};

/// Refuses the first pair of `objects` that share volume, both named.
pub(super) fn check_disjoint(ck: &Check, objects: &[Object]) -> Result<()> {
    let boxes: Vec<(V3, V3)> = objects.iter().map(|o| o.shape.bounds()).collect();
    // A box stands in for its twelve triangles against meshes.
    let as_mesh: Vec<Option<Mesh>> = objects.iter().map(|o| box_mesh(&o.shape)).collect();
    for j in 1..objects.len() {
        for i in 0..j {
            if !boxes_meet(&boxes[i], &boxes[j]) {
                continue;
            }
            let (a, b) = (&objects[i], &objects[j]);
            if intersect(&a.shape, as_mesh[i].as_ref(), &b.shape, as_mesh[j].as_ref()) {
                return Err(ck.err(
                    &format!("object[{j}]"),
                    label(b, j),
                    format!(
                        "intersects {} (they share volume): objects must not intersect; move \
                         or shrink one of them",
                        label(a, i)
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// "object[3]", or "object[3] ('cheek')" when the file names it.
fn label(o: &Object, i: usize) -> String {
    let index = format!("object[{i}]");
    if o.name == index {
        index
    } else {
        format!("{index} ('{}')", o.name)
    }
}

/// Open boxes overlap (boxes that touch do not).
fn boxes_meet(a: &(V3, V3), b: &(V3, V3)) -> bool {
    (0..3).all(|k| a.0[k] < b.1[k] && b.0[k] < a.1[k])
}

/// Whether two shapes share volume; `am`, `bm` the boxes as meshes.
fn intersect(a: &Shape, am: Option<&Mesh>, b: &Shape, bm: Option<&Mesh>) -> bool {
    use Shape::*;
    match (a, b) {
        (Sphere { centre, radius }, other) | (other, Sphere { centre, radius }) => {
            sphere_meets(*centre, *radius, other)
        }
        (Cuboid { min: a0, max: a1 }, Cuboid { min: b0, max: b1 }) => {
            boxes_meet(&(*a0, *a1), &(*b0, *b1))
        }
        (Cylinder(_), Cylinder(_)) => false,
        (Cylinder(cy), _) => as_mesh(b, bm).is_some_and(|m| cylinder_meets_mesh(cy, m)),
        (_, Cylinder(cy)) => as_mesh(a, am).is_some_and(|m| cylinder_meets_mesh(cy, m)),
        _ => match (as_mesh(a, am), as_mesh(b, bm)) {
            (Some(x), Some(y)) => meshes_meet(x, y),
            _ => false,
        },
    }
}

fn as_mesh<'a>(s: &'a Shape, boxed: Option<&'a Mesh>) -> Option<&'a Mesh> {
    match s {
        Shape::Mesh(m) => Some(m),
        _ => boxed,
    }
}

/// Whether the open ball (c, r) meets the solid `s`.
fn sphere_meets(c: V3, r: f64, s: &Shape) -> bool {
    match s {
        Shape::Sphere { centre, radius } => (c - centre).norm() < r + radius,
        Shape::Cuboid { min, max } => {
            let nearest = V3::from_fn(|k, _| c[k].clamp(min[k], max[k]));
            (c - nearest).norm() < r
        }
        Shape::Cylinder(cy) => cylinder_distance(cy, c) < r,
        Shape::Mesh(m) => {
            let reach = V3::repeat(r);
            m.contains(c)
                || m.any_near(c - reach, c + reach, |t| {
                    (c - closest_on_triangle(c, t)).norm() < r
                })
        }
    }
}

/// Distance from `p` to the solid cylinder (0 inside): the axial and radial
/// excesses in the cylinder's frame, combined.
fn cylinder_distance(cy: &Cylinder, p: V3) -> f64 {
    let q = p - cy.centre;
    let h = q.dot(&cy.axis);
    let radial = (q - h * cy.axis).norm();
    let dh = (h.abs() - cy.half_height).max(0.0);
    let dr = (radial - cy.radius).max(0.0);
    dh.hypot(dr)
}

/// Whether the open solid cylinder and the closed mesh share volume: a
/// triangle enters the cylinder, or the mesh holds it whole (then it holds
/// its centre).
fn cylinder_meets_mesh(cy: &Cylinder, m: &Mesh) -> bool {
    let (lo, hi) = Shape::Cylinder(cy.clone()).bounds();
    m.any_near(lo, hi, |t| triangle_enters_cylinder(cy, t)) || m.contains(cy.centre)
}

/// Whether triangle `t` meets the open cylinder |h| < half height, r <
/// radius. In the cylinder's frame (h along the axis, x and y across it)
/// the triangle is clipped to the closed slab; the open cylinder is met iff
/// the clipped polygon reaches off the cap planes and comes nearer than the
/// radius to the axis, i.e. its projection across the axis (a convex
/// polygon) holds a point nearer than the radius to the origin.
fn triangle_enters_cylinder(cy: &Cylinder, t: &[V3; 3]) -> bool {
    let local = |p: V3| {
        let q = p - cy.centre;
        [q.dot(&cy.axis), q.dot(&cy.u), q.dot(&cy.v)]
    };
    let mut poly: Vec<[f64; 3]> = t.iter().map(|&p| local(p)).collect();
    let hh = cy.half_height;
    poly = clip_below(&poly, hh, 1.0);
    poly = clip_below(&poly, hh, -1.0);
    if poly.is_empty() || poly.iter().all(|p| p[0] == hh) || poly.iter().all(|p| p[0] == -hh) {
        return false;
    }
    let flat: Vec<[f64; 2]> = poly.iter().map(|p| [p[1], p[2]]).collect();
    distance_to_origin(&flat) < cy.radius
}

/// The part of the convex polygon `poly` (points [h, x, y]) where
/// `sign * h <= limit` (Sutherland and Hodgman 1974); points made on the
/// plane get h = sign * limit exactly, so a face on a cap stays on it.
fn clip_below(poly: &[[f64; 3]], limit: f64, sign: f64) -> Vec<[f64; 3]> {
    let inside = |p: &[f64; 3]| sign * p[0] <= limit;
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, p) in poly.iter().enumerate() {
        let q = &poly[(i + 1) % poly.len()];
        if inside(p) {
            out.push(*p);
        }
        if inside(p) != inside(q) {
            let f = (sign * limit - p[0]) / (q[0] - p[0]);
            out.push([
                sign * limit,
                p[1] + f * (q[1] - p[1]),
                p[2] + f * (q[2] - p[2]),
            ]);
        }
    }
    out
}

/// Distance from the origin to a convex polygon of the plane (0 inside;
/// a polygon of one or two points is a point or a segment).
fn distance_to_origin(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    let cross = |a: &[f64; 2], b: &[f64; 2]| a[0] * b[1] - a[1] * b[0];
    let sides: Vec<f64> = (0..n)
        .map(|i| cross(&poly[i], &poly[(i + 1) % n]))
        .collect();
    // The origin is inside when it is on the same side of every edge.
    if n >= 3 && (sides.iter().all(|&s| s > 0.0) || sides.iter().all(|&s| s < 0.0)) {
        return 0.0;
    }
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let f = if len2 > 0.0 {
                (-(a[0] * d[0] + a[1] * d[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (a[0] + f * d[0]).hypot(a[1] + f * d[1])
        })
        .fold(f64::INFINITY, f64::min)
}

/// The point of triangle `t` nearest to `p`, by the Voronoi regions of its
/// vertices, edges and face (Ericson 2005, section 5.1.5).
fn closest_on_triangle(p: V3, t: &[V3; 3]) -> V3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + d1 / (d1 - d3) * ab;
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + d2 / (d2 - d6) * ac;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Whether two closed meshes share volume: their surfaces cross, or one
/// holds the other (then it holds any vertex of it).
fn meshes_meet(a: &Mesh, b: &Mesh) -> bool {
    let (small, large) = if a.triangles() <= b.triangles() {
        (a, b)
    } else {
        (b, a)
    };
    let crossed = small.tris().iter().any(|t| {
        let (lo, hi) = triangle_box(t);
        large.any_near(lo, hi, |u| triangles_cross(t, u))
    });
    crossed || a.contains(b.vertex()) || b.contains(a.vertex())
}

fn triangle_box(t: &[V3; 3]) -> (V3, V3) {
    (
        V3::from_fn(|k, _| t[0][k].min(t[1][k]).min(t[2][k])),
        V3::from_fn(|k, _| t[0][k].max(t[1][k]).max(t[2][k])),
    )
}

/// Two triangles in general position cross where an edge of one passes
/// through the other (the ends of their common segment lie on edges).
/// Coplanar triangles (shared faces) are taken as touching.
fn triangles_cross(t: &[V3; 3], u: &[V3; 3]) -> bool {
    let edges = |x: &[V3; 3]| [(x[0], x[1]), (x[1], x[2]), (x[2], x[0])];
    edges(t).iter().any(|&(p, q)| segment_crosses(p, q, u))
        || edges(u).iter().any(|&(p, q)| segment_crosses(p, q, t))
}

/// Whether the open segment (p, q) passes through the open triangle `t`
/// (Möller and Trumbore 1997 with the direction q - p: the hit at a
/// fraction strictly between 0 and 1, inside the triangle's edges).
fn segment_crosses(p: V3, q: V3, t: &[V3; 3]) -> bool {
    let d = q - p;
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let h = d.cross(&e2);
    let det = e1.dot(&h);
    // A segment parallel to the plane (to round-off) does not cross it.
    if det.abs() <= 1e-12 * e1.norm() * e2.norm() * d.norm() {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - t[0];
    let u = s.dot(&h) * inv;
    if !(u > 0.0 && u < 1.0) {
        return false;
    }
    let k = s.cross(&e1);
    let v = d.dot(&k) * inv;
    if !(v > 0.0 && u + v < 1.0) {
        return false;
    }
    let f = e2.dot(&k) * inv;
    f > 0.0 && f < 1.0
}

/// The first triangle of `m` that an edge of another triangle, sharing no
/// vertex with it, passes through (or whose edge passes through that one):
/// a surface crossing itself, which bounds no medium (two sheets of one
/// object's boundary through each other). Triangles that share a vertex
/// are not tested against each other (they meet there by construction).
pub(super) fn self_crossing(m: &Mesh) -> Option<usize> {
    m.tris().iter().position(|t| {
        let (lo, hi) = triangle_box(t);
        m.any_near(lo, hi, |u| {
            let shares = t.iter().any(|a| u.contains(a));
            !shares && triangles_cross(t, u)
        })
    })
}

/// A box as a closed mesh of twelve triangles (for the mesh tests).
fn box_mesh(s: &Shape) -> Option<Mesh> {
    let Shape::Cuboid { min, max } = s else {
        return None;
    };
    let corner = |i: usize| {
        V3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let v: Vec<V3> = (0..8).map(corner).collect();
    // Counter-clockwise seen from outside; Mesh::new turns a mesh wound the
    // other way, so only the consistency matters.
    let faces = [
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    Mesh::new(&v, &faces).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn object(i: usize, shape: Shape) -> Object {
        Object {
            name: format!("object[{i}]"),
            shape,
            material: crate::material::preset("skin1").unwrap(),
        }
    }

    fn sphere(x: f64, r: f64) -> Shape {
        Shape::Sphere {
            centre: V3::new(x, 0.0, 0.0),
            radius: r,
        }
    }

    /// A closed cube mesh of half-side `h` about (x, 0, 0).
    fn cube(x: f64, h: f64) -> Shape {
        let b = Shape::Cuboid {
            min: V3::new(x - h, -h, -h),
            max: V3::new(x + h, h, h),
        };
        Shape::Mesh(box_mesh(&b).unwrap())
    }

    fn check(shapes: Vec<Shape>) -> std::result::Result<(), String> {
        let objects: Vec<Object> = shapes
            .into_iter()
            .enumerate()
            .map(|(i, s)| object(i, s))
            .collect();
        check_disjoint(&Check { context: "t.toml" }, &objects).map_err(|e| e.to_string())
    }

    fn refused(shapes: Vec<Shape>, first: usize, second: usize) {
        let e = check(shapes).unwrap_err();
        assert!(
            e.contains(&format!("object[{second}]"))
                && e.contains(&format!("intersects object[{first}]")),
            "{e}"
        );
    }

    #[test]
    fn objects_that_share_volume_are_refused_with_both_named() {
        // Overlapping and coincident spheres.
        refused(vec![sphere(0.0, 1.0), sphere(1.5, 1.0)], 0, 1);
        refused(
            vec![sphere(0.0, 1.0), sphere(5.0, 1.0), sphere(5.0, 1.0)],
            1,
            2,
        );
        // A mesh around a sphere, and a sphere around a mesh.
        refused(vec![cube(0.0, 2.0), sphere(0.0, 1.0)], 0, 1);
        refused(vec![sphere(0.0, 5.0), cube(0.0, 1.0)], 0, 1);
        // A closed mesh inside another: no surfaces cross, parity finds it.
        refused(vec![cube(0.0, 3.0), cube(0.0, 1.0)], 0, 1);
        // Meshes whose surfaces cross.
        refused(vec![cube(0.0, 1.0), cube(1.5, 1.0)], 0, 1);
        // A box (as triangles) inside a mesh, and a sphere in a box.
        let small_box = Shape::Cuboid {
            min: V3::repeat(-0.5),
            max: V3::repeat(0.5),
        };
        refused(vec![cube(0.0, 2.0), small_box.clone()], 0, 1);
        refused(vec![small_box, sphere(0.9, 0.5)], 0, 1);
        // A sphere reaching into a cylinder's side.
        let cyl = Shape::Cylinder(Cylinder::new(V3::zeros(), V3::y(), 1.0, 2.0));
        refused(vec![cyl, sphere(1.5, 0.6)], 0, 1);
    }

    #[test]
    fn objects_that_only_touch_or_stand_apart_are_accepted() {
        check(vec![sphere(0.0, 1.0), sphere(2.0, 1.0)]).unwrap();
        check(vec![sphere(0.0, 1.0), sphere(2.5, 1.0)]).unwrap();
        // A sphere beside a mesh, its box overlapping the mesh's box.
        check(vec![cube(0.0, 1.0), sphere(1.9, 0.85)]).unwrap();
        // Meshes side by side, and sharing a face.
        check(vec![cube(0.0, 1.0), cube(2.5, 1.0)]).unwrap();
        check(vec![cube(0.0, 1.0), cube(2.0, 1.0)]).unwrap();
        let b = |x: f64| Shape::Cuboid {
            min: V3::new(x, 0.0, 0.0),
            max: V3::new(x + 1.0, 1.0, 1.0),
        };
        check(vec![b(0.0), b(1.0), sphere(2.6, 0.5)]).unwrap();
        let cyl = Shape::Cylinder(Cylinder::new(V3::zeros(), V3::y(), 1.0, 2.0));
        check(vec![cyl, sphere(1.5, 0.4)]).unwrap();
    }

    /// A cylinder of radius 1 and half height 2 about the y axis, against
    /// boxes and meshes: overlapping, touching (side and cap) and apart.
    #[test]
    fn cylinders_against_boxes_and_meshes() {
        let cyl = || Shape::Cylinder(Cylinder::new(V3::zeros(), V3::y(), 1.0, 2.0));
        let cuboid = |min: [f64; 3], max: [f64; 3]| Shape::Cuboid {
            min: V3::from(min),
            max: V3::from(max),
        };
        // A box through the side, one resting across the top cap's rim,
        // one wholly inside, one holding the cylinder whole.
        refused(
            vec![cyl(), cuboid([0.5, -0.5, -0.5], [3.0, 0.5, 0.5])],
            0,
            1,
        );
        refused(vec![cuboid([0.5, 1.9, 0.5], [3.0, 3.0, 3.0]), cyl()], 0, 1);
        refused(
            vec![cyl(), cuboid([-0.2, -0.2, -0.2], [0.2, 0.2, 0.2])],
            0,
            1,
        );
        refused(
            vec![cuboid([-5.0, -5.0, -5.0], [5.0, 5.0, 5.0]), cyl()],
            0,
            1,
        );
        // A mesh cube through the side; a box off both cross axes whose
        // edge reaches 0.07 past the radius along the diagonal.
        refused(vec![cyl(), cube(1.5, 0.6)], 0, 1);
        let diagonal = 1.0 / 2f64.sqrt() + 0.45;
        let corner_cube = Shape::Cuboid {
            min: V3::new(diagonal - 0.5, -0.5, diagonal - 0.5),
            max: V3::new(diagonal + 0.5, 0.5, diagonal + 0.5),
        };
        refused(vec![cyl(), corner_cube], 0, 1);
        // Touching: a face tangent to the side, a box on the top cap, a
        // mesh on the bottom cap; apart: beside it, its box overlapping
        // the cylinder's box (the corner region).
        check(vec![cyl(), cuboid([1.0, -1.0, -1.0], [2.0, 1.0, 1.0])]).unwrap();
        check(vec![cyl(), cuboid([-1.0, 2.0, -1.0], [1.0, 3.0, 1.0])]).unwrap();
        let below = Shape::Cuboid {
            min: V3::new(-0.5, -3.0, -0.5),
            max: V3::new(0.5, -2.0, 0.5),
        };
        check(vec![cyl(), Shape::Mesh(box_mesh(&below).unwrap())]).unwrap();
        check(vec![cyl(), cube(2.5, 1.0)]).unwrap();
        check(vec![cyl(), cuboid([0.8, -1.0, 0.8], [2.0, 1.0, 2.0])]).unwrap();
        // A face in a cap's plane touches (reached only by tilted
        // cylinders through check_disjoint: the box test drops it here);
        // one just inside the cap enters.
        let c = Cylinder::new(V3::zeros(), V3::y(), 1.0, 2.0);
        let at = |y: f64| {
            [
                V3::new(-0.5, y, -0.5),
                V3::new(0.5, y, -0.5),
                V3::new(0.0, y, 0.5),
            ]
        };
        assert!(!triangle_enters_cylinder(&c, &at(2.0)));
        assert!(!triangle_enters_cylinder(&c, &at(-2.0)));
        assert!(triangle_enters_cylinder(&c, &at(1.999)));
    }

    /// The nearest point of a triangle from each of its seven regions.
    #[test]
    fn closest_points_on_a_triangle_follow_its_regions() {
        // Round-off of the barycentric weights of unit-sized coordinates.
        const ROUND_OFF: f64 = 1e-15;
        let t = [V3::zeros(), V3::x(), V3::y()];
        let cases = [
            ([0.2, 0.2, 3.0], [0.2, 0.2, 0.0]),
            ([-1.0, -1.0, 0.0], [0.0, 0.0, 0.0]),
            ([2.0, -0.5, 0.0], [1.0, 0.0, 0.0]),
            ([-0.5, 2.0, 0.0], [0.0, 1.0, 0.0]),
            ([0.5, -1.0, 1.0], [0.5, 0.0, 0.0]),
            ([-1.0, 0.5, 0.0], [0.0, 0.5, 0.0]),
            ([1.0, 1.0, 0.0], [0.5, 0.5, 0.0]),
        ];
        for (p, want) in cases {
            let got = closest_on_triangle(V3::from(p), &t);
            assert!((got - V3::from(want)).norm() < ROUND_OFF, "{p:?}: {got:?}");
        }
    }
}
