//! A heightfield from a grey image, as a closed solid: the image's pixels
//! are the vertices of the top surface (column 0 at -x, row 0 at -z, white
//! rising by `height` along +y), above a flat bottom `depth` below the
//! base plane, joined by vertical walls.

use super::ray::V3;
use crate::error::{Error, Result};
use std::path::Path;

/// Heights in [0, 1] on a grid of `nx` x `nz` samples, row-major in z.
pub struct Heights {
    pub nx: usize,
    pub nz: usize,
    pub h: Vec<f64>,
}

/// Reads a PNG as raw grey values in [0, 1] (8 or 16 bit; no sRGB
/// decoding: heights are data, not colours).
pub fn read_heights(path: &Path) -> Result<Heights> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if ext.as_deref() != Some("png") {
        return Err(Error::format(
            path,
            "a heightfield image must be a grey PNG (8 or 16 bit)",
        ));
    }
    let img = crate::io::decode_png(path)?;
    let grey = img.to_luma16();
    Ok(Heights {
        nx: grey.width() as usize,
        nz: grey.height() as usize,
        h: grey.pixels().map(|p| p.0[0] as f64 / 65535.0).collect(),
    })
}

/// Triangles of the solid for an `nx` x `nz` grid.
pub fn triangle_count(nx: usize, nz: usize) -> usize {
    let cells = (nx.saturating_sub(1)).saturating_mul(nz.saturating_sub(1));
    4usize
        .saturating_mul(cells)
        .saturating_add(4usize.saturating_mul(nx + nz).saturating_sub(8))
}

/// Vertices and counter-clockwise triangles of the solid; `Err` says why
/// not (too small, too many triangles, the top below the bottom).
#[allow(clippy::type_complexity)]
pub fn solid(
    hf: &Heights,
    centre: V3,
    size: [f64; 2],
    height: f64,
    depth: f64,
    max_triangles: usize,
) -> std::result::Result<(Vec<V3>, Vec<[usize; 3]>), String> {
    let (nx, nz) = (hf.nx, hf.nz);
    if nx < 2 || nz < 2 {
        return Err(format!(
            "{nx}x{nz} pixels: a heightfield needs at least 2x2 pixels"
        ));
    }
    let n = triangle_count(nx, nz);
    if n > max_triangles {
        return Err(format!(
            "{nx}x{nz} pixels make {n} triangles; heightfields are limited to {max_triangles}: \
             use a smaller image"
        ));
    }
    let lowest = hf.h.iter().fold(f64::INFINITY, |m, &v| m.min(height * v));
    if !(lowest > -depth) {
        return Err(format!(
            "the surface dips {} below the base plane, through the bottom at depth {depth} mm",
            -lowest
        ));
    }
    let top = |i: usize, j: usize| j * nx + i;
    let bottom = |i: usize, j: usize| nx * nz + j * nx + i;
    let mut positions = Vec::with_capacity(2 * nx * nz);
    for y in [1.0, 0.0] {
        for j in 0..nz {
            for i in 0..nx {
                let x = centre.x + size[0] * (i as f64 / (nx - 1) as f64 - 0.5);
                let z = centre.z + size[1] * (j as f64 / (nz - 1) as f64 - 0.5);
                let v = if y > 0.0 {
                    centre.y + height * hf.h[top(i, j)]
                } else {
                    centre.y - depth
                };
                positions.push(V3::new(x, v, z));
            }
        }
    }
    let mut tris = Vec::with_capacity(n);
    for j in 0..nz - 1 {
        for i in 0..nx - 1 {
            // Seen from +y, (i, j), (i, j + 1), (i + 1, j) turn
            // counter-clockwise: the top's normal is +y.
            tris.push([top(i, j), top(i, j + 1), top(i + 1, j)]);
            tris.push([top(i + 1, j), top(i, j + 1), top(i + 1, j + 1)]);
            tris.push([bottom(i, j), bottom(i + 1, j), bottom(i, j + 1)]);
            tris.push([bottom(i + 1, j), bottom(i + 1, j + 1), bottom(i, j + 1)]);
        }
    }
    // Walls: along each boundary edge a -> b of the top (an edge whose
    // reverse no top triangle uses), the quad b, a, a', b' (' = below),
    // wound so that every edge is used once in each direction.
    let mut boundary = Vec::new();
    let perimeter = (0..nx - 1)
        .map(|i| (top(i + 1, 0), top(i, 0)))
        .chain((0..nz - 1).map(|j| (top(nx - 1, j + 1), top(nx - 1, j))))
        .chain((0..nx - 1).map(|i| (top(i, nz - 1), top(i + 1, nz - 1))))
        .chain((0..nz - 1).map(|j| (top(0, j), top(0, j + 1))));
    boundary.extend(perimeter);
    let below = nx * nz;
    for (a, b) in boundary {
        tris.push([b, a, a + below]);
        tris.push([b, a + below, b + below]);
    }
    Ok((positions, tris))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::geometry::Shape;
    use crate::scene::mesh::Mesh;
    use crate::scene::ray::Ray;

    #[test]
    fn the_solid_is_closed_and_its_top_follows_the_image() {
        let hf = Heights {
            nx: 4,
            nz: 3,
            h: vec![0.0, 0.1, 0.2, 0.3, 0.5, 0.5, 0.5, 0.5, 1.0, 0.0, 1.0, 0.0],
        };
        let (p, t) = solid(&hf, V3::new(1.0, 2.0, 3.0), [3.0, 2.0], 2.0, 1.0, 1000).unwrap();
        assert_eq!(t.len(), triangle_count(4, 3));
        let mesh = Mesh::new(&p, &t).unwrap();
        let shape = Shape::Mesh(mesh);
        // Straight down onto vertex (1, 1): x = 0.5, z = 3, height 2 + 2 x 0.5.
        let r = Ray {
            o: V3::new(0.5, 10.0, 3.0),
            d: V3::new(0.0, -1.0, 0.0),
        };
        let h = shape.intersect(&r, 1e9).unwrap();
        assert!((h.t - 7.0).abs() < 1e-12, "{}", h.t);
        assert!(h.n.y > 0.2, "{}", h.n);
        // Up through the bottom.
        let r = Ray {
            o: V3::new(1.2, -5.0, 2.7),
            d: V3::new(0.0, 1.0, 0.0),
        };
        let h = shape.intersect(&r, 1e9).unwrap();
        assert!((h.t - 6.0).abs() < 1e-12 && (h.n.y + 1.0).abs() < 1e-12);
        assert!(shape.contains(V3::new(1.0, 1.5, 3.0)));
        assert!(!shape.contains(V3::new(1.0, 0.5, 3.0)));
        // A surface dipping through the bottom, and too many triangles.
        assert!(solid(&hf, V3::zeros(), [1.0, 1.0], -2.0, 1.0, 1000).is_err());
        assert!(solid(&hf, V3::zeros(), [1.0, 1.0], 1.0, 1.0, 10).is_err());
    }
}
