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
//! [[light]]
//! type = "point"                  # outside every object; index-matched objects only
//! position = [0, 40, 0]
//! intensity = 1600                # or [r, g, b]: irradiance x distance^2 (scene units)
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

mod camera;
mod check;
mod light;
mod obj;
mod object;
mod overlap;

use super::beam::SPHERE_MAX_ETA;
use super::{Light, Object, Scene, Shape, Unit};
use crate::error::{Error, Result};
use crate::material::describe_toml_error;
use camera::{parse_camera, RawCamera};
use check::Check;
use light::{parse_light, RawLight};
use object::{parse_object, RawObject};
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
    let unit = parse_unit(&ck, raw.unit.as_deref())?;
    let camera = parse_camera(&ck, ck.need("camera", raw.camera)?, unit)?;
    ck.count(
        "light",
        raw.light.len(),
        MAX_LIGHTS,
        "give at least one [[light]] (directional, environment or point)",
    )?;
    let lights = raw
        .light
        .into_iter()
        .enumerate()
        .map(|(i, l)| parse_light(&ck, i, l, unit))
        .collect::<Result<Vec<_>>>()?;
    ck.count(
        "object",
        raw.object.len(),
        MAX_OBJECTS,
        "give at least one [[object]]",
    )?;
    let objects = raw
        .object
        .into_iter()
        .enumerate()
        .map(|(i, o)| parse_object(&ck, i, o, unit, dir))
        .collect::<Result<Vec<_>>>()?;
    overlap::check_disjoint(&ck, &objects)?;
    if lights
        .iter()
        .any(|l| matches!(l, Light::Directional { .. }))
    {
        check_beams_traceable(&ck, &objects)?;
    }
    check_point_lights(&ck, &lights, &objects, unit)?;
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

/// The file's length unit.
fn parse_unit(ck: &Check, unit: Option<&str>) -> Result<Unit> {
    match unit {
        Some("mm") => Ok(Unit::Mm),
        Some("cm") => Ok(Unit::Cm),
        Some("m") => Ok(Unit::M),
        Some(u) => Err(ck.err(
            "unit",
            format!("\"{u}\""),
            "expected \"mm\", \"cm\" or \"m\"",
        )),
        None => Err(ck.err(
            "unit",
            "missing",
            "state the scene's length unit: unit = \"mm\", \"cm\" or \"m\"",
        )),
    }
}

/// Point lights: outside every object, and only with index-matched
/// objects. The tracer reaches a point light from a scattering event along
/// the straight line to it, which a refracting boundary would bend (a
/// caustic path, as for the directional light, that the tracer solves for
/// only under a directional light); and a light inside an object would
/// need an omnidirectional light map for the light-space method (Dal Corso
/// et al. 2017, section 3.3), which ssskit does not build.
fn check_point_lights(ck: &Check, lights: &[Light], objects: &[Object], unit: Unit) -> Result<()> {
    for (i, l) in lights.iter().enumerate() {
        let Light::Point { position, .. } = l else {
            continue;
        };
        if let Some((k, o)) = objects
            .iter()
            .enumerate()
            .find(|(_, o)| o.shape.contains(*position))
        {
            return Err(ck.err(
                &format!("light[{i}].position"),
                format!("{:?}", (position / unit.mm()).as_slice()),
                format!(
                    "the light is inside object[{k}] ({}): a point light must be outside every \
                     object (the tracer and the light-space method light a surface from \
                     outside)",
                    o.name
                ),
            ));
        }
        if let Some((k, o)) = objects.iter().enumerate().find(|(_, o)| o.eta() != 1.0) {
            return Err(ck.err(
                &format!("object[{k}].eta"),
                o.eta(),
                "a point light reaches the inside of an object only through an index-matched \
                 boundary (the tracer does not solve for the rays a refracting one bends): \
                 set eta = 1, or use a directional light",
            ));
        }
    }
    Ok(())
}

/// A delta light seen through a smooth boundary that refracts is a
/// caustic path a backward tracer cannot sample (Veach 1997, section
/// 8.3.3): the tracer solves for the beam's entry point instead, on a
/// sphere (1 < eta <= SPHERE_MAX_ETA) and on a box's faces; elsewhere
/// refuse rather than render it black.
fn check_beams_traceable(ck: &Check, objects: &[Object]) -> Result<()> {
    for (i, o) in objects.iter().enumerate() {
        let eta = o.eta();
        if !beam_traceable(&o.shape, eta) {
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
    Ok(())
}

/// Whether the tracer follows a directional light's beam into `shape` of
/// index `eta` (see [`check_beams_traceable`]).
pub(super) fn beam_traceable(shape: &Shape, eta: f64) -> bool {
    eta == 1.0
        || match shape {
            Shape::Cuboid { .. } => true,
            Shape::Sphere { .. } => eta > 1.0 && eta <= SPHERE_MAX_ETA,
            _ => false,
        }
}
