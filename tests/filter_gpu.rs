//! The wgpu post-process against the f64 CPU twin of the same algorithm.
//! Runs on lavapipe in CI; fails (never skips) when no adapter is found.
//! Tolerance: 1e-4 of the CPU image's peak per channel (f32 arithmetic and
//! f32 tap offsets against f64).

mod filter_support;
use filter_support::*;
use ssskit::filter::{cpu, gpu, screen_space, taps_for, Image, Plane, Scale, Setup, Which};
use std::path::{Path, PathBuf};
use std::sync::Once;

/// Sets the lavapipe variables once, before any test reads the environment.
fn gpu_env() {
    static ENV: Once = Once::new();
    ENV.call_once(ssskit::gpu::use_software_vulkan_if_unset);
}

fn open_gpu() -> gpu::Gpu {
    gpu_env();
    match gpu::Gpu::new() {
        Ok(g) => g,
        Err(e) => panic!("GPU test needs an adapter (lavapipe in CI): {e}"),
    }
}

fn scene(w: usize, h: usize) -> Image {
    let mut img = noise_image(w, h, 7, 0.0);
    let shapes =
        ssskit::filter::signals::generate(ssskit::filter::signals::Signal::Shapes, w, h, 1)
            .unwrap();
    for c in 0..3 {
        for (v, s) in img.rgb[c].iter_mut().zip(&shapes.rgb[c]) {
            *v = 0.3 * *v + 2.0 * s;
        }
    }
    img
}

/// A foreground disc (depth about 1, slightly tilted) over a far background
/// (depth 3): discontinuities all round the disc.
fn depth_with_discontinuities(w: usize, h: usize) -> Plane {
    let mut data = vec![3.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 - 0.45 * w as f64, y as f64 - 0.5 * h as f64);
            if dx * dx + dy * dy < (0.3 * h as f64).powi(2) {
                data[y * w + x] = 1.0 + 0.002 * x as f64;
            }
        }
    }
    Plane {
        width: w,
        height: h,
        data,
    }
}

fn check(g: &gpu::Gpu, image: &Image, setup: &Setup, what: &str) {
    let c = screen_space::apply_screen_space(image, setup);
    let mut c = c;
    if let Some(s) = &setup.specular {
        for ch in 0..3 {
            c.rgb[ch]
                .iter_mut()
                .zip(&s.rgb[ch])
                .for_each(|(o, v)| *o += v);
        }
    }
    let fast = cpu::apply(image, setup).unwrap();
    let gp = g.apply(image, setup).unwrap();
    let e = max_rel(&c, &gp);
    eprintln!("{what}: GPU vs CPU max relative difference {e:.2e}");
    assert!(
        e < GPU_REL,
        "{what}: GPU vs CPU max relative difference {e:e}"
    );
    assert!(
        max_rel(&c, &fast) < F64_REL,
        "{what}: the CPU paths disagree"
    );
    assert!(
        max_rel(image, &gp) > FILTERED,
        "{what}: nothing was filtered"
    );
}

/// GPU against CPU for 1D tables of `taps` taps, rank 1 and 3, at
/// `mm` per pixel and in perspective with depth-aware lerp.
fn flat_and_depth_aware(taps: &[usize], mm: f64, jitter: bool) {
    let g = open_gpu();
    let (w, h) = (40, 32);
    let image = scene(w, h);
    let depth = depth_with_discontinuities(w, h);
    let what = if jitter { "jitter, " } else { "" };
    for &n in taps {
        for rank in [1, 3] {
            let k = gaussian_kernel(rank, n);
            let flat = Setup {
                jitter,
                ..plain_setup(taps_for(&k, Which::stored(&k), None).unwrap(), mm)
            };
            check(
                &g,
                &image,
                &flat,
                &format!("{what}flat, {n} taps, rank {rank}"),
            );
            let deep = Setup {
                scale: Scale::Perspective {
                    fov_y_deg: 40.0,
                    sss_width: 0.1,
                },
                depth: Some(depth.clone()),
                follow_surface: Some(ssskit::filter::FollowSurface::InSceneUnits(300.0)),
                ..flat.clone()
            };
            check(
                &g,
                &image,
                &deep,
                &format!("{what}depth + follow-surface, {n} taps, rank {rank}"),
            );
        }
    }
}

#[test]
fn gpu_equals_cpu_for_flat_and_depth_aware_inputs() {
    flat_and_depth_aware(&[11, 17, 25], 0.25, false);
}

/// Jitter draws the same bits on both sides (fixed-point interleaved
/// gradient noise), so the GPU stays within the f32 tolerance of the CPU
/// twin, at rank 1 and rank 3, flat and depth-aware.
#[test]
fn gpu_equals_cpu_with_jittered_taps() {
    flat_and_depth_aware(&[9, 17], 0.1, true);
}

#[test]
fn gpu_equals_cpu_with_strength_specular_and_full_factors() {
    let g = open_gpu();
    let (w, h) = (36, 28);
    let image = scene(w, h);
    let k = gaussian_kernel(3, 17);
    let strength = Plane::from_index(w, h, |i| (i % w) as f64 / w as f64 * 1.5);
    let setup = Setup {
        depth: Some(depth_with_discontinuities(w, h)),
        strength: Some(strength),
        follow_surface: Some(ssskit::filter::FollowSurface::InSceneUnits(2.0)),
        specular: Some(noise_image(w, h, 99, 0.0)),
        ..plain_setup(taps_for(&k, Which::Full, None).unwrap(), 0.2)
    };
    check(&g, &image, &setup, "strength + specular + full factors");
}

#[test]
fn far_background_does_not_bleed_into_the_foreground_on_the_gpu() {
    let g = open_gpu();
    assert_no_background_bleed(|img, setup| g.apply(img, setup).unwrap(), 1, 17);
}

/// Runs `ssskit apply` on a dirac with an 11-tap Gaussian kernel and the
/// given backend flags; returns the process output and the output image path.
fn apply_dirac(dir: &Path, backend: &[&str]) -> (std::process::Output, PathBuf) {
    let k = dir.join("k.json");
    gaussian_kernel(1, 11).write(&k).unwrap();
    let input = dir.join("in.exr");
    let out = dir.join("out.exr");
    let o = run(&[
        "signal",
        "dirac",
        "--image-size",
        "21x17",
        "--out",
        p(&input),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut args = apply_args(p(&k), p(&input), p(&out), "0.2", &[]);
    args.extend_from_slice(backend);
    (run(&args), out)
}

#[test]
fn cli_gpu_backend_names_its_adapter() {
    gpu_env();
    let dir = tempfile::tempdir().unwrap();
    let (o, out) = apply_dirac(dir.path(), &["--backend", "gpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("adapter"), "{}", stderr(&o));
    let (img, _) = ssskit::filter::image::read_image(&out, None).unwrap();
    // The impulse response holds the kernel's whole mass (1) away from borders.
    let sum: f64 = img.rgb[0].iter().sum();
    assert!((sum - 1.0).abs() < 1e-5, "{sum}");
}

#[test]
fn auto_backend_does_not_pick_a_software_rasteriser() {
    gpu_env();
    let g = open_gpu();
    let dir = tempfile::tempdir().unwrap();
    let (o, _) = apply_dirac(dir.path(), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    if g.is_software() {
        assert!(
            e.contains("backend: cpu") && e.contains("software rasteriser"),
            "{e}"
        );
    } else {
        assert!(e.contains("backend: gpu (auto)"), "{e}");
    }
}
