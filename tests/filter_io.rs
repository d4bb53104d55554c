//! Images in and out: lossless sRGB round trips and every bad-input case
//! (clear error, exit code 2, no panic, no output left behind).

mod filter_support;
use filter_support::*;
use ssskit::filter::image::{read_image, write_exr, write_image, PngDepth};
use ssskit::filter::Plane;
use ssskit::kernel::{Pass, TapTable};
use std::path::{Path, PathBuf};

/// A kernel that leaves the image as it is: one tap of weight 1 at 0.
fn identity_kernel(dir: &Path) -> PathBuf {
    let mut k = gaussian_kernel(1, 11);
    let delta = Pass {
        offsets_mm: vec![0.0],
        weights: vec![[1.0; 3]],
    };
    k.passes = vec![delta.clone()];
    k.taps = TapTable {
        count: 1,
        passes: vec![delta],
        extent_mm: None,
    };
    let path = dir.join("identity.json");
    k.write(&path).unwrap();
    path
}

/// `apply` of `k` to `input` into `out` on the CPU, then the `view`
/// flags (last: tests drop or replace them).
fn cpu_apply_with<'a>(
    k: &'a Path,
    input: &'a Path,
    out: &'a Path,
    view: &[&'a str],
) -> Vec<&'a str> {
    let head = [
        "apply",
        "--kernel",
        p(k),
        "--input",
        p(input),
        "--out",
        p(out),
    ];
    [&head[..], &["--backend", "cpu"], view].concat()
}

/// [`cpu_apply_with`] at 0.1 mm per pixel.
fn cpu_apply_args<'a>(k: &'a Path, input: &'a Path, out: &'a Path) -> Vec<&'a str> {
    cpu_apply_with(k, input, out, &["--mm-per-pixel", "0.1"])
}

/// [`cpu_apply_with`] under a perspective camera (40 degrees, 0.01 scene
/// units a mm): a view that needs depth.
fn perspective_args<'a>(k: &'a Path, input: &'a Path, out: &'a Path) -> Vec<&'a str> {
    cpu_apply_with(k, input, out, &["--fov-y", "40", "--units-per-mm", "0.01"])
}

/// Runs and expects a clean failure whose message contains every `needle`.
fn fails_with(args: &[&str], needles: &[&str], out: &Path) {
    assert_fails(&run(args), args, needles);
    assert!(!out.exists(), "a failed run left {}", out.display());
}

#[test]
fn srgb_round_trip_of_an_unfiltered_png_is_lossless() {
    let dir = tempfile::tempdir().unwrap();
    let k = identity_kernel(dir.path());
    let (w, h) = (23u32, 17u32);
    let mut s = 1u64;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 33) as u32
    };
    // 8-bit RGB: every code appears.
    let rgb8 = image::RgbImage::from_fn(w, h, |x, y| {
        let i = (y * w + x) as u8;
        image::Rgb([i, i.wrapping_mul(7), (next() & 255) as u8])
    });
    let in8 = dir.path().join("in8.png");
    rgb8.save(&in8).unwrap();
    // 16-bit RGBA with random samples.
    let rgba16 = image::ImageBuffer::<image::Rgba<u16>, _>::from_fn(w, h, |_, _| {
        image::Rgba([next() as u16, next() as u16, next() as u16, next() as u16])
    });
    let in16 = dir.path().join("in16.png");
    rgba16.save(&in16).unwrap();
    for (input, bits) in [(&in8, 8), (&in16, 16)] {
        let out = dir.path().join(format!("out{bits}.png"));
        let o = run(&cpu_apply_args(&k, input, &out));
        assert!(o.status.success(), "{}", stderr(&o));
        let a = image::open(input).unwrap();
        let b = image::open(&out).unwrap();
        assert_eq!(a.color(), b.color(), "{bits} bit");
        assert_eq!(a.as_bytes(), b.as_bytes(), "{bits}-bit PNG changed");
    }
}

#[test]
fn exr_float_round_trip_keeps_values_and_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let k = identity_kernel(dir.path());
    let mut img = noise_image(9, 7, 5, -0.5);
    img.alpha = Some(vec![0.25; 63]);
    let input = dir.path().join("in.exr");
    write_exr(&input, &img, None).unwrap();
    let out = dir.path().join("out.exr");
    let o = run(&cpu_apply_args(&k, &input, &out));
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, _) = read_image(&input, None).unwrap();
    let (b, _) = read_image(&out, None).unwrap();
    assert_eq!(a, b);
}

fn write_channels(path: &Path, w: usize, h: usize, names: &[&str], value: f32) {
    use exr::prelude::*;
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = names
        .iter()
        .map(|n| AnyChannel::new(*n, FlatSamples::F32(vec![value; w * h])))
        .collect();
    exr::image::Image::from_channels((w, h), AnyChannels::sort(list))
        .write()
        .to_file(path)
        .unwrap();
}

#[test]
fn bad_inputs_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let k = identity_kernel(d);
    let out = d.join("out.exr");
    let good = d.join("good.exr");
    write_image(&good, &noise_image(12, 10, 1, 0.0), PngDepth::Eight).unwrap();

    // Missing file.
    let missing = d.join("nope.exr");
    fails_with(&cpu_apply_args(&k, &missing, &out), &["nope.exr"], &out);
    // Unreadable files.
    let junk: [(&str, &[u8], &[&str]); 3] = [
        (
            "junk.exr",
            b"not an exr",
            &["junk.exr", "unreadable OpenEXR"],
        ),
        ("junk.png", b"not a png", &["junk.png", "unreadable PNG"]),
        ("in.tiff", b"x", &["unknown image type"]),
    ];
    for (name, bytes, needles) in junk {
        let f = d.join(name);
        std::fs::write(&f, bytes).unwrap();
        fails_with(&cpu_apply_args(&k, &f, &out), needles, &out);
    }
    let bad_out = d.join("out.jpg");
    fails_with(
        &cpu_apply_args(&k, &good, &bad_out),
        &["unknown image type"],
        &bad_out,
    );

    // Missing colour channel.
    let rg = d.join("rg.exr");
    write_channels(&rg, 12, 10, &["R", "G"], 0.5);
    fails_with(
        &cpu_apply_args(&k, &rg, &out),
        &["missing channel B", "R, G"],
        &out,
    );
    // Missing depth channel, named or default.
    let mut a = cpu_apply_args(&k, &good, &out);
    a.extend(["--follow-surface", "300", "--depth-channel", "depth"]);
    fails_with(&a, &["missing depth channel depth"], &out);
    let mut a = cpu_apply_args(&k, &good, &out);
    a.extend(["--follow-surface", "300"]);
    fails_with(&a, &["missing depth channel Z"], &out);
    let no_z = d.join("noz.exr");
    write_channels(&no_z, 12, 10, &["A"], 1.0);
    let mut a = cpu_apply_args(&k, &good, &out);
    a.extend(["--follow-surface", "300", "--depth", p(&no_z)]);
    fails_with(&a, &["no channel Z or Y or R"], &out);
    // Perspective scale without depth.
    let png = d.join("good.png");
    write_image(&png, &noise_image(12, 10, 1, 0.0), PngDepth::Eight).unwrap();
    let a = perspective_args(&k, &png, &out);
    fails_with(
        &a,
        &["--depth: invalid value none", "perspective", "depth image"],
        &out,
    );
    // Following the surface without depth.
    let mut a = a[..a.len() - 4].to_vec();
    a.extend(["--mm-per-pixel", "0.1", "--follow-surface", "300"]);
    fails_with(
        &a,
        &["--depth: invalid value none", "following the surface"],
        &out,
    );

    // Mismatched sizes.
    let small = d.join("small.exr");
    write_channels(&small, 10, 10, &["R", "G", "B", "Z"], 1.0);
    for flag in ["--depth", "--strength", "--specular"] {
        let mut a = cpu_apply_args(&k, &good, &out);
        a.extend([flag, p(&small)]);
        if flag == "--depth" {
            a.extend(["--follow-surface", "1"]);
        }
        fails_with(&a, &["is 10x10 but the input image is 12x10"], &out);
    }

    // Non-positive depth under the perspective scale.
    let zero_z = d.join("zero_z.exr");
    write_exr(
        &zero_z,
        &noise_image(12, 10, 2, 0.0),
        Some(&Plane {
            width: 12,
            height: 10,
            data: vec![0.0; 120],
        }),
    )
    .unwrap();
    let a = perspective_args(&k, &zero_z, &out);
    fails_with(&a, &["depth", "must be > 0"], &out);

    // NaN and Inf: rejected with count and first position, or sanitised.
    let mut img = noise_image(12, 10, 3, 0.0);
    img.rgb[1][2 * 12 + 3] = f64::NAN;
    img.rgb[0][5 * 12 + 7] = f64::INFINITY;
    let nan = d.join("nan.exr");
    write_exr(&nan, &img, None).unwrap();
    fails_with(
        &cpu_apply_args(&k, &nan, &out),
        &["2 NaN/Inf samples", "pixel (3, 2)", "--sanitize"],
        &out,
    );
    // compare has no --sanitize: it must not suggest one.
    let report = d.join("cmp");
    let cmp = skin1_pbd_args(
        "compare",
        &[
            "--models",
            "svd",
            "--images",
            p(&nan),
            "--no-plots",
            "--out-dir",
            p(&report),
        ],
    );
    let o = run(&cmp);
    assert_fails(&o, &cmp, &["2 NaN/Inf samples", "pixel (3, 2)"]);
    assert!(!stderr(&o).contains("--sanitize"), "{}", stderr(&o));
    let args = ["diff", p(&nan), p(&nan)];
    let o = run(&args);
    assert_fails(&o, &args, &["2 NaN/Inf samples", "pixel (3, 2) channel G"]);
    assert!(!stderr(&o).contains("--sanitize"), "{}", stderr(&o));
    let mut a = cpu_apply_args(&k, &nan, &out);
    a.push("--sanitize");
    let o = run(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("replaced 2 NaN/Inf"), "{}", stderr(&o));
    let (clean, _) = read_image(&out, None).unwrap();
    assert_eq!(clean.non_finite().0, 0);
    assert_eq!(clean.rgb[1][2 * 12 + 3], 0.0);
    std::fs::remove_file(&out).unwrap();

    // Bad scale values.
    let mut a = cpu_apply_args(&k, &good, &out);
    a.truncate(a.len() - 2);
    a.push("--mm-per-pixel=-1");
    fails_with(&a, &["--mm-per-pixel: invalid value -1: must be"], &out);
    let mut a = cpu_apply_args(&k, &zero_z, &out);
    a.truncate(a.len() - 2);
    a.extend(["--fov-y", "180", "--units-per-mm", "0.01"]);
    fails_with(
        &a,
        &["--fov-y: invalid value 180: must be in (0, 180)"],
        &out,
    );
    let mut a = cpu_apply_args(&k, &zero_z, &out);
    a.push("--follow-surface=-1");
    fails_with(&a, &["--follow-surface: invalid value -1: must be"], &out);

    // diff: sizes must match.
    let diff_out = d.join("diff.png");
    fails_with(
        &["diff", p(&good), p(&small), "--out", p(&diff_out)],
        &["differ in size", "12x10", "10x10"],
        &diff_out,
    );
}

#[test]
fn diff_reports_json_and_writes_a_false_colour_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = noise_image(16, 12, 1, 1.0);
    let mut b = a.clone();
    b.rgb[2][7] += 0.5;
    let (pa, pb, out) = (d.join("a.exr"), d.join("b.exr"), d.join("d.png"));
    write_exr(&pa, &a, None).unwrap();
    write_exr(&pb, &b, None).unwrap();
    let o = run(&["diff", p(&pa), p(&pb), "--json", "--out", p(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["rms", "max_abs", "rms_rel", "max_rel"] {
        assert_eq!(v[key].as_array().unwrap().len(), 3, "{v}");
    }
    assert_eq!(v["max_abs"][0].as_f64().unwrap(), 0.0);
    assert!((v["max_abs"][2].as_f64().unwrap() - 0.5).abs() < 1e-6);
    let peak = a.peak()[2];
    assert!((v["max_rel"][2].as_f64().unwrap() - 0.5 / peak).abs() < 1e-6);
    let img = image::open(&out).unwrap().to_rgb8();
    // The changed pixel is the hottest (white), the others black.
    assert_eq!(img.get_pixel(7, 0).0, [255, 255, 255]);
    assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
    // Below the image, in the same file, its colour bar: a row that runs
    // the heat ramp from black through yellow (the ramp's stop at 3/4 is
    // sRGB (1, 0.85, 0): full red, green within 3% of it, no blue).
    assert!(img.height() > 12, "no room for a colour bar");
    let yellow = |p: &[u8; 3]| p[0] == 255 && (210..=224).contains(&p[1]) && p[2] < 8;
    let ramp_row = (12..img.height()).find(|&y| {
        let row: Vec<[u8; 3]> = (0..img.width()).map(|x| img.get_pixel(x, y).0).collect();
        row.contains(&[0, 0, 0]) && row.iter().any(yellow)
    });
    assert!(
        ramp_row.is_some(),
        "no colour bar below the difference image"
    );
}

#[test]
fn signals_are_written_by_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    for kind in ["edge", "shapes", "dirac", "checker"] {
        let out = dir.path().join(format!("{kind}.png"));
        let o = run(&["signal", kind, "--image-size", "40x20", "--out", p(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (img, _) = read_image(&out, None).unwrap();
        assert_eq!((img.width, img.height), (40, 20));
        assert!(img.peak()[0] > 0.99);
    }
    let out = dir.path().join("x.png");
    fails_with(
        &["signal", "edge", "--image-size", "40by20", "--out", p(&out)],
        &["--image-size"],
        &out,
    );
}
