//! Filter benchmark: a 1920x1080 image, 17 taps, rank 1, CPU paths.
//!
//! `cargo bench --bench filter` prints the median time per frame of
//! - `separable-f32`: the plain separable case (17 whole-pixel taps) as
//!   `ssskit apply` runs it by default (`--precision f32`, the f64 image
//!   filtered in place), compared with OpenCV's sepFilter2D by
//!   scripts/bench-opencv; `separable`: the same in f64 (`--precision f64`);
//!   `separable-f32-reused`: f32 planes into reused f32 planes (a
//!   renderer's frame, OpenCV's own case); `separable-reused`: the f64
//!   reference into a reused f64 image;
//! - `table`: the 17-tap real-time table (f64) (quadratic offsets) at a uniform
//!   scale, folded into a fixed pixel kernel;
//! - `per-pixel`: Freude 2014, algorithm 4.1 with a per-pixel step (strength image);
//! - `depth-aware`: perspective scale from depth (Freude 2014, eq. 4.11) plus the
//!   follow-surface lerp (Freude 2014, eq. 4.12): the cost of depth-awareness.
//!
//! In the same run, at 1 thread and at every core, it times OpenCV's
//! `cv2.sepFilter2D` (float32, `BORDER_REPLICATE` = our clamp-to-edge) on
//! the same image and kernel through `python3` (needs `pip install
//! opencv-python-headless numpy`), checks both computed the same image, and
//! writes the record `docs/records/filter-cpu.json` (tables `opencv` for
//! README.md and `threads` for docs/filter.md). `SSSKIT_BENCH_REPS=N` sets
//! the frames per case (default 9; other values do not write the record).

#[path = "../tests/common/mod.rs"]
mod common;
mod docs_record;
use ssskit::filter::{cpu, sample, separable, Image, Plane, Setup, Taps};
use std::time::Instant;

const W: usize = 1920;
const H: usize = 1080;

/// The frame filtered: white noise (every spatial frequency).
fn image() -> Image {
    ssskit::filter::signals::noise(W, H, 42)
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

/// The OpenCV side, run by python3 on the dumped image and kernel: per
/// thread count, (median wall ms, mean CPU ms) per frame of sepFilter2D on
/// three planes split beforehand (our layout), with one kernel on the
/// interleaved image (OpenCV's fastest form), and per channel including the
/// split and merge copies; and the largest difference from our result
/// relative to the peak.
const OPENCV: &str = r#"
import json, sys, time
import numpy as np, cv2
d, W, H = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
threads = [int(t) for t in sys.argv[4].split(",")]
reps = int(sys.argv[5])
img = np.fromfile(f"{d}/image.f32", dtype="<f4").reshape(H, W, 3)
ours = np.fromfile(f"{d}/ours.f32", dtype="<f4").reshape(H, W, 3)
w = np.fromfile(f"{d}/weights.f32", dtype="<f4").reshape(17, 3)
k = [w[:, c].copy() for c in range(3)]
planes = [np.ascontiguousarray(img[:, :, c]) for c in range(3)]
R = cv2.BORDER_REPLICATE
def rgb():
    return np.dstack([cv2.sepFilter2D(np.ascontiguousarray(img[:, :, c]), cv2.CV_32F, k[c], k[c], borderType=R) for c in range(3)])
def planar():
    return [cv2.sepFilter2D(planes[c], cv2.CV_32F, k[c], k[c], borderType=R) for c in range(3)]
def one():
    return cv2.sepFilter2D(img, cv2.CV_32F, k[0], k[0], borderType=R)
def median_ms(f):
    f()
    t = []
    c0 = time.process_time()
    for _ in range(reps):
        s = time.perf_counter(); f(); t.append((time.perf_counter() - s) * 1e3)
    return [sorted(t)[reps // 2], (time.process_time() - c0) * 1e3 / reps]
out = {"version": cv2.__version__, "threads": {}}
ref = rgb()
out["max_diff_rel"] = float(np.abs(ref - ours).max() / np.abs(ref).max())
for n in threads:
    cv2.setNumThreads(n)
    out["threads"][str(n)] = {"planar": median_ms(planar), "one": median_ms(one), "rgb": median_ms(rgb)}
print(json.dumps(out))
"#;

/// Runs [`OPENCV`]; None (with the reason on stderr) when python3 or cv2 is
/// missing.
fn opencv(dir: &std::path::Path, threads: &[usize], reps: usize) -> Option<serde_json::Value> {
    let list: Vec<String> = threads.iter().map(|t| t.to_string()).collect();
    let o = std::process::Command::new("python3")
        .args(["-c", OPENCV])
        .arg(dir)
        .args([
            W.to_string(),
            H.to_string(),
            list.join(","),
            reps.to_string(),
        ])
        .output();
    match o {
        Ok(o) if o.status.success() => serde_json::from_slice(&o.stdout).ok(),
        Ok(o) => {
            eprintln!(
                "OpenCV side failed (pip install opencv-python-headless numpy): {}",
                String::from_utf8_lossy(&o.stderr)
            );
            None
        }
        Err(e) => {
            eprintln!("python3: {e}");
            None
        }
    }
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

/// Our cases at the current rayon pool size: name -> (wall ms, CPU ms).
fn ours(img: &Image, reps: usize) -> Vec<(&'static str, (f64, f64))> {
    let plain = |t: Taps, mm: f64| common::plain_setup(vec![t], mm);
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
    let depth_aware = common::perspective_setup(
        table.passes.clone(),
        (30.0, 0.0025),
        depth,
        ssskit::filter::FollowSurface::InSceneUnits(300.0),
    );
    let mut out = Vec::new();
    let kernel = [sample::PixelKernel::from_taps(&taps(true), 10.0)];
    // A renderer's frame: f32 planes in, f32 planes out, buffers reused
    // (what OpenCV's sepFilter2D computes on the same planes).
    let src: Vec<Vec<f32>> = (0..3)
        .map(|c| img.rgb[c].iter().map(|&v| v as f32).collect())
        .collect();
    let mut dst = vec![vec![0f32; W * H]; 3];
    out.push((
        "separable-f32-reused",
        median_ms(reps, || {
            for c in 0..3 {
                separable::apply_separable_f32(&src[c], &mut dst[c], (W, H), &kernel, c);
            }
        }),
    ));
    // The f64 reference into a reused f64 image.
    let mut reused = Image::new(W, H);
    out.push((
        "separable-reused",
        median_ms(reps, || {
            separable::apply_separable_into::<f64>(img, &kernel, &mut reused)
        }),
    ));
    // `ssskit apply` on the CPU: the f64 image filtered in place (each
    // frame blurs the last; a normalised kernel keeps it finite).
    use separable::Precision::{F32, F64};
    let mut work = img.clone();
    for (name, precision) in [("separable-f32", F32), ("separable", F64)] {
        out.push((
            name,
            median_ms(reps, || {
                cpu::apply_in_place(&mut work, &sep, precision).unwrap();
            }),
        ));
    }
    // Into a fresh output image each frame (the library's `apply_with`).
    for (name, setup, precision) in [
        ("table", &table, F64),
        ("per-pixel", &per_pixel, F64),
        ("depth-aware", &depth_aware, F64),
    ] {
        out.push((
            name,
            median_ms(reps, || {
                drop(cpu::apply_with(img, setup, precision).unwrap());
            }),
        ));
    }
    out
}

fn main() {
    let machine = ssskit::report::present::record::machine_line();
    let reps: usize = std::env::var("SSSKIT_BENCH_REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(9);
    let img = image();
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut threads = vec![1];
    if all > 1 {
        threads.push(all);
    }
    // The OpenCV side reads the image, the weights and our result from
    // here.
    let dir = tempfile::tempdir().expect("a temporary folder");
    let interleaved = |im: &Image| {
        let im = im.clone();
        (0..W * H).flat_map(move |i| [0, 1, 2].map(|c| im.rgb[c][i]))
    };
    write_f32(&dir.path().join("image.f32"), interleaved(&img));
    let sep = common::plain_setup(vec![taps(true)], 0.1);
    let result = cpu::apply(&img, &sep).expect("the separable case runs");
    write_f32(&dir.path().join("ours.f32"), interleaved(&result));
    let t = taps(true);
    write_f32(
        &dir.path().join("weights.f32"),
        t.weights.iter().flat_map(|w| *w),
    );
    // Per thread count ours, then OpenCV right after, so that both see
    // about the same load.
    let mut mine = std::collections::BTreeMap::new();
    let mut cv = serde_json::json!({"threads": {}});
    for &n in &threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .expect("a thread pool");
        let cases = pool.install(|| ours(&img, reps));
        for (name, (ms, cpu)) in &cases {
            report(name, *ms, *cpu, n);
        }
        mine.insert(n, cases);
        let Some(c) = opencv(dir.path(), &[n], reps) else {
            eprintln!("no OpenCV baseline: record not written");
            std::process::exit(1);
        };
        cv["threads"][n.to_string()] = c["threads"][n.to_string()].clone();
        cv["version"] = c["version"].clone();
        cv["max_diff_rel"] = c["max_diff_rel"].clone();
    }
    let diff = cv["max_diff_rel"].as_f64().unwrap_or(f64::NAN);
    assert!(diff < 1e-5, "OpenCV and ssskit differ: {diff} of the peak");
    let cvt = |n: usize, case: &str| -> (f64, f64) {
        let v = &cv["threads"][n.to_string()][case];
        (
            v[0].as_f64().unwrap_or(f64::NAN),
            v[1].as_f64().unwrap_or(f64::NAN),
        )
    };
    let me = |n: usize, case: &str| -> (f64, f64) {
        mine[&n]
            .iter()
            .find(|(c, _)| *c == case)
            .map(|(_, t)| *t)
            .unwrap()
    };
    let ms = |x: f64| {
        if x >= 100.0 {
            format!("{x:.0}")
        } else {
            format!("{x:.1}")
        }
    };
    let version = cv["version"].as_str().unwrap_or("?").to_string();
    // README: the renderer's case and the CLI default against OpenCV on
    // planes, at every core.
    let n = *threads.last().unwrap();
    let mut readme = ssskit::report::present::table::Table::new(&[
        &format!("path ({n} threads, wall ms per frame)"),
        "ssskit",
        &format!("OpenCV {version} sepFilter2D on 3 planes"),
        "ratio, wall / CPU time",
    ]);
    let (cv_ms, cv_cpu) = cvt(n, "planar");
    for (label, case) in [
        (
            "separable f32 planes into reused f32 planes (a renderer's frame)",
            "separable-f32-reused",
        ),
        (
            "CLI default: f32 sweep in place in the f64 image",
            "separable-f32",
        ),
    ] {
        let (m, m_cpu) = me(n, case);
        readme.push(vec![
            label.into(),
            ms(m),
            ms(cv_ms),
            format!("{:.2}x / {:.2}x", m / cv_ms, m_cpu / cv_cpu),
        ]);
    }
    readme.push(vec![
        "per-pixel algorithm 4.1 / with depth-awareness (f64 reference)".into(),
        format!(
            "{} / {}",
            ms(me(n, "per-pixel").0),
            ms(me(n, "depth-aware").0)
        ),
        String::new(),
        String::new(),
    ]);
    // docs/filter.md: every path, wall / CPU ms at each thread count.
    let mut header = vec!["path".to_string()];
    header.extend(threads.iter().map(|t| {
        format!(
            "{t} thread{}, wall / CPU ms",
            if *t == 1 { "" } else { "s" }
        )
    }));
    let hdr: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut all_paths = ssskit::report::present::table::Table::new(&hdr);
    let pair = |(w, c): (f64, f64)| format!("{} / {}", ms(w), ms(c));
    let rows: [(&str, bool, &str); 10] = [
        (
            "OpenCV sepFilter2D, 3 planes split beforehand (our layout)",
            true,
            "planar",
        ),
        (
            "OpenCV sepFilter2D, one kernel for all 3 interleaved channels",
            true,
            "one",
        ),
        (
            "OpenCV per channel incl. channel split/merge copies",
            true,
            "rgb",
        ),
        (
            "**ssskit separable f32, in place in the f64 image (CLI default)**",
            false,
            "separable-f32",
        ),
        (
            "ssskit separable f64, in place (`--precision f64`)",
            false,
            "separable",
        ),
        (
            "ssskit separable f32 planes into reused f32 planes (a renderer's frame)",
            false,
            "separable-f32-reused",
        ),
        (
            "ssskit separable f64 into a reused f64 image",
            false,
            "separable-reused",
        ),
        (
            "ssskit 17-tap quadratic table at 0.1 mm/px (f64, fixed kernel, 41 px wide)",
            false,
            "table",
        ),
        (
            "ssskit per-pixel algorithm 4.1 (strength image, f64)",
            false,
            "per-pixel",
        ),
        (
            "ssskit depth-aware: perspective from depth + follow-surface (f64)",
            false,
            "depth-aware",
        ),
    ];
    for (label, is_cv, case) in rows {
        let mut row = vec![label.to_string()];
        for &t in &threads {
            row.push(pair(if is_cv { cvt(t, case) } else { me(t, case) }));
        }
        all_paths.push(row);
    }
    println!("{}", readme.markdown());
    println!("{}", all_paths.markdown());
    println!("same result: max |ours - OpenCV| / peak = {diff:.1e}");
    if reps != 9 {
        eprintln!("SSSKIT_BENCH_REPS={reps}: record not written");
        return;
    }
    let record = ssskit::report::present::record::Record::new(
        "cargo bench --bench filter",
        &format!("{machine}; OpenCV {version}"),
    );
    let raw: serde_json::Map<String, serde_json::Value> = mine
        .iter()
        .map(|(t, cases)| {
            (
                t.to_string(),
                cases
                    .iter()
                    .map(|(c, (w, p))| (c.to_string(), serde_json::json!([w, p])))
                    .collect::<serde_json::Map<_, _>>()
                    .into(),
            )
        })
        .collect();
    let data = serde_json::json!({
        "size": format!("{W}x{H}"),
        "taps": 17,
        "rank": 1,
        "frames_per_case": reps,
        "ssskit_wall_cpu_ms": raw,
        "opencv": cv,
    });
    let tables = [("opencv", &readme), ("threads", &all_paths)];
    docs_record::write(record, "filter-cpu", &tables, data);
}
