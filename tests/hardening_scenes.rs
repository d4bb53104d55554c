//! Scenes that break their own rule (objects must not intersect,
//! docs/scene.md) are refused by the real binary before any work, with
//! both objects named; objects that only touch are rendered.

mod common;

use common::{assert_fails, assert_ok, run_in};
use std::path::Path;

const HEAD: &str = "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 60]\n\
look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 30\nsize = [8, 6]\n[[light]]\ntype = \
\"environment\"\nradiance = 1\n";

fn sphere(x: f64, r: f64, name: Option<&str>) -> String {
    let name = name.map_or(String::new(), |n| format!("name = \"{n}\"\n"));
    format!(
        "[[object]]\n{name}shape = \"sphere\"\ncenter = [{x}, 0, 0]\nradius = {r}\nmaterial = \
         \"skin1\"\n"
    )
}

fn mesh(file: &str) -> String {
    format!("[[object]]\nshape = \"mesh\"\nfile = \"{file}\"\nmaterial = \"skin1\"\n")
}

/// A closed OBJ cube of half-side `h` about the origin.
fn write_cube(path: &Path, h: f64) {
    std::fs::write(path, common::backlit_meshes::cube_obj(h)).unwrap();
}

fn render(d: &Path, objects: &str) -> std::process::Output {
    std::fs::write(d.join("s.toml"), format!("{HEAD}{objects}")).unwrap();
    run_in(
        d,
        &common::scene_args(&["--spp", "2", "--profile-photons", "1000"]),
    )
}

#[test]
fn intersecting_objects_are_refused_with_both_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_cube(&d.join("big.obj"), 8.0);
    write_cube(&d.join("small.obj"), 2.0);
    let coincident: String = (0..256).map(|_| sphere(0.0, 5.0, None)).collect();
    let cases = [
        (
            sphere(0.0, 5.0, Some("left")) + &sphere(8.0, 5.0, Some("right")),
            ["object[1] ('right')", "intersects object[0] ('left')"],
        ),
        (coincident, ["object[1]", "intersects object[0]"]),
        (
            mesh("big.obj") + &sphere(0.0, 3.0, None),
            ["object[1]", "intersects object[0]"],
        ),
        (
            mesh("big.obj") + &mesh("small.obj"),
            ["object[1]", "intersects object[0]"],
        ),
    ];
    for (objects, needles) in cases {
        let o = render(d, &objects);
        assert_fails(&o, &["scene"], &needles);
        assert!(!d.join("s.exr").exists());
    }
}

#[test]
fn objects_that_touch_render() {
    let dir = tempfile::tempdir().unwrap();
    let o = render(
        dir.path(),
        &(sphere(-5.0, 5.0, None) + &sphere(5.0, 5.0, None)),
    );
    assert_ok(&o, &["scene"]);
}
