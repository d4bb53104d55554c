//! Point lights in scenes (`type = "point"`): a point light far away is a
//! directional light (irradiance = intensity / distance^2), so a render
//! under one equals, pixel by pixel, the render under the other for the
//! same seed (the next-event estimate draws no random numbers, so both
//! trace the same paths): the path tracer's contribution of the light
//! (its 1 / d^2, the transmittance along the segment, the phase function)
//! and the G-buffer's irradiance. And what the scene file refuses: a light
//! inside an object, a point light with a refracting object.

mod common;

use common::scenes;
use ssskit::scene::{parse_scene_toml, render, RenderConfig, SampleBudget, Scene};
use std::path::Path;

/// Distance of the far point light, mm: the light's rays across the 15 mm
/// sphere differ from parallel by 15 / 1e6 and its irradiance by twice
/// that, so the two renders agree to [`FAR_AGREEMENT`].
const FAR: f64 = 1e6;
/// Relative agreement of the far point light with the directional one:
/// a few times the geometric difference 2 x 15 / [`FAR`] = 3e-5.
const FAR_AGREEMENT: f64 = 2e-4;
/// Agreement of the G-buffer's irradiance with the geometry recomputed
/// here: the G-buffer lights a point lifted 1e-9 of the scene's reach off
/// the surface and evaluates at 1e6 mm in f64, a few 1e-6 relative.
const NEAR_AGREEMENT: f64 = 1e-5;
/// With a second object in the way of light scattered in it, a far point
/// light's shadow edge lies 15 x 15 / [`FAR`] mm from the directional
/// light's: the few events whose shadow rays graze the sphere between the
/// two edges flip, each a share of one sample of one pixel; over the image
/// they stay below this share of its light.
const FAR_IMAGE_AGREEMENT: f64 = 1e-3;

fn scene(light: &str) -> Result<Scene, String> {
    scene_with(light, true)
}

/// The sphere, and with `slab` an index-matched slab below it in its
/// shadow.
fn scene_with(light: &str, slab: bool) -> Result<Scene, String> {
    let mut objects = scenes::object(&scenes::sphere_at_origin(15.0), "skin1", 1.0);
    if slab {
        let slab = "shape = \"box\"\ncenter = [0, 0, -40]\nsize = [60, 60, 4]";
        objects += &scenes::object(slab, "skin1", 1.0);
    }
    let text = scenes::toml(&scenes::perspective_150(12, 12), light, &objects);
    parse_scene_toml(&text, "point", Path::new(".")).map_err(|e| e.to_string())
}

/// The renders under a directional light and under a point light in its
/// direction [`FAR`] away (intensity = FAR^2): the sphere alone pixel by
/// pixel, with the slab in its shadow over the image.
#[test]
fn a_far_point_light_is_a_directional_light() {
    let d = ssskit::scene::V3::new(0.6, 0.0, 0.8);
    let far = d * FAR;
    let directional = format!(
        "type = \"directional\"\ntoward = [{}, {}, {}]\nirradiance = 1",
        d.x, d.y, d.z
    );
    let point = format!(
        "type = \"point\"\nposition = [{}, {}, {}]\nintensity = {}",
        far.x,
        far.y,
        far.z,
        FAR * FAR
    );
    let cfg = RenderConfig {
        budget: SampleBudget::Fixed(8),
        seed: 5,
        threads: None,
        gbuffer_side: 2,
        max_work: 1_000_000_000,
    };
    let p = ssskit::progress::NoProgress;
    for slab in [false, true] {
        let rd = vec![[0.4, 0.2, 0.1]; 1 + slab as usize];
        let a = render(&scene_with(&directional, slab).unwrap(), &rd, &cfg, &p).unwrap();
        let b = render(&scene_with(&point, slab).unwrap(), &rd, &cfg, &p).unwrap();
        let mut lit = 0;
        for c in 0..3 {
            let peak = a.radiance[c].iter().cloned().fold(0.0, f64::max);
            assert!(peak > 0.0);
            if slab {
                let (sa, sb) = (
                    a.radiance[c].iter().sum::<f64>(),
                    b.radiance[c].iter().sum::<f64>(),
                );
                assert!(
                    (sa - sb).abs() <= FAR_IMAGE_AGREEMENT * sa,
                    "{c}: {sa} {sb}"
                );
            } else {
                for (x, y) in a.radiance[c].iter().zip(&b.radiance[c]) {
                    assert!((x - y).abs() <= FAR_AGREEMENT * peak, "{c}: {x} {y}");
                }
            }
            let g_peak = a.gbuffer.irradiance[c].iter().cloned().fold(0.0, f64::max);
            for (x, y) in a.gbuffer.irradiance[c].iter().zip(&b.gbuffer.irradiance[c]) {
                assert!((x - y).abs() <= FAR_AGREEMENT * g_peak, "{x} {y}");
                lit += (*x > 0.0) as usize;
            }
        }
        assert!(lit > 100, "{lit}");
    }
}

/// Moved close, the light's 1 / d^2 and its direction show: the G-buffer's
/// irradiance at a pixel is intensity cos / d^2 at the point its centre
/// ray meets, recomputed here from the geometry, for a light 45 mm from
/// the centre against the far one (their ratio: the albedo and 1 / pi
/// cancel).
#[test]
fn a_near_point_light_falls_off_with_distance() {
    let at = |z: f64| ssskit::scene::V3::new(0.0, 0.0, z);
    let lit = |z: f64| {
        let s = scene(&format!(
            "type = \"point\"\nposition = [0, 0, {z}]\nintensity = {}",
            z * z
        ))
        .unwrap();
        let cfg = RenderConfig {
            budget: SampleBudget::Fixed(2),
            seed: 1,
            threads: None,
            gbuffer_side: 1,
            max_work: 1_000_000_000,
        };
        let r = render(&s, &[[0.4; 3]; 2], &cfg, &ssskit::progress::NoProgress).unwrap();
        (r.gbuffer.irradiance[0][5 * 12 + 6], s)
    };
    let ((near, s), (far, _)) = (lit(45.0), lit(FAR));
    let ray = s.camera.ray(6.5, 5.5);
    let (_, hit) = s.nearest(&ray, f64::INFINITY).unwrap();
    let p = ray.at(hit.t);
    let e = |z: f64| {
        let to = at(z) - p;
        z * z * hit.n.dot(&to) / to.norm().powi(3)
    };
    let want = e(45.0) / e(FAR);
    assert!(want > 2.0, "{want}");
    assert!(
        (near / far - want).abs() < NEAR_AGREEMENT * want,
        "{near} {far} {want}"
    );
}

#[test]
fn bad_point_lights_are_refused_with_the_reason() {
    let inside = scene("type = \"point\"\nposition = [0, 0, 5]\nintensity = 1").unwrap_err();
    assert!(
        inside.contains("light[0].position") && inside.contains("inside object[0]"),
        "{inside}"
    );
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/docs/scenes/sphere.toml"
    ))
    .unwrap()
    .replace(
        "type = \"directional\"\ntoward = [0.8660254, 0, 0.5]  # unit vector towards the light\nirradiance = 1",
        "type = \"point\"\nposition = [0, 0, 100]\nintensity = 1",
    );
    let e = parse_scene_toml(&text, "sphere", Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("object[0].eta") && e.contains("index-matched"),
        "{e}"
    );
    let e = scene("type = \"point\"\nposition = [0, 0, 100]\ntoward = [0, 0, 1]\nintensity = 1")
        .unwrap_err();
    assert!(e.contains("has no toward"), "{e}");
    let e = scene("type = \"point\"\nintensity = 1").unwrap_err();
    assert!(e.contains("light[0].position"), "{e}");
}
