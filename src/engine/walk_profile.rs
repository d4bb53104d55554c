//! The profile Cycles' Random Walk renders from a Principled BSDF's
//! values: the node's values read back into the walk's channels
//! (`cycles_walk::channel`), the walks' exits binned on a profile's grid,
//! and the profile in two independent halves on a grid of its own per
//! channel (the claim scripts/engine-cycles scores renders against).

use super::blender::{radius_and_scale, require_zero_layers};
use super::cycles_walk::{self, Channel, UnitWalk, ANISOTROPY_RANGE};
use super::printed::{in_range, number, require, text, triple};
use super::walk_table::table_edges;
use super::Scene;
use crate::error::{Error, Result};
use crate::profile::metrics::channel_error;
use crate::profile::Profile;
use crate::progress::Progress;
use serde::Serialize;
use serde_json::{json, Map, Value};

/// The method's name in Blender's UI.
pub const METHOD: &str = "Random Walk";
/// The walks' seed (fixed: the same values on every run).
pub const SEED: u64 = 0x5353_4B49_5457_414C;

/// The walk's profile of the printed values on a radial grid per channel,
/// from two independent halves of the walks (their difference is the
/// claim's noise): what scripts/engine-cycles scores the render against.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct WalkProfile {
    pub walks: usize,
    pub seed: u64,
    /// Per channel: sigma_t (1/mm), alpha walked, the clamp's throughput.
    pub sigma_t_per_mm: [f64; 3],
    pub alpha: [f64; 3],
    pub throughput: [f64; 3],
    /// The Monte Carlo standard error of `error.shape` per channel: half
    /// the difference of the shape errors of the two halves.
    pub shape_noise: [f64; 3],
    /// The Monte Carlo noise of the profile itself per channel, in the
    /// shape norm (relative L2 of r R_d over r < r99): half the norm of the
    /// two halves' difference. It adds to a shape error e in quadrature,
    /// so sqrt(e^2 - noise_l2^2) estimates the shape error of the walk's
    /// expected profile.
    pub noise_l2: [f64; 3],
    /// Per channel, the grid's edges in mm.
    pub r_edges_mm: Vec<Vec<f64>>,
    /// [half][channel][bin]: R_d per mm^2.
    pub rd_halves: Vec<Vec<Vec<f64>>>,
    /// [half][channel]: total reflectance.
    pub total_halves: Vec<Vec<f64>>,
}

const UI: &str = "Blender's socket";

/// The walk's channels from the node's values.
pub fn channels(p: &Map<String, Value>, scene: Scene) -> Result<([Channel; 3], f64)> {
    if text(p, "Subsurface Method")? != METHOD {
        return Err(Error::invalid(
            "engine",
            "Subsurface Method",
            text(p, "Subsurface Method")?,
            "these values are for Random Walk",
        ));
    }
    require(
        p,
        "Subsurface Weight",
        &json!(1.0),
        "below 1 a diffuse BSDF takes the rest",
    )?;
    require(
        p,
        "Roughness",
        &json!(0.0),
        "the walk's entry is modelled at Roughness 0",
    )?;
    require_zero_layers(p)?;
    let colour = triple(p, "Base Color")?;
    let (r, scale) = radius_and_scale(p)?;
    let g = in_range(
        UI,
        "Subsurface Anisotropy",
        number(p, "Subsurface Anisotropy")?,
        (-1.0, 1.0),
    )?;
    let (glo, ghi) = ANISOTROPY_RANGE;
    let g = g.clamp(glo, ghi);
    for x in colour {
        in_range(UI, "Base Color", x, (0.0, 1.0))?;
    }
    let ch = std::array::from_fn(|c| {
        cycles_walk::channel(colour[c], r[c] * scale / scene.units_per_mm, g)
    });
    Ok((ch, g))
}

/// The profile Cycles renders from the values `p`, on `like`'s grid, and
/// the walk's profile for the script; `walk` is reused when g = 0, else
/// each channel walks `walks` walks at its own alpha.
pub fn rendered(
    p: &Map<String, Value>,
    scene: Scene,
    like: &Profile,
    walk: Option<&UnitWalk>,
    walks: usize,
    progress: &dyn Progress,
) -> Result<(Profile, WalkProfile)> {
    let (ch, g) = channels(p, scene)?;
    let own;
    let walk = match walk {
        Some(w) if g == 0.0 => w,
        _ => {
            // g > 0: the paths depend on alpha; one walk per channel.
            own = (0..3)
                .map(|c| {
                    let what = format!(
                        "Cycles' Random Walk, the printed values, channel {}: walks",
                        ["r", "g", "b"][c]
                    );
                    progress.start(walks as u64, &what);
                    UnitWalk::run(walks, ch[c].alpha, g, SEED, progress)
                })
                .collect::<Result<Vec<_>>>()?;
            return assemble(&ch, like, |c| &own[c]);
        }
    };
    assemble(&ch, like, |_| walk)
}

fn assemble<'a>(
    ch: &[Channel; 3],
    like: &Profile,
    walk: impl Fn(usize) -> &'a UnitWalk,
) -> Result<(Profile, WalkProfile)> {
    let mut p = like.clone();
    let edges = table_edges();
    let mut out = WalkProfile {
        walks: walk(0).walks,
        seed: SEED,
        sigma_t_per_mm: ch.map(|c| c.sigma_t),
        alpha: ch.map(|c| c.alpha),
        throughput: ch.map(|c| c.throughput),
        shape_noise: [0.0; 3],
        noise_l2: [0.0; 3],
        r_edges_mm: Vec::new(),
        rd_halves: vec![Vec::new(), Vec::new()],
        total_halves: vec![Vec::new(), Vec::new()],
    };
    for (c, &chan) in ch.iter().enumerate() {
        let w = walk(c);
        let (rd, total) = w.bins(chan, &like.r_edges, 0..w.exits.len(), w.walks);
        p.rd[c] = rd;
        p.total_rd[c] = total;
        let halves = w
            .halves()
            .map(|(range, n)| w.bins(chan, &like.r_edges, range, n));
        let shapes = halves
            .each_ref()
            .map(|(rd, total)| channel_error(rd, *total, like, c).shape);
        out.shape_noise[c] = 0.5 * (shapes[0] - shapes[1]).abs();
        // |h0 - h1| / 2 relative to the profile's norm: the profile plus
        // half the difference, scored against the profile.
        let spread: Vec<f64> = (0..like.rd[c].len())
            .map(|i| like.rd[c][i] + 0.5 * (halves[0].0[i] - halves[1].0[i]))
            .collect();
        out.noise_l2[c] = channel_error(&spread, like.total_rd[c], like, c).shape;
        let mm: Vec<f64> = edges.iter().map(|e| e / chan.sigma_t).collect();
        for (h, (range, n)) in w.halves().into_iter().enumerate() {
            let (rd, total) = w.bins(chan, &mm, range, n);
            out.rd_halves[h].push(rd);
            out.total_halves[h].push(total);
        }
        out.r_edges_mm.push(mm);
    }
    let source = crate::profile::Source {
        kind: "monte-carlo".into(),
        photons: Some(vec![out.walks as u64; 3]),
        seed: Some(SEED),
        model: Some(format!("blender ({METHOD}, Cycles' walk)")),
        params: Value::Null,
    };
    Ok((p.modelled(source, p.rd.clone(), p.total_rd.clone()), out))
}
