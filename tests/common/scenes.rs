//! Scene files the tests write: one builder for the TOML every small
//! scene starts with (millimetres, a camera, one light), the tables the
//! tests put in it, and the small sphere of docs/scene.md.

use std::path::Path;

/// The TOML of a scene in millimetres: `camera` (the lines of its
/// `[camera]` table), one `[[light]]` (its lines), then `objects` (whole
/// `[[object]]` tables, as [`object`] writes them).
pub fn toml(camera: &str, light: &str, objects: &str) -> String {
    format!("unit = \"mm\"\n[camera]\n{camera}\n[[light]]\n{light}\n{objects}")
}

/// The `[camera]` lines of the perspective camera of the light-space and
/// point-light tests: 150 mm up the z axis, looking at the origin with y
/// up, 14 degrees high, `width` x `height` pixels.
pub fn perspective_150(width: usize, height: usize) -> String {
    format!(
        "type = \"perspective\"\nposition = [0, 0, 150]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\n\
         fov_y = 14\nsize = [{width}, {height}]"
    )
}

/// An `[[object]]` table: `shape` (its lines: the shape and its size),
/// then the material and eta (always written as a float: `1.0`, not `1`).
pub fn object(shape: &str, material: &str, eta: f64) -> String {
    format!("[[object]]\n{shape}\nmaterial = \"{material}\"\neta = {eta:?}\n")
}

/// The shape lines of a sphere of `radius` mm at the origin.
pub fn sphere_at_origin(radius: f64) -> String {
    format!("shape = \"sphere\"\ncenter = [0, 0, 0]\nradius = {radius}")
}

/// The scene of docs/scene.md (docs/scenes/sphere-eta1.toml: skin1,
/// eta = 1, light 60 degrees from the view) at 48 x 48 pixels instead of
/// 192 x 192, for renders of seconds.
pub fn small_sphere_eta1() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scenes/sphere-eta1.toml");
    let text = std::fs::read_to_string(path).unwrap();
    text.replace("size = [192, 192]", "size = [48, 48]")
}
