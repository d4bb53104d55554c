//! The `[[object]]` sections: the material that fills each object and its
//! shape (sphere, box, cylinder, heightfield, mesh), every field checked
//! against what the shape takes; meshes and heightfields become closed
//! triangle meshes with a hierarchy.

use super::check::Check;
use super::obj::read_obj;
use super::{MAX_COORDINATE_MM, MAX_TRIANGLES};
use crate::error::{Error, Result};
use crate::material::Material;
use crate::scene::geometry::{Cylinder, Shape};
use crate::scene::mesh::{Mesh, MeshDefect};
use crate::scene::{heightfield, Object, Unit, V3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawObject {
    name: Option<String>,
    shape: Option<String>,
    material: Option<String>,
    eta: Option<f64>,
    center: Option<[f64; 3]>,
    radius: Option<f64>,
    size: Option<Vec<f64>>,
    height: Option<f64>,
    axis: Option<[f64; 3]>,
    image: Option<String>,
    depth: Option<f64>,
    file: Option<String>,
    scale: Option<f64>,
    translate: Option<[f64; 3]>,
}
/// A path from the scene file, relative to its folder.
fn resolve(dir: &Path, s: &str) -> PathBuf {
    let p = Path::new(s);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        dir.join(p)
    }
}

/// Where object `i`'s fields are: its prefix and the scene's folder.
struct Site<'a> {
    ck: &'a Check<'a>,
    /// "object[i]".
    prefix: String,
    unit: Unit,
    dir: &'a Path,
}

impl Site<'_> {
    /// The full name of one of the object's fields.
    fn field(&self, name: &str) -> String {
        format!("{}.{name}", self.prefix)
    }

    /// A required point field, in mm.
    fn point(&self, name: &str, v: Option<[f64; 3]>) -> Result<V3> {
        let f = self.field(name);
        self.ck.point(&f, self.ck.need(&f, v)?, self.unit)
    }

    /// A required length field, in mm.
    fn length(&self, name: &str, v: Option<f64>) -> Result<f64> {
        let f = self.field(name);
        self.ck.length(&f, self.ck.need(&f, v)?, self.unit)
    }

    /// A required file path field, from the scene's folder.
    fn path(&self, name: &str, v: Option<String>) -> Result<PathBuf> {
        Ok(resolve(self.dir, &self.ck.need(&self.field(name), v)?))
    }
}

pub(super) fn parse_object(
    ck: &Check,
    i: usize,
    o: RawObject,
    unit: Unit,
    dir: &Path,
) -> Result<Object> {
    let at = Site {
        ck,
        prefix: format!("object[{i}]"),
        unit,
        dir,
    };
    let material = object_material(&at, &o)?;
    let name = o.name.clone().unwrap_or_else(|| at.prefix.clone());
    let shape_name = ck.need(&at.field("shape"), o.shape.clone())?;
    check_fields(&at, &shape_name, &o)?;
    let shape = match shape_name.as_str() {
        "sphere" => Shape::Sphere {
            centre: at.point("center", o.center)?,
            radius: at.length("radius", o.radius)?,
        },
        "box" => cuboid(&at, &o)?,
        "cylinder" => {
            let axis = ck.unit_vector(&at.field("axis"), o.axis.unwrap_or([0.0, 1.0, 0.0]))?;
            let centre = at.point("center", o.center)?;
            let radius = at.length("radius", o.radius)?;
            let half_height = 0.5 * at.length("height", o.height)?;
            Shape::Cylinder(Cylinder::new(centre, axis, radius, half_height))
        }
        "heightfield" => heightfield_shape(&at, &o)?,
        "mesh" => obj_shape(&at, &o)?,
        other => {
            return Err(ck.err(
                &at.field("shape"),
                format!("\"{other}\""),
                "expected \"sphere\", \"box\", \"cylinder\", \"heightfield\" or \"mesh\"",
            ))
        }
    };
    Ok(Object {
        name,
        shape,
        material,
    })
}

/// The object's medium: a preset or a material file (relative to the
/// scene), one semi-infinite layer, its index optionally set by `eta`.
fn object_material(at: &Site, o: &RawObject) -> Result<Material> {
    let ck = at.ck;
    let f = |name: &str| at.field(name);
    let spec = ck.need(&f("material"), o.material.clone())?;
    // A preset name, or a file relative to the scene.
    let mut material = if spec.ends_with(".toml") || spec.contains('/') {
        Material::load(&resolve(at.dir, &spec).display().to_string())
    } else {
        Material::load(&spec)
    }
    .map_err(|e| ck.err(&f("material"), format!("\"{spec}\""), e.to_string()))?;
    if !material.is_half_space() {
        return Err(ck.err(
            &f("material"),
            format!("\"{spec}\""),
            "an object is filled with one homogeneous medium: the material must have one layer \
             and no thickness (the shape is its extent)",
        ));
    }
    if let Some(eta) = o.eta {
        if !(1.0 / 3.0..=3.0).contains(&eta) {
            return Err(ck.err(&f("eta"), eta, "must be in [1/3, 3]"));
        }
        material.layers[0].eta = eta;
        material.eta_above = 1.0;
        material.name = format!("{}-eta{eta}", material.name);
    }
    material.validate(&format!("{} {}", ck.context, f("material")))?;
    Ok(material)
}

/// Refuses the fields that the shape does not take.
fn check_fields(at: &Site, shape_name: &str, o: &RawObject) -> Result<()> {
    let given = [
        ("center", o.center.is_some()),
        ("radius", o.radius.is_some()),
        ("size", o.size.is_some()),
        ("height", o.height.is_some()),
        ("axis", o.axis.is_some()),
        ("image", o.image.is_some()),
        ("depth", o.depth.is_some()),
        ("file", o.file.is_some()),
        ("scale", o.scale.is_some()),
        ("translate", o.translate.is_some()),
    ];
    let takes: &[&str] = match shape_name {
        "sphere" => &["center", "radius"],
        "box" => &["center", "size"],
        "cylinder" => &["center", "radius", "height", "axis"],
        "heightfield" => &["center", "size", "height", "image", "depth"],
        "mesh" => &["file", "scale", "translate"],
        _ => &[],
    };
    if takes.is_empty() {
        return Ok(());
    }
    at.ck.unused(&at.prefix, shape_name, &given, takes)
}

/// An axis-aligned box from its centre and size.
fn cuboid(at: &Site, o: &RawObject) -> Result<Shape> {
    let ck = at.ck;
    let c = at.point("center", o.center)?;
    let size = ck.need(&at.field("size"), o.size.clone())?;
    if size.len() != 3 {
        return Err(ck.err(&at.field("size"), format!("{size:?}"), "expected [x, y, z]"));
    }
    let mut half = V3::zeros();
    for k in 0..3 {
        half[k] = 0.5 * ck.length(&format!("{}[{k}]", at.field("size")), size[k], at.unit)?;
    }
    Ok(Shape::Cuboid {
        min: c - half,
        max: c + half,
    })
}

/// The closed solid of a grey image's heights over a base plane.
fn heightfield_shape(at: &Site, o: &RawObject) -> Result<Shape> {
    let (ck, unit) = (at.ck, at.unit);
    let f = |name: &str| at.field(name);
    let c = at.point("center", o.center)?;
    let size = ck.need(&f("size"), o.size.clone())?;
    if size.len() != 2 {
        return Err(ck.err(
            &f("size"),
            format!("{size:?}"),
            "expected [x, z]: the extent of the image on the base plane",
        ));
    }
    let sx = ck.length(&format!("{}[0]", f("size")), size[0], unit)?;
    let sz = ck.length(&format!("{}[1]", f("size")), size[1], unit)?;
    let height = ck.finite(&f("height"), ck.need(&f("height"), o.height)?)? * unit.mm();
    if height.abs() > MAX_COORDINATE_MM {
        return Err(ck.err(&f("height"), height / unit.mm(), "too large"));
    }
    let depth = at.length("depth", o.depth)?;
    let image = at.path("image", o.image.clone())?;
    let heights = heightfield::read_heights(&image)?;
    let (positions, tris) = heightfield::solid(&heights, c, [sx, sz], height, depth, MAX_TRIANGLES)
        .map_err(|why| ck.err(&f("image"), image.display(), why))?;
    mesh_shape(
        ck,
        &f("image"),
        &image.display().to_string(),
        &positions,
        &tris,
    )
}

/// A closed OBJ mesh, scaled and moved into the scene.
fn obj_shape(at: &Site, o: &RawObject) -> Result<Shape> {
    let ck = at.ck;
    let f = |name: &str| at.field(name);
    let scale = ck.positive(&f("scale"), o.scale.unwrap_or(1.0))? * at.unit.mm();
    let shift = ck.point(&f("translate"), o.translate.unwrap_or([0.0; 3]), at.unit)?;
    let path = at.path("file", o.file.clone())?;
    let (positions, tris) = read_obj(&path)?;
    let mut moved = Vec::with_capacity(positions.len());
    for (k, q) in positions.iter().enumerate() {
        let m = q * scale + shift;
        if !(m.amax() <= MAX_COORDINATE_MM) {
            return Err(Error::format(
                &path,
                format!(
                    "vertex {k} lands at {:?} mm after scale and translate: coordinates \
                     are limited to {MAX_COORDINATE_MM} mm",
                    [m.x, m.y, m.z]
                ),
            ));
        }
        moved.push(m);
    }
    let what = path.display().to_string();
    let shape = mesh_shape(ck, &f("file"), &what, &moved, &tris)?;
    if let Shape::Mesh(m) = &shape {
        if let Some(k) = super::overlap::self_crossing(m) {
            return Err(ck.err(
                &f("file"),
                what,
                format!(
                    "crosses itself: triangle {k} and another triangle that shares no vertex with \
                     it pass through each other (a medium needs a surface that does not cross \
                     itself)"
                ),
            ));
        }
    }
    Ok(shape)
}

/// The hierarchy of a closed mesh, built on a thread with room for its
/// recursion (the build recurses once per level, at worst once per
/// triangle).
fn mesh_shape(
    ck: &Check,
    field: &str,
    what: &str,
    positions: &[V3],
    tris: &[[usize; 3]],
) -> Result<Shape> {
    let stack = (64 << 20) + 1024 * tris.len();
    let built = std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(stack)
            .spawn_scoped(s, || Mesh::new(positions, tris))
            .map(|h| h.join())
    });
    let mesh = match built {
        Ok(Ok(m)) => m,
        Ok(Err(_)) => {
            return Err(Error::Unsupported(format!(
                "{}: building the hierarchy of {what} failed",
                ck.context
            )))
        }
        Err(e) => {
            return Err(Error::Unsupported(format!(
                "{}: cannot start the thread that builds the hierarchy of {what}: {e}",
                ck.context
            )))
        }
    };
    mesh.map(Shape::Mesh).map_err(|d| {
        let why = match d {
            MeshDefect::Empty => "holds no triangle".to_string(),
            MeshDefect::Degenerate(k) => format!("triangle {k} has no area"),
            MeshDefect::OpenEdge(a, b) => format!(
                "is not closed: the edge from vertex {a} to vertex {b} is not shared by exactly \
                 two triangles wound in opposite directions (a medium needs a watertight, \
                 consistently wound surface)"
            ),
            MeshDefect::NoVolume => "encloses no volume".to_string(),
        };
        ck.err(field, what, why)
    })
}
