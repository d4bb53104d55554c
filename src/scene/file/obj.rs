//! Wavefront OBJ meshes: triangles and positions read with `tobj`, bounded
//! before allocation, vertices at one position merged so that the mesh's
//! closedness can be checked.

use super::MAX_TRIANGLES;
use crate::error::{Error, Result};
use crate::scene::V3;
use std::path::Path;

/// Reads an OBJ file's triangles (faces fan-triangulated, all groups
/// merged), refusing more than [`MAX_TRIANGLES`] before allocating them.
pub(super) fn read_obj(path: &Path) -> Result<(Vec<V3>, Vec<[usize; 3]>)> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    // An OBJ face line takes at least 8 bytes ("f 1 2 3\n"): the file's
    // length bounds its triangles before the parser allocates them.
    if meta.len() > 64 * MAX_TRIANGLES as u64 {
        return Err(Error::format(
            path,
            format!(
                "{} bytes: meshes are limited to {MAX_TRIANGLES} triangles (files of at most {} \
                 bytes)",
                meta.len(),
                64 * MAX_TRIANGLES
            ),
        ));
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts)
        .map_err(|e| Error::format(path, format!("unreadable OBJ file: {e}")))?;
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for m in &models {
        let mesh = &m.mesh;
        let base = positions.len();
        if mesh.positions.len() % 3 != 0 || mesh.indices.len() % 3 != 0 {
            return Err(Error::format(path, "positions or faces are not triples"));
        }
        if tris.len() + mesh.indices.len() / 3 > MAX_TRIANGLES {
            return Err(Error::format(
                path,
                format!("meshes are limited to {MAX_TRIANGLES} triangles"),
            ));
        }
        for (k, v) in mesh.positions.chunks_exact(3).enumerate() {
            let q = V3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            if !q.iter().all(|x| x.is_finite()) {
                return Err(Error::format(path, format!("vertex {k} is not finite")));
            }
            positions.push(q);
        }
        let n = mesh.positions.len() / 3;
        for t in mesh.indices.chunks_exact(3) {
            let idx = [t[0] as usize, t[1] as usize, t[2] as usize];
            if idx.iter().any(|&i| i >= n) {
                return Err(Error::format(
                    path,
                    "a face names a vertex that does not exist",
                ));
            }
            tris.push(idx.map(|i| base + i));
        }
    }
    // Faces refer to vertices by position in OBJ; the same position
    // listed twice (seams of texture coordinates) is one vertex for the
    // closedness check.
    let mut ids: std::collections::HashMap<[u64; 3], usize> = Default::default();
    let mut unique = Vec::new();
    let remap: Vec<usize> = positions
        .iter()
        .map(|p| {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            *ids.entry(key).or_insert_with(|| {
                unique.push(*p);
                unique.len() - 1
            })
        })
        .collect();
    let tris = tris.into_iter().map(|t| t.map(|i| remap[i])).collect();
    Ok((unique, tris))
}
