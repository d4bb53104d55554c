//! The CPU reference: exact 2D convolution against the separable
//! application, conservation, and depth-aware filtering.

mod filter_support;
use filter_support::*;
use ssskit::filter::signals::{generate, Signal};
use ssskit::filter::{cpu, exact, sample, taps_for, Image, Plane, Setup, Which};
use ssskit::kernel::Kernel2D;

use filter_support::plain_setup as plain;

fn reference_2d() -> (Kernel2D, f64) {
    let profile = dipole_profile("skin1", 0.01, 8.0);
    // About 20 pixels of radius: small enough to be quick, FFT-sized.
    let radius = (0..3)
        .map(|c| ssskit::profile::radius_holding(&profile, c, 0.999))
        .fold(0.0, f64::max);
    let mm = radius / 20.0;
    (exact::reference_kernel(&profile, mm).unwrap(), mm)
}

/// Separable SSS as Jimenez's shader runs it, re-implemented from
/// github.com/iryoku/separable-sss, SeparableSSS.h, `SSSSBlurPS`: per pass
/// and pixel, sum over taps of weight times the colour fetched at the tap
/// offset with a linear (bilinear, clamp-to-edge) sampler; a horizontal
/// then a vertical pass. Offsets are in mm, `mm` per pixel (an orthographic
/// view: the shader's `finalStep` is then a constant).
fn jimenez_blur(img: &Image, passes: &[ssskit::filter::Taps], mm: f64) -> Image {
    let (w, h) = (img.width, img.height);
    let fetch = |plane: &[f64], x: f64, y: f64| {
        let x = x.clamp(0.0, (w - 1) as f64);
        let y = y.clamp(0.0, (h - 1) as f64);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let at = |xx: usize, yy: usize| plane[yy * w + xx];
        (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x1, y0))
            + fy * ((1.0 - fx) * at(x0, y1) + fx * at(x1, y1))
    };
    let mut out = Image::new(w, h);
    for t in passes {
        let mut mid = Image::new(w, h);
        for c in 0..3 {
            for y in 0..h {
                for x in 0..w {
                    mid.rgb[c][y * w + x] = t
                        .offsets_mm
                        .iter()
                        .zip(&t.weights)
                        .map(|(o, wt)| wt[c] * fetch(&img.rgb[c], x as f64 + o / mm, y as f64))
                        .sum();
                }
            }
            for y in 0..h {
                for x in 0..w {
                    out.rgb[c][y * w + x] += t
                        .offsets_mm
                        .iter()
                        .zip(&t.weights)
                        .map(|(o, wt)| wt[c] * fetch(&mid.rgb[c], x as f64, y as f64 + o / mm))
                        .sum::<f64>();
                }
            }
        }
    }
    out
}

/// Pre-integration is exact for additively separable irradiance (Freude 2014, sec. 5.2):
/// on the vertical edge the separable result equals the 2D convolution.
/// Both sides use the same discretisation (the 2D kernel's pixel cells and
/// their row sums), so the tolerance is round-off: 1e-9 of the peak. The
/// 17-tap table samples the factor: its result is Jimenez's shader's
/// (re-implemented above) to round-off, and differs from the exact one.
#[test]
fn preintegration_equals_exact_2d_on_the_edge() {
    let (k, mm) = reference_2d();
    assert!(k.size > exact::FFT_ABOVE, "the FFT path is exercised");
    let kernel = preintegration_kernel(&k, 17);
    // The exact 2D convolution of an image and the separable pass of the
    // full-resolution factor.
    let exact_and_separable = |img: &Image| {
        let full = taps_for(&kernel, Which::Full, Some(mm)).unwrap();
        let separable = cpu::apply(img, &plain(full, mm)).unwrap();
        (exact::convolve_2d(img, &k), separable)
    };
    let edge = generate(Signal::Edge, 96, 24, 1).unwrap();
    let (exact, full) = exact_and_separable(&edge);
    let e = max_rel(&exact, &full);
    eprintln!(
        "edge, kernel {0}x{0}: separable vs exact 2D {e:.2e}",
        k.size
    );
    assert!(
        e < 1e-9,
        "separable pre-integration vs exact 2D on the edge: {e:e}"
    );
    let tap_passes = taps_for(&kernel, Which::stored(&kernel), None).unwrap();
    assert_eq!(tap_passes[0].offsets_mm.len(), 17);
    let taps = cpu::apply(&edge, &plain(tap_passes.clone(), mm)).unwrap();
    let shader = jimenez_blur(&edge, &tap_passes, mm);
    let e_shader = max_rel(&shader, &taps);
    let e_taps = max_rel(&exact, &taps);
    eprintln!("edge: 17 taps vs Jimenez's shader {e_shader:.2e}, vs exact 2D {e_taps:.2e}");
    assert!(
        e_shader < F64_REL,
        "17 taps vs Jimenez's shader: {e_shader:e}"
    );
    assert!(e_taps > 1e-4, "17 taps equal the exact result: {e_taps:e}");
    // Not exact for irradiance that is not additively separable: the test
    // above compares things that can differ.
    let shapes = generate(Signal::Shapes, 96, 64, 1).unwrap();
    let (exact, sep) = exact_and_separable(&shapes);
    assert!(max_rel(&exact, &sep) > 1e-3);
}

#[test]
fn cli_reference_equals_the_library() {
    let (k, mm) = reference_2d();
    let dir = tempfile::tempdir().unwrap();
    let prof = dir.path().join("p.json");
    dipole_profile("skin1", 0.01, 8.0).write(&prof).unwrap();
    let kern = dir.path().join("k.json");
    preintegration_kernel(&k, 17).write(&kern).unwrap();
    let input = dir.path().join("edge.exr");
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    let mm_s = format!("{mm}");
    let o = run(&[
        "signal",
        "edge",
        "--image-size",
        "64x16",
        "--out",
        p(&input),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        "apply",
        "--reference",
        p(&prof),
        "--reference-sampling",
        "centre",
        "--input",
        p(&input),
        "--out",
        p(&a),
        "--mm-per-pixel",
        &mm_s,
        "--backend",
        "cpu",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("FFT"), "{}", stderr(&o));
    let o = run(&[
        "apply",
        "--kernel",
        p(&kern),
        "--full-factors",
        "--input",
        p(&input),
        "--out",
        p(&b),
        "--mm-per-pixel",
        &mm_s,
        "--backend",
        "cpu",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["diff", p(&a), p(&b), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for c in 0..3 {
        assert!(v["max_rel"][c].as_f64().unwrap() < F32_OUTPUT, "{v}");
    }
}

fn constant(w: usize, h: usize, v: f64) -> Image {
    let mut img = Image::new(w, h);
    for c in 0..3 {
        img.rgb[c]
            .iter_mut()
            .for_each(|x| *x = v * (1.0 + c as f64));
    }
    img
}

/// A normalised kernel conserves energy: a constant stays constant (with
/// clamped borders, everywhere) and black stays black, whatever the scale,
/// strength, depth or follow-surface.
#[test]
fn constant_stays_constant_and_black_stays_black() {
    let (w, h) = (30, 22);
    for rank in [1, 3] {
        let k = gaussian_kernel(rank, 17);
        for factors in [Which::stored(&k), Which::Full] {
            let setups = [
                plain(taps_for(&k, factors, Some(0.2)).unwrap(), 0.2),
                Setup {
                    strength: Some(Plane::from_index(w, h, |i| (i % 7) as f64 / 3.0)),
                    ..perspective_setup(
                        taps_for(&k, factors, None).unwrap(),
                        (30.0, 0.05),
                        step_depth(w, h),
                        ssskit::filter::FollowSurface::InSceneUnits(300.0),
                    )
                },
            ];
            for setup in &setups {
                let c = constant(w, h, 0.7);
                let out = cpu::apply(&c, setup).unwrap();
                let e = max_rel(&c, &out);
                assert!(
                    e < F64_REL,
                    "rank {rank} {factors:?}: constant moved by {e:e}"
                );
                let black = Image::new(w, h);
                let out = cpu::apply(&black, setup).unwrap();
                assert!(out.rgb.iter().all(|p| p.iter().all(|&v| v == 0.0)));
            }
        }
    }
}

#[test]
fn far_background_does_not_bleed_into_the_foreground() {
    assert_no_background_bleed(|img, setup| cpu::apply(img, setup).unwrap(), 3, 25);
}

#[test]
fn cpu_results_do_not_depend_on_the_thread_count() {
    let img = noise_image(50, 40, 3, 0.0);
    let k = gaussian_kernel(3, 17);
    let setup = Setup {
        follow_surface: Some(ssskit::filter::FollowSurface::InSceneUnits(1.0)),
        depth: Some(step_depth(50, 40)),
        ..plain(taps_for(&k, Which::stored(&k), None).unwrap(), 0.2)
    };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let a = one.install(|| cpu::apply(&img, &setup).unwrap());
    let b = cpu::apply(&img, &setup).unwrap();
    assert_eq!(a, b);
}

/// `--precision`: f64 reproduces the library's f64 result bit for bit (as
/// the f32 EXR stores it), the default is f32, and f32 is within the
/// round-off bound of f64. Bound per rank, from f32's unit round-off u: each
/// 1D pass of n taps with fused multiply-adds is within (n + 1) u sum|w| of
/// the exact sum (input and weights rounded once, n accumulations), so the
/// two passes within 2 (n + 1) u sum|w_h| sum|w_v| max|input|; plus one
/// rounding of each output to f32.
#[test]
fn cli_precision_f32_is_within_round_off_of_f64_which_is_the_library_result() {
    use ssskit::filter::image::{read_image, write_exr};
    let dir = tempfile::tempdir().unwrap();
    let (kernel, mm) = (gaussian_kernel(3, 17), 0.1);
    let kpath = dir.path().join("k.json");
    kernel.write(&kpath).unwrap();
    let input = dir.path().join("in.exr");
    write_exr(&input, &noise_image(70, 45, 7, 0.0), None).unwrap();
    let out = |name: &str, precision: Option<&str>| {
        let path = dir.path().join(name);
        let mut args = vec![
            "apply",
            "--kernel",
            p(&kpath),
            "--full-factors",
            "--input",
            p(&input),
            "--out",
            p(&path),
            "--backend",
            "cpu",
            "--mm-per-pixel",
            "0.1",
        ];
        if let Some(v) = precision {
            args.extend(["--precision", v]);
        }
        let o = run(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let expected = format!("fixed kernels, {}", precision.unwrap_or("f32"));
        assert!(stderr(&o).contains(&expected), "{}", stderr(&o));
        read_image(&path, None).unwrap().0
    };
    let (f64_cli, f32_cli, default) = (
        out("f64.exr", Some("f64")),
        out("f32.exr", Some("f32")),
        out("default.exr", None),
    );
    assert_eq!(default.rgb, f32_cli.rgb, "the default is f32");

    let (image, _) = read_image(&input, None).unwrap();
    let setup = plain(taps_for(&kernel, Which::Full, Some(mm)).unwrap(), mm);
    let lib = cpu::apply(&image, &setup).unwrap();
    for c in 0..3 {
        for (a, b) in lib.rgb[c].iter().zip(&f64_cli.rgb[c]) {
            assert_eq!((*a as f32).to_bits(), (*b as f32).to_bits(), "{a} {b}");
        }
    }

    let u = f32::EPSILON as f64 / 2.0;
    let peak_in = image
        .rgb
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let peak_out = lib.rgb.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let bound: f64 = setup
        .passes
        .iter()
        .map(|t| {
            let k = sample::PixelKernel::from_taps(t, 1.0 / mm);
            let n = k.weights.len() as f64;
            let s = (0..3)
                .map(|c| k.weights.iter().map(|w| w[c].abs()).sum::<f64>())
                .fold(0.0, f64::max);
            2.0 * (n + 1.0) * u * s * s * peak_in
        })
        .sum::<f64>()
        + 2.0 * u * peak_out;
    let err = f32_cli
        .rgb
        .iter()
        .flatten()
        .zip(f64_cli.rgb.iter().flatten())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "f32 vs f64: {:.1e} of the peak, bound {:.1e}",
        err / peak_out,
        bound / peak_out
    );
    assert!(err > 0.0, "the f32 path ran");
    assert!(err <= bound, "{err} > {bound}");
}
