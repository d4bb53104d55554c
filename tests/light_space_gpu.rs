//! The wgpu light-space pass (shaders/light_space.wgsl) against its f64
//! twin (`filter::light_space::light_space_cpu`) for the same samples:
//! the lit sphere of docs/scenes/sphere.toml at a small size (a
//! directional light, eta = 1.3) and an index-matched sphere under a point
//! light, radiance and the exitance sensor. Every pixel agrees within
//! `light_space_f32_tolerance` of the peak but the few where a sample's
//! texel differs between f32 and f64 (`light_space_texel_flips`). Runs
//! on lavapipe in CI; never skipped.

mod common;

use common::scenes;
use ssskit::filter::light_space::{light_space_cpu, LightSpaceInput, LightSpaceSetup};
use ssskit::filter::light_space_gpu::{
    light_space_f32_tolerance, light_space_texel_flips, LightSpaceGpu,
};
use ssskit::filter::Image;

/// Light-map side, samples per pixel and channel, positions per pixel side.
const MAP_SIDE: usize = 256;
const SAMPLES: usize = 24;
const SIDE: usize = 2;

/// The skin1 sphere of radius 15 mm under `light`, 40 x 32 pixels.
fn scene(light: &str, eta: f64, measure: &str) -> ssskit::scene::Scene {
    let camera = format!(
        "{}\nmeasure = \"{measure}\"",
        scenes::perspective_150(40, 32)
    );
    let sphere = scenes::object(&scenes::sphere_at_origin(15.0), "skin1", eta);
    let text = scenes::toml(&camera, light, &sphere);
    ssskit::scene::parse_scene_toml(&text, "gpu", std::path::Path::new(".")).unwrap()
}

/// (largest |gpu - cpu| / peak over the pixels within the tolerance,
/// share of pixels beyond it), over the channels.
fn compare(gpu: &Image, cpu: &Image, tol: f64) -> (f64, f64) {
    let peak = cpu.peak();
    let (mut worst, mut beyond, mut all) = (0.0f64, 0usize, 0usize);
    for (c, peak) in peak.iter().enumerate() {
        assert!(*peak > 0.0, "channel {c} is black");
        for (a, b) in gpu.rgb[c].iter().zip(&cpu.rgb[c]) {
            let e = (a - b).abs() / peak;
            all += 1;
            if e > tol {
                beyond += 1;
            } else {
                worst = worst.max(e);
            }
        }
    }
    (worst, beyond as f64 / all as f64)
}

fn agree(g: &LightSpaceGpu, s: &ssskit::scene::Scene, what: &str) {
    let input = LightSpaceInput::new(s, MAP_SIDE, SIDE, SAMPLES).unwrap();
    let setup = LightSpaceSetup {
        samples: SAMPLES,
        seed: 0x1234_5678_9abc,
    };
    let cpu = light_space_cpu(&input, &setup).unwrap();
    let gpu = g.apply(&input, &setup).unwrap();
    let tol = light_space_f32_tolerance(SAMPLES);
    let (worst, beyond) = compare(&gpu, &cpu, tol);
    let flips = light_space_texel_flips(MAP_SIDE, SAMPLES);
    eprintln!(
        "{what}: |gpu - cpu| / peak at most {worst:.3e} (tolerance {tol:.3e}); {:.3}% of the \
         pixels beyond it (allowed {:.3}%)",
        100.0 * beyond,
        100.0 * flips
    );
    assert!(
        beyond <= flips,
        "{what}: {beyond} of the pixels beyond {tol:e}"
    );
}

#[test]
fn the_gpu_pass_equals_the_cpu_reference_for_the_same_samples() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let g = LightSpaceGpu::new()
        .unwrap_or_else(|e| panic!("GPU test needs an adapter (lavapipe in CI): {e}"));
    let directional = "type = \"directional\"\ntoward = [0.8660254, 0, 0.5]\nirradiance = 1";
    agree(
        &g,
        &scene(directional, 1.3, "radiance"),
        "directional, eta 1.3",
    );
    agree(
        &g,
        &scene(directional, 1.3, "exitance"),
        "directional, exitance",
    );
    let point = "type = \"point\"\nposition = [30, 20, 40]\nintensity = 2500";
    agree(&g, &scene(point, 1.0, "radiance"), "point light, eta 1");
}
