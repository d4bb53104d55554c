//! The scene TOML format. Lengths in the file's `unit`; everything is
//! checked before anything is allocated from it:
//!
//! ```toml
//! unit = "mm"                     # "mm", "cm" or "m"
//! [camera]
//! type = "perspective"            # or "orthographic" with mm_per_pixel
//! position = [0, 0, 150]
//! look_at = [0, 0, 0]
//! up = [0, 1, 0]
//! fov_y = 14                      # degrees
//! size = [192, 192]               # width, height in pixels
//! measure = "radiance"            # or "exitance" (exitance / pi, a sensor)
//! [[light]]
//! type = "directional"
//! toward = [0.8660254, 0, 0.5]    # unit vector towards the light
//! irradiance = 1                  # or [r, g, b]
//! [[light]]
//! type = "environment"            # uniform radiance from every direction
//! radiance = 0.1                  # or [r, g, b]
//! [[object]]
//! shape = "sphere"                # center, radius
//! center = [0, 0, 0]
//! radius = 15
//! material = "skin1"              # a preset name or a material file
//! eta = 1.0                       # optional: the object's refractive index
//! ```
//!
//! Shapes: `sphere` (center, radius); `box` (center, size = [x, y, z],
//! axis-aligned); `cylinder` (center, radius, height, axis = unit vector,
//! default [0, 1, 0]); `heightfield` (image = a grey PNG, center = the
//! centre of its base plane, size = [x, z], height = the rise of a white
//! pixel along +y, depth = the solid's thickness below the base plane);
//! `mesh` (file = a closed OBJ, scale, translate).

use super::camera::{Camera, Measure, Projection};
use super::geometry::{frame, Mesh, MeshDefect, Shape, V3};
use super::trace::SPHERE_MAX_ETA;
use super::{Light, Object, Scene, Unit};
use crate::error::{Error, Result};
use crate::material::{describe_toml_error, Material, PerChannel};
use serde::Deserialize;
use std::path::Path;

/// The context of a scene's errors when it has no file name.
pub const CONTEXT: &str = "scene";

/// Largest absolute coordinate, mm: keeps the tracer's offsets (a
/// billionth of the scene's reach) far above f64's resolution.
pub const MAX_COORDINATE_MM: f64 = 1e6;
/// Most objects in a scene (each ray tests every object).
pub const MAX_OBJECTS: usize = 256;
/// Most lights.
pub const MAX_LIGHTS: usize = 64;
/// Most triangles in one mesh or heightfield.
pub const MAX_TRIANGLES: usize = 2_000_000;
/// Tolerance on the length of a unit vector.
pub const UNIT_TOLERANCE: f64 = 1e-6;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    unit: Option<String>,
    camera: Option<RawCamera>,
    #[serde(default)]
    light: Vec<RawLight>,
    #[serde(default)]
    object: Vec<RawObject>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    #[serde(rename = "type")]
    kind: Option<String>,
    position: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    fov_y: Option<f64>,
    mm_per_pixel: Option<f64>,
    size: Option<Vec<f64>>,
    measure: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: Option<String>,
    toward: Option<[f64; 3]>,
    irradiance: Option<PerChannel>,
    radiance: Option<PerChannel>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObject {
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

/// Field checks of one scene file.
struct Check<'a> {
    context: &'a str,
}

impl Check<'_> {
    fn err(&self, field: &str, value: impl std::fmt::Display, reason: impl Into<String>) -> Error {
        Error::invalid(self.context, field, value, reason)
    }

    fn need<T>(&self, field: &str, v: Option<T>) -> Result<T> {
        v.ok_or_else(|| self.err(field, "missing", "required"))
    }

    fn finite(&self, field: &str, v: f64) -> Result<f64> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, v, "must be finite"))
        }
    }

    fn positive(&self, field: &str, v: f64) -> Result<f64> {
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, v, "must be finite and > 0"))
        }
    }

    /// A point or length vector in scene units, converted to mm.
    fn point(&self, field: &str, v: [f64; 3], unit: Unit) -> Result<V3> {
        for (i, x) in v.iter().enumerate() {
            let mm = self.finite(&format!("{field}[{i}]"), *x)? * unit.mm();
            if mm.abs() > MAX_COORDINATE_MM {
                return Err(self.err(
                    &format!("{field}[{i}]"),
                    x,
                    format!(
                        "coordinates are limited to {MAX_COORDINATE_MM} mm ({} {})",
                        MAX_COORDINATE_MM / unit.mm(),
                        unit.name()
                    ),
                ));
            }
        }
        Ok(V3::from(v) * unit.mm())
    }

    /// A length in scene units, > 0, converted to mm.
    fn length(&self, field: &str, v: f64, unit: Unit) -> Result<f64> {
        let mm = self.positive(field, v)? * unit.mm();
        if mm > MAX_COORDINATE_MM {
            return Err(self.err(
                field,
                v,
                format!("lengths are limited to {MAX_COORDINATE_MM} mm"),
            ));
        }
        Ok(mm)
    }

    fn unit_vector(&self, field: &str, v: [f64; 3]) -> Result<V3> {
        for (i, x) in v.iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), *x)?;
        }
        let u = V3::from(v);
        let n = u.norm();
        if !((n - 1.0).abs() <= UNIT_TOLERANCE) {
            return Err(self.err(
                field,
                format!("{v:?}"),
                format!(
                    "must be a unit vector (length 1 within {UNIT_TOLERANCE}); its length is {n}"
                ),
            ));
        }
        Ok(u / n)
    }

    fn rgb(&self, field: &str, v: PerChannel) -> Result<[f64; 3]> {
        let v = v.rgb();
        for (c, x) in v.iter().enumerate() {
            if !(x.is_finite() && *x >= 0.0) {
                return Err(self.err(&format!("{field}[{c}]"), x, "must be finite and >= 0"));
            }
        }
        Ok(v)
    }

    /// Refuses fields that the object's shape does not use: `given` says
    /// which fields the object has, `takes` those its shape reads.
    fn unused(
        &self,
        prefix: &str,
        shape: &str,
        given: &[(&str, bool)],
        takes: &[&str],
    ) -> Result<()> {
        match given.iter().find(|(n, on)| *on && !takes.contains(n)) {
            Some((name, _)) => Err(self.err(
                &format!("{prefix}.{name}"),
                "given",
                format!("a {shape} has no {name}; it takes {}", takes.join(", ")),
            )),
            None => Ok(()),
        }
    }
}

/// Parses and validates a scene. `context` names the file in errors;
/// relative paths in it are taken from `dir`.
pub fn parse_scene_toml(text: &str, context: &str, dir: &Path) -> Result<Scene> {
    let raw: RawScene = toml::from_str(text).map_err(|e| {
        Error::format(
            context,
            format!("malformed scene TOML: {}", describe_toml_error(text, &e)),
        )
    })?;
    let ck = Check { context };
    let unit = match raw.unit.as_deref() {
        Some("mm") => Unit::Mm,
        Some("cm") => Unit::Cm,
        Some("m") => Unit::M,
        Some(u) => {
            return Err(ck.err(
                "unit",
                format!("\"{u}\""),
                "expected \"mm\", \"cm\" or \"m\"",
            ))
        }
        None => {
            return Err(ck.err(
                "unit",
                "missing",
                "state the scene's length unit: unit = \"mm\", \"cm\" or \"m\"",
            ))
        }
    };
    let camera = parse_camera(&ck, ck.need("camera", raw.camera)?, unit)?;
    if raw.light.is_empty() {
        return Err(ck.err(
            "light",
            "none",
            "give at least one [[light]] (directional or environment)",
        ));
    }
    if raw.light.len() > MAX_LIGHTS {
        return Err(ck.err(
            "light",
            raw.light.len(),
            format!("at most {MAX_LIGHTS} lights"),
        ));
    }
    let lights = raw
        .light
        .into_iter()
        .enumerate()
        .map(|(i, l)| parse_light(&ck, i, l))
        .collect::<Result<Vec<_>>>()?;
    if raw.object.is_empty() {
        return Err(ck.err("object", "none", "give at least one [[object]]"));
    }
    if raw.object.len() > MAX_OBJECTS {
        return Err(ck.err(
            "object",
            raw.object.len(),
            format!("at most {MAX_OBJECTS} objects"),
        ));
    }
    let objects = raw
        .object
        .into_iter()
        .enumerate()
        .map(|(i, o)| parse_object(&ck, i, o, unit, dir))
        .collect::<Result<Vec<_>>>()?;
    // A delta light seen through a smooth boundary that refracts is a
    // caustic path a backward tracer cannot sample (Veach 1997, section
    // 8.3.3): the tracer solves for the beam's entry point instead, on a
    // sphere (1 < eta <= SPHERE_MAX_ETA) and on a box's faces; elsewhere
    // refuse rather than render it black.
    if lights
        .iter()
        .any(|l| matches!(l, Light::Directional { .. }))
    {
        for (i, o) in objects.iter().enumerate() {
            let eta = o.eta();
            let ok = eta == 1.0
                || match o.shape {
                    Shape::Cuboid { .. } => true,
                    Shape::Sphere { .. } => eta > 1.0 && eta <= SPHERE_MAX_ETA,
                    _ => false,
                };
            if !ok {
                return Err(ck.err(
                    &format!("object[{i}].eta"),
                    eta,
                    format!(
                        "a directional light reaches the inside of an object through a \
                         refracting boundary only along the beam it refracts into, which the \
                         tracer follows into spheres (1 < eta <= {SPHERE_MAX_ETA}) and boxes; \
                         for this shape set eta = 1 (index-matched), or light the scene with an \
                         environment light"
                    ),
                ));
            }
        }
    }
    let scene = Scene {
        unit,
        camera,
        lights,
        objects,
        origin: context.to_string(),
    };
    let (lo, hi) = scene.bounds();
    if (scene.camera.position - 0.5 * (lo + hi)).norm() > 4.0 * MAX_COORDINATE_MM {
        return Err(ck.err(
            "camera.position",
            format!("{:?}", scene.camera.position / unit.mm()),
            "the camera is too far from the objects",
        ));
    }
    Ok(scene)
}

fn parse_camera(ck: &Check, c: RawCamera, unit: Unit) -> Result<Camera> {
    let position = ck.point(
        "camera.position",
        ck.need("camera.position", c.position)?,
        unit,
    )?;
    let look_at = ck.point(
        "camera.look_at",
        ck.need("camera.look_at", c.look_at)?,
        unit,
    )?;
    let up_raw = c.up.unwrap_or([0.0, 1.0, 0.0]);
    for (i, x) in up_raw.iter().enumerate() {
        ck.finite(&format!("camera.up[{i}]"), *x)?;
    }
    let Some((forward, right, up)) = Camera::frame(position, look_at, V3::from(up_raw)) else {
        return Err(ck.err(
            "camera.up",
            format!("{up_raw:?}"),
            "the camera needs position != look_at and an up vector not along the view",
        ));
    };
    let size = ck.need("camera.size", c.size)?;
    if size.len() != 2 {
        return Err(ck.err(
            "camera.size",
            format!("{size:?}"),
            "expected [width, height] in pixels",
        ));
    }
    let side = |i: usize| -> Result<usize> {
        let v = size[i];
        if !(v >= 1.0 && v <= crate::limits::MAX_IMAGE_SIDE as f64 && v.fract() == 0.0) {
            return Err(ck.err(
                &format!("camera.size[{i}]"),
                v,
                format!(
                    "must be a whole number of pixels in 1..={}",
                    crate::limits::MAX_IMAGE_SIDE
                ),
            ));
        }
        Ok(v as usize)
    };
    let (width, height) = (side(0)?, side(1)?);
    crate::limits::check_image_size(&format!("{} camera", ck.context), width, height)?;
    let kind = ck.need("camera.type", c.kind)?;
    let projection = match kind.as_str() {
        "perspective" => {
            if c.mm_per_pixel.is_some() {
                return Err(ck.err(
                    "camera.mm_per_pixel",
                    "given",
                    "a perspective camera takes fov_y, not mm_per_pixel",
                ));
            }
            let f = ck.need("camera.fov_y", c.fov_y)?;
            if !(f > 0.0 && f < 180.0) {
                return Err(ck.err("camera.fov_y", f, "must be in (0, 180) degrees"));
            }
            Projection::Perspective { fov_y_deg: f }
        }
        "orthographic" => {
            if c.fov_y.is_some() {
                return Err(ck.err(
                    "camera.fov_y",
                    "given",
                    "an orthographic camera takes mm_per_pixel, not fov_y",
                ));
            }
            let m = ck.positive(
                "camera.mm_per_pixel",
                ck.need("camera.mm_per_pixel", c.mm_per_pixel)?,
            )?;
            if m * width.max(height) as f64 > 4.0 * MAX_COORDINATE_MM {
                return Err(ck.err(
                    "camera.mm_per_pixel",
                    m,
                    "the view is wider than the space scenes may use",
                ));
            }
            Projection::Orthographic { mm_per_pixel: m }
        }
        other => {
            return Err(ck.err(
                "camera.type",
                format!("\"{other}\""),
                "expected \"perspective\" or \"orthographic\"",
            ))
        }
    };
    let measure = match c.measure.as_deref() {
        None | Some("radiance") => Measure::Radiance,
        Some("exitance") => Measure::Exitance,
        Some(m) => {
            return Err(ck.err(
                "camera.measure",
                format!("\"{m}\""),
                "expected \"radiance\" or \"exitance\"",
            ))
        }
    };
    Ok(Camera {
        projection,
        position,
        forward,
        right,
        up,
        width,
        height,
        measure,
    })
}

fn parse_light(ck: &Check, i: usize, l: RawLight) -> Result<Light> {
    let p = format!("light[{i}]");
    let kind = ck.need(&format!("{p}.type"), l.kind)?;
    match kind.as_str() {
        "directional" => {
            ck.unused(
                &p,
                "directional light",
                &[("radiance", l.radiance.is_some())],
                &["toward", "irradiance"],
            )?;
            Ok(Light::Directional {
                toward: ck.unit_vector(
                    &format!("{p}.toward"),
                    ck.need(&format!("{p}.toward"), l.toward)?,
                )?,
                irradiance: ck.rgb(
                    &format!("{p}.irradiance"),
                    ck.need(&format!("{p}.irradiance"), l.irradiance)?,
                )?,
            })
        }
        "environment" => {
            ck.unused(
                &p,
                "environment light",
                &[
                    ("toward", l.toward.is_some()),
                    ("irradiance", l.irradiance.is_some()),
                ],
                &["radiance"],
            )?;
            Ok(Light::Environment {
                radiance: ck.rgb(
                    &format!("{p}.radiance"),
                    ck.need(&format!("{p}.radiance"), l.radiance)?,
                )?,
            })
        }
        other => Err(ck.err(
            &format!("{p}.type"),
            format!("\"{other}\""),
            "expected \"directional\" or \"environment\"",
        )),
    }
}

/// A path from the scene file, relative to its folder.
fn resolve(dir: &Path, s: &str) -> std::path::PathBuf {
    let p = Path::new(s);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        dir.join(p)
    }
}

fn parse_object(ck: &Check, i: usize, o: RawObject, unit: Unit, dir: &Path) -> Result<Object> {
    let p = format!("object[{i}]");
    let f = |name: &str| format!("{p}.{name}");
    let spec = ck.need(&f("material"), o.material.clone())?;
    // A preset name, or a file relative to the scene.
    let mut material = if spec.ends_with(".toml") || spec.contains('/') {
        Material::load(&resolve(dir, &spec).display().to_string())
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
    let name = o.name.clone().unwrap_or_else(|| p.clone());
    let shape_name = ck.need(&f("shape"), o.shape.clone())?;
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
    let takes: &[&str] = match shape_name.as_str() {
        "sphere" => &["center", "radius"],
        "box" => &["center", "size"],
        "cylinder" => &["center", "radius", "height", "axis"],
        "heightfield" => &["center", "size", "height", "image", "depth"],
        "mesh" => &["file", "scale", "translate"],
        _ => &[],
    };
    if !takes.is_empty() {
        ck.unused(&p, &shape_name, &given, takes)?;
    }
    let shape = match shape_name.as_str() {
        "sphere" => Shape::Sphere {
            centre: ck.point(&f("center"), ck.need(&f("center"), o.center)?, unit)?,
            radius: ck.length(&f("radius"), ck.need(&f("radius"), o.radius)?, unit)?,
        },
        "box" => {
            let c = ck.point(&f("center"), ck.need(&f("center"), o.center)?, unit)?;
            let size = ck.need(&f("size"), o.size.clone())?;
            if size.len() != 3 {
                return Err(ck.err(&f("size"), format!("{size:?}"), "expected [x, y, z]"));
            }
            let mut half = V3::zeros();
            for k in 0..3 {
                half[k] = 0.5 * ck.length(&format!("{}[{k}]", f("size")), size[k], unit)?;
            }
            Shape::Cuboid {
                min: c - half,
                max: c + half,
            }
        }
        "cylinder" => {
            let axis = ck.unit_vector(&f("axis"), o.axis.unwrap_or([0.0, 1.0, 0.0]))?;
            let (u, v) = frame(axis);
            Shape::Cylinder {
                centre: ck.point(&f("center"), ck.need(&f("center"), o.center)?, unit)?,
                axis,
                u,
                v,
                radius: ck.length(&f("radius"), ck.need(&f("radius"), o.radius)?, unit)?,
                half_height: 0.5
                    * ck.length(&f("height"), ck.need(&f("height"), o.height)?, unit)?,
            }
        }
        "heightfield" => {
            let c = ck.point(&f("center"), ck.need(&f("center"), o.center)?, unit)?;
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
            let depth = ck.length(&f("depth"), ck.need(&f("depth"), o.depth)?, unit)?;
            let image = resolve(dir, &ck.need(&f("image"), o.image.clone())?);
            let heights = super::heightfield::read_heights(&image)?;
            let (positions, tris) =
                super::heightfield::solid(&heights, c, [sx, sz], height, depth, MAX_TRIANGLES)
                    .map_err(|why| ck.err(&f("image"), image.display(), why))?;
            mesh_shape(
                ck,
                &f("image"),
                &image.display().to_string(),
                &positions,
                &tris,
            )?
        }
        "mesh" => {
            let scale = ck.positive(&f("scale"), o.scale.unwrap_or(1.0))? * unit.mm();
            let shift = ck.point(&f("translate"), o.translate.unwrap_or([0.0; 3]), unit)?;
            let path = resolve(dir, &ck.need(&f("file"), o.file.clone())?);
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
            mesh_shape(ck, &f("file"), &path.display().to_string(), &moved, &tris)?
        }
        other => {
            return Err(ck.err(
                &f("shape"),
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

/// Reads an OBJ file's triangles (faces fan-triangulated, all groups
/// merged), refusing more than [`MAX_TRIANGLES`] before allocating them.
fn read_obj(path: &Path) -> Result<(Vec<V3>, Vec<[usize; 3]>)> {
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
