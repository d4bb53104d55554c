//! Separable against disk kernels at equal samples per pixel, as a user
//! sees them: a rank-1 separable kernel of 2 passes of T taps (T the
//! largest odd count within spp / 2: tap tables have a centre tap) against a disk kernel of N = spp samples, each on one test signal
//! against the exact 2D convolution, with its bias, its noise in one frame
//! and after K frames, and FLIP. A separable kernel is the same every
//! frame (no noise); a disk kernel's bias is the mean over many rotations,
//! its noise measured per frame and over windows of K frames
//! ([`crate::filter::disk_error`]); its FLIP is that of one K-frame
//! accumulation, the image a temporal filter shows.
//!
//! The separable kernel is the pre-integration (Freude 2014, sec. 5.2,
//! the rank-1 model `kernels` lists first) with the tap extent chosen for
//! the count; the disk kernel is the one advise scores
//! ([`crate::report::eval::disk::disk_kernel`]); both against one exact image
//! ([`crate::report::eval::evaluate::Exact`]).

use crate::error::{Error, Result};
use crate::filter::disk::{apply_disk, DiskSetup};
use crate::filter::disk_error::{disk_error, view};
use crate::filter::Which;
use crate::kernel::model::{fit_kernel_file, Model};
use crate::kernel::preintegrate::PreMethod;
use crate::kernel::Kernel2DSpec;
use crate::profile::Profile;
use crate::report::eval::disk::{disk_kernel, DISK_SEED};
use crate::report::eval::evaluate::{self, Exact, ImageCase, Options};
use serde::{Deserialize, Serialize};

/// One kernel of the comparison, each value the largest over channels,
/// relative to the exact image's peak.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EqualCostRow {
    /// The budget of the pair.
    pub budget: usize,
    /// What the kernel fetches: 2 T or N.
    pub samples_per_pixel: usize,
    /// "separable" or "disk".
    pub family: String,
    /// "2 x 8 taps", "16 samples".
    pub layout: String,
    /// Separable: its error (all of it is bias); disk: RMS of the mean over
    /// the rotations less the exact image.
    pub bias: f64,
    /// The bias's own noise floor (disk: the batch-means standard error of
    /// the mean; separable: 0).
    pub bias_noise_floor: f64,
    /// RMS of one frame about the mean (separable: 0).
    pub noise: f64,
    /// The same for the mean of K frames.
    pub noise_after: f64,
    /// Mean LDR-FLIP of the colour image (disk: one K-frame accumulation).
    pub flip: f64,
}

/// What to compare.
#[derive(Clone, Debug)]
pub struct EqualCost {
    pub case: ImageCase,
    /// Samples per pixel of each pair.
    pub samples: Vec<usize>,
    /// Frames accumulated (K).
    pub frames: u32,
    /// Rotations the disk's bias is the mean over (a multiple of K).
    pub rotations: u32,
}

fn largest(v: [f64; 3]) -> f64 {
    v.into_iter().fold(0.0, f64::max)
}

/// The separable and the disk row of `profile` at each samples count.
pub fn equal_cost(profile: &Profile, cfg: &EqualCost) -> Result<Vec<EqualCostRow>> {
    let exact = Exact::new(profile, &cfg.case)?;
    let options = Options::default();
    let mm = cfg.case.mm_per_pixel;
    let mut rows = Vec::new();
    for &spp in &cfg.samples {
        // Tap tables are odd (a centre tap): the largest odd T within
        // spp / 2, so the separable kernel never costs more than the disk.
        let taps = (spp / 2).saturating_sub(1 - (spp / 2) % 2);
        if taps == 0 {
            return Err(Error::invalid(
                "equal cost",
                "samples",
                spp,
                "must be at least 2: two passes of one tap",
            ));
        }
        let model = Model::Preintegrate {
            method: PreMethod::Abel,
        };
        let file = fit_kernel_file(profile, &Kernel2DSpec::default(), &model, taps)?;
        let passes = evaluate::tap_passes(&file, Which::stored(&file), mm)?;
        let (img, _) = evaluate::filter(&cfg.case, passes)?;
        let e = evaluate::errors(&exact, &img, &options)?;
        rows.push(EqualCostRow {
            budget: spp,
            samples_per_pixel: 2 * taps,
            family: "separable".into(),
            layout: format!("2 x {taps} taps"),
            bias: largest(e.rel_rms),
            bias_noise_floor: 0.0,
            noise: 0.0,
            noise_after: 0.0,
            flip: e.flip_rgb,
        });
        let k = disk_kernel(profile, spp)?;
        let setup = DiskSetup::new(&k, view(mm), DISK_SEED, 1);
        let d = disk_error(
            &cfg.case.image,
            &setup,
            &exact.image,
            cfg.rotations,
            cfg.frames,
        )?;
        let acc = apply_disk(&cfg.case.image, &setup.with_frames(DISK_SEED, cfg.frames))?;
        let flip = evaluate::errors(&exact, &acc, &options)?.flip_rgb;
        rows.push(EqualCostRow {
            budget: spp,
            samples_per_pixel: spp,
            family: "disk".into(),
            layout: format!("{spp} samples"),
            bias: largest(d.bias),
            bias_noise_floor: largest(d.bias_noise_floor),
            noise: largest(d.noise),
            noise_after: largest(d.noise_after),
            flip,
        });
    }
    Ok(rows)
}

/// One material's rows on one test image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiskRows {
    pub material: String,
    pub signal: String,
    pub rows: Vec<EqualCostRow>,
}

/// `compare`'s disk rows: for each material and test image, the separable
/// and the disk kernel at the samples per pixel of each separable tap
/// count (2 passes of T taps: 2 T), accumulated over `frames` with the
/// bias over [`crate::report::eval::disk::WINDOWS`] x `frames` rotations, as
/// advise scores them.
pub fn compare_rows(
    inputs: &[super::kernel::MaterialInput],
    cases: &[ImageCase],
    taps: &[usize],
    frames: u32,
) -> Result<Vec<DiskRows>> {
    crate::report::eval::disk::check_frames(frames)?;
    let samples: Vec<usize> = taps.iter().map(|&t| 2 * t).collect();
    let mut out = Vec::new();
    for m in inputs {
        for case in cases {
            let cfg = EqualCost {
                case: case.clone(),
                samples: samples.clone(),
                frames,
                rotations: crate::report::eval::disk::WINDOWS * frames,
            };
            out.push(DiskRows {
                material: m.name.clone(),
                signal: case.name.clone(),
                rows: equal_cost(&m.profile, &cfg)?,
            });
        }
    }
    Ok(out)
}
