//! Closed-form diffusion profiles: cheap alternatives to simulation.
//!
//! Every model gives R_d(r) per unit flux incident at normal incidence on a
//! half-space, with the entry transmission 1 - R_sp applied (the Monte Carlo
//! launches photons with that weight), so both kinds of profile compare
//! directly. `profile` tabulates a model on a radial grid as bin averages and
//! reports its total over the whole plane.

pub mod burley;
pub mod dipole;
pub mod directional_dipole;
pub mod pbd;

use super::fresnel::{specular_normal, FresnelMode};
use super::{Profile, RadialGrid, Source, PROFILE_SCHEMA};
use crate::error::{Error, Result};
use crate::material::{Channel, Material, Medium};
// The quadrature lives in `crate::numerics`; the engine's fits still name
// two of its functions through this module.
use crate::numerics::bin_averages_resolved;
use crate::numerics::plane_total;
use rayon::prelude::*;
use serde_json::json;

/// The analytic profile models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// Standard dipole, Jensen et al. 2001.
    Dipole,
    /// Photon beam diffusion, Habel et al. 2013 (multiple + single).
    Pbd,
    /// Normalized diffusion, Christensen and Burley 2015.
    Burley,
    /// Directional dipole, Frisvad et al. 2014, at normal incidence.
    DirectionalDipole,
}

impl Model {
    pub const ALL: [Model; 4] = [
        Model::Dipole,
        Model::Pbd,
        Model::Burley,
        Model::DirectionalDipole,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Model::Dipole => "dipole",
            Model::Pbd => "pbd",
            Model::Burley => "burley",
            Model::DirectionalDipole => "directional-dipole",
        }
    }

    pub fn parse(s: &str) -> Result<Model> {
        Model::ALL
            .into_iter()
            .find(|m| m.name() == s.to_ascii_lowercase())
            .ok_or_else(|| {
                Error::invalid(
                    "analytic profile",
                    "model",
                    s,
                    "expected one of dipole, pbd, burley, directional-dipole",
                )
            })
    }
}

/// Settings shared by all models.
#[derive(Clone, Debug)]
pub struct Options {
    pub fresnel: FresnelMode,
    pub channels: Vec<Channel>,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            fresnel: FresnelMode::Fit,
            channels: Channel::ALL.to_vec(),
        }
    }
}

/// One model set up for one channel's medium.
#[derive(Clone, Debug)]
pub enum ChannelModel {
    Dipole(dipole::Dipole),
    Pbd(Box<pbd::BeamDiffusion>),
    Burley(burley::NormalizedDiffusion),
    DirectionalDipole(directional_dipole::DirectionalDipole),
}

impl ChannelModel {
    /// Sets up `model` for `medium`; `t_entry` is 1 - R_sp. Fails where the
    /// Fresnel fits leave their range (C_phi <= 0 or A not finite).
    pub fn new(model: Model, medium: &Medium, fresnel: FresnelMode, t_entry: f64) -> Result<Self> {
        check_fresnel(model, medium.eta, fresnel)?;
        Ok(match model {
            Model::Dipole => ChannelModel::Dipole(dipole::Dipole::new(medium, fresnel, t_entry)),
            Model::Pbd => {
                ChannelModel::Pbd(Box::new(pbd::BeamDiffusion::new(medium, fresnel, t_entry)))
            }
            Model::Burley => {
                ChannelModel::Burley(burley::NormalizedDiffusion::new(medium, fresnel, t_entry))
            }
            Model::DirectionalDipole => ChannelModel::DirectionalDipole(
                directional_dipole::DirectionalDipole::new(medium, fresnel, t_entry),
            ),
        })
    }

    /// R_d(r) in mm^-2 per unit incident flux.
    pub fn rd(&self, r: f64) -> f64 {
        match self {
            ChannelModel::Dipole(m) => m.rd(r),
            ChannelModel::Pbd(m) => m.rd(r),
            ChannelModel::Burley(m) => m.rd(r),
            ChannelModel::DirectionalDipole(m) => m.rd(r),
        }
    }

    /// Total over the plane: closed form where there is one, otherwise
    /// `plane_total` with the medium's length scales.
    pub fn total(&self, medium: &Medium) -> (f64, &'static str) {
        match self {
            ChannelModel::Dipole(m) => (m.total(), "closed form"),
            ChannelModel::Burley(m) => (m.total(), "closed form"),
            _ => (
                plane_total(|r| self.rd(r), length_scale(medium), decay_length(medium)),
                "radial quadrature",
            ),
        }
    }

    /// Every parameter the model used, for the profile's source.params.
    pub fn params(&self) -> serde_json::Value {
        match self {
            ChannelModel::Dipole(m) => json!({
                "A": m.a,
                "z_r": m.z_r(),
                "z_v": m.z_v(),
                "D": m.medium.diffusion_coefficient(),
                "sigma_tr": m.medium.sigma_tr(),
                "reduced_albedo": m.medium.reduced_albedo(),
            }),
            ChannelModel::Pbd(m) => json!({
                "fresnel_moment1": m.fm1,
                "fresnel_moment2": m.fm2,
                "beam_samples": pbd::BEAM_SAMPLES,
                "D_g": pbd::grosjean_diffusion_coefficient(&m.medium),
                "single_scattering_albedo": m.medium.albedo(),
                "reduced_albedo": m.medium.reduced_albedo(),
                "g": m.medium.g,
            }),
            ChannelModel::Burley(m) => json!({
                "A": m.a,
                "A_source": "standard dipole closed-form total (times 1 - R_sp)",
                "l": m.l,
                "l_source": "transport mean free path 1/sigma_t'",
                "s": m.s,
                "s_source": "searchlight fit 1.85 - A + 7|A - 0.8|^3",
            }),
            ChannelModel::DirectionalDipole(m) => json!({
                "D": m.d,
                "d_e": m.d_e,
                "A": m.a,
                "C_phi": m.c_phi,
                "C_E": m.c_e,
                "sigma_tr": m.sigma_tr,
                "z_v": m.z_v(),
            }),
        }
    }
}

/// Rejects a Fresnel mode whose constants, as `model` uses them, are
/// unphysical at `eta`: the standard dipole (and normalized diffusion, whose
/// albedo is the dipole's total) needs only A = (1 + F_dr) / (1 - F_dr);
/// photon beam diffusion and the directional dipole need C_phi, C_E and
/// A = (1 - C_E) / (2 C_phi) at eta (the directional dipole's exit
/// normalisation C_phi(1/eta) cancels at normal incidence and is never
/// evaluated, so it is not checked).
fn check_fresnel(model: Model, eta: f64, mode: FresnelMode) -> Result<()> {
    let (valid, detail) = match model {
        Model::Dipole | Model::Burley => {
            let a = dipole::boundary_a(eta, mode);
            let f_dr = dipole::diffuse_fresnel(eta, mode);
            (
                a.is_finite() && a > 0.0,
                format!("F_dr = {f_dr:.4}, A = {a:.4}"),
            )
        }
        Model::Pbd | Model::DirectionalDipole => {
            let (c_phi, c_e, a) = (mode.c_phi(eta), mode.c_e(eta), mode.boundary_a(eta));
            (
                c_phi > 0.0 && c_e > 0.0 && a.is_finite() && a > 0.0,
                format!("C_phi = {c_phi:.4}, C_E = {c_e:.4}"),
            )
        }
    };
    if valid {
        return Ok(());
    }
    Err(Error::invalid(
        "Fresnel fits",
        "eta",
        eta,
        format!(
            "the Fresnel fits give {detail} here (outside their range); the exact \
             moments hold at every eta"
        ),
    ))
}

/// The shortest length of the medium: where the profile's structure starts.
fn length_scale(m: &Medium) -> f64 {
    m.mfp().min(1.0 / m.sigma_t())
}

/// The asymptotic decay length 1/sigma_tr (infinite when sigma_a = 0).
fn decay_length(m: &Medium) -> f64 {
    1.0 / m.sigma_tr()
}

/// The default grid, shared with the Monte Carlo tally so that profiles
/// compare bin by bin: `RadialGrid::for_material` (dr = min MFP / 20 as Freude 2014
/// table 6.1, r_max large enough for the tail).
pub fn default_grid(material: &Material, channels: &[Channel]) -> Result<RadialGrid> {
    Ok(RadialGrid::for_material(material, channels))
}

/// Tabulates `model` for a half-space `material` on `grid`: bin averages
/// (finite even where R_d is singular at r = 0), totals over the whole plane,
/// every parameter recorded.
pub fn profile(
    material: &Material,
    model: Model,
    grid: &RadialGrid,
    options: &Options,
) -> Result<Profile> {
    let start = std::time::Instant::now();
    material.validate_named()?;
    if !material.is_half_space() {
        return Err(Error::Unsupported(format!(
            "material '{}' has {} layer(s){}: analytic models describe one semi-infinite \
             layer only; use `ssskit simulate` for layered or finite materials",
            material.name,
            material.layers.len(),
            if material.layers.iter().any(|l| l.thickness.is_some()) {
                " of finite thickness"
            } else {
                ""
            }
        )));
    }
    if options.channels.is_empty() {
        return Err(Error::invalid("channels", "channels", "''", "empty"));
    }
    let specular = specular_normal(material.eta_above, material.layers[0].eta);
    let t_entry = 1.0 - specular;
    let mut rd = Vec::new();
    let mut totals = Vec::new();
    let mut per_channel = serde_json::Map::new();
    let mut extra = serde_json::Map::new();
    // Channels are independent: computed in parallel, collected in order.
    let per: Vec<(Vec<f64>, f64, serde_json::Value, serde_json::Value)> = options
        .channels
        .par_iter()
        .map(|&ch| channel_profile(model, material.top(ch), ch, grid, options.fresnel, t_entry))
        .collect::<Result<_>>()?;
    for (&ch, (bins, total, params, info)) in options.channels.iter().zip(per) {
        per_channel.insert(ch.name().into(), params);
        extra.insert(ch.name().into(), info);
        rd.push(bins);
        totals.push(total);
    }
    let n = options.channels.len();
    Ok(Profile {
        schema: PROFILE_SCHEMA.into(),
        material: material.clone(),
        units: "mm".into(),
        source: Source {
            kind: "analytic".into(),
            photons: None,
            seed: None,
            model: Some(model.name().into()),
            params: json!({
                "fresnel": options.fresnel.name(),
                "entry_transmission": t_entry,
                "grid": {"bins": grid.len(), "r_max": grid.r_max(), "dr_first": grid.edges[1]},
                "bins": bin_quadrature(),
                "channels": per_channel,
            }),
        },
        channels: options.channels.clone(),
        r_edges: grid.edges.clone(),
        r: grid.centres(),
        rd,
        rd_stderr: None,
        total_rd: totals,
        total_rd_stderr: None,
        specular: vec![specular; n],
        transmittance: None,
        transmittance_stderr: None,
        absorbed: None,
        extra: serde_json::Value::Object(extra),
        elapsed_s: start.elapsed().as_secs_f64(),
    })
}

/// The quadrature `profile` tabulates with (`bin_averages_resolved`), as
/// recorded in a profile's `source.params.bins`: enough to recompute every
/// bin from the model.
fn bin_quadrature() -> serde_json::Value {
    use crate::numerics::{FAR_BIN_WIDTHS, FIRST_BIN_RATIO, FIRST_BIN_START};
    json!({
        "average": "int 2 pi r R_d(r) dr over the bin / the bin's area",
        "first_bin": {
            "rule": "8-point Gauss-Legendre on geometric panels",
            "first_panel_of_width": FIRST_BIN_START,
            "ratio": FIRST_BIN_RATIO,
        },
        "far_bins": {
            "rule": "2-point Gauss-Legendre",
            "from_widths": FAR_BIN_WIDTHS,
        },
        "other_bins": "8-point Gauss-Legendre",
    })
}

/// Bins, total, parameters and diagnostics of one channel.
fn channel_profile(
    model: Model,
    medium: Medium,
    ch: Channel,
    grid: &RadialGrid,
    fresnel: FresnelMode,
    t_entry: f64,
) -> Result<(Vec<f64>, f64, serde_json::Value, serde_json::Value)> {
    let cm = ChannelModel::new(model, &medium, fresnel, t_entry)?;
    let bins = bin_averages_resolved(|r| cm.rd(r), &grid.edges);
    if let Some((i, v)) = bins
        .iter()
        .enumerate()
        .find(|(_, v)| !v.is_finite() || **v < 0.0)
    {
        return Err(Error::Unsupported(format!(
            "{} gave R_d = {v} in bin {i} of channel {}: numerically unstable here",
            model.name(),
            ch.name()
        )));
    }
    let (total, method) = cm.total(&medium);
    if !total.is_finite() || total < 0.0 {
        return Err(Error::Unsupported(format!(
            "{} gave total R_d = {total} in channel {}",
            model.name(),
            ch.name()
        )));
    }
    let tabulated: f64 = bins.iter().zip(grid.areas()).map(|(v, a)| v * a).sum();
    let mut params = cm.params();
    params["total_method"] = json!(method);
    let info = json!({
        "tabulated_fraction": if total > 0.0 { tabulated / total } else { 1.0 },
        "reduced_albedo": medium.reduced_albedo(),
        "diffusion_regime": diffusion_regime(&medium),
    });
    Ok((bins, total, params, info))
}

/// Where diffusion theory can be trusted: it needs many scattering events
/// before absorption (reduced albedo near 1).
pub fn diffusion_regime(m: &Medium) -> &'static str {
    let a = m.reduced_albedo();
    if a >= 0.9 {
        "diffusive (reduced albedo >= 0.9)"
    } else if a >= 0.5 {
        "marginal (0.5 <= reduced albedo < 0.9): expect errors of tens of percent"
    } else {
        "not diffusive (reduced albedo < 0.5): diffusion models fail"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::preset;
    use crate::numerics::gauss_legendre;

    #[test]
    fn resolved_bin_averages_match_fine_quadrature() {
        // Against 64 panels of 8-point Gauss-Legendre per bin: every bin to
        // 1e-5 relative, for the singular (Burley, PBD single scattering)
        // and smooth (dipole) profiles.
        let mat = preset("skin1").unwrap();
        let m = mat.top(Channel::B);
        let grid = RadialGrid::uniform(m.mfp() / 20.0, 5.0 * m.mfp()).unwrap();
        for model in Model::ALL {
            let cm = ChannelModel::new(model, &m, FresnelMode::Fit, 1.0).unwrap();
            let fast = bin_averages_resolved(|r| cm.rd(r), &grid.edges);
            for (i, (e, area)) in grid.edges.windows(2).zip(grid.areas()).enumerate() {
                let g = |r: f64| cm.rd(r) * 2.0 * std::f64::consts::PI * r;
                let h = (e[1] - e[0]) / 64.0;
                let fine: f64 = if i == 0 {
                    // Geometric panels resolve the origin independently.
                    plane_total_range(&g, e[1])
                } else {
                    (0..64)
                        .map(|k| gauss_legendre(g, e[0] + k as f64 * h, e[0] + (k + 1) as f64 * h))
                        .sum()
                };
                let fine = fine / area;
                assert!(
                    (fast[i] - fine).abs() <= 1e-5 * fine,
                    "{model:?} bin {i}: {} vs {fine}",
                    fast[i]
                );
            }
        }
    }

    /// int_0^b g by geometric panels of ratio 1.1 from 1e-12 b.
    fn plane_total_range(g: &impl Fn(f64) -> f64, b: f64) -> f64 {
        let (mut lo, mut hi, mut s) = (0.0, b * 1e-12, 0.0);
        while lo < b {
            s += gauss_legendre(g, lo, hi);
            lo = hi;
            hi = (hi * 1.1).min(b);
        }
        s
    }

    #[test]
    fn fresnel_check_tests_the_constants_each_model_uses() {
        // At eta = 3 the moment fits give C_phi < 0 (PBD and the directional
        // dipole cannot use them), but the dipole's F_dr fit is 0.936 there:
        // A = 30, a valid (if strongly mismatched) boundary.
        let m = Medium {
            sigma_a: 0.01,
            sigma_s: 2.0,
            g: 0.0,
            eta: 3.0,
        };
        assert!(FresnelMode::Fit.c_phi(3.0) < 0.0);
        for model in [Model::Dipole, Model::Burley] {
            let cm = ChannelModel::new(model, &m, FresnelMode::Fit, 1.0).unwrap();
            let (total, _) = cm.total(&m);
            assert!(cm.rd(0.1) > 0.0 && total > 0.0 && total < 1.0, "{model:?}");
        }
        if let ChannelModel::Dipole(d) =
            ChannelModel::new(Model::Dipole, &m, FresnelMode::Fit, 1.0).unwrap()
        {
            assert!((d.a - 30.0).abs() < 0.5, "A = {}", d.a);
        }
        for model in [Model::Pbd, Model::DirectionalDipole] {
            assert!(
                ChannelModel::new(model, &m, FresnelMode::Fit, 1.0).is_err(),
                "{model:?}"
            );
            assert!(
                ChannelModel::new(model, &m, FresnelMode::Exact, 1.0).is_ok(),
                "{model:?}"
            );
        }
        // Beyond eta ~ 3.9 the F_dr fit passes 1, and at eta = 0.5 it is
        // -3.6: A < 0 either way, and the dipole is refused too.
        for eta in [4.0, 0.5] {
            let m = Medium { eta, ..m };
            let a = dipole::boundary_a(eta, FresnelMode::Fit);
            assert!(a < 0.0, "eta {eta}: A = {a}");
            assert!(
                ChannelModel::new(Model::Dipole, &m, FresnelMode::Fit, 1.0).is_err(),
                "eta {eta}"
            );
            assert!(
                ChannelModel::new(Model::Dipole, &m, FresnelMode::Exact, 1.0).is_ok(),
                "eta {eta}"
            );
        }
    }

    #[test]
    fn directional_dipole_is_checked_at_its_own_eta_only() {
        // At eta = 0.3 the moment fits are valid (C_phi = 0.17) but not at
        // 1/eta = 3.3 (C_phi < 0). The directional dipole evaluates its
        // constants at eta only, so it is accepted like photon beam
        // diffusion, and its profile is finite and positive.
        let m = Medium {
            sigma_a: 0.01,
            sigma_s: 2.0,
            g: 0.0,
            eta: 0.3,
        };
        let fit = FresnelMode::Fit;
        assert!(fit.c_phi(0.3) > 0.0 && fit.c_e(0.3) > 0.0 && fit.boundary_a(0.3) > 0.0);
        assert!(fit.c_phi(1.0 / 0.3) < 0.0);
        for model in [Model::Pbd, Model::DirectionalDipole] {
            let cm = ChannelModel::new(model, &m, fit, 1.0).unwrap();
            let v = cm.rd(0.5);
            assert!(v.is_finite() && v > 0.0, "{model:?}: {v}");
        }
    }

    #[test]
    fn model_names_round_trip() {
        for m in Model::ALL {
            assert_eq!(Model::parse(m.name()).unwrap(), m);
        }
        assert!(Model::parse("tripole").is_err());
    }
}
