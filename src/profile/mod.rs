//! Radial diffuse reflectance profiles R_d(r): the data type every later stage
//! reads, the radial grid, Fresnel terms, and the two ways to get a profile
//! (Monte Carlo simulation in `mc`, closed-form models in `analytic`).

pub mod analytic;
pub mod fresnel;
pub mod grid;
pub mod grid_spec;
pub mod interp;
pub mod mc;
pub mod metrics;
pub mod radius;
pub mod source;
pub mod transmission;

pub use grid::RadialGrid;
pub use grid_spec::GridSpec;
pub use interp::RadialInterp;
pub use radius::radius_holding;
pub use source::{make_profile, make_profile_on, ProfileSource};

use crate::error::{check_header, Error, Result};
use crate::material::{Channel, Material};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const PROFILE_SCHEMA: &str = "ssskit.profile/1";

/// Largest total reflectance per channel a profile may hold (physically at
/// most 1; see `Profile::validate`).
pub const MAX_TOTAL: f64 = 10.0;

/// Where a profile came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Source {
    /// "monte-carlo" or "analytic".
    pub kind: String,
    /// Photons traced per channel (Monte Carlo).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub photons: Option<Vec<u64>>,
    /// RNG seed (Monte Carlo).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Model name (analytic), e.g. "dipole".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// Free-form parameters of the method (grid rule, Fresnel mode, ...).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub params: serde_json::Value,
}

/// A radially symmetric diffuse reflectance profile, per channel, in mm^-2.
/// Per-channel vectors are indexed like `channels`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    pub schema: String,
    pub material: Material,
    pub units: String,
    pub source: Source,
    pub channels: Vec<Channel>,
    /// Bin edges in mm (n + 1 values, increasing, starting at 0).
    pub r_edges: Vec<f64>,
    /// Bin centres in mm (n values), the `r` of each `rd` value.
    pub r: Vec<f64>,
    /// Bin-averaged R_d, mm^-2: `rd[channel][bin]`.
    pub rd: Vec<Vec<f64>>,
    /// Standard error of each bin (zero for analytic profiles).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rd_stderr: Option<Vec<Vec<f64>>>,
    /// Total diffuse reflectance over the whole plane (including r > r_max).
    pub total_rd: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub total_rd_stderr: Option<Vec<f64>>,
    /// Specular reflection at entry, reported apart from R_d.
    #[serde(default)]
    pub specular: Vec<f64>,
    /// Total transmittance (finite stacks; 0 for a half-space).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmittance: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmittance_stderr: Option<Vec<f64>>,
    /// Fraction absorbed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub absorbed: Option<Vec<f64>>,
    /// Anything else the producer wants to keep (energy balance, truncation
    /// residuals, warnings, ...).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub extra: serde_json::Value,
    /// Wall-clock seconds spent producing the profile.
    pub elapsed_s: f64,
}

impl Profile {
    /// Another model's profile on this one's grid, material and channels:
    /// `source`, its R_d per bin and totals; nothing measured is carried
    /// over (no standard errors, transmittance, absorption, extras or time).
    pub fn modelled(&self, source: Source, rd: Vec<Vec<f64>>, total_rd: Vec<f64>) -> Profile {
        Profile {
            source,
            rd,
            rd_stderr: None,
            total_rd,
            total_rd_stderr: None,
            transmittance: None,
            transmittance_stderr: None,
            absorbed: None,
            extra: serde_json::Value::Null,
            elapsed_s: 0.0,
            ..self.clone()
        }
    }

    /// Index of `ch` in this profile's channel list.
    pub fn channel_index(&self, ch: Channel) -> Option<usize> {
        self.channels.iter().position(|&c| c == ch)
    }

    /// The bin-averaged values of one channel.
    pub fn channel(&self, ch: Channel) -> Result<&[f64]> {
        self.channel_index(ch)
            .map(|i| self.rd[i].as_slice())
            .ok_or_else(|| Error::Unsupported(format!("profile has no channel '{}'", ch.name())))
    }

    /// R_d at radius `r` (mm) by linear interpolation between bin centres;
    /// constant below the first centre, zero beyond the last edge.
    pub fn eval(&self, ch_index: usize, r: f64) -> f64 {
        let rd = &self.rd[ch_index];
        let n = self.r.len();
        if n == 0 || !(r >= 0.0) || r > self.r_edges[n] {
            return 0.0;
        }
        if r <= self.r[0] {
            return rd[0];
        }
        if r >= self.r[n - 1] {
            // Fade linearly to zero at the outer edge to avoid a step.
            let (r0, r1) = (self.r[n - 1], self.r_edges[n]);
            return if r1 > r0 {
                rd[n - 1] * (r1 - r) / (r1 - r0)
            } else {
                0.0
            };
        }
        let i = self.r.partition_point(|&x| x <= r) - 1;
        let t = (r - self.r[i]) / (self.r[i + 1] - self.r[i]);
        rd[i] * (1.0 - t) + rd[i + 1] * t
    }

    /// 2 pi int R_d r dr over the tabulated range (bin averages times annulus
    /// areas): the part of the total inside r_max.
    pub fn tabulated_total(&self, ch_index: usize) -> f64 {
        self.bin_amounts(ch_index).sum()
    }

    /// The reflectance of each bin of channel `ch_index`: its average times
    /// its annulus area.
    pub fn bin_amounts(&self, ch_index: usize) -> impl Iterator<Item = f64> + '_ {
        self.rd[ch_index]
            .iter()
            .zip(self.r_edges.windows(2))
            .map(|(v, e)| v * crate::numerics::annulus_area(e[0], e[1]))
    }

    /// What the maker of the profile warned about (`extra.warnings`: the
    /// grid rule's and the simulation's), none when it recorded none.
    pub fn warnings(&self) -> Result<Vec<String>> {
        Ok(self
            .extra_record("warnings", "a list of sentences")?
            .unwrap_or_default())
    }

    /// Per channel, the diffuse reflectance a simulation scored beyond the
    /// last bin edge (`extra.rd_beyond_rmax`, a fraction of the incident
    /// light, counted in `total_rd` but not in `rd`); `None` when the maker
    /// recorded none (an analytic profile).
    pub fn rd_beyond_rmax(&self) -> Result<Option<Vec<f64>>> {
        let v: Option<Vec<f64>> = self.extra_record("rd_beyond_rmax", "one number per channel")?;
        if let Some(v) = &v {
            if v.len() != self.channels.len() || v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(self.bad_record(
                    "rd_beyond_rmax",
                    &self.extra["rd_beyond_rmax"],
                    "expected one finite number >= 0 per channel",
                ));
            }
        }
        Ok(v)
    }

    /// The angle-resolved tallies of a simulation (`extra.angular`: exit
    /// angles, oblique incidence); `None` when it recorded none.
    pub fn angular(&self) -> Result<Option<mc::Angular>> {
        self.extra_record("angular", "the angle-resolved tables of `ssskit simulate`")
    }

    /// The transmitted light of a simulated finite stack
    /// (`extra.transmittance_profile`: T_d(r) with standard errors, exit
    /// angles when tallied); `None` when it recorded none.
    pub fn transmittance_profile(&self) -> Result<Option<mc::TransmittanceProfile>> {
        let t: Option<mc::TransmittanceProfile> = self.extra_record(
            "transmittance_profile",
            "the transmittance profile of `ssskit simulate`",
        )?;
        if let Some(t) = &t {
            let n = self.r.len();
            let ok = t.td.len() == self.channels.len()
                && t.td_stderr.len() == self.channels.len()
                && t.beyond_rmax.len() == self.channels.len()
                && t.td
                    .iter()
                    .chain(&t.td_stderr)
                    .all(|v| v.len() == n && v.iter().all(|x| x.is_finite() && *x >= 0.0));
            if !ok {
                return Err(self.bad_record(
                    "transmittance_profile",
                    &self.extra["transmittance_profile"],
                    "expected td and td_stderr of one finite value >= 0 per channel and bin",
                ));
            }
        }
        Ok(t)
    }

    /// `extra[key]` read as a `T`; `None` when absent.
    fn extra_record<T: serde::de::DeserializeOwned>(
        &self,
        key: &str,
        expected: &str,
    ) -> Result<Option<T>> {
        let v = &self.extra[key];
        if v.is_null() {
            return Ok(None);
        }
        serde_json::from_value(v.clone())
            .map(Some)
            .map_err(|e| self.bad_record(key, v, &format!("{e}: expected {expected}")))
    }

    fn bad_record(&self, key: &str, v: &serde_json::Value, reason: &str) -> Error {
        Error::invalid(
            format!("profile of '{}'", self.material.name),
            format!("extra.{key}"),
            v,
            reason,
        )
    }

    /// Checks structure and values; `context` names the file in errors.
    pub fn validate(&self, context: &str) -> Result<()> {
        check_header(context, &self.schema, PROFILE_SCHEMA, &self.units)?;
        self.material.validate(context)?;
        self.check_grid(context)?;
        self.check_tables(context)?;
        self.check_totals(context)
    }

    /// Channels, bins, edges from 0 increasing and centres inside them.
    fn check_grid(&self, context: &str) -> Result<()> {
        let bad = |msg: String| Err(Error::format(context, msg));
        let n = self.r.len();
        let nc = self.channels.len();
        if nc == 0 {
            return bad("no channels".into());
        }
        if n == 0 {
            return bad("no radial bins".into());
        }
        if n > crate::limits::MAX_RADIAL_BINS {
            return bad(format!(
                "{n} radial bins, more than {}",
                crate::limits::MAX_RADIAL_BINS
            ));
        }
        if self.r_edges.len() != n + 1 {
            return bad(format!(
                "r_edges has {} values, expected {}",
                self.r_edges.len(),
                n + 1
            ));
        }
        if self.r_edges[0] != 0.0
            || self
                .r_edges
                .windows(2)
                .any(|w| !(w[1] > w[0]) || !w[1].is_finite())
        {
            return bad("r_edges must start at 0 and increase strictly".into());
        }
        if self
            .r
            .iter()
            .zip(self.r_edges.windows(2))
            .any(|(c, e)| !(*c >= e[0] && *c <= e[1]))
        {
            return bad("bin centres r must lie inside their bins".into());
        }
        Ok(())
    }

    /// The reflectance tables and totals: one per channel, of the grid's
    /// size, finite and >= 0.
    fn check_tables(&self, context: &str) -> Result<()> {
        let (n, nc) = (self.r.len(), self.channels.len());
        let per_channel = |name: &str, v: &Vec<f64>| -> Result<()> {
            if v.len() != nc {
                return Err(Error::format(
                    context,
                    format!(
                        "{name} has {} values, expected one per channel ({nc})",
                        v.len()
                    ),
                ));
            }
            if let Some(x) = v.iter().find(|x| !x.is_finite() || **x < 0.0) {
                return Err(Error::format(
                    context,
                    format!("{name} holds {x}: must be finite and >= 0"),
                ));
            }
            Ok(())
        };
        let table = |name: &str, t: &Vec<Vec<f64>>| -> Result<()> {
            if t.len() != nc || t.iter().any(|row| row.len() != n) {
                return Err(Error::format(
                    context,
                    format!("{name} must be {nc} channels x {n} bins"),
                ));
            }
            for (c, row) in t.iter().enumerate() {
                if let Some((i, x)) = row
                    .iter()
                    .enumerate()
                    .find(|(_, x)| !x.is_finite() || **x < 0.0)
                {
                    return Err(Error::format(
                        context,
                        format!(
                            "{name}[{}][{i}] = {x}: must be finite and >= 0",
                            self.channels[c].name()
                        ),
                    ));
                }
            }
            Ok(())
        };
        table("rd", &self.rd)?;
        if let Some(e) = &self.rd_stderr {
            table("rd_stderr", e)?;
        }
        per_channel("total_rd", &self.total_rd)?;
        if let Some(e) = &self.total_rd_stderr {
            per_channel("total_rd_stderr", e)?;
        }
        Ok(())
    }

    /// Energy conservation: R_d integrates to at most 1 over the plane.
    /// MAX_TOTAL leaves room for unnormalised tables; far beyond it the
    /// numbers are not a reflectance and overflow what reads them.
    fn check_totals(&self, context: &str) -> Result<()> {
        let bad = |msg: String| Err(Error::format(context, msg));
        for (c, ch) in self.channels.iter().enumerate() {
            let tab = self.tabulated_total(c);
            for (what, v) in [
                ("2 pi int R_d r dr over r_edges", tab),
                ("total_rd", self.total_rd[c]),
            ] {
                if !(v <= MAX_TOTAL) {
                    return bad(format!(
                        "channel {}: {what} = {v:.4e}, above {MAX_TOTAL} (reflectance is at most 1 \
                         of the incident energy): not a reflectance profile",
                        ch.name()
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads and validates a profile file.
    pub fn read(path: &Path) -> Result<Profile> {
        let p: Profile = crate::io::read_json(path)?;
        p.validate(&path.display().to_string())?;
        Ok(p)
    }

    /// Writes the profile atomically as pretty JSON, after the checks a
    /// reader makes: ssskit never writes a profile it would refuse to read.
    pub fn write(&self, path: &Path) -> Result<()> {
        let mut group = crate::io::AtomicGroup::new();
        self.write_into(&mut group, path)?;
        group.commit()
    }

    /// [`Profile::write`] as part of a group of outputs renamed together.
    pub fn write_into(&self, group: &mut crate::io::AtomicGroup, path: &Path) -> Result<()> {
        crate::io::check_extension(path, &["json"], "profile")?;
        self.validate(&format!("refusing to write {}", path.display()))?;
        group.add_json(path, self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn profile() -> Profile {
        let m = crate::material::preset("skin1").unwrap();
        let grid = RadialGrid::uniform(0.05, 4.0).unwrap();
        analytic::profile(
            &m,
            analytic::Model::Dipole,
            &grid,
            &analytic::Options::default(),
        )
        .unwrap()
    }

    /// The records a simulation leaves in `extra` read back typed; absent
    /// ones are none, malformed ones an error naming the record.
    #[test]
    fn extra_records_read_back_typed() {
        let mut p = profile();
        assert_eq!(p.rd_beyond_rmax().unwrap(), None);
        assert!(p.warnings().unwrap().is_empty());
        p.extra["rd_beyond_rmax"] = json!([1e-4, 0.0, 2e-3]);
        p.extra["warnings"] = json!(["a", "b"]);
        assert_eq!(p.rd_beyond_rmax().unwrap(), Some(vec![1e-4, 0.0, 2e-3]));
        assert_eq!(p.warnings().unwrap(), ["a", "b"]);
        for bad in [json!([1e-4, 0.0]), json!([1e-4, -1.0, 0.0]), json!("x")] {
            p.extra["rd_beyond_rmax"] = bad;
            let e = p.rd_beyond_rmax().unwrap_err().to_string();
            assert!(e.contains("extra.rd_beyond_rmax"), "{e}");
        }
        p.extra["warnings"] = json!([1]);
        let e = p.warnings().unwrap_err().to_string();
        assert!(
            e.contains("extra.warnings") && e.contains("sentences"),
            "{e}"
        );
    }
}
