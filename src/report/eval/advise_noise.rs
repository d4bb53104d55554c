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

use super::evaluate::{round_f32, Exact, ImageCase};
use crate::error::{Error, Result};
use crate::filter::exact::KernelBank;
use crate::filter::{cpu, diff, Image, Scale, Setup, Taps};
use crate::kernel::Kernel2D;
use crate::profile::Profile;
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
    /// The replicate profiles' exact images, rounded to f32 (empty for an
    /// analytic profile).
    pub replicates: Vec<Image>,
}

/// A candidate's score on one test image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Score {
    /// Largest relative RMS over channels against the exact image.
    pub rel_rms: f64,
    /// Standard deviation of that score over the replicates (0 without).
    pub sigma: f64,
}

/// Largest relative RMS over channels of `filtered` against `exact`.
fn rel_rms(exact: &Image, filtered: &Image) -> Result<f64> {
    Ok(diff::compare(exact, filtered)?
        .rms_rel
        .iter()
        .cloned()
        .fold(0.0, f64::max))
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
        // One reference kernel per profile serves every image; the
        // replicates' convolutions share their transforms (KernelBank).
        let k0 = cpu::reference_kernel(profile, scale)?;
        let exact: Vec<Exact> = cases
            .par_iter()
            .map(|c| Exact::with_kernel(c, &k0))
            .collect();
        let kernels: Vec<Kernel2D> = reps
            .par_iter()
            .map(|p| cpu::reference_kernel(p, scale))
            .collect::<Result<_>>()?;
        let bank = (!kernels.is_empty()).then(|| {
            let (w, h) = cases
                .first()
                .map_or((0, 0), |c| (c.image.width, c.image.height));
            KernelBank::new(&kernels.iter().collect::<Vec<_>>(), w, h)
        });
        let mut out = Vec::with_capacity(cases.len());
        for exact in exact {
            let replicates = match &bank {
                Some(b) => b
                    .convolve(&exact.case.image)?
                    .iter()
                    .map(round_f32)
                    .collect(),
                None => Vec::new(),
            };
            out.push(Reference {
                exact_f32: round_f32(&exact.image),
                replicates,
                exact,
            });
        }
        Ok(out)
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
        Ok(round_f32(&cpu::apply_screen_space(
            &self.exact.case.image,
            &setup,
        )))
    }

    /// The score of `passes` with its bootstrap uncertainty.
    pub fn score(&self, passes: Vec<Taps>) -> Result<Score> {
        let f = self.filtered(passes)?;
        let rel = rel_rms(&self.exact_f32, &f)?;
        let reps: Vec<f64> = self
            .replicates
            .iter()
            .map(|r| rel_rms(r, &f))
            .collect::<Result<_>>()?;
        Ok(Score {
            rel_rms: rel,
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
