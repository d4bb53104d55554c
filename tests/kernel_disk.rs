//! Oracles of the importance-sampled disk kernels (`kernel::disk`,
//! `filter::disk`): the radii follow the profile's CDF (Kolmogorov-Smirnov
//! against the closed-form CDF of an exponential profile), a constant image
//! stays constant, the mean over
//! rotations converges to the exact 2D convolution (`filter::exact`) as N
//! grows, frames accumulate noise away, and a seed gives the same image
//! whatever the thread count.

use ssskit::filter::disk::{apply_disk, DiskSetup};
use ssskit::filter::disk_error::{disk_error, full_reference, view};
use ssskit::filter::signals::{generate, Signal};
use ssskit::filter::{Image, Plane, Scale};
use ssskit::kernel::disk::{DiskKernelFile, RadiusPdf};
use ssskit::kernel::disk_fit::{fit_disk, DiskPdf};
use ssskit::kernel::reference::dipole_profile;
use ssskit::material::Material;
use ssskit::numerics::bin_averages;
use ssskit::profile::{Profile, RadialGrid};

/// Decay lengths d (mm) of the three channels of the test profile:
/// different per channel, so that the mixture differs from each channel.
const DECAY: [f64; 3] = [0.8, 0.4, 0.2];

/// The profile's bins: fine enough that the reconstruction between bin
/// centres moves the CDF by far less than a stratum.
const DR: f64 = 0.005;

/// R(r) = e^{-r/d} / (2 pi d^2), which integrates to 1 over the plane,
/// binned on a uniform grid out to `r_max`: smooth at the origin, so its
/// binned reconstruction is second-order accurate everywhere.
fn exp_profile(r_max: f64) -> Profile {
    let m = Material::load("skin1").unwrap();
    let grid = RadialGrid::uniform(DR, r_max).unwrap();
    let mut p = dipole_profile(&m, &grid).unwrap();
    p.rd = DECAY
        .iter()
        .map(|&d| {
            bin_averages(
                |r| (-r / d).exp() / (2.0 * std::f64::consts::PI * d * d),
                &p.r_edges,
            )
        })
        .collect();
    p
}

/// The exponential profile's CDF over the disk, 1 - (1 + r/d) e^{-r/d},
/// renormalised to the tabulated range.
fn exp_cdf(d: f64, r: f64, r_max: f64) -> f64 {
    let f = |r: f64| 1.0 - (1.0 + r / d) * (-r / d).exp();
    f(r.min(r_max)) / f(r_max)
}

/// The Kolmogorov-Smirnov statistic of sorted samples against `cdf`.
fn ks(radii: &[f64], cdf: impl Fn(f64) -> f64) -> f64 {
    let n = radii.len() as f64;
    radii
        .iter()
        .enumerate()
        .map(|(i, &r)| {
            let f = cdf(r);
            (f - i as f64 / n).abs().max(((i + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max)
}

/// What the binned profile's reconstruction (geometric between bin
/// centres, `profile::RadialInterp`) may move the CDF by: second order in
/// the bin width against a profile that changes on the scale d,
/// (dr / d_min)^2 = 6.25e-4; the first bin, linear from the origin, errs
/// at second order too on a profile with a finite slope there.
const RECONSTRUCTION_CDF_ERROR: f64 = (DR / 0.2) * (DR / 0.2);

#[test]
fn radii_follow_the_profile_cdf_within_the_stratified_bound() {
    let r_max = 6.0;
    let p = exp_profile(r_max);
    for n in [16, 128, 1024] {
        // Per-channel radii: each channel's set against its own CDF.
        let k = fit_disk(&p, n, RadiusPdf::PerChannel).unwrap();
        for (c, &decay) in DECAY.iter().enumerate() {
            let radii: Vec<f64> = k.samples[c * n..(c + 1) * n]
                .iter()
                .map(|s| s.radius_mm)
                .collect();
            let d = ks(&radii, |r| exp_cdf(decay, r, r_max));
            // Stratified samples at u = (i + 1/2) / N lie half a stratum
            // from the empirical CDF's steps: D = 1 / (2N) for exact
            // inversion.
            let bound = 0.5 / n as f64 + RECONSTRUCTION_CDF_ERROR;
            assert!(
                d <= bound,
                "per-channel, N {n}, channel {c}: D {d:.3e} > {bound:.3e}"
            );
            assert!(
                d >= 0.5 / n as f64 - 1e-12,
                "D {d} below 1/(2N): not stratified"
            );
        }
        // One set from the mean of the channels: the mixture's CDF.
        let k = fit_disk(&p, n, RadiusPdf::Mean).unwrap();
        let radii: Vec<f64> = k.samples.iter().map(|s| s.radius_mm).collect();
        let mean_cdf = |r: f64| (0..3).map(|c| exp_cdf(DECAY[c], r, r_max)).sum::<f64>() / 3.0;
        let d = ks(&radii, mean_cdf);
        let bound = 0.5 / n as f64 + RECONSTRUCTION_CDF_ERROR;
        assert!(d <= bound, "mean, N {n}: D {d:.3e} > {bound:.3e}");
    }
}

/// How far the stratified (midpoint in u) estimate of a channel's integral
/// from 37 samples, the weights' raw sum, may sit from 1. Not derived from
/// a bound: the variation bound V / (2 N) of centred points allows 0.22 here
/// (blue under the widest channel's radii: weights from (0.8 / 0.2)^2 = 16
/// down to 0), far above what the midpoint rule does on these smooth
/// weights (largest measured 1.3e-2, blue under widest radii; the test
/// prints the sums); 0.05 is the claim checked. Per-channel radii draw
/// from each channel's own kernel: their sum is 1 to round-off.
const RAW_SUM_ERROR: f64 = 0.05;

/// f64 round-off of a sum of at most 3 x 1024 weights that sum to 1.
const NORMALISATION_ERROR: f64 = 1e-12;

#[test]
fn a_constant_image_stays_constant() {
    let p = exp_profile(3.0);
    let (w, h) = (23, 17);
    let mut img = Image::new(w, h);
    for c in 0..3 {
        img.rgb[c].iter_mut().for_each(|v| *v = [0.7, 0.3, 1.9][c]);
    }
    // Depth and strength vary the step per pixel; the lerp toward the
    // centre colour of a constant image changes nothing either.
    let depth = Plane::from_index(w, h, |i| 0.5 + (i % 7) as f64 * 0.1);
    for radii in [RadiusPdf::Mean, RadiusPdf::Widest, RadiusPdf::PerChannel] {
        let k = fit_disk(&p, 37, radii).unwrap();
        for (c, s) in k.raw_weight_sum.iter().enumerate() {
            // The stratified estimate of the kernel's integral before the
            // weights were scaled: 1 exactly for per-channel radii.
            eprintln!("{radii:?} channel {c}: raw sum {s}");
            let tol = if radii == RadiusPdf::PerChannel {
                NORMALISATION_ERROR
            } else {
                RAW_SUM_ERROR
            };
            assert!((s - 1.0).abs() < tol, "{radii:?} channel {c}: raw sum {s}");
        }
        let mut v = view(0.05);
        v.scale = Scale::Perspective {
            fov_y_deg: 40.0,
            sss_width: 1.0,
        };
        v.depth = Some(depth.clone());
        v.follow_surface = Some(ssskit::filter::FollowSurface::InSceneUnits(2.0));
        let out = apply_disk(&img, &DiskSetup::new(&k, v, 7, 3)).unwrap();
        for c in 0..3 {
            for x in &out.rgb[c] {
                let want = [0.7, 0.3, 1.9][c];
                assert!(
                    (x - want).abs() <= NORMALISATION_ERROR,
                    "{radii:?}: {x} != {want}"
                );
            }
        }
    }
}

/// Largest bias (RMS of the mean over rotations against the exact
/// convolution, relative to the peak) at N = 1024: the midpoint rule in u
/// has error O(1 / N^2) on a smooth integrand; the edge and the shapes
/// make the angular mean kinked where a circle first touches an edge,
/// which leaves O(1 / N^1.5), about 1e-4 here. 5e-4 holds it with room and
/// fails a sampling whose pdf or weight is off by more than a few parts in
/// ten thousand of the signal.
const BIAS_AT_1024: f64 = 5e-4;

/// Rotations averaged for the bias: more than enough that the mean's own
/// noise (added as 4 times its standard error) is below the bias tolerance.
const ROTATIONS: u32 = 32;

#[test]
fn the_mean_over_rotations_converges_to_the_exact_convolution() {
    let mm = 0.1;
    let p = exp_profile(2.0);
    for signal in [Signal::Edge, Signal::Shapes] {
        let img = generate(signal, 48, 48, 8).unwrap();
        let reference = full_reference(&p, &img, mm).unwrap();
        let mut biases = Vec::new();
        for n in [16, 1024] {
            let k = fit_disk(&p, n, RadiusPdf::Mean).unwrap();
            let setup = DiskSetup::new(&k, view(mm), 0, 1);
            let e = disk_error(&img, &setup, &reference, ROTATIONS, 4).unwrap();
            biases.push(e.bias);
            if n == 1024 {
                for c in 0..3 {
                    let tol = BIAS_AT_1024 + 4.0 * e.bias_noise_floor[c];
                    assert!(
                        e.bias[c] <= tol,
                        "{signal:?} N 1024 channel {c}: bias {:.3e} > {tol:.3e} ({e:?})",
                        e.bias[c]
                    );
                    assert!(e.noise_after[c] < e.noise[c], "{e:?}");
                }
            }
        }
        for c in 0..3 {
            assert!(
                biases[1][c] < biases[0][c],
                "{signal:?} channel {c}: bias does not fall with N: {biases:?}"
            );
        }
    }
}

#[test]
fn a_seed_gives_the_same_image_whatever_the_thread_count() {
    let p = exp_profile(2.0);
    let k = fit_disk(&p, 32, RadiusPdf::Mean).unwrap();
    let img = generate(Signal::Shapes, 40, 30, 8).unwrap();
    let run = |threads: usize, seed: u32| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| apply_disk(&img, &DiskSetup::new(&k, view(0.05), seed, 2)).unwrap())
    };
    let a = run(1, 5);
    assert_eq!(a.rgb, run(2, 5).rgb);
    assert_ne!(a.rgb, run(2, 6).rgb, "another seed must rotate the samples");
}

#[test]
fn files_round_trip_and_bad_ones_are_refused() {
    let p = exp_profile(2.0);
    let k = fit_disk(&p, 16, RadiusPdf::Mean).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("k.json");
    k.write(&path).unwrap();
    let back = DiskKernelFile::read(&path).unwrap();
    assert_eq!(back.samples, k.samples);
    assert!(ssskit::kernel::disk::is_disk_file(&path));
    type Break = (&'static str, fn(&mut DiskKernelFile));
    let breaks: [Break; 5] = [
        ("weight", |k| k.samples[3].weight[1] = -0.1),
        ("angle", |k| k.samples[2].angle = 7.0),
        ("radius", |k| k.samples[0].radius_mm = f64::NAN),
        ("samples", |k| k.samples.truncate(3)),
        ("schema", |k| k.schema = "ssskit.kernel/1".into()),
    ];
    for (what, f) in breaks {
        let mut bad = k.clone();
        f(&mut bad);
        let e = bad.validate("test").unwrap_err().to_string();
        assert!(e.contains(what), "{what}: {e}");
    }
    for n in [3, 1025] {
        let e = fit_disk(&p, n, RadiusPdf::Mean).unwrap_err().to_string();
        assert!(e.contains("samples"), "{e}");
    }
}

#[test]
fn the_pdf_inverts_its_own_cdf() {
    let p = exp_profile(3.0);
    let pdf = DiskPdf::new(&p).unwrap();
    for mix in [[1.0, 0.0, 0.0], [1.0 / 3.0; 3]] {
        for u in [1e-4, 0.1, 0.5, 0.9, 0.9999] {
            let r = pdf.invert(mix, u);
            assert!((pdf.cdf(mix, r) - u).abs() < 1e-12, "{mix:?} {u}");
        }
    }
}
