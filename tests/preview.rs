//! The material's preview of the main job (`report::eval::ship::preview`): the
//! lit sphere of docs/scenes/sphere.toml path-traced by the scene
//! renderer, what ships through the screen-space pass on its G-buffer, and
//! no blur.
//!
//! - Physics: with the entry and exit factors around it, the screen-space
//!   pass of skin1's committed pre-integrated kernel, and of the disk
//!   kernel the advice ships, is closer to the path trace than the
//!   unblurred irradiance, beyond the render's noise (docs/scene.md: on a
//!   lit sphere the factors are what brings the pass under no blur).
//! - Presentation: report.md's lines and the panel show the preview's own
//!   numbers (a preview of made-up numbers comes out with those numbers),
//!   the panel's texts neither overlap nor cover its images, and the panel
//!   matches its golden PNG.

mod common;

use common::golden;
use common::skin1::{profile, root};
use ssskit::filter::{taps_for, Image, Which};
use ssskit::kernel::angular::{simulate_factors, AngularFactors};
use ssskit::kernel::KernelFile;
use ssskit::report::eval::advise::scene::ScenePass;
use ssskit::report::eval::disk::{disk_kernel, with_frames};
use ssskit::report::eval::ship::preview::{
    preview, preview_sized, Preview, PreviewImages, PreviewKernel, PreviewRow, PREVIEW_SIDE,
};
use ssskit::report::present::layout::{collisions, Rect};
use ssskit::report::present::preview_panel::{preview_markdown, preview_panel};

/// Photons per channel and incidence of the factors' run: a tenth of the
/// default, entry factors to about 1-2% (docs/scene.md), far inside the
/// tens of percent by which they move the lit sphere's error.
const FACTOR_PHOTONS: u64 = 20_000;
/// Standard deviations of the render's noise a difference must exceed to
/// count (the project's Monte Carlo margin).
const K: f64 = 4.0;
/// Samples of the disk kernel (the advice's choice for skin1 at 0.1 mm per
/// pixel) and the frames it is scored after (advise's default).
const DISK_SAMPLES: usize = 32;
const DISK_FRAMES: u32 = 8;

fn factors() -> AngularFactors {
    let m = profile().material;
    simulate_factors(&m, FACTOR_PHOTONS, 7, None, &ssskit::progress::NoProgress).unwrap()
}

/// No blur is further from the path trace than `p`'s shipped pass: over
/// the three channels beyond K standard deviations of the render's noise
/// (channels are traced with independent streams), and in no channel
/// closer beyond K of them.
fn ships_closer_than_no_blur(p: &Preview) {
    eprintln!(
        "{}: no blur - shipped {:?} +- {:?}, noise {:?}",
        p.shipped.label, p.gap, p.gap_sigma, p.noise
    );
    let case = format!("{}: {:?}", p.shipped.label, p);
    let total: f64 = p.gap.iter().sum();
    let sigma = p.gap_sigma.iter().map(|s| s * s).sum::<f64>().sqrt();
    assert!(sigma > 0.0, "{case}");
    assert!(total > K * sigma, "{total} vs {K} x {sigma}: {case}");
    for c in 0..3 {
        assert!(p.gap[c] > -K * p.gap_sigma[c], "channel {c}: {case}");
        // The gap is the rows' difference, and RMS holds the noise.
        let d = p.no_blur.rel_rms[c] - p.shipped.rel_rms[c];
        assert!((p.gap[c] - d).abs() < 1e-15, "{case}");
        for r in [&p.shipped, &p.no_blur] {
            assert!(r.rel_rms[c] >= r.beyond_noise[c], "{case}");
            assert!(r.rel_rms[c] > 0.5 * p.noise[c], "{case}");
        }
    }
    assert!(p.with_factors && p.pixels > PREVIEW_SIDE * PREVIEW_SIDE / 3);
}

/// The committed pre-integrated kernel (17 taps) and the disk kernel of
/// the advice, each with the material's factors, beat no blur on the
/// preview's sphere.
#[test]
fn what_ships_beats_no_blur_on_the_lit_sphere() {
    let profile = profile();
    let f = factors();
    let k = KernelFile::read(&root().join("kernels/skin1-preintegrate.json")).unwrap();
    let separable = PreviewKernel {
        label: "preintegrate".into(),
        pass: ScenePass::Separable(taps_for(&k, Which::stored(&k), None).unwrap()),
        factors: Some(f.clone()),
    };
    ships_closer_than_no_blur(&preview(&profile, &separable).unwrap());
    let disk = PreviewKernel {
        label: "disk".into(),
        pass: ScenePass::Disk(Box::new(with_frames(
            disk_kernel(&profile, DISK_SAMPLES).unwrap(),
            DISK_FRAMES,
        ))),
        factors: Some(f),
    };
    ships_closer_than_no_blur(&preview(&profile, &disk).unwrap());
}

/// Renders of the spread check: 60 seeds measure a standard deviation to
/// 1 / sqrt(2 x 59) = 9% per channel, 5% pooled over the three.
const SEEDS: u64 = 60;
/// The spread check's preview: 24 pixels at 4 samples per pixel, a
/// sixteenth of the preview's cost per render with the same pass.
const SMALL: (usize, u64) = (24, 4);
/// How far the measured spread over the stated deviation (pooled over the
/// channels) may stray from 1: 4 x its 5% sampling error, rounded up.
const SPREAD_TOLERANCE: f64 = 0.25;

/// The standard deviation the preview states for the difference between
/// no blur and what ships is the spread of that difference over renders
/// of independent seeds: the noise of the preview's comparison is stated
/// as it is.
#[test]
fn the_stated_noise_of_the_difference_is_its_spread_over_seeds() {
    let profile = profile();
    let k = KernelFile::read(&root().join("kernels/skin1-preintegrate.json")).unwrap();
    let pk = PreviewKernel {
        label: "preintegrate".into(),
        pass: ScenePass::Separable(taps_for(&k, Which::stored(&k), None).unwrap()),
        factors: Some(factors()),
    };
    let runs: Vec<Preview> = (0..SEEDS)
        .map(|s| preview_sized(&profile, &pk, SMALL, 1000 + s).unwrap())
        .collect();
    let mut ratios = [0.0; 3];
    for (c, ratio) in ratios.iter_mut().enumerate() {
        let gaps: Vec<f64> = runs.iter().map(|p| p.gap[c]).collect();
        let mean = gaps.iter().sum::<f64>() / SEEDS as f64;
        let var = gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / (SEEDS - 1) as f64;
        let stated = runs.iter().map(|p| p.gap_sigma[c]).sum::<f64>() / SEEDS as f64;
        *ratio = var.sqrt() / stated;
    }
    let pooled = ratios.iter().sum::<f64>() / 3.0;
    assert!(
        (pooled - 1.0).abs() < SPREAD_TOLERANCE,
        "measured / stated spread {ratios:?}"
    );
}

/// Side of the made-up preview's images.
const SIDE: usize = 24;

/// A made-up preview: a lit disc and scaled copies, and numbers no
/// measurement gives, each distinct.
fn made_up() -> Preview {
    let disc = |scale: f64| {
        let mut img = Image::new(SIDE, SIDE);
        for y in 0..SIDE {
            for x in 0..SIDE {
                let (dx, dy) = (x as f64 - 11.5, y as f64 - 11.5);
                let r2 = (dx * dx + dy * dy) / 100.0;
                let lit = if r2 < 1.0 {
                    (1.0 - r2) * (0.5 + dx / 24.0)
                } else {
                    0.0
                };
                for (c, k) in [1.0, 0.6, 0.45].iter().enumerate() {
                    img.rgb[c][y * SIDE + x] = scale * k * lit.max(0.0);
                }
            }
        }
        img
    };
    let row = |label: &str, rms: [f64; 3], beyond: [f64; 3], flip: f64| PreviewRow {
        label: label.into(),
        rel_rms: rms,
        beyond_noise: beyond,
        bias: [-0.1, -0.2, -0.3],
        flip,
    };
    Preview {
        material: "madeup".into(),
        side: SIDE,
        samples_per_pixel: 13,
        seed: 99,
        radius_mm: 15.0,
        mm_per_pixel: 0.7123,
        pixels: 1234,
        noise: [0.0512, 0.0634, 0.0756],
        with_factors: true,
        shipped: row(
            "disk, 32 samples within 12.366 mm, mean of 8 frames",
            [0.123, 0.0456, 0.0789],
            [0.111, 0.0222, 0.0333],
            0.2346,
        ),
        no_blur: row(
            "no blur",
            [0.2101, 0.3202, 0.4303],
            [0.1901, 0.2902, 0.3903],
            0.5432,
        ),
        gap: [0.0123, 0.0234, 0.0345],
        gap_sigma: [0.0011, 0.0022, 0.0033],
        events: [111, 222, 333],
        render_seconds: 0.5,
        exposure: 1.0,
        images: PreviewImages {
            path_traced: disc(1.0),
            shipped: disc(0.9),
            no_blur: disc(0.8),
            shipped_diff: disc(0.1),
            no_blur_diff: disc(0.2),
            window_noise: disc(0.02),
        },
    }
}

/// The numbers of the made-up preview as report.md and the panel print
/// them: relative RMS, beyond the noise, noise (percent to 0.1), FLIP (to
/// 0.001), the difference and its deviation (percent to 0.01), the scale,
/// the pixels, the events.
const SHOWN: [&str; 12] = [
    "12.3 / 4.6 / 7.9",
    "11.1 / 2.2 / 3.3",
    "0.235",
    "21.0 / 32.0 / 43.0",
    "19.0 / 29.0 / 39.0",
    "0.543",
    "5.1 / 6.3 / 7.6",
    "1.23 / 2.34 / 3.45",
    "0.11 / 0.22 / 0.33",
    "0.71 mm per pixel",
    "1234 pixels",
    "111 / 222 / 333",
];

/// report.md's lines on the preview print its own numbers, link its PNG
/// and state the chosen scale beside the preview's.
#[test]
fn the_report_shows_the_previews_numbers() {
    let md = preview_markdown(&made_up(), "preview.png", 0.1);
    for s in SHOWN {
        assert!(md.contains(s), "no '{s}' in:\n{md}");
    }
    assert!(md.contains("](preview.png)") && md.contains("not the chosen 0.1"));
}

/// The panel's labels carry the rows' relative RMS and FLIP and the
/// noise; no text overlaps another, leaves the page or covers an image;
/// the page matches tests/golden/preview-panel.png.
#[test]
fn the_panel_reads_and_matches_its_golden() {
    let p = made_up();
    golden::check_png("preview-panel.png", |out| {
        let layout = preview_panel(&p, out).unwrap();
        let (w, h) = image::image_dimensions(out).unwrap();
        let mut bad = collisions(&layout.texts, &Rect::at(0, 0, (w, h)));
        for t in &layout.texts {
            for r in &layout.images {
                if t.rect.overlaps(r) {
                    bad.push(format!("'{}' covers an image", t.text));
                }
            }
        }
        assert!(bad.is_empty(), "{}", bad.join("\n"));
        assert_eq!(layout.images.len(), 6);
        let text: Vec<&str> = layout.texts.iter().map(|t| t.text.as_str()).collect();
        let text = text.join(" ");
        for s in [&SHOWN[0], &SHOWN[2], &SHOWN[3], &SHOWN[5], &SHOWN[6]] {
            assert!(text.contains(s), "no '{s}' in the panel: {text}");
        }
    });
}
