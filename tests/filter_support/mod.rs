//! Shared by the tests/filter_*.rs files: kernels built in the tests,
//! profiles, images, scenes, and the binary.
#![allow(dead_code)]

use ssskit::filter::{taps_for, Image, Plane, Setup, Which};
use ssskit::kernel::{Kernel2D, KernelFile, Metrics, ModelInfo, Pass, TapTable, KERNEL_SCHEMA};
use ssskit::material::preset;
use ssskit::profile::{Profile, RadialGrid};
#[path = "../common/mod.rs"]
mod common;
#[allow(unused_imports)] // each test file uses some of them
pub use common::{
    apply_args, assert_fails, bin, golden, p, perspective_setup, plain_setup, run, shader,
    skin1_pbd_args, stderr,
};

/// The dipole profile of a preset over a uniform radial grid.
pub fn dipole_profile(material: &str, dr: f64, r_max: f64) -> Profile {
    let m = preset(material).unwrap();
    let grid = RadialGrid::uniform(dr, r_max).unwrap();
    ssskit::kernel::reference::dipole_profile(&m, &grid).unwrap()
}

/// Real-time tap positions (Jimenez et al. 2015): quadratic, dense near 0.
pub fn tap_offsets(n: usize) -> Vec<f64> {
    let range = if n > 20 { 3.0 } else { 2.0 };
    (0..n)
        .map(|i| {
            let o: f64 = -range + i as f64 * 2.0 * range / (n as f64 - 1.0);
            range * o.signum() * o * o / (range * range)
        })
        .collect()
}

/// Taps of a density `a(x, c)` at `n` quadratic offsets spanning `width` mm,
/// weights times the tap footprint, normalised per channel to `norm[c]`.
pub fn taps_of(a: impl Fn(f64, usize) -> f64, n: usize, width: f64, norm: [f64; 3]) -> Pass {
    let off: Vec<f64> = tap_offsets(n).iter().map(|o| o * width).collect();
    let mut weights = vec![[0.0; 3]; n];
    for c in 0..3 {
        let mut s = 0.0;
        for i in 0..n {
            let l = if i > 0 { off[i] - off[i - 1] } else { 0.0 };
            let r = if i + 1 < n { off[i + 1] - off[i] } else { 0.0 };
            weights[i][c] = a(off[i], c) * (l + r) / 2.0;
            s += weights[i][c];
        }
        for w in weights.iter_mut() {
            w[c] *= norm[c] / s;
        }
    }
    Pass {
        offsets_mm: off,
        weights,
    }
}

fn kernel_file(name: &str, passes: Vec<Pass>, taps: Vec<Pass>, n: usize) -> KernelFile {
    KernelFile {
        schema: KERNEL_SCHEMA.into(),
        material: None,
        profile: serde_json::Value::Null,
        model: ModelInfo {
            name: name.into(),
            params: serde_json::Value::Null,
        },
        units: "mm".into(),
        total_rd: [0.5, 0.4, 0.3],
        metrics: Metrics {
            passes: passes.len(),
            ..Default::default()
        },
        passes,
        taps: TapTable {
            count: n,
            passes: taps,
            extent_mm: None,
        },
        usage: None,
        angular: None,
        transmission: None,
    }
}

fn gauss(x: f64, s: f64) -> f64 {
    (-x * x / (2.0 * s * s)).exp() / (s * (2.0 * std::f64::consts::PI).sqrt())
}

/// Rank-`rank` sum of 1D Gaussians, per-channel widths, known 2D form:
/// term i is sqrt(m_i) G(x; s_i) sqrt(m_i) G(y; s_i) with masses m_i summing to 1.
pub fn gaussian_kernel(rank: usize, n_taps: usize) -> KernelFile {
    let masses = [0.6, 0.3, 0.1];
    let widths = [[0.25, 0.18, 0.1], [0.6, 0.45, 0.3], [1.2, 0.9, 0.5]];
    let total: f64 = masses[..rank].iter().sum();
    let mut passes = Vec::new();
    let mut taps = Vec::new();
    for i in 0..rank {
        let amp = (masses[i] / total).sqrt();
        let s = widths[i];
        let offsets: Vec<f64> = (-60..=60).map(|k| k as f64 * 0.05).collect();
        // Normalised on the truncated grid so each term has mass amp^2.
        let weights: Vec<[f64; 3]> = offsets
            .iter()
            .map(|&x| [0, 1, 2].map(|c| gauss(x, s[c])))
            .collect();
        let sums = [0, 1, 2].map(|c| weights.iter().map(|w| w[c]).sum::<f64>());
        let weights = weights
            .iter()
            .map(|w| [0, 1, 2].map(|c| amp * w[c] / sums[c]))
            .collect();
        passes.push(Pass {
            offsets_mm: offsets,
            weights,
        });
        taps.push(taps_of(
            |x, c| gauss(x, s[c]),
            n_taps,
            1.0 + i as f64,
            [amp; 3],
        ));
    }
    kernel_file("test-gaussians", passes, taps, n_taps)
}

/// Pre-integration (Freude 2014, section 5.2): a_p(x) = sum over y of the 2D cells,
/// on the 2D kernel's own grid; taps from the same factor.
pub fn preintegration_kernel(k: &Kernel2D, n_taps: usize) -> KernelFile {
    let offsets: Vec<f64> = (0..k.size).map(|i| k.offset(i)).collect();
    let weights: Vec<[f64; 3]> = (0..k.size)
        .map(|ix| [0, 1, 2].map(|c| (0..k.size).map(|iy| k.at(c, ix, iy)).sum()))
        .collect();
    let pass = Pass {
        offsets_mm: offsets.clone(),
        weights: weights.clone(),
    };
    let density = |x: f64, c: usize| -> f64 {
        // Linear interpolation of the cell masses.
        let t = (x / k.cell_mm + k.half() as f64).clamp(0.0, (k.size - 1) as f64);
        let i = (t.floor() as usize).min(k.size - 2);
        let f = t - i as f64;
        weights[i][c] * (1.0 - f) + weights[i + 1][c] * f
    };
    let width = offsets[k.size - 1] / 3.0;
    let taps = taps_of(density, n_taps, width, [1.0; 3]);
    kernel_file("test-preintegration", vec![pass], vec![taps], n_taps)
}

/// Deterministic pseudo-random image in [lo, lo + 1): the library's noise
/// signal shifted by `lo`.
pub fn noise_image(w: usize, h: usize, seed: u64, lo: f64) -> Image {
    let mut img = ssskit::filter::signals::noise(w, h, seed);
    img.rgb.iter_mut().flatten().for_each(|v| *v += lo);
    img
}

/// GPU (f32) against the CPU's f64 reference, as a fraction of the peak
/// ([`max_rel`]): the bound docs/filter.md states for every GPU case. f32
/// keeps 2^-24 = 6e-8 of each value; the error grows with the taps summed
/// (two passes of up to 33) and the texel coordinates computed in f32.
pub const GPU_REL: f64 = 1e-4;
/// Two f64 computations of the same image by different routes (fast path
/// and reference): a sum of n terms carries at most about n x 1.1e-16
/// relative rounding, and these passes sum at most a few thousand terms.
pub const F64_REL: f64 = 1e-12;
/// The command writes its images as f32 EXR: 2^-24 = 6e-8 of each value,
/// so an image through the command and the library's f64 (or two runs of
/// the command) agree to this, relative to the peak.
pub const F32_OUTPUT: f64 = 1e-6;
/// An output that differs from its input by less than 1% of the peak was
/// not filtered: a sanity bound far above rounding and far below what any
/// of these kernels does to an edge or to noise.
pub const FILTERED: f64 = 1e-2;

/// Largest |a - b| over the peak of `a`, per channel, worst channel.
pub fn max_rel(a: &Image, b: &Image) -> f64 {
    let s = ssskit::filter::diff::compare(a, b).unwrap();
    s.max_rel.iter().fold(0.0f64, |m, &v| m.max(v))
}

/// 0 on the left half, 1 on the right in every channel: a vertical edge.
pub fn right_half_lit(w: usize, h: usize) -> Image {
    let mut image = Image::new(w, h);
    for plane in &mut image.rgb {
        for (i, v) in plane.iter_mut().enumerate() {
            if i % w >= w / 2 {
                *v = 1.0;
            }
        }
    }
    image
}

/// Depth 1 on the left half, 4 on the right: a silhouette edge.
pub fn step_depth(w: usize, h: usize) -> Plane {
    Plane::from_index(w, h, |i| if i % w < w / 2 { 1.0 } else { 4.0 })
}

/// A black foreground (left half, depth 1) against a bright far background
/// (right half, depth 4), in perspective with follow-surface on (Freude 2014, eq.
/// 4.12, C = 300): with it the foreground must stay black, without it the
/// background bleeds in. `apply` is the backend under test.
pub fn assert_no_background_bleed(
    apply: impl Fn(&Image, &Setup) -> Image,
    rank: usize,
    taps: usize,
) {
    let (w, h) = (32, 24);
    let image = right_half_lit(w, h);
    let k = gaussian_kernel(rank, taps);
    let mut setup = perspective_setup(
        taps_for(&k, Which::stored(&k), None).unwrap(),
        (40.0, 0.1),
        step_depth(w, h),
        ssskit::filter::FollowSurface::InSceneUnits(300.0),
    );
    let foreground_max = |img: &Image| {
        (0..h)
            .flat_map(|y| (0..w / 2).map(move |x| y * w + x))
            .flat_map(|i| img.rgb.iter().map(move |p| p[i]))
            .fold(0.0f64, f64::max)
    };
    // Bound of the lerp at the one interpolated position straddling the edge.
    let followed = apply(&image, &setup);
    assert!(
        foreground_max(&followed) < 1e-3,
        "{}",
        foreground_max(&followed)
    );
    setup.follow_surface = None;
    let bled = apply(&image, &setup);
    assert!(
        foreground_max(&bled) > 0.05,
        "the test cannot fail: {}",
        foreground_max(&bled)
    );
}
