//! How an engine model is scored against a profile: the least-squares
//! target on r R_d(r) every fit minimises, the model's profile on the
//! input's grid, and its total and shape errors (`profile::metrics`).

use super::{FitError, Scene};
use crate::error::{Error, Result};
use crate::profile::metrics::{self, channel_error, same_grid};
use crate::profile::Profile;
use serde_json::Value;

/// Total and shape error of `model` against `reference` (same grid,
/// channels r, g, b in that order), as `profile::metrics` defines them.
pub fn error(model: &Profile, reference: &Profile) -> Result<FitError> {
    same_grid(model, reference)?;
    check(reference)?;
    if model.rd.len() != 3 || model.total_rd.len() != 3 {
        return Err(Error::Unsupported(format!(
            "the model profile has {} channels: engine parameters are RGB",
            model.rd.len()
        )));
    }
    let e: [_; 3] =
        std::array::from_fn(|c| channel_error(&model.rd[c], model.total_rd[c], reference, c));
    Ok(FitError {
        total: e.map(|e| e.total),
        shape: e.map(|e| e.shape),
    })
}

/// Refuses a profile an engine's RGB parameters cannot be fitted to.
pub fn check(profile: &Profile) -> Result<()> {
    use crate::material::Channel;
    if profile.channels != [Channel::R, Channel::G, Channel::B] {
        return Err(Error::Unsupported(format!(
            "the profile's channels are {:?}: engine parameters need r, g, b in that order",
            profile.channels
        )));
    }
    if let Some(c) = (0..3).find(|&c| !(profile.total_rd[c] > 0.0)) {
        return Err(Error::Unsupported(format!(
            "channel {c} of the profile reflects nothing (total R_d {}): nothing to fit",
            profile.total_rd[c]
        )));
    }
    Ok(())
}

/// Refuses scene units that are not a finite positive length.
pub fn check_scene(scene: Scene) -> Result<()> {
    crate::error::finite_positive("engine", "scene units per mm", scene.units_per_mm, "")?;
    Ok(())
}

/// The engine model's profile on `like`'s grid: `rd` per channel and
/// its totals, named "`engine` (`model`)".
pub fn modelled(
    like: &Profile,
    engine: &str,
    model: &str,
    rd: Vec<Vec<f64>>,
    total_rd: Vec<f64>,
) -> Profile {
    let source = crate::profile::Source {
        kind: "analytic".into(),
        photons: None,
        seed: None,
        model: Some(format!("{engine} ({model})")),
        params: Value::Null,
    };
    like.modelled(source, rd, total_rd)
}

/// Weights and targets of the least squares on r R_d(r): bins inside the
/// radius holding 99% of channel `c`, weight w = bin width r^2 (the
/// discrete norm of `profile::metrics::l2_errors`).
pub(crate) struct Target {
    pub bins: usize,
    pub weight: Vec<f64>,
    pub value: Vec<f64>,
}

impl Target {
    pub fn new(p: &Profile, c: usize) -> Target {
        let r99 = crate::profile::radius_holding(p, c, metrics::SHAPE_HOLD);
        let weight = metrics::shape_weights(p, r99);
        let bins = weight.len();
        Target {
            bins,
            weight,
            value: p.rd[c][..bins].to_vec(),
        }
    }

    /// The squared residual of `a` times `shape`.
    pub fn residual_at(&self, shape: &[f64], a: f64) -> f64 {
        (0..self.bins)
            .map(|i| self.weight[i] * (a * shape[i] - self.value[i]).powi(2))
            .sum()
    }

    /// Best non-negative amplitude for `shape` and its squared residual.
    pub fn scale_of(&self, shape: &[f64]) -> (f64, f64) {
        let (mut sg, mut gg, mut ss) = (0.0, 0.0, 0.0);
        for ((w, g), v) in self.weight.iter().zip(shape).zip(&self.value) {
            sg += w * g * v;
            gg += w * g * g;
            ss += w * v * v;
        }
        let a = if gg > 0.0 { (sg / gg).max(0.0) } else { 0.0 };
        (a, ss - 2.0 * a * sg + a * a * gg)
    }
}
