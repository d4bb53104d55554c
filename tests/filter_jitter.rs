//! Jittered tap offsets (interleaved gradient noise, Jimenez 2014) on the
//! CPU twin of the wgpu pass: the image mean is kept, the banding stripes of
//! a 9-tap table on a large kernel go. The GPU agreement with jitter on is
//! in filter_gpu.rs.

mod filter_support;
use filter_support::*;
use ssskit::filter::{cpu, jitter_unit, taps_for, Image, Setup, Which};

/// 9 taps, kernel +-2 mm at 0.02 mm per pixel: +-100 pixels, tap gaps up
/// to 44 pixels.
const MM: f64 = 0.02;

fn setup(factors: Which, jitter: bool) -> Setup {
    let k = gaussian_kernel(1, 9);
    let uniform = (factors == Which::Full).then_some(MM);
    Setup {
        jitter,
        ..plain_setup(taps_for(&k, factors, uniform).unwrap(), MM)
    }
}

/// Standard errors a check of a statistic allows: a fair draw lands
/// beyond 4 sigma once in about 16,000.
const SIGMAS: f64 = 4.0;
/// What the jittered image's mean may move, relative: each pixel's taps
/// keep their weights and move inside their own footprints, so only the
/// jitter pattern's residual correlation with the image moves the mean
/// (the test prints it).
const MEAN_KEPT: f64 = 1e-3;

fn mean(img: &Image, c: usize) -> f64 {
    img.rgb[c].iter().sum::<f64>() / img.rgb[c].len() as f64
}

#[test]
fn jitter_values_are_uniform_and_differ_between_taps() {
    let (mut sum, mut n) = (0.0f64, 0.0f64);
    let mut hist = [0usize; 10];
    for y in 0..64 {
        for x in 0..64 {
            for tap in 0..9 {
                let u = jitter_unit(x, y, tap, 0);
                assert!((0.0..1.0).contains(&u));
                hist[(u * 10.0) as usize] += 1;
                sum += u;
                n += 1.0;
            }
            assert_ne!(jitter_unit(x, y, 0, 0), jitter_unit(x, y, 1, 0));
            assert_ne!(jitter_unit(x, y, 0, 0), jitter_unit(x, y, 0, 1));
        }
    }
    // A uniform value has variance 1/12: the mean of n has standard error
    // 1 / sqrt(12 n) (1.5e-3 for 36864 values).
    let mean_se = 1.0 / (12.0 * n).sqrt();
    assert!(
        (sum / n - 0.5).abs() < SIGMAS * mean_se,
        "mean {} +- {mean_se:.1e}",
        sum / n
    );
    // Each tenth of [0, 1) holds a binomial share of p = 0.1: standard
    // error sqrt(p (1 - p) / n) (1.6e-3 for 36864 values).
    let share_se = (0.1 * 0.9 / n).sqrt();
    for h in hist {
        assert!(
            (h as f64 / n - 0.1).abs() < SIGMAS * share_se,
            "{hist:?} (+- {share_se:.1e} each)"
        );
    }
}

/// Content inside a black margin wider than the kernel, so clamping at the
/// border plays no part: without jitter the mean is the input's times the
/// 2D weight sum exactly; with it, each pixel gathers from its own offsets
/// and the mean holds to [`MEAN_KEPT`].
#[test]
fn jitter_keeps_the_mean() {
    let (w, h) = (320, 320);
    let mut img = Image::new(w, h);
    for y in 110..210 {
        for x in 110..210 {
            let (dx, dy) = (x as f64 - 160.0, y as f64 - 160.0);
            let disc = if dx * dx + dy * dy < 45.0 * 45.0 {
                1.0
            } else {
                0.2
            };
            for c in 0..3 {
                img.rgb[c][y * w + x] = disc * (1.0 + 0.3 * c as f64) + 0.005 * (x - 110) as f64;
            }
        }
    }
    let plain = cpu::apply(&img, &setup(Which::Taps(9), false)).unwrap();
    let jittered = cpu::apply(&img, &setup(Which::Taps(9), true)).unwrap();
    let k = gaussian_kernel(1, 9);
    for c in 0..3 {
        let s: f64 = k.taps.passes[0].weights.iter().map(|w| w[c]).sum();
        let expected = mean(&img, c) * s * s;
        assert!((mean(&plain, c) - expected).abs() < F64_REL * expected);
        let rel = (mean(&jittered, c) - expected).abs() / expected;
        eprintln!("channel {c}: jittered mean off by {rel:.2e}");
        assert!(rel < MEAN_KEPT, "channel {c}: mean moved by {rel:e}");
    }
    assert!(
        max_rel(&plain, &jittered) > FILTERED,
        "jitter changed nothing"
    );
}

/// Banding energy: on a vertical edge, the row-averaged result (which
/// averages the jitter noise away and keeps the stripes, constant down each
/// column) against the full-resolution factor's result, summed squared over
/// the columns the kernel reaches, per unit edge height squared. 9 taps on
/// a 200-pixel kernel turn the edge into a staircase of 9 steps up to 44
/// pixels wide; jitter spreads each tap over its footprint.
#[test]
fn jitter_removes_the_banding_of_few_taps_on_a_large_kernel() {
    let (w, h) = (320, 128);
    let edge = right_half_lit(w, h);
    let reference = cpu::apply(&edge, &setup(Which::Full, false)).unwrap();
    let plain = cpu::apply(&edge, &setup(Which::Taps(9), false)).unwrap();
    let jittered = cpu::apply(&edge, &setup(Which::Taps(9), true)).unwrap();
    let row_mean = |img: &Image, c: usize, x: usize| -> f64 {
        (0..h).map(|y| img.rgb[c][y * w + x]).sum::<f64>() / h as f64
    };
    let banding = |img: &Image, c: usize| -> f64 {
        (w / 2 - 110..w / 2 + 110)
            .map(|x| (row_mean(img, c, x) - row_mean(&reference, c, x)).powi(2))
            .sum()
    };
    let energies: Vec<(f64, f64)> = (0..3)
        .map(|c| (banding(&plain, c), banding(&jittered, c)))
        .collect();
    for (c, (b0, b1)) in energies.iter().enumerate() {
        eprintln!(
            "channel {c}: banding energy {b0:.3e} without jitter, {b1:.3e} with: {:.1}x less",
            b0 / b1
        );
    }
    // Measured (deterministic): 6.4x (red, Gaussian sigma 0.25 mm) and
    // 6.6x (green, 0.18 mm). What is left is the box-smoothed kernel's own
    // deviation from the full factor (a jittered tap's expectation is its
    // weight spread over its footprint), not stripes. Blue (0.1 mm) is no
    // large kernel for this table: its central taps' footprints (up to
    // 0.25 mm) are wider than the Gaussian, and the box smoothing costs
    // more than the 9-tap staircase (0.6x, reported, not asserted).
    for (c, (b0, b1)) in energies.iter().enumerate().take(2) {
        assert!(*b0 > 1e-3, "channel {c}: the 9-tap table shows no banding");
        assert!(
            *b1 < b0 / 4.0,
            "channel {c}: jitter reduced banding only {:.1}x",
            b0 / b1
        );
    }
}

/// `apply --jitter` runs the library's jittered path (the same image as
/// `cpu::apply` with jitter, to the f32 of the EXR), a different image from
/// the plain run; the exact reference refuses the flag. (A dirac's total is
/// not kept under jitter: its few samples are the noise.)
#[test]
fn cli_jitter_changes_the_image_and_the_reference_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let k = dir.path().join("k.json");
    gaussian_kernel(1, 9).write(&k).unwrap();
    let input = dir.path().join("in.exr");
    let o = run(&[
        "signal",
        "dirac",
        "--image-size",
        "65x65",
        "--out",
        p(&input),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let apply = |out: &std::path::Path, extra: &[&str]| {
        let mut args = apply_args(p(&k), p(&input), p(out), "0.1", &["--backend", "cpu"]);
        args.extend_from_slice(extra);
        let o = run(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        ssskit::filter::image::read_image(out, None).unwrap().0
    };
    let plain = apply(&dir.path().join("plain.exr"), &[]);
    let jittered = apply(&dir.path().join("jitter.exr"), &["--jitter"]);
    assert!(
        max_rel(&plain, &jittered) > FILTERED,
        "--jitter changed nothing"
    );
    let (img, _) = ssskit::filter::image::read_image(&input, None).unwrap();
    let kernel = ssskit::kernel::KernelFile::read(&k).unwrap();
    let library = cpu::apply(
        &img,
        &Setup {
            jitter: true,
            ..plain_setup(
                taps_for(&kernel, Which::stored(&kernel), None).unwrap(),
                0.1,
            )
        },
    )
    .unwrap();
    assert!(
        max_rel(&library, &jittered) < F32_OUTPUT,
        "{}",
        max_rel(&library, &jittered)
    );
    let o = run(&[
        "apply",
        "--reference",
        "profiles/reference/skin1.json",
        "--input",
        p(&input),
        "--out",
        p(&dir.path().join("r.exr")),
        "--mm-per-pixel",
        "0.1",
        "--jitter",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--jitter"), "{}", stderr(&o));
}
