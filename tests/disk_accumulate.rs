//! The accumulation of a disk kernel's frames (`filter::accumulate`): the
//! pass weighs its frames as `Accumulate::weights` says, and the noise an
//! exponential moving average leaves after K frames is the closed form
//! `Accumulate::noise_factor` times the noise of one frame, for frames
//! whose rotations are independent (seeds drawn at random), within the
//! standard error of the measurement.

use ssskit::filter::accumulate::Accumulate;
use ssskit::filter::disk::{apply_disk, disk_frames, DiskSetup};
use ssskit::filter::disk_error::view;
use ssskit::filter::signals::{generate, Signal};
use ssskit::filter::Image;
use ssskit::kernel::disk::RadiusPdf;
use ssskit::kernel::disk_fit::fit_disk;
use ssskit::profile::Profile;
use std::path::Path;

const MM_PER_PIXEL: f64 = 0.1;
const SIZE: usize = 32;
/// Frames accumulated.
const K: u32 = 8;
/// Independent accumulations per batch, and batches (the standard error
/// of the measured noise comes from the spread of the batches).
const REPLICATES: usize = 16;
const BATCHES: usize = 8;
/// Agreement in standard errors: 4 sigma, the suite's Monte Carlo rule.
const SIGMAS: f64 = 4.0;
/// Two sums of the same products in another order.
const ROUND_OFF: f64 = 1e-12;

fn setup() -> DiskSetup {
    let p = Profile::read(Path::new("profiles/reference/skin1.json")).unwrap();
    let kernel = fit_disk(&p, 16, RadiusPdf::Widest).unwrap();
    DiskSetup::new(&kernel, view(MM_PER_PIXEL), 0, 1)
}

/// A frame at seed `seed` (one rotation).
fn frame(image: &Image, s: &DiskSetup, seed: u32) -> Image {
    disk_frames(image, &s.with_frames(seed, 1))
        .unwrap()
        .swap_remove(0)
}

fn weighted(frames: &[Image], w: &[f64]) -> Vec<[f64; 3]> {
    (0..frames[0].len())
        .map(|i| std::array::from_fn(|c| frames.iter().zip(w).map(|(f, w)| w * f.rgb[c][i]).sum()))
        .collect()
}

#[test]
fn the_pass_weighs_its_frames_as_stated() {
    let img = generate(Signal::Edge, SIZE, SIZE, 8).unwrap();
    let base = setup();
    for acc in [Accumulate::Mean, Accumulate::Ema(0.25)] {
        let s = base.with_frames(5, K).accumulated_by(acc);
        let got = apply_disk(&img, &s).unwrap();
        let frames: Vec<Image> = (0..K).map(|k| frame(&img, &base, 5 + k)).collect();
        let want = weighted(&frames, &acc.weights(K));
        for (i, w) in want.iter().enumerate() {
            for (c, wc) in w.iter().enumerate() {
                assert!((got.rgb[c][i] - wc).abs() <= ROUND_OFF, "{acc:?} pixel {i}");
            }
        }
    }
}

/// splitmix64: seeds independent of each other.
fn seeds(n: usize) -> Vec<u32> {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|_| {
            x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = x;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) as u32
        })
        .collect()
}

/// RMS over pixels and channel `c` of the spread of `samples` (each a
/// whole image's values) about their per-pixel mean, unbiased.
fn spread(samples: &[Vec<[f64; 3]>], c: usize) -> f64 {
    let n = samples.len() as f64;
    let pixels = samples[0].len();
    let total: f64 = (0..pixels)
        .map(|i| {
            let m = samples.iter().map(|s| s[i][c]).sum::<f64>() / n;
            samples.iter().map(|s| (s[i][c] - m).powi(2)).sum::<f64>() / (n - 1.0)
        })
        .sum();
    (total / pixels as f64).sqrt()
}

#[test]
fn ema_noise_after_k_frames_matches_the_closed_form() {
    let img = generate(Signal::Edge, SIZE, SIZE, 8).unwrap();
    let base = setup();
    let acc = Accumulate::Ema(0.25);
    let w = acc.weights(K);
    let all = seeds(BATCHES * REPLICATES * K as usize);
    let frames: Vec<Image> = all.iter().map(|&s| frame(&img, &base, s)).collect();
    let singles: Vec<Vec<[f64; 3]>> = frames
        .iter()
        .map(|f| weighted(std::slice::from_ref(f), &[1.0]))
        .collect();
    // Red: the widest channel, the largest noise.
    let c = 0;
    let one = spread(&singles, c);
    let batch: Vec<f64> = frames
        .chunks(REPLICATES * K as usize)
        .map(|b| {
            let emas: Vec<Vec<[f64; 3]>> = b.chunks(K as usize).map(|f| weighted(f, &w)).collect();
            spread(&emas, c)
        })
        .collect();
    let mean = batch.iter().sum::<f64>() / BATCHES as f64;
    let sd =
        (batch.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (BATCHES as f64 - 1.0)).sqrt();
    let se = sd / (BATCHES as f64).sqrt();
    let predicted = one * acc.noise_factor(K);
    assert!(
        (mean - predicted).abs() <= SIGMAS * se,
        "EMA noise after {K}: measured {mean:.5} +- {se:.5}, closed form {predicted:.5} (one frame {one:.5})"
    );
    // And it is not the plain mean's: the test can tell them apart.
    let mean_pred = one * Accumulate::Mean.noise_factor(K);
    assert!(
        (mean - mean_pred).abs() > SIGMAS * se,
        "{mean} vs mean's {mean_pred}"
    );
}
