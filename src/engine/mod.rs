//! Engine parameters fitted to a reflectance profile: the values to type
//! into an engine's own diffusion model so that it matches a measured or
//! simulated R_d(r) as closely as that model can.
//!
//! Every engine here renders one of two models: Christensen and Burley's
//! radial normalized diffusion (Unreal, Unity HDRP, Blender's
//! Christensen-Burley) or a separable tap table sampled from Jimenez's skin
//! profile (iryoku, Godot; `jimenez.rs` scores the table as the kernel it
//! stands for). The fit works in the model's own parameters (surface albedo
//! A and shape distance d per channel for Burley; width, strength, falloff
//! and tap count for Jimenez) by least squares on r R_d(r) over the radius holding 99% of the
//! profile, the norm `profiles compare` reports as the shape error; each
//! engine file then converts them to the engine's parameter names, units
//! and world scale, and back (the round trip the tests check).

pub mod blender;
pub mod burley;
pub mod godot;
pub mod hdrp;
pub mod iryoku;
pub mod jimenez;
pub mod unreal;

use crate::error::{Error, Result};
use crate::profile::{Profile, RadialGrid};
use crate::report::compare;
use serde::Serialize;
use serde_json::{Map, Value};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    Unreal,
    UnityHdrp,
    Blender,
    Godot,
    Iryoku,
}

impl Engine {
    pub const ALL: [Engine; 5] = [
        Engine::Unreal,
        Engine::UnityHdrp,
        Engine::Blender,
        Engine::Godot,
        Engine::Iryoku,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Engine::Unreal => "unreal",
            Engine::UnityHdrp => "unity-hdrp",
            Engine::Blender => "blender",
            Engine::Godot => "godot",
            Engine::Iryoku => "iryoku",
        }
    }
}

impl std::str::FromStr for Engine {
    type Err = Error;
    fn from_str(s: &str) -> Result<Engine> {
        Engine::ALL
            .into_iter()
            .find(|e| e.name() == s.to_ascii_lowercase())
            .ok_or_else(|| {
                Error::invalid(
                    "engine",
                    "engine",
                    s,
                    "expected unreal, unity-hdrp, blender, godot or iryoku",
                )
            })
    }
}

/// The fitted profile's error against the input, per channel, as
/// `profiles compare` computes it: total (model - input) / input, and the
/// relative L2 error of r R_d(r) over the radius holding 99% of the input.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitError {
    pub total: [f64; 3],
    pub shape: [f64; 3],
}

/// Parameter name (the engine's) -> its unit and meaning.
pub type Units = std::collections::BTreeMap<String, String>;

/// The answer for one engine: `{"engine", "params", "units", "error"}`.
#[derive(Clone, Debug, Serialize)]
pub struct EngineFit {
    pub engine: String,
    /// The engine version whose conversion chain the parameters follow
    /// (e.g. "Unreal Engine 5.4"), as read from that version's source.
    pub version: String,
    /// Parameter name (the engine's) -> a number or [r, g, b].
    pub params: Map<String, Value>,
    /// Parameter name -> unit and meaning.
    pub units: Units,
    pub error: FitError,
    /// Which of the engine's rendering paths `error` is for (e.g. the
    /// radial Burley path, or the separable tap table).
    pub error_for: String,
    /// What else must hold in the engine for `error` to apply (material
    /// settings, world scale), one sentence each.
    pub requirements: Vec<String>,
    /// Values moved to fit the engine's UI (clamps, rounding) and what
    /// that costs, one sentence each.
    pub warnings: Vec<String>,
    /// The engine model's profile on the input's grid.
    #[serde(skip)]
    pub profile: Profile,
}

/// Scene and engine settings the conversion needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Scene units per millimetre (0.001 for a scene in metres).
    pub units_per_mm: f64,
}

impl Default for Scene {
    fn default() -> Scene {
        Scene {
            units_per_mm: 0.001,
        }
    }
}

/// Fits `engine`'s model to `profile`.
pub fn fit(engine: Engine, profile: &Profile, scene: Scene) -> Result<EngineFit> {
    check(profile)?;
    if !(scene.units_per_mm > 0.0 && scene.units_per_mm.is_finite()) {
        return Err(Error::invalid(
            "engine",
            "scene units per mm",
            scene.units_per_mm,
            "must be finite and > 0",
        ));
    }
    let (params, units, model) = match engine {
        Engine::Unreal => {
            let b = burley::fit(profile)?;
            let (p, u) = unreal::params(&b);
            (p, u, Model::Burley(b))
        }
        Engine::UnityHdrp => {
            let b = burley::fit(profile)?;
            let (p, u) = hdrp::params(&b, scene);
            (p, u, Model::Burley(b))
        }
        Engine::Blender => {
            let b = burley::fit(profile)?;
            let (p, u) = blender::params(&b, scene);
            (p, u, Model::Burley(b))
        }
        // The separable engines fill their whole answer (`jimenez.rs`).
        Engine::Iryoku => return iryoku::fit(profile, scene),
        Engine::Godot => return godot::fit(profile, scene),
    };
    let model_profile = model.profile(profile, engine.name());
    let error = error(&model_profile, profile)?;
    Ok(EngineFit {
        engine: engine.name().into(),
        version: String::new(),
        params,
        units,
        error,
        error_for: String::new(),
        requirements: Vec::new(),
        warnings: Vec::new(),
        profile: model_profile,
    })
}

/// The engine model given its own parameters (as `fit` writes them),
/// tabulated on `profile`'s grid: the round trip of a fit.
pub fn model_from_params(
    engine: Engine,
    params: &Map<String, Value>,
    profile: &Profile,
    scene: Scene,
) -> Result<Profile> {
    check(profile)?;
    let model = match engine {
        Engine::Unreal => Model::Burley(unreal::from_params(params)?),
        Engine::UnityHdrp => Model::Burley(hdrp::from_params(params)?),
        Engine::Blender => Model::Burley(blender::from_params(params, scene)?),
        Engine::Iryoku => {
            Model::Separable(iryoku::from_params(params, scene)?.on_grid(&profile.r_edges)?)
        }
        Engine::Godot => {
            Model::Separable(godot::from_params(params, scene)?.on_grid(&profile.r_edges)?)
        }
    };
    Ok(model.profile(profile, engine.name()))
}

/// Total and shape error of `model` against `reference` (same grid).
pub fn error(model: &Profile, reference: &Profile) -> Result<FitError> {
    let rows = compare::compare(model, reference, 0.0)?;
    if rows.len() != 3 {
        return Err(Error::Unsupported(format!(
            "the profile has {} of the channels r, g, b: engine parameters are RGB",
            rows.len()
        )));
    }
    Ok(FitError {
        total: std::array::from_fn(|c| rows[c].rel_total_error),
        shape: std::array::from_fn(|c| rows[c].rel_l2_error),
    })
}

fn check(profile: &Profile) -> Result<()> {
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

/// A fitted radial model, per channel, or a separable tap table on the
/// profile's grid.
#[derive(Clone, Debug)]
enum Model {
    Burley(burley::Burley),
    Separable(jimenez::Binned),
}

impl Model {
    fn profile(&self, like: &Profile, engine: &str) -> Profile {
        let grid = RadialGrid {
            edges: like.r_edges.clone(),
        };
        let (rd, total_rd, name) = match self {
            Model::Burley(b) => (
                (0..3).map(|c| b.bins(c, &grid)).collect(),
                b.albedo.to_vec(),
                "burley",
            ),
            Model::Separable(b) => (b.rd.to_vec(), b.total.to_vec(), "separable taps"),
        };
        let mut p = like.clone();
        p.source = crate::profile::Source {
            kind: "analytic".into(),
            photons: None,
            seed: None,
            model: Some(format!("{engine} ({name})")),
            params: Value::Null,
        };
        p.rd = rd;
        p.rd_stderr = None;
        p.total_rd = total_rd;
        p.total_rd_stderr = None;
        p.transmittance = None;
        p.transmittance_stderr = None;
        p.absorbed = None;
        p.extra = Value::Null;
        p.elapsed_s = 0.0;
        p
    }
}

/// Golden-section search for the minimum of `f` on [lo, hi] in log space,
/// after a scan of `scan` log-spaced points (the objectives here are
/// smooth but not guaranteed unimodal over decades).
pub(crate) fn minimise_log(f: impl Fn(f64) -> f64, lo: f64, hi: f64, scan: usize) -> f64 {
    let (a, b) = (lo.ln(), hi.ln());
    let xs: Vec<f64> = (0..scan)
        .map(|i| a + (b - a) * i as f64 / (scan - 1) as f64)
        .collect();
    let best = (0..scan)
        .min_by(|&i, &j| f(xs[i].exp()).total_cmp(&f(xs[j].exp())))
        .unwrap_or(0);
    let (mut x0, mut x1) = (xs[best.saturating_sub(1)], xs[(best + 1).min(scan - 1)]);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = x1 - g * (x1 - x0);
    let mut d = x0 + g * (x1 - x0);
    let (mut fc, mut fd) = (f(c.exp()), f(d.exp()));
    for _ in 0..80 {
        if fc < fd {
            x1 = d;
            d = c;
            fd = fc;
            c = x1 - g * (x1 - x0);
            fc = f(c.exp());
        } else {
            x0 = c;
            c = d;
            fc = fd;
            d = x0 + g * (x1 - x0);
            fd = f(d.exp());
        }
        if (x1 - x0).abs() < 1e-10 {
            break;
        }
    }
    (0.5 * (x0 + x1)).exp()
}

/// Weights and targets of the least squares on r R_d(r): bins inside the
/// radius holding 99% of channel `c`, weight w = bin width r^2 (the
/// discrete norm of `compare::l2_errors`).
pub(crate) struct Target {
    pub bins: usize,
    pub weight: Vec<f64>,
    pub value: Vec<f64>,
}

impl Target {
    pub fn new(p: &Profile, c: usize) -> Target {
        let r99 = crate::profile::radius_holding(p, c, 0.99);
        let bins = p.r_edges.windows(2).take_while(|e| e[0] < r99).count();
        Target {
            bins,
            weight: (0..bins)
                .map(|i| (p.r_edges[i + 1] - p.r_edges[i]) * p.r[i] * p.r[i])
                .collect(),
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

fn rgb(v: [f64; 3]) -> Value {
    serde_json::json!(v)
}

/// Reads a number parameter.
pub(crate) fn number(params: &Map<String, Value>, name: &str) -> Result<f64> {
    params
        .get(name)
        .and_then(Value::as_f64)
        .filter(|v| v.is_finite())
        .ok_or_else(|| Error::Unsupported(format!("parameter '{name}' is missing or not a number")))
}

/// Reads an [r, g, b] parameter.
pub(crate) fn triple(params: &Map<String, Value>, name: &str) -> Result<[f64; 3]> {
    let v = params
        .get(name)
        .and_then(Value::as_array)
        .filter(|a| a.len() == 3)
        .ok_or_else(|| Error::Unsupported(format!("parameter '{name}' is not [r, g, b]")))?;
    let mut out = [0.0; 3];
    for c in 0..3 {
        out[c] = v[c].as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            Error::Unsupported(format!("parameter '{name}'[{c}] is not a number"))
        })?;
    }
    Ok(out)
}

/// A parameter map from (name, value, unit) rows.
pub(crate) fn table(rows: Vec<(&str, Value, &str)>) -> (Map<String, Value>, Units) {
    let mut p = Map::new();
    let mut u = Units::new();
    for (name, v, unit) in rows {
        p.insert(name.into(), v);
        u.insert(name.into(), unit.into());
    }
    (p, u)
}

pub(crate) fn color(v: [f64; 3]) -> Value {
    rgb(v)
}
