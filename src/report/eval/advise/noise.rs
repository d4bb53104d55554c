//! The references advise scores against, and how uncertain each score is.
//!
//! A Monte Carlo profile carries a standard error per bin
//! ([`Profile::rd_stderr`]); the exact image a candidate is scored against
//! is a convolution with that profile, so it is uncertain too, and so is
//! every score. The uncertainty is carried by a parametric bootstrap
//! (Efron and Tibshirani 1993, ch. 6): [`REPLICATES`] replicate profiles,
//! each bin drawn around R_d with its standard error, the exact image of
//! each, and the candidate's relative RMS against each; the score's
//! uncertainty is the standard deviation of those replicate scores. Each
//! bin is drawn log-normal with the bin's relative standard error
//! (`R_d exp(s z - s^2 / 2)`, z standard normal, s = se / R_d): its mean
//! is R_d, its standard deviation se to first order in s, and it is
//! never negative, as a reflectance must be (a normal draw would make the
//! far tail's bins negative, which no profile holds).
//!
//! Only the reference is drawn: the candidate is a fixed kernel (the one
//! that would ship, fitted once to the measured profile), and the question
//! is how far it is from the true profile's image, which the measured one
//! estimates to within its Monte Carlo error. Analytic profiles have no
//! standard error: no replicates, zero uncertainty.

use crate::error::{Error, Result};
use crate::filter::diff::RefStack;
use crate::filter::exact::KernelBank;
use crate::filter::{exact, screen_space, Image, Scale, Setup, Taps};
use crate::profile::Profile;
use crate::report::eval::evaluate::{round_f32, Exact, ImageCase};
use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// Replicate profiles of the bootstrap: the standard deviation of K scores
/// is itself uncertain by about 1 / sqrt(2 (K - 1)), 18% at 16, enough to
/// tell a miss of 0.01 points from one of 1 point; each replicate costs
/// one exact convolution per test image.
pub const REPLICATES: usize = 16;

/// Seed of the replicate draws: the same profile gives the same
/// uncertainties, whatever the thread count (replicate i draws from its
/// own stream, seeded with `BOOTSTRAP_SEED + i`).
pub const BOOTSTRAP_SEED: u64 = 0x5353_4b49_545f_4254;

/// A standard normal draw (Box and Muller 1958, the cosine branch).
fn standard_normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    // 53-bit uniforms in (0, 1]: ln never sees 0.
    let u =
        |rng: &mut Xoshiro256PlusPlus| ((rng.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64;
    let (u1, u2) = (u(rng), u(rng));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Replicate `i` of `profile`: each bin drawn log-normal around R_d with
/// its standard error (module doc). None when the profile has no
/// standard errors (analytic) or they are all zero.
pub fn replicate(profile: &Profile, i: usize) -> Option<Profile> {
    let se = profile.rd_stderr.as_ref()?;
    if !se.iter().flatten().any(|&s| s > 0.0) {
        return None;
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(BOOTSTRAP_SEED.wrapping_add(i as u64));
    let mut p = profile.clone();
    for (rd, se) in p.rd.iter_mut().zip(se) {
        for (v, &s) in rd.iter_mut().zip(se) {
            let z = standard_normal(&mut rng);
            if *v > 0.0 && s > 0.0 && s.is_finite() {
                let rel = s / *v;
                *v *= (rel * z - 0.5 * rel * rel).exp();
            }
        }
    }
    Some(p)
}

/// One test image: its exact convolution and the replicates'.
pub struct Reference {
    pub exact: Exact,
    /// `exact`'s image rounded to f32.
    pub exact_f32: Image,
    /// `exact_f32` and then the replicate profiles' exact images, rounded
    /// to f32 (none for an analytic profile), packed to be scored in one
    /// pass.
    stack: RefStack,
    /// The last disk accumulation scored on this image, with its key
    /// (the kernel's fingerprint and frames) and seconds per frame: the
    /// chosen row's is the image its prediction filters again otherwise
    /// ([`super::advise_disk`]).
    last_disk: std::sync::Mutex<Option<(String, u32, Image, f64)>>,
}

/// A candidate's score on one test image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Score {
    /// Largest relative RMS over channels against the exact image.
    pub rel_rms: f64,
    /// Standard deviation of that score over the replicates (0 without).
    pub sigma: f64,
}

/// Bytes the replicates' kernels and spectra may hold at once: the banks
/// are made for a few replicates at a time within it (at 0.05 mm per pixel
/// a skin1 kernel is 801 pixels wide, 15 MB, and a pair's spectra 44 MB).
const REPLICATE_BYTES: usize = 160 << 20;

/// Per case, the replicate profiles' exact images rounded to f32, in the
/// order of `reps`: their kernels are integrated together (one radial grid,
/// [`exact::reference_kernels`]) and their convolutions share their
/// transforms ([`KernelBank`], two kernels a spectrum), a group of
/// replicates at a time within [`REPLICATE_BYTES`]. The groups hold whole
/// pairs and pad as one bank of all would, so each image is the one bank's,
/// bit for bit.
fn replicate_images(reps: &[Profile], cases: &[ImageCase], scale: f64) -> Result<Vec<Vec<Image>>> {
    let mut out: Vec<Vec<Image>> = cases.iter().map(|_| Vec::new()).collect();
    let (Some(first), false) = (cases.first(), reps.is_empty()) else {
        return Ok(out);
    };
    let (w, h) = (first.image.width, first.image.height);
    let sizes: Vec<usize> = reps
        .iter()
        .map(|p| exact::reference_size(p, scale))
        .collect::<Result<_>>()?;
    let widest = sizes.iter().copied().max().unwrap_or(1);
    let half = widest / 2;
    // A replicate's kernel (three f64 planes) and half a pair's spectra.
    let per = 3 * widest * widest * 8 + KernelBank::pair_bytes(w, h, half) / 2;
    let group = (REPLICATE_BYTES / per.max(1)).max(2) & !1;
    for chunk in reps.chunks(group) {
        let kernels = exact::reference_kernels(&chunk.iter().collect::<Vec<_>>(), scale)?;
        let bank = KernelBank::with_half(&kernels.iter().collect::<Vec<_>>(), w, h, half);
        drop(kernels);
        for (images, case) in out.iter_mut().zip(cases) {
            images.extend(bank.convolve(&case.image)?.iter().map(round_f32));
        }
    }
    Ok(out)
}

/// The largest of a relative RMS over channels.
fn largest(rms_rel: [f64; 3]) -> f64 {
    rms_rel.iter().cloned().fold(0.0, f64::max)
}

impl Reference {
    /// The references of `cases`, each with the [`REPLICATES`] replicate
    /// images when `profile` has standard errors.
    pub fn all(profile: &Profile, cases: &[ImageCase]) -> Result<Vec<Reference>> {
        let reps: Vec<Profile> = (0..REPLICATES)
            .map_while(|i| replicate(profile, i))
            .collect();
        let scale = cases.first().map_or(1.0, |c| c.mm_per_pixel);
        if cases.iter().any(|c| c.mm_per_pixel != scale) {
            return Err(Error::Unsupported(
                "advise: the test images differ in scale".into(),
            ));
        }
        // One reference kernel per profile serves every image.
        let k0 = exact::reference_kernel(profile, scale)?;
        let exact: Vec<Exact> = cases
            .par_iter()
            .map(|c| Exact::with_kernel(c, &k0))
            .collect();
        drop(k0);
        let replicates = replicate_images(&reps, cases, scale)?;
        let mut out = Vec::with_capacity(cases.len());
        for (exact, replicates) in exact.into_iter().zip(replicates) {
            let exact_f32 = round_f32(&exact.image);
            let stack = RefStack::new(
                &std::iter::once(&exact_f32)
                    .chain(&replicates)
                    .collect::<Vec<_>>(),
            )?;
            out.push(Reference {
                exact_f32,
                stack,
                exact,
                last_disk: Default::default(),
            });
        }
        Ok(out)
    }

    /// Keeps `image`, the accumulation of `frames` frames of the disk
    /// kernel of fingerprint `key`, made in `seconds` per frame (the last
    /// one kept: one image per reference).
    pub fn keep_disk(&self, key: String, frames: u32, image: Image, seconds: f64) {
        *self.last_disk.lock().unwrap_or_else(|e| e.into_inner()) =
            Some((key, frames, image, seconds));
    }

    /// The image [`Self::keep_disk`] kept for (`key`, `frames`) and its
    /// seconds per frame.
    pub fn kept_disk(&self, key: &str, frames: u32) -> Option<(Image, f64)> {
        let kept = self.last_disk.lock().unwrap_or_else(|e| e.into_inner());
        match &*kept {
            Some((k, f, image, secs)) if k == key && *f == frames => Some((image.clone(), *secs)),
            _ => None,
        }
    }

    /// Replicate images scored against.
    pub fn replicates(&self) -> usize {
        self.stack.len() - 1
    }

    /// The largest relative RMS over channels of `image` against each
    /// replicate's exact image (as `ssskit diff` takes it), and against the
    /// exact image itself first.
    pub fn rel_rms_all(&self, image: &Image) -> Result<Vec<[f64; 3]>> {
        self.stack.rms_rel(image)
    }

    /// The image `passes` make of this reference's test image, rounded to
    /// f32. The search filters with the per-pixel algorithm, whose work
    /// grows with the taps, not with the span in pixels as the
    /// fixed-kernel path's does; both give the same image
    /// (`PixelKernel::from_taps`), up to the order of the sums.
    pub fn filtered(&self, passes: Vec<Taps>) -> Result<Image> {
        let setup = Setup {
            passes,
            scale: Scale::MmPerPixel(self.exact.case.mm_per_pixel),
            depth: None,
            strength: None,
            follow_surface: None,
            specular: None,
            jitter: false,
        };
        setup.validate(&self.exact.case.image)?;
        Ok(round_f32(&screen_space::apply_screen_space(
            &self.exact.case.image,
            &setup,
        )))
    }

    /// The score of `passes` with its bootstrap uncertainty.
    pub fn score(&self, passes: Vec<Taps>) -> Result<Score> {
        let f = self.filtered(passes)?;
        let all = self.rel_rms_all(&f)?;
        let reps: Vec<f64> = all[1..].iter().map(|&r| largest(r)).collect();
        Ok(Score {
            rel_rms: largest(all[0]),
            sigma: crate::numerics::std_dev(&reps),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The draws are standard normal: mean 0 and variance 1 within 4
    /// standard errors of 20000 draws (se of the mean 1/sqrt(n), of the
    /// variance sqrt(2/n)).
    #[test]
    fn box_muller_is_standard_normal() {
        const N: usize = 20_000;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let z: Vec<f64> = (0..N).map(|_| standard_normal(&mut rng)).collect();
        let mean = z.iter().sum::<f64>() / N as f64;
        let var = z.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (N - 1) as f64;
        let n = N as f64;
        assert!(mean.abs() < 4.0 / n.sqrt(), "mean {mean}");
        assert!((var - 1.0).abs() < 4.0 * (2.0 / n).sqrt(), "variance {var}");
    }
}
