//! Random valid-but-extreme materials, profiles, kernels and images thrown at
//! the library: every stage returns an error or finite output, never panics,
//! and whatever it writes reads back. Case counts are small (seconds).

mod common;

use proptest::prelude::*;
use ssskit::filter::image::{read_image, write_image, PngDepth};
use ssskit::filter::{check_kernel_fits, cpu, taps_for, Image, Which};
use ssskit::kernel::{fit_kernel_file, Kernel2DSpec, KernelFile, Model as KernelModel, Pass};
use ssskit::material::{Layer, Material};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::{Profile, RadialGrid};

const REPO: &str = env!("CARGO_MANIFEST_DIR");

/// 10^e for e drawn uniformly: spans many decades with few cases.
fn decades(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo..hi).prop_map(|e: f64| 10f64.powf(e))
}

fn half_space(sa: [f64; 3], ss: [f64; 3], g: f64, eta: f64) -> Material {
    Material {
        name: "extreme".into(),
        eta_above: 1.0,
        eta_below: 1.0,
        layers: vec![Layer {
            sigma_a: sa,
            sigma_s: ss,
            g: [g; 3],
            eta,
            thickness: None,
        }],
    }
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Writes `p` and reads it back: the file must load as written.
fn round_trip(p: &Profile) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.json");
    match p.write(&path) {
        Ok(()) => {
            let back = Profile::read(&path).expect("ssskit must read back what it wrote");
            // serde_json writes the shortest representation that parses back
            // to the same double, and its float_roundtrip feature (on in
            // Cargo.toml) parses it exactly: every bit comes back.
            for (a, b) in back.rd.iter().flatten().zip(p.rd.iter().flatten()) {
                assert_eq!(a.to_bits(), b.to_bits(), "{b:e} read back as {a:e}");
            }
            for (a, b) in back.total_rd.iter().zip(&p.total_rd) {
                assert_eq!(a.to_bits(), b.to_bits(), "{b:e} read back as {a:e}");
            }
        }
        Err(e) => assert!(!path.exists(), "failed write left {path:?}: {e}"),
    }
}

/// A kernel from the repository with its passes replaced.
fn kernel_with(passes: Vec<Pass>) -> KernelFile {
    let mut k = KernelFile::read(&std::path::Path::new(REPO).join("kernels/marble-svd1.json"))
        .expect("repository kernel");
    k.taps.passes = passes.clone();
    k.taps.count = passes[0].offsets_mm.len();
    k.passes = passes;
    k
}

fn image(w: usize, h: usize, values: &[f64]) -> Image {
    let mut img = Image::new(w, h);
    for c in 0..3 {
        for (i, v) in img.rgb[c].iter_mut().enumerate() {
            *v = values[(i * 3 + c) % values.len()];
        }
    }
    img
}

/// Applies `k` the way `ssskit apply` does; returns the image or the error.
fn apply(k: &KernelFile, img: &Image, mm: f64) -> ssskit::Result<Image> {
    check_kernel_fits(k, Which::Full, Some(mm), img.width, img.height)?;
    cpu::apply(
        img,
        &common::plain_setup(taps_for(k, Which::Full, Some(mm)).unwrap(), mm),
    )
}

/// How far a case got before the library refused it (or to the end).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Reached {
    Refused,
    Checked,
    Deepest,
}

/// Runs `cases` cases of `strategy` through `test` from proptest's fixed
/// seed, so the counts are the same on every run, and returns how many
/// cases ended at each stage. A property whose every case is refused
/// early checks nothing: the callers assert that the deep stages are
/// reached.
fn run_counted<S: Strategy>(
    cases: u32,
    strategy: S,
    test: impl Fn(S::Value) -> Result<Reached, TestCaseError>,
) -> std::collections::BTreeMap<Reached, usize>
where
    S::Value: std::fmt::Debug,
{
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let counts = std::sync::Mutex::new(std::collections::BTreeMap::new());
    let result = runner.run(&strategy, |v| {
        let reached = test(v)?;
        *counts.lock().unwrap().entry(reached).or_insert(0) += 1;
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let counts = counts.into_inner().unwrap();
    eprintln!("cases by stage reached: {counts:?}");
    counts
}

/// A refusal must be the library's error about its input (a parameter out
/// of its domain, a malformed or non-finite value), not some other failure
/// passing as one.
fn refusal(e: ssskit::Error) -> Result<Reached, TestCaseError> {
    prop_assert!(
        matches!(
            e,
            ssskit::Error::Invalid { .. }
                | ssskit::Error::Format { .. }
                | ssskit::Error::NonFinite { .. }
        ),
        "refused with an error that is not about the input: {e}"
    );
    Ok(Reached::Refused)
}

/// The last stage of the profile properties: a 31-cell rank-1 SVD kernel
/// that validates (`Deepest`), or a clear error (`Checked`).
fn fit_stage(p: &Profile, renormalize: bool) -> Result<Reached, TestCaseError> {
    let spec = Kernel2DSpec {
        size: Some(31),
        extent_mm: None,
    };
    let svd = KernelModel::Svd {
        rank: 1,
        renormalize,
    };
    match fit_kernel_file(p, &spec, &svd, 9) {
        Ok(k) => {
            prop_assert!(k.validate("fitted").is_ok());
            Ok(Reached::Deepest)
        }
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            Ok(Reached::Checked)
        }
    }
}

/// At least `min_checked` of the cases got past the refusals and at least
/// `min_deepest` to the last stage.
fn assert_reached(
    counts: &std::collections::BTreeMap<Reached, usize>,
    min_checked: usize,
    min_deepest: usize,
    what: &str,
) {
    let deep = counts.get(&Reached::Deepest).copied().unwrap_or(0);
    let past = deep + counts.get(&Reached::Checked).copied().unwrap_or(0);
    assert!(
        past >= min_checked,
        "{what}: only {past} cases got past the refusals"
    );
    assert!(
        deep >= min_deepest,
        "{what}: only {deep} cases reached the last stage"
    );
}

/// Materials from a picometre to a kilometre of mean free path: the
/// library accepts and tabulates them finitely, or refuses them with a
/// parameter error. Of 64 cases (fixed seed) at least 16 must get through
/// to a tabulated profile and 8 to a fitted kernel.
#[test]
fn extreme_materials_give_finite_profiles_or_errors() {
    let strategy = (
        decades(-13.0, 10.0),
        decades(-13.0, 10.0),
        -0.999f64..0.999,
        decades(-1.0, 1.0),
        0usize..3,
    );
    let counts = run_counted(64, strategy, |(sa, ss, g, eta, model)| {
        let m = half_space([sa, sa * 0.5, sa * 2.0], [ss; 3], g, eta);
        if let Err(e) = m.validate("m") {
            return refusal(e);
        }
        let auto = RadialGrid::for_material(&m, &[]);
        prop_assert!(all_finite(&auto.edges));
        // A few hundred bins over the default radius keeps every case fast.
        let grid = match RadialGrid::uniform(auto.r_max() / 300.0, auto.r_max()) {
            Ok(g) => g,
            Err(e) => return refusal(e),
        };
        let model = [Model::Dipole, Model::Burley, Model::DirectionalDipole][model];
        let p = match analytic::profile(&m, model, &grid, &Options::default()) {
            Ok(p) => p,
            // Unstable or out-of-range models say so in their own words.
            Err(e) => {
                prop_assert!(!e.to_string().is_empty());
                return Ok(Reached::Refused);
            }
        };
        for row in &p.rd {
            prop_assert!(all_finite(row));
        }
        prop_assert!(all_finite(&p.total_rd));
        round_trip(&p);
        fit_stage(&p, false)
    });
    assert_reached(
        &counts,
        16,
        8,
        "materials (profile tabulated, kernel fitted)",
    );
}

/// Profiles with values from 1e-300 to 1e300: refused on validation, or
/// every reader downstream (kernel fit) gives an error or a valid kernel.
/// Of 64 cases at least 16 must pass validation and 8 give a kernel.
#[test]
fn extreme_profiles_are_refused_or_fit() {
    let base = analytic::profile(
        &ssskit::material::preset("skin1").unwrap(),
        Model::Dipole,
        &RadialGrid::uniform(0.05, 2.5).unwrap(),
        &Options::default(),
    )
    .unwrap();
    let strategy = (decades(-300.0, 300.0), decades(-300.0, 300.0), 0usize..50);
    let counts = run_counted(64, strategy, |(scale, spike, at)| {
        let mut p = base.clone();
        for row in p.rd.iter_mut() {
            for v in row.iter_mut() {
                *v *= scale;
            }
            row[at] = spike;
        }
        for t in p.total_rd.iter_mut() {
            *t = (*t * scale).min(1.0);
        }
        if let Err(e) = p.validate("p") {
            return refusal(e);
        }
        round_trip(&p);
        fit_stage(&p, true)
    });
    assert_reached(&counts, 16, 8, "profiles (validated, gave a kernel)");
}

/// Kernels with tap spacings over 24 decades, shifted off centre by up to
/// a thousand taps, weights over 150 decades, applied at any pixel scale
/// (1e-9 to 1e30 mm per pixel): refused on read, refused by the caps, or
/// finite. Of 64 cases at least 16 must pass validation and 8 give an
/// image (the kernel file's own refusals are fuzzed by its reader tests).
#[test]
fn extreme_kernels_are_refused_or_give_finite_images() {
    let strategy = (
        decades(-12.0, 12.0),
        -1e3f64..1e3,
        // Weights from far below to above what sums to 1: a kernel whose
        // 2D sum is under 1e-3 is refused (it would turn the image black),
        // so most cases keep a sum the validation takes.
        decades(-4.0, 1.0),
        0usize..5,
        decades(-9.0, 30.0),
    );
    let img = image(16, 12, &[0.0, 1.0, 0.25, 4.0, 0.5]);
    let counts = run_counted(64, strategy, |(step, shift, weight, half, mm)| {
        let n = 2 * half + 1;
        let offsets: Vec<f64> = (0..n)
            .map(|i| step * (shift + i as f64 - half as f64))
            .collect();
        let weights: Vec<[f64; 3]> = (0..n)
            .map(|i| [weight, weight * (i + 1) as f64, weight])
            .collect();
        let k = kernel_with(vec![Pass {
            offsets_mm: offsets,
            weights,
        }]);
        if let Err(e) = k.validate("k") {
            return refusal(e);
        }
        match apply(&k, &img, mm) {
            Ok(out) => {
                for c in 0..3 {
                    prop_assert!(all_finite(&out.rgb[c]));
                }
                Ok(Reached::Deepest)
            }
            Err(e) => {
                prop_assert!(!e.to_string().is_empty());
                Ok(Reached::Checked)
            }
        }
    });
    assert_reached(&counts, 16, 8, "kernels (validated, gave an image)");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    /// Images with samples from 1e-300 to 1e300 through a real kernel: the
    /// result is finite, and is either written and read back or refused.
    #[test]
    fn extreme_images_are_filtered_finitely_and_written_readably(
        big in decades(-300.0, 300.0),
        small in decades(-300.0, 0.0),
        w in 1usize..24,
        h in 1usize..24,
        png in any::<bool>(),
    ) {
        let k = KernelFile::read(&std::path::Path::new(REPO).join("kernels/skin1-svd1.json")).unwrap();
        let img = image(w, h, &[big, small, 0.0, 1.0]);
        let out = apply(&k, &img, 0.5).unwrap();
        for c in 0..3 {
            prop_assert!(all_finite(&out.rgb[c]));
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(if png { "o.png" } else { "o.exr" });
        match write_image(&path, &out, PngDepth::Sixteen) {
            Ok(()) => {
                let (back, _) = read_image(&path, None).unwrap();
                prop_assert_eq!(back.non_finite().0, 0);
            }
            Err(_) => prop_assert!(!path.exists()),
        }
    }
}

/// Found by the property above: a kernel shifted wholly past the image used
/// to index out of its row; with clamp-to-edge it reads the border pixel.
#[test]
fn a_kernel_shifted_past_the_image_reads_the_border() {
    let k = kernel_with(vec![Pass {
        offsets_mm: vec![41366.0, 41367.0, 41368.0],
        weights: vec![[0.25; 3], [0.5; 3], [0.25; 3]],
    }]);
    let img = image(16, 12, &[0.0, 1.0, 0.25, 4.0, 0.5]);
    let out = apply(&k, &img, 1.0).unwrap();
    // Both passes read the bottom-right pixel: weights sum to 1 per pass.
    for c in 0..3 {
        let corner = img.rgb[c][16 * 12 - 1];
        for v in &out.rgb[c] {
            assert!((v - corner).abs() < 1e-6, "{v} vs {corner}");
        }
    }
}

/// The caps live in `Setup::validate`, which both backends run first: a
/// three-tap kernel 60 mm wide at 1e-6 mm per pixel (6e7 pixels) is refused
/// by the CPU and by wgpu (lavapipe in CI) alike, before any allocation.
#[test]
fn both_backends_refuse_a_kernel_span_over_the_cap() {
    let passes = vec![ssskit::filter::Taps {
        offsets_mm: vec![-30.0, 0.0, 30.0],
        weights: vec![[0.25; 3], [0.5; 3], [0.25; 3]],
    }];
    let setup = common::plain_setup(passes, 1e-6);
    let img = image(16, 12, &[1.0]);
    let e = cpu::apply(&img, &setup).unwrap_err().to_string();
    assert!(
        e.contains("would span") && e.contains("use at least"),
        "{e}"
    );
    ssskit::gpu::use_software_vulkan_if_unset();
    let g = ssskit::filter::gpu::Gpu::new().expect("GPU test needs an adapter (lavapipe in CI)");
    let e = g.apply(&img, &setup).unwrap_err().to_string();
    assert!(
        e.contains("would span") && e.contains("use at least"),
        "{e}"
    );
}
