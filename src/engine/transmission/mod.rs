//! Each engine's thin-object transmission fitted to a thickness table
//! (`profile::transmission`): the values to type into the engine's
//! transmission settings so that the light its formula lets through a
//! slab of each thickness, lit from directly behind and seen along the
//! normal, matches the table's T, with the error at every thickness.
//!
//! Every engine here computes transmission as a function of one thickness
//! per pixel, from the diffusion profile it renders reflection with
//! (Unreal, HDRP: the Burley profile's integral beyond the thickness) or
//! from a shape of its own (Godot: a Gaussian in the thickness), times
//! colours and a view term; `unreal.rs`, `hdrp.rs` and `godot.rs` write
//! that formula out from each engine's source (files and functions in
//! their headers). The quantity compared is pi L / E: the radiance the
//! engine's formula puts on the unlit face over the irradiance of the
//! light behind, against the slab's T (the exitance of a Lambertian
//! exit, which is what the engines' diffuse transmission term models).
//! The fit minimises the squared log ratio over the table's rows whose T
//! stands `SIGNIFICANT` standard errors above 0; the error is computed
//! from the printed (rounded) values. Cycles needs none of this: its
//! Random Walk walks through the mesh itself, so a thin part transmits
//! what the medium transmits.

pub mod files;
pub mod godot;
pub mod hdrp;
pub mod unreal;

use super::printed::table;
use super::{Engine, EngineFit, Scene};
use crate::error::{Error, Result};
use crate::material::Channel;
use crate::numerics::minimise_log;
use crate::profile::transmission::ThicknessTable;
use serde::Serialize;
use serde_json::{Map, Value};

/// Standard errors a row's T must stand above 0 to enter a fit: below it
/// the Monte Carlo cannot tell the light from nothing.
pub const SIGNIFICANT: f64 = 4.0;

/// An engine's transmission settings fitted to a table, with the light
/// they let through at every thickness of the table.
#[derive(Clone, Debug, Serialize)]
pub struct TransmissionFit {
    pub engine: String,
    /// The engine's source the formula was read in: files, functions and
    /// release.
    pub source: String,
    /// Setting name (the engine's UI or asset field) -> value.
    pub params: Map<String, Value>,
    /// Setting name -> unit, range and meaning.
    pub units: Map<String, Value>,
    pub thickness_mm: Vec<f64>,
    /// The table's scattered T per row and channel (r, g, b) and its
    /// standard error.
    pub table: Vec<[f64; 3]>,
    pub table_stderr: Vec<[f64; 3]>,
    /// pi L / E of the engine's formula from the printed values.
    pub engine_t: Vec<[f64; 3]>,
    /// engine / table - 1 per row and channel (None where the table holds
    /// no significant light).
    pub rel_error: Vec<[Option<f64>; 3]>,
    /// RMS of ln(engine / table) over the significant rows, per channel.
    pub rms_log_error: [f64; 3],
    /// What else must hold in the engine for the error to apply.
    pub requirements: Vec<String>,
    /// Values moved to fit the engine's ranges, and what that costs.
    pub warnings: Vec<String>,
    /// The formula with the printed settings, to evaluate elsewhere.
    #[serde(skip)]
    pub model: Option<Model>,
}

/// An engine's transmission formula with its printed settings.
#[derive(Clone, Debug)]
pub enum Model {
    Unreal(unreal::Settings, unreal::Reflection, Scene),
    /// Settings, S per channel, Base Map colour, the thickness map's scale.
    Hdrp(hdrp::Settings, [f64; 3], [f64; 3], f64),
    /// Depth, linear colour, albedo, scene.
    Godot(f64, [f64; 3], [f64; 3], Scene),
}

/// Where an engine reads the thickness it transmits through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThicknessSource {
    /// The light's shadow map: the depth difference along the light.
    ShadowMap,
    /// A baked thickness map: the object's thickness through its surface.
    ThicknessMap,
}

impl Model {
    pub fn thickness_source(&self) -> ThicknessSource {
        match self {
            Model::Hdrp(..) => ThicknessSource::ThicknessMap,
            _ => ThicknessSource::ShadowMap,
        }
    }

    /// pi L / E on a pixel whose thickness (from `thickness_source`) is
    /// `t_mm`, with `n_dot_l` its normal against the light and `back_cos`
    /// = dot(-L, V).
    pub fn eval(&self, t_mm: f64, n_dot_l: f64, back_cos: f64) -> [f64; 3] {
        match self {
            Model::Unreal(s, r, scene) => unreal::rendered_at(s, r, *scene, t_mm, back_cos),
            Model::Hdrp(s, shape, base, map) => {
                hdrp::rendered_at(s, *shape, *base, t_mm, *map, n_dot_l)
            }
            Model::Godot(d, c, a, scene) => godot::rendered_at(*d, *c, *a, *scene, t_mm, n_dot_l),
        }
    }
}

impl TransmissionFit {
    /// The largest |engine / table - 1| over the significant rows, per
    /// channel.
    pub fn worst(&self) -> [f64; 3] {
        std::array::from_fn(|c| {
            self.rel_error
                .iter()
                .filter_map(|e| e[c])
                .fold(0.0f64, |m, e| m.max(e.abs()))
        })
    }
}

/// The rows of a table as a fit sees them: thicknesses (mm), T and its
/// standard error per channel r, g, b, and which values are significant.
pub struct Target {
    pub thickness: Vec<f64>,
    pub t: Vec<[f64; 3]>,
    pub se: Vec<[f64; 3]>,
    pub significant: Vec<[bool; 3]>,
}

impl Target {
    pub fn new(table: &ThicknessTable) -> Result<Target> {
        let idx: Vec<usize> = Channel::ALL
            .iter()
            .map(|&c| table.channel_index(c))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| {
                Error::Unsupported(format!(
                    "the table's channels are {:?}: engine settings need r, g and b",
                    table.channels
                ))
            })?;
        let per = |v: &[f64]| -> [f64; 3] { std::array::from_fn(|c| v[idx[c]]) };
        let t: Vec<[f64; 3]> = table.rows.iter().map(|r| per(&r.diffuse)).collect();
        let se: Vec<[f64; 3]> = table.rows.iter().map(|r| per(&r.diffuse_stderr)).collect();
        let significant: Vec<[bool; 3]> = t
            .iter()
            .zip(&se)
            .map(|(t, s)| std::array::from_fn(|c| t[c] > 0.0 && t[c] > SIGNIFICANT * s[c]))
            .collect();
        if let Some(c) = (0..3).find(|&c| significant.iter().all(|s| !s[c])) {
            return Err(Error::Unsupported(format!(
                "channel {} of the table transmits no significant light at any thickness: \
                 nothing to fit (thinner slabs, or more photons)",
                Channel::ALL[c].name()
            )));
        }
        Ok(Target {
            thickness: table.thicknesses(),
            t,
            se,
            significant,
        })
    }

    /// The best amplitude k per channel for a model `shape` (per row and
    /// channel) in the log least squares, and the summed squared log
    /// residual: ln k = mean over significant rows of ln(T / shape).
    pub fn amplitude(&self, shape: &[[f64; 3]]) -> ([f64; 3], f64) {
        let mut k = [0.0; 3];
        let mut cost = 0.0;
        for c in 0..3 {
            let logs: Vec<f64> = (0..self.t.len())
                .filter(|&i| self.significant[i][c])
                .map(|i| (self.t[i][c] / shape[i][c].max(TINY)).ln())
                .collect();
            let mean = logs.iter().sum::<f64>() / logs.len().max(1) as f64;
            k[c] = mean.exp();
            cost += logs.iter().map(|l| (l - mean).powi(2)).sum::<f64>();
        }
        (k, cost)
    }

    /// The squared log residual of a complete model.
    pub fn cost(&self, model: &[[f64; 3]]) -> f64 {
        (0..self.t.len())
            .flat_map(|i| (0..3).map(move |c| (i, c)))
            .filter(|&(i, c)| self.significant[i][c])
            .map(|(i, c)| (model[i][c].max(TINY) / self.t[i][c]).ln().powi(2))
            .sum()
    }
}

/// Where a model's light is taken as zero in a log (a texel Unreal leaves
/// black, a Gaussian far in its tail): far below any T a table holds.
const TINY: f64 = 1e-300;

/// A fit's answer from its printed settings and the engine's light at each
/// row (pi L / E per channel).
pub(crate) struct Scored {
    pub params: Map<String, Value>,
    pub units: Map<String, Value>,
    pub requirements: Vec<String>,
    pub warnings: Vec<String>,
}

impl Scored {
    /// From the printed (name, value, unit) rows, as `printed::table`
    /// takes them.
    pub(crate) fn new(
        rows: Vec<(&str, Value, &str)>,
        requirements: Vec<String>,
        warnings: Vec<String>,
    ) -> Scored {
        let (params, units) = table(rows);
        Scored {
            params,
            units: units
                .into_iter()
                .map(|(k, u)| (k, Value::String(u)))
                .collect(),
            requirements,
            warnings,
        }
    }
}

/// A warning for each channel whose wanted amplitude `k` is above 1, the
/// most the engine's colour takes; `say(channel, k)` words it.
pub(crate) fn capped(k: [f64; 3], say: impl Fn(&str, f64) -> String) -> Vec<String> {
    (0..3)
        .filter(|&c| k[c] > 1.0)
        .map(|c| say(["r", "g", "b"][c], k[c]))
        .collect()
}

/// The lowest cost over a grid of one setting (`grid`), the other found at
/// each grid value by golden section in log space over `range` (`iters`
/// steps): (grid value, searched value) for `shape(grid value, searched
/// value)` at amplitude 1. `keep(i, amplitudes)` says whether the i-th grid
/// value's best point may be taken (the engine's UI takes its amplitudes);
/// `start` stands until a point is kept with a lower cost.
pub(crate) struct Grid<'a> {
    pub grid: &'a [f64],
    pub range: (f64, f64),
    pub iters: usize,
    pub start: (f64, f64),
}

impl Target {
    pub(crate) fn search(
        &self,
        g: Grid,
        shape: impl Fn(f64, f64) -> Vec<[f64; 3]>,
        keep: impl Fn(usize, &[f64; 3]) -> bool,
    ) -> (f64, f64) {
        let (mut best, mut cost) = (g.start, f64::INFINITY);
        for (i, &x) in g.grid.iter().enumerate() {
            let (lo, hi) = g.range;
            let y = minimise_log(|y| self.amplitude(&shape(x, y)).1, lo, hi, g.iters);
            let (k, c) = self.amplitude(&shape(x, y));
            if keep(i, &k) && c < cost {
                (best, cost) = ((x, y), c);
            }
        }
        best
    }

    /// The light of `at(t)` at each row's thickness t (mm).
    pub(crate) fn rows(&self, at: impl Fn(f64) -> [f64; 3]) -> Vec<[f64; 3]> {
        self.thickness.iter().map(|&t| at(t)).collect()
    }
}

fn finish(
    engine: Engine,
    source: &str,
    target: &Target,
    s: Scored,
    (model, formula): (Vec<[f64; 3]>, Model),
) -> TransmissionFit {
    let rel_error = model
        .iter()
        .zip(&target.t)
        .zip(&target.significant)
        .map(|((m, t), sig)| std::array::from_fn(|c| sig[c].then(|| m[c] / t[c] - 1.0)))
        .collect();
    let rms_log_error = std::array::from_fn(|c| {
        let logs: Vec<f64> = (0..model.len())
            .filter(|&i| target.significant[i][c])
            .map(|i| (model[i][c].max(TINY) / target.t[i][c]).ln())
            .collect();
        (logs.iter().map(|l| l * l).sum::<f64>() / logs.len().max(1) as f64).sqrt()
    });
    TransmissionFit {
        engine: engine.name().into(),
        source: source.into(),
        params: s.params,
        units: s.units,
        thickness_mm: target.thickness.clone(),
        table: target.t.clone(),
        table_stderr: target.se.clone(),
        engine_t: model,
        rel_error,
        rms_log_error,
        requirements: s.requirements,
        warnings: s.warnings,
        model: Some(formula),
    }
}

/// `engine`'s transmission settings fitted to `table`, the reflectance
/// side taken from `reflect` (the engine's fit to the material's profile): None for an
/// engine without a thickness-based transmission model (Blender: Cycles'
/// Random Walk walks through the mesh; iryoku: its reference code's
/// translucency is not modelled here).
pub fn fit(
    engine: Engine,
    reflect: &EngineFit,
    table: &ThicknessTable,
    scene: Scene,
) -> Result<Option<TransmissionFit>> {
    let target = Target::new(table)?;
    let (scored, model, formula, source) = match engine {
        Engine::Unreal => {
            let (s, m, f) = unreal::fit(reflect, &target, scene)?;
            (s, m, f, unreal::SOURCE)
        }
        Engine::UnityHdrp => {
            let (s, m, f) = hdrp::fit(reflect, &target, scene)?;
            (s, m, f, hdrp::SOURCE)
        }
        Engine::Godot => {
            let (s, m, f) = godot::fit(reflect, &target, scene)?;
            (s, m, f, godot::SOURCE)
        }
        Engine::Blender | Engine::Iryoku => return Ok(None),
    };
    Ok(Some(finish(
        engine,
        source,
        &target,
        scored,
        (model, formula),
    )))
}

/// A line for an engine without a fitted transmission model.
pub fn none_for(engine: Engine) -> Option<&'static str> {
    match engine {
        Engine::Blender => Some(
            "Cycles' Random Walk traces the light through the mesh itself: a thin part \
             transmits what its thickness lets through, nothing to set (EEVEE and \
             Christensen-Burley are not thickness-aware and are not fitted)",
        ),
        Engine::Iryoku => Some(
            "iryoku's translucency (SSSSTransmittance) is not modelled by ssskit: no \
             transmission values",
        ),
        _ => None,
    }
}
