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
    let text = obj_text(path)?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Material libraries (`mtllib`) are never opened: ssskit takes the
    // medium from the scene file, and a library may name any file (a
    // device, a pipe, one outside the scene's folder, a huge one).
    let no_materials = |_: &Path| -> tobj::MTLLoadResult { Ok((Vec::new(), Default::default())) };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, no_materials)
        .map_err(|e| Error::format(path, format!("unreadable OBJ file: {e}")))?;
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for m in &models {
        let mesh = &m.mesh;
        if mesh.positions.len() % 3 != 0 || mesh.indices.len() % 3 != 0 {
            return Err(Error::format(path, "positions or faces are not triples"));
        }
        if tris.len() + mesh.indices.len() / 3 > MAX_TRIANGLES {
            return Err(Error::format(
                path,
                format!("meshes are limited to {MAX_TRIANGLES} triangles"),
            ));
        }
        append_model(&mesh.positions, &mesh.indices, &mut positions, &mut tris)
            .map_err(|e| Error::format(path, e))?;
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

/// Appends one model's vertices and triangles (indices into the model's
/// own positions) to the merged lists, refusing a vertex that is not
/// finite (an f32 literal past 3.4e38 parses as infinite) and a face index
/// past the model's vertices. `tobj` already refuses out-of-range face
/// indices while parsing; this check keeps the indexing below safe on its
/// own, whatever a parser hands over.
fn append_model(
    model_positions: &[f32],
    indices: &[u32],
    positions: &mut Vec<V3>,
    tris: &mut Vec<[usize; 3]>,
) -> std::result::Result<(), String> {
    let base = positions.len();
    for (k, v) in model_positions.chunks_exact(3).enumerate() {
        let q = V3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        if !q.iter().all(|x| x.is_finite()) {
            return Err(format!("vertex {k} is not finite"));
        }
        positions.push(q);
    }
    let n = model_positions.len() / 3;
    for t in indices.chunks_exact(3) {
        let idx = [t[0] as usize, t[1] as usize, t[2] as usize];
        if idx.iter().any(|&i| i >= n) {
            return Err("a face names a vertex that does not exist".into());
        }
        tris.push(idx.map(|i| base + i));
    }
    Ok(())
}

/// The text of an OBJ file: a regular file only (a pipe could block, a
/// device never end), read through the bounded reader; a byte-order mark
/// and bytes that are not UTF-8 are refused with their line.
fn obj_text(path: &Path) -> Result<String> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(Error::format(path, "a folder, not an OBJ file"));
    }
    if !meta.is_file() {
        return Err(Error::format(
            path,
            "not a regular file (a device or a named pipe): meshes are read from files",
        ));
    }
    // An OBJ face line takes at least 8 bytes ("f 1 2 3\n"): a cap of 64
    // bytes per triangle bounds the parser's allocations.
    let max = 64 * MAX_TRIANGLES as u64;
    let bytes = crate::io::read_bytes_capped(path, max, "mesh (OBJ)")?;
    if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        return Err(Error::format(
            path,
            "line 1: a byte-order mark (U+FEFF) opens the file: save it as UTF-8 without one",
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        Error::format(
            path,
            format!("line {line}: bytes that are not UTF-8 text (byte {at})"),
        )
    })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    const CUBE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

    fn fifo(path: &Path) {
        let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
        // SAFETY: a NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    }

    /// `mtllib` lines are parsed past, never opened: pipes with no writer
    /// (which an open would wait on forever), one beside the mesh and one
    /// in another folder, and a device.
    #[test]
    fn material_libraries_are_never_opened() {
        let (dir, other) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let d = dir.path();
        fifo(&d.join("m.mtl"));
        let outside = other.path().join("o.mtl");
        fifo(&outside);
        let obj = d.join("c.obj");
        let libs = format!(
            "mtllib m.mtl\nmtllib {}\nmtllib /dev/zero\n",
            outside.display()
        );
        std::fs::write(&obj, format!("{libs}usemtl x\n{CUBE}")).unwrap();
        let (v, f) = read_obj(&obj).unwrap();
        assert_eq!((v.len(), f.len()), (8, 12));
    }

    /// A vertex past f32's range parses as infinite and is refused by name
    /// (through the file: tobj accepts it); a face index past the model's
    /// vertices, which tobj refuses before it gets here, is refused by the
    /// check itself.
    #[test]
    fn infinite_vertices_and_missing_face_vertices_are_refused() {
        let (_dir, obj) = crate::io::scratch("inf.obj");
        std::fs::write(&obj, CUBE.replacen("v 1 1 1", "v 1 1e39 1", 1)).unwrap();
        let e = read_obj(&obj).unwrap_err().to_string();
        assert!(e.contains("vertex 6 is not finite"), "{e}");
        let (mut p, mut t) = (Vec::new(), Vec::new());
        let tri = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        append_model(&tri, &[0, 1, 2], &mut p, &mut t).unwrap();
        assert_eq!(t, vec![[0, 1, 2]]);
        let e = append_model(&tri, &[0, 1, 3], &mut p, &mut t).unwrap_err();
        assert!(e.contains("does not exist"), "{e}");
        // No triangle of the refused face was kept.
        assert_eq!(t, vec![[0, 1, 2]]);
    }

    /// A pipe, a device and a folder as the mesh are refused at once; a
    /// byte-order mark and bad bytes are named with their line.
    #[test]
    fn only_regular_utf8_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        fifo(&d.join("p.obj"));
        for (p, needle) in [
            (d.join("p.obj"), "not a regular file"),
            (std::path::PathBuf::from("/dev/zero"), "not a regular file"),
            (d.to_path_buf(), "a folder"),
        ] {
            let e = read_obj(&p).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
        let bom = d.join("bom.obj");
        std::fs::write(&bom, format!("\u{feff}{CUBE}")).unwrap();
        let e = read_obj(&bom).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("byte-order mark"), "{e}");
        let bad = d.join("bad.obj");
        std::fs::write(&bad, [CUBE.as_bytes(), b"v 0 0 \xff\n"].concat()).unwrap();
        let e = read_obj(&bad).unwrap_err().to_string();
        assert!(e.contains("line 15") && e.contains("not UTF-8"), "{e}");
    }
}
