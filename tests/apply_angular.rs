//! `apply` with a kernel that carries the angular entry and exit factors:
//! `scene --irradiance-out` -> `apply` -> the scene's score reproduces the
//! "depth+follow+angular" row of `compare --scene` (and, with
//! `--no-factors`, its "depth+follow" row); the entry-weighted input, the
//! CPU against the GPU, and what a missing input says.

mod common;

use common::{fails_with, ok, ok_both, p, read_json};
use ssskit::filter::image::{read_exr_channels, read_image};
use std::path::Path;

/// `compare --scene` scores in f64 on images rounded to f32; `apply` works
/// in f64 and writes f32 EXR: the two RMS agree to a few f32 roundings of
/// the peak, far below the render's noise (about 1% of the peak per pixel
/// at the spp used here), relative to the RMS.
const F32_AGREEMENT: f64 = 1e-6;
/// CPU (f64) against the GPU pass (f32), per pixel relative to the
/// image's peak: the separable pass's documented f32 tolerance
/// (docs/filtering.md: a few 1e-6 of the peak), with a margin for the
/// factors' own f32 rounding.
const GPU_AGREEMENT: f64 = 1e-5;

/// The camera's fov_y in docs/scenes/sphere-eta1.toml (degrees).
const FOV_Y: &str = "14";

/// One channel of an EXR by name.
fn channel(path: &Path, name: &str) -> Vec<f64> {
    let (_, ch) = read_exr_channels(path).unwrap();
    ch.into_iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("{}: no channel {name}", path.display()))
        .1
}

/// The relative RMS per channel of `img` against the render's radiance
/// over the covered pixels, over their 99th percentile: region "all" of
/// `compare --scene` (report::eval::scene::score).
fn scene_rms(img: &Path, render: &Path) -> [f64; 3] {
    let (a, _) = read_image(img, None).unwrap();
    let coverage = channel(render, "coverage");
    let seen: Vec<usize> = (0..coverage.len()).filter(|&i| coverage[i] > 0.0).collect();
    std::array::from_fn(|c| {
        let truth = channel(render, ["R", "G", "B"][c]);
        let mut v: Vec<f64> = seen.iter().map(|&i| truth[i]).collect();
        v.sort_by(f64::total_cmp);
        let peak = v[((0.99 * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        let sq: f64 = seen.iter().map(|&i| (a.rgb[c][i] - truth[i]).powi(2)).sum();
        (sq / seen.len() as f64).sqrt() / peak
    })
}

/// The row `label` / `variant` of scene.json: its region "all" RMS.
fn row_rms(j: &serde_json::Value, label: &str, variant: &str) -> [f64; 3] {
    let r = j["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["label"] == label && r["variant"] == variant)
        .unwrap_or_else(|| panic!("no row {label} {variant}"));
    let all = r["regions"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["region"] == "all")
        .unwrap();
    std::array::from_fn(|c| all["rel_rms"][c].as_f64().unwrap())
}

struct Chain {
    dir: tempfile::TempDir,
    compare: serde_json::Value,
}

impl Chain {
    fn path(&self, name: &str) -> std::path::PathBuf {
        self.dir.path().join(name)
    }

    /// `apply` of kernel `k.json` on the G-buffer with the scene's camera
    /// and lerp, and `extra`; the output's path.
    fn apply(&self, out: &str, extra: &[&str]) -> std::path::PathBuf {
        let c = self.compare["follow_constant"]
            .as_f64()
            .unwrap()
            .to_string();
        let o = self.path(out);
        let (k, irr) = (self.path("k.json"), self.path("irr.exr"));
        let mut args = vec![
            "apply",
            "--kernel",
            p(&k),
            "--input",
            p(&irr),
            "--fov-y",
            FOV_Y,
            "--units-per-mm",
            "1",
            "--follow-surface-scene-units",
            &c,
            "--precision",
            "f64",
            "--out",
            p(&o),
        ];
        args.extend_from_slice(extra);
        ok(&args);
        o
    }
}

/// The sphere of docs/scene.md at 48 x 48 pixels: rendered with its
/// G-buffer, compared with preintegrate and the factors, and the same
/// kernel fitted from the render's own profile with compare's factors
/// attached (`k.json`).
fn chain() -> Chain {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = common::scenes::small_sphere_eta1();
    assert!(scene.contains(&format!("fov_y = {FOV_Y}\n")));
    let toml = d.join("s.toml");
    std::fs::write(&toml, &scene).unwrap();
    let (exr, irr, cmp) = (d.join("r.exr"), d.join("irr.exr"), d.join("cmp"));
    common::render_scene(&toml, &exr, "16", "1e5", &["--irradiance-out", p(&irr)]);
    let flags = common::args::words("--models preintegrate --angular-photons 2e4 --no-plots");
    common::compare_scene(&toml, &exr, &cmp, &flags);
    let compare = read_json(&cmp.join("scene.json"));
    let record = read_json(&d.join("r.json"));
    let prof = d.join("prof.json");
    std::fs::write(&prof, record["profiles"][0].to_string()).unwrap();
    let k = d.join("k.json");
    ok(&common::fit_args(p(&prof), "preintegrate", p(&k), &[]));
    let mut kj = read_json(&k);
    assert!(kj.get("angular").is_none());
    kj["angular"] = compare["angular"].clone();
    std::fs::write(&k, kj.to_string()).unwrap();
    Chain { dir, compare }
}

/// scene -> apply -> score reproduces compare's rows: with the factors
/// (normals and N.L from the G-buffer file) the "depth+follow+angular" row,
/// with --no-factors the "depth+follow" row; the factors change the image
/// (the two rows differ by far more than the agreement).
#[test]
fn scene_apply_reproduces_the_angular_rows_of_compare() {
    let c = chain();
    let render = c.path("r.exr");
    let with = scene_rms(&c.apply("with.exr", &["--backend", "cpu"]), &render);
    let without = scene_rms(
        &c.apply("without.exr", &["--backend", "cpu", "--no-factors"]),
        &render,
    );
    let want_with = row_rms(&c.compare, "preintegrate", "depth+follow+angular");
    let want_without = row_rms(&c.compare, "preintegrate", "depth+follow");
    eprintln!("apply {with:?} vs compare {want_with:?}; without {without:?} vs {want_without:?}");
    for ch in 0..3 {
        for (got, want) in [(with[ch], want_with[ch]), (without[ch], want_without[ch])] {
            assert!(
                (got - want).abs() <= F32_AGREEMENT * want,
                "channel {ch}: apply {got} vs compare {want}"
            );
        }
        assert!((want_with[ch] - want_without[ch]).abs() > 100.0 * F32_AGREEMENT * want_with[ch]);
    }
}

/// The same chain on the GPU (lavapipe in CI) within the f32 tolerance of
/// the CPU's; the input already weighted by the entry factor (what an
/// engine's lighting pass writes) with --entry-weighted gives the image of
/// the full chain; and a kernel with factors on an input without normals
/// says so in one line and applies the pass alone.
#[test]
fn gpu_entry_weighted_and_missing_normals() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let c = chain();
    let cpu = c.apply("cpu.exr", &["--backend", "cpu"]);
    let gpu = c.apply("gpu.exr", &["--backend", "gpu"]);
    let (a, _) = read_image(&cpu, None).unwrap();
    let (b, _) = read_image(&gpu, None).unwrap();
    for ch in 0..3 {
        let peak = a.rgb[ch].iter().cloned().fold(0.0, f64::max);
        let worst = a.rgb[ch]
            .iter()
            .zip(&b.rgb[ch])
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(
            worst <= GPU_AGREEMENT * peak,
            "channel {ch}: {worst} of {peak}"
        );
    }
    // The entry factor applied here, as an engine's lighting pass would.
    let factors: ssskit::kernel::angular::AngularFactors =
        serde_json::from_value(c.compare["angular"].clone()).unwrap();
    let irr = c.path("irr.exr");
    let (img, extras) = read_image(&irr, Some("Z")).unwrap();
    let nl = channel(&irr, "NdotL");
    let lit = ssskit::filter::angular::entry_weighted(&img, &nl, &factors).unwrap();
    let lit_path = c.path("lit.exr");
    ssskit::filter::image::write_exr(&lit_path, &lit, extras.depth.as_ref()).unwrap();
    let normals = c.path("normals.exr");
    let n = ssskit::filter::Image {
        width: img.width,
        height: img.height,
        rgb: [
            channel(&irr, "N.X"),
            channel(&irr, "N.Y"),
            channel(&irr, "N.Z"),
        ],
        alpha: None,
    };
    ssskit::filter::image::write_exr(&normals, &n, None).unwrap();
    let o = c.path("engine.exr");
    let cc = c.compare["follow_constant"].as_f64().unwrap().to_string();
    let k = c.path("k.json");
    let base = [
        "apply",
        "--kernel",
        p(&k),
        "--fov-y",
        FOV_Y,
        "--units-per-mm",
        "1",
        "--follow-surface-scene-units",
        &cc,
        "--precision",
        "f64",
        "--backend",
        "cpu",
    ];
    let mut args = base.to_vec();
    args.extend_from_slice(&[
        "--input",
        p(&lit_path),
        "--normals",
        p(&normals),
        "--entry-weighted",
        "--out",
        p(&o),
    ]);
    ok(&args);
    let (e, _) = read_image(&o, None).unwrap();
    for ch in 0..3 {
        let peak = a.rgb[ch].iter().cloned().fold(0.0, f64::max);
        for (x, y) in a.rgb[ch].iter().zip(&e.rgb[ch]) {
            assert!((x - y).abs() <= 1e-6 * peak, "channel {ch}: {x} vs {y}");
        }
    }
    // Without normals: one line, the pass alone (the image of --no-factors).
    let plain = c.path("plain.exr");
    let bare = ssskit::filter::Image {
        alpha: None,
        ..img.clone()
    };
    ssskit::filter::image::write_exr(&plain, &bare, extras.depth.as_ref()).unwrap();
    let mut args = base.to_vec();
    let o2 = c.path("bare.exr");
    args.extend_from_slice(&["--input", p(&plain), "--out", p(&o2)]);
    let (_, err) = ok_both(&args);
    assert!(
        err.contains("has no normals") && err.contains("applied without them"),
        "{err}"
    );
    let without = c.apply("without.exr", &["--backend", "cpu", "--no-factors"]);
    let (x, _) = read_image(&o2, None).unwrap();
    let (y, _) = read_image(&without, None).unwrap();
    assert_eq!(x.rgb, y.rgb);
    // The plain image into x.exr, with the normals or a light.
    let o3 = c.path("x.exr");
    let plain_in = ["--input", p(&plain), "--out", p(&o3)];
    let normals_in = ["--normals", p(&normals)];
    // Normals without the light: the entry factor's input is asked for.
    fails_with(
        &[&base[..], &plain_in, &normals_in].concat(),
        &["--light-toward", "--n-dot-l", "--entry-weighted"],
    );
    // A light without the normals is refused by its flag's name.
    fails_with(
        &[&base[..], &plain_in, &["--light-toward", "0,0,1"]].concat(),
        &["--light-toward: the exit factor needs the normals"],
    );
    // A factor-only flag on a kernel without factors is refused.
    let mut kj = read_json(&k);
    kj.as_object_mut().unwrap().remove("angular");
    let bare_kernel = c.path("bare-k.json");
    std::fs::write(&bare_kernel, kj.to_string()).unwrap();
    let mut args = [&base[..], &plain_in, &normals_in].concat();
    args[2] = p(&bare_kernel);
    fails_with(
        &args,
        &["--normals: the kernel carries no angular entry and exit factors"],
    );
}
