//! The scene tracer against exact answers: a flat slab seen from above
//! reproduces the half-space's total R_d (Chandrasekhar's H-function
//! values, and `simulate`) within 4 standard errors, for an index-matched
//! and a refracting boundary, under a directional light (exitance sensor)
//! and under a uniform environment (radiance, by reciprocity); an
//! albedo-1 slab returns all the light that enters, at oblique incidence
//! through a refracting boundary too; a sphere much larger than the mean
//! free path gives the flat result, at oblique incidence as well (the
//! sphere's entry solve against the box's planar one); a lossless object
//! in a uniform environment is invisible (the furnace test); the image is
//! bit-identical for any thread count.

mod common;

use common::mc::{albedo_09, within, ALBEDO_09};
use ssskit::material::{Channel, Material};
use ssskit::profile::fresnel::fresnel_dielectric;
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::progress::NoProgress;
use ssskit::scene::{parse_scene_toml, render, Render, RenderConfig, SampleBudget, Scene};
use std::path::Path;

/// A scene whose one object is filled with `material` (written beside it).
fn scene(dir: &Path, material: &Material, text: &str) -> Scene {
    let l = &material.layers[0];
    let m = format!(
        "unit = \"mm\"\nsigma_a = {:?}\nsigma_s = {:?}\ng = {:?}\neta = {}\n",
        l.sigma_a, l.sigma_s, l.g, l.eta
    );
    std::fs::write(dir.join("m.toml"), m).unwrap();
    parse_scene_toml(text, "test scene", dir).unwrap()
}

fn run(s: &Scene, spp: u64, seed: u64, threads: Option<usize>) -> Render {
    let cfg = RenderConfig {
        budget: SampleBudget::Fixed(spp),
        seed,
        threads,
        ..RenderConfig::default()
    };
    // The irradiance channels are not under test here.
    render(s, &vec![[1.0; 3]; s.objects.len()], &cfg, &NoProgress).unwrap()
}

/// Mean over every pixel and the three channels (the grey materials'
/// channels are independent estimates of one value) with its standard
/// error; the pixels see equivalent points.
fn mean(r: &Render) -> (f64, f64) {
    let n = (3 * r.width * r.height) as f64;
    let m = r.radiance.iter().flatten().sum::<f64>() / n;
    let var: f64 = r.stderr.iter().flatten().map(|s| s * s).sum::<f64>();
    (m, var.sqrt() / n)
}

/// An orthographic exitance sensor looking down at the origin over a
/// slab's top face (z = 0), lit by `light`.
fn slab(light: &str, measure: &str, eta: f64) -> String {
    format!(
        "unit = \"mm\"\n[camera]\ntype = \"orthographic\"\nposition = [0, 0, 10]\nlook_at = \
         [0, 0, 0]\nup = [0, 1, 0]\nmm_per_pixel = 0.5\nsize = [2, 2]\nmeasure = \"{measure}\"\n\
         {light}\n[[object]]\nshape = \"box\"\ncenter = [0, 0, -50000]\nsize = [200000, 200000, \
         100000]\nmaterial = \"m.toml\"\neta = {eta}\n"
    )
}

fn sun(toward: [f64; 3]) -> String {
    format!(
        "[[light]]\ntype = \"directional\"\ntoward = [{}, {}, {}]\nirradiance = 1",
        toward[0], toward[1], toward[2]
    )
}

const ENVIRONMENT: &str = "[[light]]\ntype = \"environment\"\nradiance = 1";

/// A flat slab lit from above, seen by the exitance sensor: exitance / pi
/// x pi = E R_d, the H-function value, for n = 1 and n = 1.5 (the light
/// refracted through the top face at normal incidence); and simulate's
/// R_d agrees within the two runs' combined error, also for a strongly
/// forward-scattering medium (g = 0.8: the phase function's cosine at the
/// light's next-event estimate has the sign that sends light on).
#[test]
fn flat_slab_gives_the_half_space_total() {
    let dir = tempfile::tempdir().unwrap();
    let forward = |eta: f64| {
        common::mc::material(&format!(
            "unit = \"mm\"\nsigma_a = 0.1\nsigma_s = 4.5\ng = 0.8\neta = {eta}\n"
        ))
    };
    let cases = ALBEDO_09
        .iter()
        .map(|&(eta, rd, _)| (albedo_09(eta), eta, Some(rd)))
        .chain([1.0, 1.5].map(|eta| (forward(eta), eta, None)));
    for (m, eta, exact) in cases {
        let s = scene(
            dir.path(),
            &m,
            &slab(&sun([0.0, 0.0, 1.0]), "exitance", eta),
        );
        let (v, se) = mean(&run(&s, 4000, 7, None));
        let (v, se) = (std::f64::consts::PI * v, std::f64::consts::PI * se);
        eprintln!("eta {eta}: exitance x pi = {v:.5} +- {se:.5}, exact R_d {exact:?}");
        if let Some(rd) = exact {
            within(v, rd, se, &format!("slab R_d, eta {eta}"));
        }
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(100_000),
            seed: 5,
            threads: None,
            channels: vec![Channel::R],
            grid: None,
        };
        let p = simulate(&m, &cfg, &NoProgress).unwrap();
        let (sim, sim_se) = (p.total_rd[0], p.total_rd_stderr.as_ref().unwrap()[0]);
        within(
            v,
            sim,
            (se * se + sim_se * sim_se).sqrt(),
            "slab vs simulate",
        );
    }
}

/// Under a uniform environment of radiance L the radiance leaving a slab
/// along its normal is L (R_sp + R_d): by reciprocity it is the
/// reflectance of light arriving along the normal, specular part
/// included. Exercises the path that escapes rather than the light's
/// next-event estimate.
#[test]
fn slab_under_an_environment_is_reciprocal() {
    let dir = tempfile::tempdir().unwrap();
    for (eta, rd, specular) in ALBEDO_09 {
        let s = scene(
            dir.path(),
            &albedo_09(eta),
            &slab(ENVIRONMENT, "radiance", eta),
        );
        let (v, se) = mean(&run(&s, 4000, 8, None));
        eprintln!("eta {eta}: L = {v:.5} +- {se:.5}, exact {}", specular + rd);
        within(v, specular + rd, se, &format!("slab under sky, eta {eta}"));
    }
}

/// Albedo 1: every bit of light that enters comes back out of a
/// half-space. Lit at 60 degrees through an n = 1.5 boundary, the exitance
/// is E cos(theta) (1 - R(theta)): checks the Fresnel transmittance and
/// the beam's compression cos_i / cos_t of the refracted light.
#[test]
fn lossless_slab_returns_what_enters() {
    let dir = tempfile::tempdir().unwrap();
    let m = common::mc::material("unit = \"mm\"\nsigma_a = 0\nsigma_s = 1\neta = 1.5\n");
    let (s60, c60) = (60f64.to_radians().sin(), 60f64.to_radians().cos());
    for eta in [1.0, 1.5] {
        let s = scene(
            dir.path(),
            &m,
            &slab(&sun([s60, 0.0, c60]), "exitance", eta),
        );
        let (v, se) = mean(&run(&s, 800, 9, None));
        let exact = c60 * (1.0 - fresnel_dielectric(c60, eta)) / std::f64::consts::PI;
        eprintln!("eta {eta}: exitance / pi {v:.5} +- {se:.5}, exact {exact:.5}");
        within(v, exact, se, &format!("albedo 1, eta {eta}"));
    }
}

/// A sphere much larger than the mean free path, seen at its pole, gives
/// the flat slab's exitance: lit along the normal (the H-function value)
/// and at 50 degrees (the box's planar entry as the second method), for
/// n = 1 and n = 1.5; a small sphere differs, so the check resolves
/// curvature.
#[test]
fn large_sphere_approaches_the_flat_result() {
    let dir = tempfile::tempdir().unwrap();
    let (s50, c50) = (50f64.to_radians().sin(), 50f64.to_radians().cos());
    let sphere = |radius: f64, eta: f64, toward: [f64; 3]| {
        format!(
            "unit = \"mm\"\n[camera]\ntype = \"orthographic\"\nposition = [0, 0, {}]\nlook_at = \
             [0, 0, 0]\nup = [0, 1, 0]\nmm_per_pixel = 0.25\nsize = [2, 2]\nmeasure = \
             \"exitance\"\n{}\n[[object]]\nshape = \"sphere\"\ncenter = [0, 0, 0]\nradius = \
             {radius}\nmaterial = \"m.toml\"\neta = {eta}\n",
            radius + 10.0,
            sun(toward)
        )
    };
    for (eta, rd, _) in ALBEDO_09 {
        let m = albedo_09(eta);
        let big = scene(dir.path(), &m, &sphere(2000.0, eta, [0.0, 0.0, 1.0]));
        let (v, se) = mean(&run(&big, 4000, 10, None));
        let (v, se) = (std::f64::consts::PI * v, std::f64::consts::PI * se);
        eprintln!("eta {eta}: large sphere {v:.5} +- {se:.5}, flat {rd}");
        within(v, rd, se, &format!("large sphere, eta {eta}"));
        let small = scene(dir.path(), &m, &sphere(1.5, eta, [0.0, 0.0, 1.0]));
        let (w, we) = mean(&run(&small, 4000, 10, None));
        let w = std::f64::consts::PI * w;
        eprintln!("eta {eta}: small sphere {w:.5}");
        assert!(
            (w - rd).abs() > 8.0 * std::f64::consts::PI * we,
            "a 1.5 mm sphere should not look flat"
        );
        // Oblique: the sphere's entry solve and the box's planar entry.
        let tilted = [s50, 0.0, c50];
        let big = scene(dir.path(), &m, &sphere(2000.0, eta, tilted));
        let flat = scene(dir.path(), &m, &slab(&sun(tilted), "exitance", eta));
        let (a, ae) = mean(&run(&big, 4000, 11, None));
        let (b, be) = mean(&run(&flat, 4000, 12, None));
        eprintln!("eta {eta}, 50 deg: sphere {a:.5} +- {ae:.5}, slab {b:.5} +- {be:.5}");
        within(a, b, (ae * ae + be * be).sqrt(), "oblique sphere vs slab");
    }
}

/// The white furnace: a lossless sphere (albedo 1) in a uniform
/// environment is invisible whatever its boundary, so every pixel's mean
/// is the environment's radiance.
#[test]
fn lossless_sphere_in_a_furnace_is_invisible() {
    let dir = tempfile::tempdir().unwrap();
    let m = common::mc::material("unit = \"mm\"\nsigma_a = 0\nsigma_s = 2\ng = 0.5\neta = 1.3\n");
    let text = format!(
        "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 20]\nlook_at = [0, \
         0, 0]\nup = [0, 1, 0]\nfov_y = 20\nsize = [6, 6]\n{ENVIRONMENT}\n[[object]]\nshape = \
         \"sphere\"\ncenter = [0, 0, 0]\nradius = 3\nmaterial = \"m.toml\"\n"
    );
    let s = scene(dir.path(), &m, &text);
    let r = run(&s, 300, 13, None);
    let (v, se) = mean(&r);
    eprintln!("furnace: {v:.6} +- {se:.6}");
    // A path keeps weight 1 until it leaves (albedo 1, all-or-none
    // boundaries) unless a roulette plays: most pixels are exactly 1.
    // Such a pixel has a standard error of 0 and a mean of 1 up to the
    // rounding of its sum of weights (a few hundred terms of 1.1e-16).
    const ROUNDING: f64 = 1e-12;
    assert!(
        (v - 1.0).abs() <= common::SIGMAS * se + ROUNDING,
        "furnace: {v} +- {se}"
    );
    for c in 0..3 {
        for (i, (&x, &e)) in r.radiance[c].iter().zip(&r.stderr[c]).enumerate() {
            assert!(
                (x - 1.0).abs() <= common::SIGMAS * e + ROUNDING,
                "pixel {i}: {x} +- {e}"
            );
        }
    }
}

/// Same seed, same image, whatever the thread count; another seed, another
/// image.
#[test]
fn renders_are_reproducible_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let m = albedo_09(1.3);
    let text = format!(
        "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 30]\nlook_at = [0, \
         0, 0]\nup = [0, 1, 0]\nfov_y = 30\nsize = [20, 13]\n{ENVIRONMENT}\n{}\n[[object]]\n\
         shape = \"sphere\"\ncenter = [0, 0, 0]\nradius = 5\nmaterial = \"m.toml\"\n",
        sun([0.6, 0.0, 0.8])
    );
    let s = scene(dir.path(), &m, &text);
    let a = run(&s, 12, 3, Some(1));
    let b = run(&s, 12, 3, Some(3));
    assert_eq!(a.radiance, b.radiance);
    assert_eq!(a.stderr, b.stderr);
    assert_eq!(a.gbuffer, b.gbuffer);
    let c = run(&s, 12, 4, Some(2));
    assert_ne!(a.radiance, c.radiance);
    // A target-error run stops after the same rounds for any thread count.
    let target = |threads| {
        let cfg = RenderConfig {
            budget: SampleBudget::TargetError {
                rel: 0.2,
                max_spp: 4096,
            },
            seed: 3,
            threads: Some(threads),
            ..RenderConfig::default()
        };
        render(&s, &[[0.5; 3]], &cfg, &NoProgress).unwrap()
    };
    let (x, y) = (target(1), target(4));
    assert_eq!(x.radiance, y.radiance);
    assert_eq!(x.info.spp, y.info.spp);
    assert!(x.info.converged && x.info.noise.iter().all(|&e| e <= 0.2));
}
