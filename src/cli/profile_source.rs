//! Flags shared by the commands that make their own profile (advise,
//! kernels, study): where the profile comes from, and the test images
//! kernels and study measure on and where their report goes.

use super::errors::{between, invalid, positive};
use clap::ValueEnum;
use ssskit::profile::analytic::Model as AnalyticModel;
use ssskit::profile::Profile;
use ssskit::report::pipeline::{ProfileSource, MC_MAX_PHOTONS, MC_SEED};
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ProfileModelArg {
    /// Monte Carlo to --mc-error relative standard error.
    Mc,
    /// Photon beam diffusion (closed form, instant).
    Pbd,
    Dipole,
    Burley,
}

#[derive(clap::Args)]
pub struct ProfileArgs {
    /// Material preset or TOML file.
    #[arg(long)]
    pub material: Option<String>,
    /// Use this profile (ssskit.profile/1 JSON) instead of making one.
    #[arg(long, value_name = "FILE.json", conflicts_with_all = ["material", "profile_model"])]
    pub profile: Option<PathBuf>,
    /// How to make the profile from --material.
    #[arg(long, value_enum)]
    pub profile_model: Option<ProfileModelArg>,
    /// Monte Carlo: target relative standard error.
    #[arg(long, default_value_t = 0.02)]
    pub mc_error: f64,
    /// Monte Carlo: photons per channel at most.
    #[arg(long, default_value_t = MC_MAX_PHOTONS)]
    pub mc_photons: u64,
    /// Monte Carlo seed.
    #[arg(long, default_value_t = MC_SEED)]
    pub seed: u64,
}

/// What kernels and study measure on and where their report goes.
#[derive(clap::Args)]
pub struct ReportArgs {
    /// Surface millimetres per pixel of the test images: the scale the
    /// image-space errors (and a recommendation) are for.
    #[arg(long, default_value_t = 0.1)]
    pub mm_per_pixel: f64,
    /// Side of the square test signals, pixels.
    #[arg(long, default_value_t = 128)]
    pub size: usize,
    /// Skip the PNG plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Output folder (created).
    #[arg(long)]
    pub out: PathBuf,
}

impl ReportArgs {
    pub fn check(&self) -> anyhow::Result<()> {
        positive("--mm-per-pixel", self.mm_per_pixel)?;
        between("--size", self.size, 8, 1024)?;
        Ok(())
    }
}

impl ProfileArgs {
    pub fn source(&self, default: ProfileModelArg) -> anyhow::Result<ProfileSource> {
        Ok(match self.profile_model.unwrap_or(default) {
            ProfileModelArg::Mc => {
                if !(self.mc_error > 0.0 && self.mc_error < 1.0) {
                    return Err(invalid("--mc-error", self.mc_error, "must be in (0, 1)"));
                }
                if self.mc_photons == 0 {
                    return Err(invalid("--mc-photons", 0, "must be > 0"));
                }
                ProfileSource::MonteCarlo {
                    rel_error: self.mc_error,
                    max_photons: self.mc_photons,
                    seed: self.seed,
                }
            }
            ProfileModelArg::Pbd => ProfileSource::Analytic(AnalyticModel::Pbd),
            ProfileModelArg::Dipole => ProfileSource::Analytic(AnalyticModel::Dipole),
            ProfileModelArg::Burley => ProfileSource::Analytic(AnalyticModel::Burley),
        })
    }

    /// The profile and a sentence saying where it came from.
    pub fn load(&self, default: ProfileModelArg) -> anyhow::Result<(Profile, String)> {
        if let Some(p) = &self.profile {
            let profile = Profile::read(p)?;
            return Ok((profile, format!("read from {}", p.display())));
        }
        let Some(name) = &self.material else {
            anyhow::bail!("give --material NAME (a preset or a TOML file) or --profile FILE.json");
        };
        let material = ssskit::material::Material::load(name)?;
        let source = self.source(default)?;
        let (profile, secs) = ssskit::report::pipeline::make_profile(
            &material,
            &source,
            &super::progress::Bar::new(),
        )?;
        for w in profile.warnings()? {
            super::errors::warn(&w);
        }
        let photons = profile
            .source
            .photons
            .as_ref()
            .map(|p| format!(", {p:?} photons"))
            .unwrap_or_default();
        Ok((
            profile,
            format!("{}{photons}, {secs:.1} s", source.describe()),
        ))
    }
}

/// The command line as a report prints it, the output folder as "OUT".
pub fn command_line(out: &std::path::Path) -> String {
    let o = out.display().to_string();
    let mut v = vec!["ssskit".to_string()];
    v.extend(std::env::args().skip(1).map(|s| {
        if s == o {
            "OUT".into()
        } else if s.is_empty() || s.contains(' ') {
            format!("'{s}'")
        } else {
            s
        }
    }));
    v.join(" ")
}
