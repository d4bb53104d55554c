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
                    "--model",
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
        check_fresnel(medium.eta, fresnel)?;
        if model == Model::DirectionalDipole {
            // The directional dipole's exit normalisation uses C_phi(1/eta).
            check_fresnel(1.0 / medium.eta, fresnel)?;
        }
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
                "z_r": m.medium.mfp(),
                "z_v": m.medium.mfp() + 4.0 * m.a * m.medium.diffusion_coefficient(),
                "D": m.medium.diffusion_coefficient(),
                "sigma_tr": m.medium.sigma_tr(),
                "reduced_albedo": m.medium.reduced_albedo(),
            }),
            ChannelModel::Pbd(m) => json!({
                "fresnel_moment1": m.fm1,
                "fresnel_moment2": m.fm2,
                "beam_samples": pbd::BEAM_SAMPLES,
                "D_g": (2.0 * m.medium.sigma_a + m.medium.sigma_s_reduced())
                    / (3.0 * m.medium.sigma_t_reduced().powi(2)),
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
                "z_v": 2.0 * m.a * m.d_e,
            }),
        }
    }
}

/// Rejects a Fresnel mode whose constants are unphysical at `eta`.
fn check_fresnel(eta: f64, mode: FresnelMode) -> Result<()> {
    let (c_phi, a) = (mode.c_phi(eta), mode.boundary_a(eta));
    let c_e = mode.c_e(eta);
    if !(c_phi > 0.0 && c_e > 0.0 && a.is_finite() && a > 0.0) {
        return Err(Error::invalid(
            "--fresnel fit",
            "eta",
            eta,
            format!(
                "the Fresnel moment fits give C_phi = {c_phi:.4}, C_E = {c_e:.4} here \
                 (outside their range); use --fresnel exact"
            ),
        ));
    }
    Ok(())
}

/// The shortest length of the medium: where the profile's structure starts.
fn length_scale(m: &Medium) -> f64 {
    m.mfp().min(1.0 / m.sigma_t())
}

/// The asymptotic decay length 1/sigma_tr (infinite when sigma_a = 0).
fn decay_length(m: &Medium) -> f64 {
    1.0 / m.sigma_tr()
}

/// 2 pi int_0^inf f(r) r dr over the whole plane for a profile with
/// structure from `scale` and asymptotic decay exp(-r / decay) (decay may be
/// infinite, e.g. sigma_a = 0, where diffusion profiles fall like r^-3):
/// 8-point Gauss-Legendre on geometric panels (ratio 1.15) from 1e-6 scale
/// out to min(80 decay, 1e7 scale), plus the tail of an r^-3 fall-off,
/// 2 pi R^2 f(R), which is exact for the power law and negligible after an
/// exponential decay of 80 lengths.
pub fn plane_total(f: impl Fn(f64) -> f64, scale: f64, decay: f64) -> f64 {
    let g = |r: f64| f(r) * 2.0 * std::f64::consts::PI * r;
    let end = (80.0 * decay).min(1e7 * scale).max(100.0 * scale);
    let (mut a, mut b) = (0.0, scale * 1e-6);
    let mut s = 0.0;
    while a < end {
        let b_clamped = b.min(end);
        s += gauss_legendre(g, a, b_clamped);
        a = b_clamped;
        b = b_clamped * 1.15;
    }
    let tail = 2.0 * std::f64::consts::PI * end * end * f(end);
    s + if tail.is_finite() { tail.max(0.0) } else { 0.0 }
}

/// The default grid, shared with the Monte Carlo tally so that profiles
/// compare bin by bin: `RadialGrid::for_material` (dr = min MFP / 20 as 002
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
    material.validate(&format!("material '{}'", material.name))?;
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
        return Err(Error::invalid("--channels", "channels", "''", "empty"));
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
                "bins": "bin averages, 8-point Gauss-Legendre per bin",
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
    let bins = bin_averages_resolved(|r| cm.rd(r), grid);
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

/// Bin averages of a radial function over annuli: int f(r) 2 pi r dr / area,
/// by 8-point Gauss-Legendre per bin. Averages stay finite where f has an
/// integrable singularity at r = 0 because no node sits at r = 0.
pub fn bin_averages(f: impl Fn(f64) -> f64, grid: &RadialGrid) -> Vec<f64> {
    grid.edges
        .windows(2)
        .zip(grid.areas())
        .map(|(e, area)| {
            gauss_legendre(|r| f(r) * 2.0 * std::f64::consts::PI * r, e[0], e[1]) / area
        })
        .collect()
}

/// Bin averages like `bin_averages`, adapted to profiles whose structure
/// scale is the radius itself: the first bin on geometric panels (ratio
/// 1.5, from 1e-9 of its width) so that structure at r -> 0 much finer than
/// the bin (single scattering at depth ~1/sigma_t, the 1/r of normalized
/// diffusion) is resolved; bins starting beyond 8 widths from the origin by
/// 2-point Gauss-Legendre (exact for cubics; for e^{-s r} r^-k with k <= 3
/// the relative error is below (3/8)^4 / 4320 ~ 5e-6); the rest by 8 points.
pub fn bin_averages_resolved(f: impl Fn(f64) -> f64, grid: &RadialGrid) -> Vec<f64> {
    let g = |r: f64| f(r) * 2.0 * std::f64::consts::PI * r;
    grid.edges
        .windows(2)
        .zip(grid.areas())
        .map(|(e, area)| {
            let (a, b) = (e[0], e[1]);
            let integral = if a == 0.0 {
                let (mut lo, mut hi) = (0.0, b * 1e-9);
                let mut s = 0.0;
                while lo < b {
                    s += gauss_legendre(g, lo, hi);
                    lo = hi;
                    hi = (hi * 1.5).min(b);
                }
                s
            } else if a >= 8.0 * (b - a) {
                let (m, h) = (0.5 * (a + b), 0.5 * (b - a) / 3f64.sqrt());
                (b - a) * 0.5 * (g(m - h) + g(m + h))
            } else {
                gauss_legendre(g, a, b)
            };
            integral / area
        })
        .collect()
}

/// 8-point Gauss-Legendre quadrature of `f` over [a, b].
pub fn gauss_legendre(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut s = 0.0;
    for k in 0..4 {
        s += W[k] * (f(m - h * X[k]) + f(m + h * X[k]));
    }
    s * h
}

/// 2 pi int_0^inf f(r) r dr for a profile decaying at least like
/// exp(-r / scale): geometric panels from scale * 1e-6 out to 60 scales.
pub fn radial_total(f: impl Fn(f64) -> f64, scale: f64) -> f64 {
    let g = |r: f64| f(r) * 2.0 * std::f64::consts::PI * r;
    let g = &g;
    let mut a = 0.0;
    let mut b = scale * 1e-6;
    let mut s = 0.0;
    while a < 60.0 * scale {
        s += gauss_legendre(g, a, b);
        a = b;
        b = (b * 1.15).max(b + scale * 1e-6);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::preset;

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
            let fast = bin_averages_resolved(|r| cm.rd(r), &grid);
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
    fn model_names_round_trip() {
        for m in Model::ALL {
            assert_eq!(Model::parse(m.name()).unwrap(), m);
        }
        assert!(Model::parse("tripole").is_err());
    }
}
