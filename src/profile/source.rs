//! The one way a command makes a profile from a material: Monte Carlo to a
//! budget or a closed-form model, on a given grid or the method's own.
//! `advise`, `kernels`, `study`, `compare` and `profiles compare` all call
//! [`make_profile_on`], so their seeds, budgets, work caps and Fresnel terms
//! are stated once here (`simulate` and `profile` expose every option of
//! their method and call it directly).

use crate::error::Result;
use crate::material::{Channel, Material};
use crate::numerics::Bounded;
use crate::profile::analytic::{self, Model as AnalyticModel};
use crate::profile::fresnel::FresnelMode;
use crate::profile::mc::{self, McConfig, McOptions, PhotonBudget};
use crate::profile::{Profile, RadialGrid};
use crate::progress::Progress;
use std::time::Instant;

/// Where the profile comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ProfileSource {
    /// Monte Carlo in every channel to `budget`, stopping at `max_work`
    /// events per channel (a fixed count above it is refused up front).
    MonteCarlo {
        budget: PhotonBudget,
        seed: u64,
        max_work: u64,
    },
    /// A closed-form model, with its Fresnel terms.
    Analytic {
        model: AnalyticModel,
        fresnel: FresnelMode,
    },
}

/// Photon cap per channel of the pipeline's Monte Carlo: the tracer's, so
/// that a preset stops on its target, not on this cap (the most a preset
/// takes under the default rule is coffee's 9.6M, docs/records/mc-presets.json).
pub const MC_MAX_PHOTONS: u64 = mc::DEFAULT_MAX_PHOTONS;
/// Event cap per channel of the pipeline's Monte Carlo (about 4 s of
/// one core at 2.5e7 events/s): keeps slow media (albedo near 1) inside the
/// pipeline's minute.
pub const MC_MAX_WORK: u64 = 100_000_000;
pub const MC_SEED: u64 = mc::DEFAULT_SEED;

/// The one default stopping rule of every Monte Carlo profile the command
/// line makes (`simulate`, `scene`, and the pipeline: `kernels`, `advise`,
/// `compare`, the study's reference): the kernel-factor rule at
/// [`mc::DEFAULT_KERNEL_ERROR`], with the tracer's absolute floor
/// ([`mc::DEFAULT_ABS_FLOOR`], in [`McOptions::default`]). It bounds the
/// error of what the pipeline uses, the pre-integrated kernel factor and
/// its colour, rather than of the profile's bins.
pub fn default_budget(max_photons: u64) -> PhotonBudget {
    PhotonBudget::KernelFactor {
        rel: mc::DEFAULT_KERNEL_ERROR,
        max_photons,
    }
}

impl ProfileSource {
    /// The pipeline's Monte Carlo: [`default_budget`] with at most
    /// `max_photons` photons and [`MC_MAX_WORK`] events per channel.
    pub fn monte_carlo(max_photons: u64, seed: u64) -> ProfileSource {
        ProfileSource::MonteCarlo {
            budget: default_budget(max_photons),
            seed,
            max_work: MC_MAX_WORK,
        }
    }

    /// Monte Carlo to `rel_error` by the total-and-profile rule, with the
    /// pipeline's work cap.
    pub fn target_error(rel_error: f64, max_photons: u64, seed: u64) -> ProfileSource {
        ProfileSource::MonteCarlo {
            budget: PhotonBudget::TargetError {
                rel: rel_error,
                max_photons,
            },
            seed,
            max_work: MC_MAX_WORK,
        }
    }

    /// Monte Carlo with `photons` per channel, under the tracer's default
    /// work cap.
    pub fn photons(photons: u64, seed: u64) -> ProfileSource {
        ProfileSource::MonteCarlo {
            budget: PhotonBudget::Fixed(photons),
            seed,
            max_work: mc::DEFAULT_MAX_WORK,
        }
    }

    /// A closed-form model with the fitted Fresnel moments.
    pub fn analytic(model: AnalyticModel) -> ProfileSource {
        ProfileSource::Analytic {
            model,
            fresnel: FresnelMode::Fit,
        }
    }

    pub fn describe(&self) -> String {
        match self {
            ProfileSource::MonteCarlo { budget, seed, .. } => match *budget {
                PhotonBudget::Fixed(n) => {
                    format!("Monte Carlo, {n} photons per channel (seed {seed})")
                }
                PhotonBudget::TargetError { rel, max_photons } => format!(
                    "Monte Carlo to {:.1}% relative standard error of total R_d and profile \
                     (rule {}, at most {max_photons} photons per channel, seed {seed})",
                    Bounded(100.0 * rel),
                    budget.rule()
                ),
                // The floor is the one `make_profile_on` runs with.
                PhotonBudget::KernelFactor { rel, max_photons } => format!(
                    "Monte Carlo to {:.1}% relative error of the 1D kernel factor and of \
                     total R_d (rule {}, absolute floor {:e}, at most {max_photons} photons per \
                     channel, seed {seed})",
                    Bounded(100.0 * rel),
                    budget.rule(),
                    McOptions::default().abs_floor
                ),
            },
            ProfileSource::Analytic { model, fresnel } => match fresnel {
                FresnelMode::Fit => format!("analytic {} (closed form)", model.name()),
                FresnelMode::Exact => format!(
                    "analytic {} (closed form, exact Fresnel moments)",
                    model.name()
                ),
            },
        }
    }
}

/// The profile of `material` from `source` in every channel, and the
/// seconds it took.
pub fn make_profile(
    material: &Material,
    source: &ProfileSource,
    progress: &dyn Progress,
) -> Result<(Profile, f64)> {
    make_profile_on(material, source, None, progress)
}

/// [`make_profile`] on `grid` (None: Monte Carlo's own grid, the analytic
/// models' default grid).
pub fn make_profile_on(
    material: &Material,
    source: &ProfileSource,
    grid: Option<&RadialGrid>,
    progress: &dyn Progress,
) -> Result<(Profile, f64)> {
    let t0 = Instant::now();
    let channels = Channel::ALL.to_vec();
    let p = match source {
        ProfileSource::MonteCarlo {
            budget,
            seed,
            max_work,
        } => {
            let cfg = McConfig {
                budget: budget.clone(),
                seed: *seed,
                threads: None,
                channels,
                grid: grid.cloned(),
            };
            let opts = McOptions {
                max_work: *max_work,
                ..McOptions::default()
            };
            mc::simulate_with(material, &cfg, &opts, progress)?
        }
        ProfileSource::Analytic { model, fresnel } => {
            // The caller's grid is borrowed: `profiles compare` calls this
            // in its timing loop, which should time the model, not a copy.
            let default;
            let grid = match grid {
                Some(g) => g,
                None => {
                    default = analytic::default_grid(material, &channels)?;
                    &default
                }
            };
            let options = analytic::Options {
                fresnel: *fresnel,
                channels,
            };
            analytic::profile(material, *model, grid, &options)?
        }
    };
    Ok((p, t0.elapsed().as_secs_f64()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;

    /// Each source runs the method it names with the settings it states:
    /// the profile's own provenance says so.
    #[test]
    fn each_source_makes_the_profile_it_describes() {
        let m = Material::load("skin1").unwrap();
        let (p, _) = make_profile(&m, &ProfileSource::photons(2000, 7), &NoProgress).unwrap();
        assert_eq!(p.source.kind, "monte-carlo");
        assert_eq!(p.source.seed, Some(7));
        assert_eq!(p.source.photons, Some(vec![2000; 3]));
        assert_eq!(p.channels, Channel::ALL.to_vec());

        let exact = ProfileSource::Analytic {
            model: AnalyticModel::Dipole,
            fresnel: FresnelMode::Exact,
        };
        let fit = ProfileSource::analytic(AnalyticModel::Dipole);
        let (pe, _) = make_profile(&m, &exact, &NoProgress).unwrap();
        let (pf, _) = make_profile(&m, &fit, &NoProgress).unwrap();
        assert_eq!(pe.source.model.as_deref(), Some("dipole"));
        // skin1 has eta 1.4: the exact and fitted Fresnel moments differ,
        // so the source's Fresnel mode must reach the model.
        assert_ne!(pe.total_rd, pf.total_rd);
        assert!(exact.describe().contains("exact"));

        let grid = RadialGrid::uniform(0.05, 4.0).unwrap();
        let (pg, _) = make_profile_on(&m, &fit, Some(&grid), &NoProgress).unwrap();
        assert_eq!(pg.r_edges, grid.edges);
    }

    /// The pipeline's default is the kernel-factor rule, and each rule's
    /// description names the rule and the error it bounds.
    #[test]
    fn each_rule_describes_itself() {
        let d = ProfileSource::monte_carlo(MC_MAX_PHOTONS, MC_SEED);
        let ProfileSource::MonteCarlo { budget, .. } = &d else {
            panic!("{d:?}")
        };
        assert_eq!(budget.rule(), "kernel-factor");
        let text = d.describe();
        assert!(text.contains("rule kernel-factor"), "{text}");
        assert!(
            text.contains("0.5% relative error of the 1D kernel factor"),
            "{text}"
        );
        assert!(text.contains("absolute floor 2e-6"), "{text}");
        let t = ProfileSource::target_error(0.02, 1000, 1).describe();
        assert!(t.contains("rule total-and-profile"), "{t}");
        assert!(
            t.contains("2.0% relative standard error of total R_d and profile"),
            "{t}"
        );
    }

    /// A fixed count over the source's work cap is refused before tracing.
    #[test]
    fn a_fixed_count_over_the_work_cap_is_refused() {
        let m = Material::load("skin1").unwrap();
        let s = ProfileSource::MonteCarlo {
            budget: PhotonBudget::Fixed(1_000_000),
            seed: 1,
            max_work: 1000,
        };
        let e = make_profile(&m, &s, &NoProgress).unwrap_err().to_string();
        assert!(e.contains("max_work"), "{e}");
    }
}
