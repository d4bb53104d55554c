//! Memory of reading an image, measured by a counting allocator: at most
//! what `limits.rs` states an image costs (32 bytes per pixel: f64 RGB and
//! alpha) plus the decoder's own samples, never several copies of the
//! image. The rule is per pixel, so a 1024 x 1024 image checks what holds
//! at the 8K cap (`MAX_IMAGE_PIXELS`, 1 GiB in memory).

mod common;

use ssskit::filter::image::{read_image, write_exr, write_image, PngDepth};
use ssskit::filter::Image;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static NOW: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(by: usize) {
    let now = NOW.fetch_add(by, Ordering::Relaxed) + by;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: every call is forwarded to the system allocator unchanged; the
// counters only observe sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        grew(l.size());
        System.alloc(l)
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        grew(l.size());
        System.alloc_zeroed(l)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        NOW.fetch_sub(l.size(), Ordering::Relaxed);
        System.dealloc(p, l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        if new > l.size() {
            grew(new - l.size());
        } else {
            NOW.fetch_sub(l.size() - new, Ordering::Relaxed);
        }
        System.realloc(p, l, new)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Bytes per pixel a read may peak at: the image (32) and the decoder's
/// samples (at most 8 for 16-bit RGBA; an f32 EXR's are freed channel by
/// channel as they are converted, at most one f32 plane beyond the image),
/// with 4 to spare for buffers and tables.
const PEAK_BYTES_PER_PIXEL: f64 = 44.0;

/// One test at a time: the counters see every thread's allocations.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The peak of allocated bytes above what was allocated before, while `f`
/// runs (callers hold `SERIAL`).
fn peak_of<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = NOW.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let out = f();
    (out, PEAK.load(Ordering::Relaxed) - base)
}

#[test]
fn reading_an_image_holds_it_once() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (w, h) = (1024, 1024);
    let dir = tempfile::tempdir().unwrap();
    {
        let mut img = Image::new(w, h);
        for c in 0..3 {
            for (i, v) in img.rgb[c].iter_mut().enumerate() {
                *v = ((i * (c + 3)) % 97) as f64 / 97.0;
            }
        }
        img.alpha = Some(vec![0.75; w * h]);
        write_exr(&dir.path().join("i.exr"), &img, None).unwrap();
        write_image(&dir.path().join("i.png"), &img, PngDepth::Sixteen).unwrap();
    }
    for name in ["i.exr", "i.png"] {
        let ((img, _), peak) = peak_of(|| read_image(&dir.path().join(name), None).unwrap());
        assert!(img.alpha.is_some());
        let per_pixel = peak as f64 / (w * h) as f64;
        eprintln!("{name}: peak {per_pixel:.1} bytes per pixel");
        assert!(
            per_pixel <= PEAK_BYTES_PER_PIXEL,
            "{name}: reading peaked at {per_pixel:.1} bytes per pixel, above \
             {PEAK_BYTES_PER_PIXEL} (32 for the image itself)"
        );
        // The image itself is 32 bytes per pixel: the measure is not vacuous.
        assert!(per_pixel >= 32.0, "{name}: {per_pixel}");
    }
}

/// Bytes per pixel that filtering in place (the CLI's default path) and
/// writing the EXR may add to the image: the halo rows (at most 1/8 of one
/// f64 plane, 1 byte), the rings of filtered rows (17 rows per thread) and
/// the encoder's blocks, with 1 to spare. A fresh f64 output (24 bytes) or
/// an f32 copy for the writer (12 bytes) would be far above.
const FILTER_WRITE_EXTRA_BYTES_PER_PIXEL: f64 = 2.0;

/// A 17-tap box of 0.1 mm steps, one pass.
fn box_taps() -> Vec<ssskit::filter::Taps> {
    let n = 17;
    vec![ssskit::filter::Taps {
        offsets_mm: (0..n).map(|i| (i as f64 - 8.0) * 0.1).collect(),
        weights: vec![[1.0 / n as f64; 3]; n],
    }]
}

#[test]
fn filtering_in_place_and_writing_add_little_to_the_image() {
    use ssskit::filter::{cpu, separable};
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (w, h) = (1024, 1024);
    let dir = tempfile::tempdir().unwrap();
    let mut img = ssskit::filter::signals::noise(w, h, 7);
    let setup = common::plain_setup(box_taps(), 0.1);
    for precision in [separable::Precision::F32, separable::Precision::F64] {
        let (_, peak) = peak_of(|| {
            cpu::apply_in_place(&mut img, &setup, precision).unwrap();
            write_image(&dir.path().join("o.exr"), &img, PngDepth::Eight).unwrap();
        });
        let per_pixel = peak as f64 / (w * h) as f64;
        eprintln!("{precision:?}: filter and write peak {per_pixel:.2} bytes per pixel");
        assert!(
            per_pixel <= FILTER_WRITE_EXTRA_BYTES_PER_PIXEL,
            "{precision:?}: filtering and writing added {per_pixel:.2} bytes per pixel, above \
             {FILTER_WRITE_EXTRA_BYTES_PER_PIXEL}"
        );
    }
}

/// Bytes per pixel that the per-pixel paths (depth-aware separable,
/// algorithm 4.1; the disk pass) may add to the image and its depth while
/// filtering it in place: their windows of rows (here at most 52 rows of
/// 1024 per rank, f64 RGB: 1.2 bytes a pixel) and the rayon bookkeeping,
/// with the rest to spare. A fresh f64 output (24 bytes), an intermediate
/// image (24) or a plane of steps (8) would be far above.
const PER_PIXEL_PATH_EXTRA_BYTES_PER_PIXEL: f64 = 3.0;

/// A 1024 x 1024 noise image, a depth ramp, and the view of the pass:
/// 0.1 mm a pixel, the depth-aware lerp on.
fn per_pixel_case() -> (ssskit::filter::Image, ssskit::filter::Setup) {
    use ssskit::filter::{FollowSurface, Plane, Setup};
    let (w, h) = (1024, 1024);
    let img = ssskit::filter::signals::noise(w, h, 11);
    let depth = Plane::from_index(w, h, |i| 100.0 + (i % 977) as f64 * 0.01);
    let view = Setup {
        depth: Some(depth),
        follow_surface: Some(FollowSurface::InSceneUnits(0.5)),
        ..common::plain_setup(vec![], 0.1)
    };
    (img, view)
}

#[test]
fn the_depth_aware_path_filters_in_place() {
    use ssskit::filter::{cpu, separable, Setup};
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (mut img, view) = per_pixel_case();
    let setup = Setup {
        passes: box_taps(),
        ..view
    };
    assert!(
        !setup.is_uniform(),
        "the per-pixel path, not the fixed kernels"
    );
    let before = img.rgb[0].clone();
    let (_, peak) =
        peak_of(|| cpu::apply_in_place(&mut img, &setup, separable::Precision::F64).unwrap());
    assert_ne!(img.rgb[0], before, "the image was filtered");
    let per_pixel = peak as f64 / img.len() as f64;
    eprintln!("depth-aware: filter peak {per_pixel:.2} bytes per pixel");
    assert!(
        per_pixel <= PER_PIXEL_PATH_EXTRA_BYTES_PER_PIXEL,
        "the depth-aware path added {per_pixel:.2} bytes per pixel, above \
         {PER_PIXEL_PATH_EXTRA_BYTES_PER_PIXEL}"
    );
}

/// A disk sample at radius `r` mm and angle `a` (radians).
fn polar_tap(r: f64, a: f64, weight: [f64; 3]) -> ssskit::filter::disk::DiskTap {
    let (y_mm, x_mm) = (r * a.sin(), r * a.cos());
    ssskit::filter::disk::DiskTap { x_mm, y_mm, weight }
}

#[test]
fn the_disk_path_filters_in_place() {
    use ssskit::filter::accumulate::Accumulate;
    use ssskit::filter::disk::{apply_disk_in_place, DiskSetup};
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let (mut img, view) = per_pixel_case();
    // 32 samples on a spiral of radius up to 0.8 mm: 8 pixels.
    let taps = (0..32)
        .map(|i| polar_tap(0.025 * i as f64, 2.4 * i as f64, [1.0 / 32.0; 3]))
        .collect();
    let setup = DiskSetup {
        taps,
        view,
        seed: 0,
        frames: 1,
        accumulate: Accumulate::Mean,
    };
    let before = img.rgb[0].clone();
    let (_, peak) = peak_of(|| apply_disk_in_place(&mut img, &setup).unwrap());
    assert_ne!(img.rgb[0], before, "the image was filtered");
    let per_pixel = peak as f64 / img.len() as f64;
    eprintln!("disk: filter peak {per_pixel:.2} bytes per pixel");
    assert!(
        per_pixel <= PER_PIXEL_PATH_EXTRA_BYTES_PER_PIXEL,
        "the disk path added {per_pixel:.2} bytes per pixel, above \
         {PER_PIXEL_PATH_EXTRA_BYTES_PER_PIXEL}"
    );
}
