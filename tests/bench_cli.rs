//! `ssskit bench filter` on lavapipe: names the adapter, runs the
//! timestamp path, and refuses to report a software rasteriser's time.
//! A hardware timing is run by hand (docs/filter.md).

mod filter_support;
use filter_support::*;
use ssskit::filter::{gpu, timing};
use ssskit::kernel::KernelFile;
use std::path::Path;

#[test]
fn bench_refuses_to_time_a_software_rasteriser() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let o = bin()
        .args([
            "bench",
            "filter",
            "--kernel",
            "kernels/skin1-svd1.json",
            "--image-size",
            "64x48",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("adapter: "), "{out}");
    assert!(out.contains("17 taps, rank 1"), "{out}");
    assert!(out.contains("software rasteriser"), "{out}");
    assert!(!out.contains("GPU time per frame"), "{out}");
}

/// The timestamps themselves: one positive, finite time per frame.
#[test]
fn timestamps_give_one_time_per_frame() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let g = gpu::Gpu::new().expect("GPU test needs an adapter (lavapipe in CI)");
    assert!(
        g.has_timestamps(),
        "{} has no timestamp queries",
        g.describe()
    );
    let k = KernelFile::read(Path::new("kernels/skin1-svd1.json")).unwrap();
    let t = timing::time_post_process(&g, &k, 48, 32, 3).unwrap();
    assert_eq!(t.frames_ms.len(), 3);
    assert!(
        t.frames_ms.iter().all(|v| v.is_finite() && *v > 0.0),
        "{:?}",
        t.frames_ms
    );
    assert!(g
        .time_frames(&noise_image(8, 8, 1, 0.0), &plain_setup(&k), 0)
        .is_err());
}

fn plain_setup(k: &KernelFile) -> ssskit::filter::Setup {
    let passes = ssskit::filter::taps_for(k, ssskit::filter::Which::stored(k), None).unwrap();
    filter_support::plain_setup(passes, 0.1)
}
