//! `ssskit fit --model disk` and `ssskit apply` with a disk kernel through
//! the binary: the sample table, its shader arrays (parsed and validated
//! by naga, wgpu's shader compiler, in WGSL and GLSL; HLSL mapped to GLSL's
//! types, as tests/kernel_emit.rs does), the validated sample count, and
//! `apply --frames` equal to the library's disk pass.

mod common;

use common::shader::{parse_glsl, validate, wgsl_vectors};
use common::{fails_with, ok, p as s, read_json};
use ssskit::filter::disk::{apply_disk, DiskSetup};
use ssskit::filter::disk_error::view;
use ssskit::filter::image::read_image;
use ssskit::filter::Image;
use ssskit::kernel::disk::DiskKernelFile;
use std::path::{Path, PathBuf};

const SKIN: &str = "profiles/reference/skin1.json";

/// A GLSL fragment shader that reads every point and weight.
fn glsl_shader(arrays: &str) -> String {
    format!(
        "#version 450\n{arrays}\nlayout(location = 0) out vec4 o;\nvoid main() {{\n    \
         vec3 s = vec3(0.0);\n    for (uint i = 0u; i < sss_disk_count; i++) {{ s += \
         sss_disk_weights[i] * sss_disk_points[i].x; }}\n    o = vec4(s, 1.0);\n}}\n"
    )
}

/// `ssskit apply` of disk kernel `k` to `img` into `out` at 0.1 mm per
/// pixel, then `extra`.
fn apply_args<'a>(k: &'a Path, img: &'a Path, out: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    common::apply_args(s(k), s(img), s(out), "0.1", extra)
}

/// `got` (read back from an EXR, which stores f32) equals `want` to f32
/// rounding.
fn assert_exr_equals(got: &ssskit::filter::Image, want: &ssskit::filter::Image) {
    for c in 0..3 {
        for (a, b) in got.rgb[c].iter().zip(&want.rgb[c]) {
            assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "{a} {b}");
        }
    }
}

/// `ssskit fit --model disk` of the committed skin1 profile with
/// `samples` into `out`, and `extra`; its stdout.
fn fit_disk_file(out: &Path, samples: &str, extra: &[&str]) -> String {
    let mut args = common::fit_args(SKIN, "disk", s(out), &["--samples", samples]);
    args.extend(extra);
    ok(&args)
}

/// A temporary folder holding a disk kernel of `samples` samples
/// (`disk.json`), a `signal` test image of `size` (`e.exr`), and the path
/// `apply` writes to (`o.exr`).
struct DiskCase {
    _dir: tempfile::TempDir,
    k: PathBuf,
    img: PathBuf,
    out: PathBuf,
}

impl DiskCase {
    fn new(samples: &str, signal: &str, size: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let (k, img, out) = (d.join("disk.json"), d.join("e.exr"), d.join("o.exr"));
        fit_disk_file(&k, samples, &[]);
        ok(&["signal", signal, "--size", size, "--out", s(&img)]);
        DiskCase {
            _dir: dir,
            k,
            img,
            out,
        }
    }

    /// The input image, the image `apply` wrote and the kernel file.
    fn read_back(&self) -> (Image, Image, DiskKernelFile) {
        let (input, _) = read_image(&self.img, None).unwrap();
        let (got, _) = read_image(&self.out, None).unwrap();
        (input, got, DiskKernelFile::read(&self.k).unwrap())
    }
}

#[test]
fn fit_writes_the_sample_table_and_shader_arrays_that_naga_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let k = dir.path().join("disk.json");
    let wgsl = fit_disk_file(&k, "32", &["--emit", "wgsl"]);
    let j = read_json(&k);
    assert_eq!(j["schema"], "ssskit.disk/1");
    let samples = j["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 32);
    for key in ["radius_mm", "angle", "weight"] {
        assert!(samples[0].get(key).is_some(), "{key}");
    }
    assert!(j["usage"]["rotation"]
        .as_str()
        .unwrap()
        .contains("Jimenez 2014"));
    let file = DiskKernelFile::read(&k).unwrap();
    // WGSL: parses, validates, and holds the file's numbers in f32.
    let src = format!(
        "{wgsl}\n@group(0) @binding(0) var<storage, read_write> o: array<vec4<f32>>;\n\
         @compute @workgroup_size(1)\nfn main() {{\n    var p = sss_disk_points;\n    \
         var w = sss_disk_weights;\n    for (var i = 0u; i < sss_disk_count; i++) {{ o[i] = \
         vec4<f32>(w[i], p[i].x + p[i].y); }}\n}}\n"
    );
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("WGSL: {}", e.emit_to_string(&src)));
    validate(&module, "wgsl");
    let points = wgsl_vectors(&module, "sss_disk_points");
    let weights = wgsl_vectors(&module, "sss_disk_weights");
    assert_eq!((points.len(), weights.len()), (32, 32));
    for (i, smp) in file.samples.iter().enumerate() {
        let (x, y) = (
            smp.radius_mm * smp.angle.cos(),
            smp.radius_mm * smp.angle.sin(),
        );
        assert_eq!(points[i], vec![x as f32, y as f32], "point {i}");
        let w: Vec<f32> = smp.weight.iter().map(|&v| v as f32).collect();
        assert_eq!(weights[i], w, "weight {i}");
    }
    // GLSL, and HLSL mapped to GLSL's types, from the file read back.
    let glsl = ok(&["fit", "--kernel", s(&k), "--emit", "glsl", "--quiet"]);
    validate(&parse_glsl(&glsl_shader(&glsl), "glsl"), "glsl");
    let hlsl = ok(&["fit", "--kernel", s(&k), "--emit", "hlsl", "--quiet"]);
    assert!(hlsl.contains("static const float2 sss_disk_points[32]"));
    let mapped = hlsl
        .replace("static const float2", "const vec2")
        .replace("static const float3", "const vec3")
        .replace("static const uint", "const uint")
        .replace("float2(", "vec2(")
        .replace("float3(", "vec3(")
        .replace("[32] = {", "[32] = vec2[32](")
        .replace("};", ");");
    // The weights' array constructor is vec3's.
    let mapped = match mapped.split_once("const vec3 sss_disk_weights[32] = vec2[32](") {
        Some((a, b)) => format!("{a}const vec3 sss_disk_weights[32] = vec3[32]({b}"),
        None => mapped,
    };
    validate(&parse_glsl(&glsl_shader(&mapped), "hlsl"), "hlsl");
}

#[test]
fn the_sample_count_is_validated() {
    let dir = tempfile::tempdir().unwrap();
    let k = dir.path().join("disk.json");
    for n in ["3", "1025"] {
        fails_with(
            &common::fit_args(SKIN, "disk", s(&k), &["--samples", n]),
            &["samples", n],
        );
    }
    assert!(!k.exists());
}

#[test]
fn apply_accumulates_frames_as_the_library_does() {
    let case = DiskCase::new("16", "shapes", "40x32");
    let (k, img, out) = (&case.k, &case.img, &case.out);
    let extra = ["--frames", "4", "--frame-seed", "9", "--backend", "cpu"];
    ok(&apply_args(k, img, out, &extra));
    let (input, got, kernel) = case.read_back();
    let want = apply_disk(&input, &DiskSetup::new(&kernel, view(0.1), 9, 4)).unwrap();
    assert_exr_equals(&got, &want);
    for (extra, needles) in [
        (&["--frames", "0"][..], &["frames", "0"][..]),
        (&["--jitter"], &["--jitter", "disk kernel"]),
    ] {
        fails_with(&apply_args(k, img, out, extra), needles);
    }
}

/// `--accumulate ema:W` weighs the frames as the library's EMA; bad
/// weights, the wgpu backend and separable kernels are refused by name.
#[test]
fn apply_accumulates_by_an_ema_when_asked() {
    use ssskit::filter::accumulate::Accumulate;
    let case = DiskCase::new("8", "edge", "24x16");
    let apply = |extra: &[&'static str]| -> Vec<String> {
        let mut a = apply_args(&case.k, &case.img, &case.out, &["--frames", "4"]);
        a.extend(extra);
        a.into_iter().map(String::from).collect()
    };
    let args = apply(&["--accumulate", "ema:0.3", "--backend", "cpu"]);
    ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    let (input, got, kernel) = case.read_back();
    let setup = DiskSetup::new(&kernel, view(0.1), 0, 4).accumulated_by(Accumulate::Ema(0.3));
    let want = apply_disk(&input, &setup).unwrap();
    let mean = apply_disk(&input, &DiskSetup::new(&kernel, view(0.1), 0, 4)).unwrap();
    assert_exr_equals(&got, &want);
    let differs = (0..3).any(|c| {
        got.rgb[c]
            .iter()
            .zip(&mean.rgb[c])
            .any(|(a, m)| (a - m).abs() > 1e-4)
    });
    assert!(differs, "the EMA image is the plain mean's");
    for (extra, needles) in [
        (
            vec!["--accumulate", "ema:1.5"],
            vec!["--accumulate", "(0, 1]"],
        ),
        (vec!["--accumulate", "median"], vec!["--accumulate", "mean"]),
        (
            vec!["--accumulate", "ema:0.3", "--backend", "gpu"],
            vec!["ema:0.3", "--backend cpu"],
        ),
    ] {
        let args = apply(&extra);
        fails_with(
            &args.iter().map(String::as_str).collect::<Vec<_>>(),
            &needles,
        );
    }
}

/// The rotations a disk kernel's predicted error assumes, as its file
/// records them (`accumulation`, written by advise and kernels; here added
/// to a fitted kernel as they write it).
const RECORDED_FRAMES: u32 = 4;
const RECORDED_FIRST: u32 = 9;

/// `apply` runs the frames a disk kernel records when --frames is not
/// given (the image of `--frames 4 --frame-seed 9`, bit for bit, and the
/// library's disk pass) and says so; --frames wins and is said, with the
/// assumption it departs from; a kernel that records none runs one frame
/// from seed 0 and says that it is assumed. The shader arrays carry the
/// count (`sss_disk_frames`, naga-validated) and the static camera; a file
/// whose record is not a static camera's plain mean is refused.
#[test]
fn apply_runs_the_frames_the_kernel_records() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (bare, rec, img) = (d.join("bare.json"), d.join("rec.json"), d.join("e.exr"));
    fit_disk_file(&bare, "8", &[]);
    let mut j = read_json(&bare);
    assert!(j.get("accumulation").is_none(), "fit predicts nothing: {j}");
    j["accumulation"] = serde_json::json!({
        "frames": RECORDED_FRAMES, "first_frame": RECORDED_FIRST, "accumulate": "mean",
        "camera": "static"
    });
    std::fs::write(&rec, serde_json::to_string(&j).unwrap()).unwrap();
    ok(&["signal", "shapes", "--size", "40x32", "--out", s(&img)]);
    let apply = |kernel: &Path, out: &str, extra: &[&str]| {
        let out = d.join(out);
        let mut args = apply_args(kernel, &img, &out, &["--backend", "cpu"]);
        args.extend(extra);
        let (_, err) = common::ok_both(&args);
        (read_image(&out, None).unwrap().0, err)
    };
    let (by_default, err) = apply(&rec, "d.exr", &[]);
    assert!(
        err.contains("frames: 4 from frame seed 9: the plain mean of 4 frames")
            && err.contains("static camera, as the kernel's predicted error assumes"),
        "{err}"
    );
    let (explicit, _) = apply(&rec, "x.exr", &["--frames", "4", "--frame-seed", "9"]);
    assert_eq!(by_default.rgb, explicit.rgb);
    let (input, _) = read_image(&img, None).unwrap();
    let kernel = DiskKernelFile::read(&rec).unwrap();
    let want = apply_disk(
        &input,
        &DiskSetup::new(&kernel, view(0.1), RECORDED_FIRST, RECORDED_FRAMES),
    )
    .unwrap();
    assert_exr_equals(&by_default, &want);
    let (one, err) = apply(&rec, "1.exr", &["--frames", "1"]);
    assert!(
        err.contains(
            "frames: 1 from frame seed 9 (--frames), where the kernel's predicted error \
                      assumes the plain mean of 4 frames"
        ),
        "{err}"
    );
    assert_ne!(one.rgb, by_default.rgb);
    let (old, err) = apply(&bare, "o.exr", &[]);
    assert!(
        err.contains("frames: 1 from frame seed 0: the kernel records no frames"),
        "{err}"
    );
    let (old_one, _) = apply(&bare, "o1.exr", &["--frames", "1", "--frame-seed", "0"]);
    assert_eq!(old.rgb, old_one.rgb);

    let wgsl = ok(&["fit", "--kernel", s(&rec), "--emit", "wgsl", "--quiet"]);
    assert!(wgsl.contains("const sss_disk_frames: u32 = 4u;"), "{wgsl}");
    // The header's comment lines wrap with "//   ".
    let header = wgsl.replace("\n//   ", " ");
    assert!(
        header.contains("static camera") && header.contains("frame = 9 + k"),
        "{wgsl}"
    );
    let src = format!(
        "{wgsl}\n@group(0) @binding(0) var<storage, read_write> o: array<u32>;\n\
         @compute @workgroup_size(1)\nfn main() {{ o[0] = sss_disk_frames; }}\n"
    );
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("WGSL: {}", e.emit_to_string(&src)));
    validate(&module, "wgsl");
    let glsl = ok(&["fit", "--kernel", s(&rec), "--emit", "glsl", "--quiet"]);
    assert!(glsl.contains("const uint sss_disk_frames = 4u;"), "{glsl}");
    validate(&parse_glsl(&glsl_shader(&glsl), "glsl"), "glsl");
    let hlsl = ok(&["fit", "--kernel", s(&rec), "--emit", "hlsl", "--quiet"]);
    assert!(
        hlsl.contains("static const uint sss_disk_frames = 4u;"),
        "{hlsl}"
    );
    let none = ok(&["fit", "--kernel", s(&bare), "--emit", "hlsl", "--quiet"]);
    assert!(
        !none.contains("sss_disk_frames") && none.contains("Frames: none recorded"),
        "{none}"
    );

    for (field, value, needle) in [
        ("frames", serde_json::json!(0), "accumulation.frames is 0"),
        (
            "camera",
            serde_json::json!("moving"),
            "under a 'moving' camera",
        ),
    ] {
        let mut bad = j.clone();
        bad["accumulation"][field] = value;
        let path = d.join(format!("bad-{field}.json"));
        std::fs::write(&path, serde_json::to_string(&bad).unwrap()).unwrap();
        let bad_out = d.join("bad.exr");
        fails_with(&apply_args(&path, &img, &bad_out, &[]), &[needle, s(&path)]);
    }
}
