//! The wgpu disk pass (shaders/disk.wgsl) against its f64 twin
//! (`filter::disk::apply_disk`) for the same rotation seed, within the
//! documented f32 tolerance: orthographic, and perspective with depth,
//! strength, the depth-aware lerp and a specular image, over several
//! frames. Runs on lavapipe in CI; never skipped.

use ssskit::filter::disk::{apply_disk, DiskSetup};
use ssskit::filter::disk_error::view;
use ssskit::filter::disk_gpu::{disk_f32_tolerance, DiskGpu};
use ssskit::filter::signals::{generate, noise, Signal};
use ssskit::filter::{FollowSurface, Image, Plane, Scale};
use ssskit::kernel::disk::RadiusPdf;
use ssskit::kernel::disk_fit::fit_disk;
use ssskit::profile::Profile;
use std::path::Path;

fn open_gpu() -> DiskGpu {
    ssskit::gpu::use_software_vulkan_if_unset();
    DiskGpu::new().unwrap_or_else(|e| panic!("GPU test needs an adapter (lavapipe in CI): {e}"))
}

/// Largest |gpu - cpu| over the peak of the CPU image, per channel.
fn worst(gpu: &Image, cpu: &Image) -> f64 {
    let peak = cpu.peak();
    (0..3)
        .map(|c| {
            gpu.rgb[c]
                .iter()
                .zip(&cpu.rgb[c])
                .map(|(a, b)| (a - b).abs() / peak[c])
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[test]
fn the_gpu_disk_pass_equals_the_cpu_reference_for_the_same_seed() {
    let g = open_gpu();
    let p = Profile::read(Path::new("profiles/reference/skin1.json")).unwrap();
    let (w, h) = (48, 40);
    let mut img = generate(Signal::Shapes, w, h, 8).unwrap();
    let n = noise(w, h, 3);
    for c in 0..3 {
        for (v, x) in img.rgb[c].iter_mut().zip(&n.rgb[c]) {
            *v += 0.3 * x;
        }
    }
    for radii in [RadiusPdf::Widest, RadiusPdf::PerChannel] {
        let k = fit_disk(&p, 64, radii).unwrap();
        let tol = disk_f32_tolerance(w, h, k.samples.len());
        // Orthographic.
        let s = DiskSetup::new(&k, view(0.1), 11, 3);
        let e = worst(&g.apply(&img, &s).unwrap(), &apply_disk(&img, &s).unwrap());
        eprintln!("{radii:?} orthographic: |gpu - cpu| / peak at most {e:.3e}");
        assert!(e <= tol, "{radii:?} orthographic: {e:.3e}");
        // Perspective, depth-aware, with strength and specular.
        let mut v = view(0.1);
        v.scale = Scale::Perspective {
            fov_y_deg: 30.0,
            sss_width: 1.0,
        };
        v.depth = Some(Plane::from_index(w, h, |i| {
            if (i % w) < w / 2 {
                60.0
            } else {
                90.0 + (i / w) as f64
            }
        }));
        v.strength = Some(Plane::from_index(w, h, |i| 0.5 + (i % 5) as f64 * 0.25));
        v.follow_surface = Some(FollowSurface::InSceneUnits(0.2));
        v.specular = Some(noise(w, h, 5));
        let s = DiskSetup::new(&k, v, 4_000_000_000, 2);
        let cpu = apply_disk(&img, &s).unwrap();
        let gpu = g.apply(&img, &s).unwrap();
        let e = worst(&gpu, &cpu);
        eprintln!("{radii:?} perspective: |gpu - cpu| / peak at most {e:.3e}");
        assert!(e <= tol, "{radii:?} perspective: {e:.3e}");
        // Another seed rotates differently by far more than the tolerance.
        let other = apply_disk(&img, &s.with_frames(5, 2)).unwrap();
        assert!(worst(&gpu, &other) > 10.0 * tol);
    }
}
