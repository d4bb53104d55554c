//! Filter benchmark: a 1920x1080 image, 17 taps, rank 1, CPU paths.
//!
//! `cargo bench --bench filter` prints the median time per frame of
//! - `separable-f32`: the plain separable case (17 whole-pixel taps) as
//!   `ssskit apply` runs it by default (`--precision f32`, a fresh output
//!   image per frame), the case compared with OpenCV's sepFilter2D by
//!   scripts/bench-opencv; `separable`: the same in f64 (`--precision f64`);
//!   `separable-reused`, `separable-f32-reused`: into a reused output buffer;
//! - `table`: the 17-tap real-time table (f64) (quadratic offsets) at a uniform
//!   scale, folded into a fixed pixel kernel;
//! - `per-pixel`: Freude 2014, algorithm 4.1 with a per-pixel step (strength image);
//! - `depth-aware`: perspective scale from depth (Freude 2014, eq. 4.11) plus the
//!   follow-surface lerp (Freude 2014, eq. 4.12): the cost of depth-awareness.
//!
//! `-- --dump DIR` also writes the image, the 17 weights and our separable
//! result as raw little-endian f32 for the OpenCV side.

use ssskit::filter::{cpu, Image, Plane, Scale, Setup, Taps};
use std::time::Instant;

const W: usize = 1920;
const H: usize = 1080;

fn image() -> Image {
    let mut img = Image::new(W, H);
    let mut s = 42u64;
    for c in 0..3 {
        for v in img.rgb[c].iter_mut() {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v = (s >> 40) as f64 / (1u64 << 24) as f64;
        }
    }
    img
}

/// 17 taps: a Gaussian on whole pixels (-8..8) and the quadratic table.
fn taps(whole_pixels: bool) -> Taps {
    let n = 17;
    let offsets_mm: Vec<f64> = (0..n)
        .map(|i| {
            let o = -2.0 + i as f64 * 4.0 / (n - 1) as f64;
            if whole_pixels {
                (i as f64 - 8.0) * 0.1
            } else {
                2.0 * o.signum() * o * o / 4.0
            }
        })
        .collect();
    let g: Vec<[f64; 3]> = offsets_mm
        .iter()
        .map(|x| [0.3f64, 0.5, 0.7].map(|s| (-x * x / (2.0 * s * s)).exp()))
        .collect();
    let sum = [0, 1, 2].map(|c| g.iter().map(|w| w[c]).sum::<f64>());
    Taps {
        offsets_mm,
        weights: g.iter().map(|w| [0, 1, 2].map(|c| w[c] / sum[c])).collect(),
    }
}

/// Process CPU time (user + system) in ms, from /proc/self/stat (Linux;
/// 0 elsewhere). On a shared machine CPU time is steadier than wall time.
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .map(|v| v.parse().unwrap_or(0.0))
        .collect();
    // Fields 14 and 15 (utime, stime), counted after the ')' that ends field 2.
    if f.len() > 13 {
        (f[11] + f[12]) * 10.0
    } else {
        0.0
    }
}

/// (median wall ms, mean CPU ms) per frame.
fn median_ms(reps: usize, mut f: impl FnMut()) -> (f64, f64) {
    f();
    let c0 = cpu_ms();
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let cpu = (cpu_ms() - c0) / reps as f64;
    t.sort_by(|a, b| a.total_cmp(b));
    (t[reps / 2], cpu)
}

fn report(name: &str, ms: f64, cpu: f64, threads: usize) {
    println!(
        "{{\"case\": \"{name}\", \"ms_per_frame\": {ms:.2}, \"cpu_ms_per_frame\": {cpu:.1}, \"size\": \"{W}x{H}\", \"taps\": 17, \"rank\": 1, \"threads\": {threads}}}"
    );
}

fn write_f32(path: &std::path::Path, v: impl Iterator<Item = f64>) {
    let bytes: Vec<u8> = v.flat_map(|x| (x as f32).to_le_bytes()).collect();
    std::fs::write(path, bytes).expect("writes the dump");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dump = args
        .iter()
        .position(|a| a == "--dump")
        .and_then(|i| args.get(i + 1))
        .map(std::path::PathBuf::from);
    let reps: usize = std::env::var("SSSKIT_BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(9);
    let img = image();
    let plain = |t: Taps, mm: f64| Setup {
        passes: vec![t],
        scale: Scale::MmPerPixel(mm),
        depth: None,
        strength: None,
        follow_surface: None,
        specular: None,
        jitter: false,
    };
    let sep = plain(taps(true), 0.1);
    let table = plain(taps(false), 0.1);
    let per_pixel = Setup {
        strength: Some(Plane {
            width: W,
            height: H,
            data: vec![1.0; W * H],
        }),
        ..table.clone()
    };
    // A tilted plane with a step: the depth-aware path at its full cost.
    let depth = Plane {
        width: W,
        height: H,
        data: (0..W * H)
            .map(|i| {
                if i % W < W / 2 {
                    1.0 + (i / W) as f64 * 1e-4
                } else {
                    3.0
                }
            })
            .collect(),
    };
    let depth_aware = Setup {
        scale: Scale::Perspective {
            fov_y_deg: 30.0,
            sss_width: 0.0025,
        },
        depth: Some(depth),
        follow_surface: Some(300.0),
        ..table.clone()
    };
    let threads = rayon::current_num_threads();
    // The plain separable case into a reused output buffer (no page faults
    // for a fresh 48 MB image each frame), as a renderer would run it, in
    // f64 (the reference) and f32 (OpenCV's precision).
    let kernel = [cpu::PixelKernel::from_taps(&taps(true), 10.0)];
    let mut reused = Image::new(W, H);
    let (ms, cpu) = median_ms(reps, || {
        cpu::apply_separable_into::<f64>(&img, &kernel, &mut reused)
    });
    report("separable-reused", ms, cpu, threads);
    let (ms, cpu) = median_ms(reps, || {
        cpu::apply_separable_into::<f32>(&img, &kernel, &mut reused)
    });
    report("separable-f32-reused", ms, cpu, threads);
    // Each frame into a fresh output image, freed before the next frame, as
    // one `ssskit apply` process does: the new 48 MB are faulted in per frame.
    use cpu::Precision::{F32, F64};
    for (name, setup, precision) in [
        ("separable-f32", &sep, F32),
        ("separable", &sep, F64),
        ("table", &table, F64),
        ("per-pixel", &per_pixel, F64),
        ("depth-aware", &depth_aware, F64),
    ] {
        let (ms, cpu) = median_ms(reps, || {
            drop(cpu::apply_with(&img, setup, precision).unwrap());
        });
        report(name, ms, cpu, threads);
    }
    if let Some(dir) = &dump {
        std::fs::create_dir_all(dir).expect("creates the dump folder");
        let interleaved = |im: &Image| {
            let im = im.clone();
            (0..W * H).flat_map(move |i| [0, 1, 2].map(|c| im.rgb[c][i]))
        };
        write_f32(&dir.join("image.f32"), interleaved(&img));
        let ours = cpu::apply(&img, &sep).expect("the separable case runs");
        write_f32(&dir.join("ours.f32"), interleaved(&ours));
        let t = taps(true);
        write_f32(&dir.join("weights.f32"), t.weights.iter().flat_map(|w| *w));
    }
}
