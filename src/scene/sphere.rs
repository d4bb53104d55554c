//! The lit sphere of docs/scenes/sphere.toml built in code for any
//! half-space material and any image size: the scene of a material's
//! preview (`kernels` shows it path-traced beside the screen-space pass of
//! what it ships).

use super::camera::{Camera, Measure, Projection};
use super::file::beam_traceable;
use super::geometry::Shape;
use super::{Light, Object, Scene, Unit, V3};
use crate::error::{Error, Result};
use crate::material::Material;

/// The sphere's radius, mm (docs/scenes/sphere.toml).
pub const SPHERE_RADIUS_MM: f64 = 15.0;
/// The camera's distance from the sphere's centre, mm, looking at it.
pub const CAMERA_DISTANCE_MM: f64 = 150.0;
/// The camera's vertical field of view, degrees: the sphere fills 0.8 of
/// the image's height.
pub const FOV_Y_DEG: f64 = 14.0;
/// Degrees between the view and the directional light, which lies in the
/// image's horizontal plane (lit from the right).
pub const LIGHT_FROM_VIEW_DEG: f64 = 60.0;

/// The scene of docs/scenes/sphere.toml with a `side` x `side` image and
/// the sphere filled with `material` at its own index: one directional
/// light of unit irradiance, nothing else. Refused where the tracer cannot
/// render it: a layered material (an object holds one homogeneous medium)
/// or an index whose refracted beam the tracer does not follow into a
/// sphere.
pub fn lit_sphere(material: &Material, side: usize) -> Result<Scene> {
    let origin = format!(
        "the lit sphere of {} (docs/scenes/sphere.toml, {side}x{side} px)",
        material.name
    );
    material.validate(&origin)?;
    crate::limits::check_image_size(&origin, side, side)?;
    if !material.is_half_space() {
        return Err(Error::Unsupported(format!(
            "{origin}: an object is filled with one homogeneous medium, and {} has {} layers",
            material.name,
            material.layers.len()
        )));
    }
    let shape = Shape::Sphere {
        centre: V3::zeros(),
        radius: SPHERE_RADIUS_MM,
    };
    let object = Object {
        name: material.name.clone(),
        shape,
        material: material.clone(),
    };
    if !beam_traceable(&object.shape, object.eta()) {
        return Err(Error::Unsupported(format!(
            "{origin}: the tracer follows a directional light into a sphere of index 1 or in \
             (1, 2], and {} has {}",
            material.name,
            object.eta()
        )));
    }
    let position = V3::new(0.0, 0.0, CAMERA_DISTANCE_MM);
    let (forward, right, up) = Camera::frame(position, V3::zeros(), V3::y())
        .ok_or_else(|| Error::Unsupported(format!("{origin}: no camera frame")))?;
    let a = LIGHT_FROM_VIEW_DEG.to_radians();
    Ok(Scene {
        unit: Unit::Mm,
        camera: Camera {
            projection: Projection::Perspective {
                fov_y_deg: FOV_Y_DEG,
            },
            position,
            forward,
            right,
            up,
            width: side,
            height: side,
            measure: Measure::Radiance,
        },
        lights: vec![Light::Directional {
            toward: V3::new(a.sin(), 0.0, a.cos()),
            irradiance: [1.0; 3],
        }],
        objects: vec![object],
        origin,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene is docs/scenes/sphere.toml's, read by the scene parser,
    /// at another image size: camera, light and sphere agree to round-off.
    #[test]
    fn the_sphere_is_the_one_of_the_docs() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scenes");
        let text = std::fs::read_to_string(dir.join("sphere.toml"))
            .unwrap()
            .replace("size = [192, 192]", "size = [40, 40]");
        let file = crate::scene::parse_scene_toml(&text, "sphere.toml", &dir).unwrap();
        let skin = crate::material::preset("skin1").unwrap();
        let built = lit_sphere(&skin, 40).unwrap();
        assert_eq!(built.camera.projection, file.camera.projection);
        assert_eq!((built.camera.width, built.camera.height), (40, 40));
        for (a, b) in [
            (built.camera.position, file.camera.position),
            (built.camera.forward, file.camera.forward),
            (built.camera.up, file.camera.up),
        ] {
            assert!((a - b).norm() < 1e-12, "{a:?} vs {b:?}");
        }
        let (Light::Directional { toward: t0, .. }, Light::Directional { toward: t1, .. }) =
            (&built.lights[0], &file.lights[0])
        else {
            panic!("not directional")
        };
        // The file rounds cos 30 degrees to 7 digits.
        assert!((t0 - t1).norm() < 1e-7, "{t0:?} vs {t1:?}");
        assert_eq!(built.lights.len(), file.lights.len());
        assert_eq!(built.objects[0].material, file.objects[0].material);
        assert_eq!(
            built.objects[0].shape.bounds(),
            file.objects[0].shape.bounds()
        );
        let mut layered = skin.clone();
        layered.layers.push(layered.layers[0].clone());
        layered.layers[0].thickness = Some(1.0);
        assert!(lit_sphere(&layered, 40).is_err());
        let mut dense = skin;
        dense.layers[0].eta = 2.5;
        let e = lit_sphere(&dense, 40).unwrap_err().to_string();
        assert!(e.contains("2.5"), "{e}");
    }
}
