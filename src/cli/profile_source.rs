//! Where `advise`, `kernels` and `study` get their profile (the flags are
//! `args::ProfileSourceArgs`): a profile file, or one made from a material
//! by Monte Carlo or an analytic model.

use super::args::{FactorsArg, ProfileSourceArgs};
use super::errors::invalid;
use ssskit::profile::source::ProfileSource;
use ssskit::profile::Profile;

impl ProfileSourceArgs {
    /// How the profile is made from `--material`.
    pub fn source(&self) -> anyhow::Result<ProfileSource> {
        let model = self
            .model
            .profile_model
            .ok_or_else(|| anyhow::anyhow!("give --profile-model"))?;
        Ok(match model.analytic() {
            Some(m) => ProfileSource::analytic(m),
            None => {
                let max_photons = self.max_photons.max_photons;
                if max_photons == 0 {
                    return Err(invalid("--max-photons", 0, "must be > 0"));
                }
                match self.mc_error.mc_error {
                    None => ProfileSource::monte_carlo(max_photons, self.seed.seed),
                    Some(rel) if !(rel > 0.0 && rel < 1.0) => {
                        return Err(invalid("--mc-error", rel, "must be in (0, 1)"))
                    }
                    Some(rel) => ProfileSource::target_error(rel, max_photons, self.seed.seed),
                }
            }
        })
    }

    /// Whether --profile or --material was given.
    pub fn given(&self) -> bool {
        self.profile.profile.is_some() || self.material.material.is_some()
    }

    /// The profile and a sentence saying where it came from.
    pub fn load(&self) -> anyhow::Result<(Profile, String)> {
        if let Some(p) = &self.profile.profile {
            let profile = Profile::read(p)?;
            return Ok((profile, format!("read from {}", p.display())));
        }
        let Some(name) = &self.material.material else {
            anyhow::bail!("give --material NAME (a preset or a TOML file) or --profile FILE.json");
        };
        let material = ssskit::material::Material::load(name)?;
        let source = self.source()?;
        let (profile, secs) = ssskit::profile::source::make_profile(
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

impl ProfileSourceArgs {
    /// [`Self::load`], and for a profile made from --material by Monte
    /// Carlo the angular entry and exit factors unless `--no-factors`
    /// (a run the Monte Carlo refuses is a warning: the kernels then go
    /// without). A profile left without them says so in one line.
    pub fn load_with_factors(&self, factors: &FactorsArg) -> anyhow::Result<(Profile, String)> {
        let (profile, source) = self.load()?;
        self.with_factors(profile, source, factors)
    }

    /// [`Self::load_with_factors`], or where a scene's render is given
    /// (`rendered`: its profiles) and no profile source is, the render's
    /// own profile of its first object (the material it was rendered with,
    /// to its Monte Carlo error) with the factors.
    pub fn load_for_scene(
        &self,
        rendered: Option<&[Profile]>,
        factors: &FactorsArg,
    ) -> anyhow::Result<(Profile, String)> {
        match rendered {
            Some(profiles) if !self.given() => match profiles.first() {
                Some(p) => self.with_factors(
                    p.clone(),
                    "the render's (its first object's)".to_string(),
                    factors,
                ),
                None => anyhow::bail!("--render: its record holds no profile: give --material"),
            },
            _ => self.load_with_factors(factors),
        }
    }

    /// `profile` (from `source`) with the entry and exit factors attached
    /// where `factors` asks for them and it has none: a Monte Carlo
    /// profile gets its material's factor run, any other says in one line
    /// what is missing.
    pub fn with_factors(
        &self,
        mut profile: Profile,
        mut source: String,
        factors: &FactorsArg,
    ) -> anyhow::Result<(Profile, String)> {
        use ssskit::kernel::angular::{self, AngularFactors};
        if factors.no_factors {
            // Said on the profile, so that the kernels and the scene check
            // of the advice leave them out too.
            angular::leave_out(&mut profile);
            return Ok((profile, source));
        }
        if AngularFactors::from_profile(&profile)?.is_some() {
            return Ok((profile, source));
        }
        if self.profile.profile.is_some() || profile.source.kind != "monte-carlo" {
            super::errors::warn(&angular::missing_note(&profile));
            return Ok((profile, source));
        }
        let t0 = std::time::Instant::now();
        let events: Option<Vec<f64>> =
            serde_json::from_value(profile.extra["events_per_photon"].clone()).ok();
        let photons = angular::photons_within_work(events.as_deref());
        match angular::simulate_factors(
            &profile.material,
            photons,
            self.seed.seed,
            None,
            &super::progress::Bar::new(),
        ) {
            Ok(f) => {
                angular::attach(&mut profile, &f);
                source += &format!(
                    "; entry and exit factors from {photons} photons per channel and incidence, \
                     {:.1} s",
                    t0.elapsed().as_secs_f64()
                );
            }
            Err(e) => super::errors::warn(&format!(
                "the entry and exit factors' Monte Carlo run was refused ({e}): the kernels \
                 carry no factors"
            )),
        }
        Ok((profile, source))
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
