//! Blender's Principled BSDF with Cycles' Random Walk subsurface: the
//! node's values fitted to a profile through the walk of `cycles_walk`,
//! printed, read back and scored.
//!
//! The fit, per channel: the Base Color (through Cycles' remap to the
//! walk's alpha) and the extinction, by least squares on r R_d(r) over
//! the radius holding 99% of the profile (the norm of the Burley fits).
//! One walk in a medium of unit extinction serves every extinction (the
//! exit profile scales as sigma_t^2 R(sigma_t r)) and, for g = 0, every
//! alpha (each exit weighted by alpha^n); the fit reads it from a fine
//! radial table, the printed values' profile from the walk's exits.

use super::blender::{scale_and_radius, subsurface_rows, RADIUS_RANGE, SCALE_RANGE};
use super::cycles_walk::{self, Channel, UnitWalk, ANISOTROPY_RANGE, MAX_BOUNCES};
use super::printed::{in_range, number, printed, require, text, triple, typed};
use super::{EngineFit, Scene, Target};
use crate::error::{Error, Result};
use crate::numerics::minimise_log;
use crate::profile::Profile;
use serde::Serialize;
use serde_json::{json, Map, Value};
use std::f64::consts::PI;

pub const METHOD: &str = "Random Walk";
/// Walks of the fit and of the printed values' profile: the claim's
/// edge response then scatters by about 0.05% of the step (binomial, 1 /
/// sqrt(4 N) at most), a quarter of the lowest render noise recorded in
/// docs/records/engine-cycles.json.
pub const WALKS: usize = 1 << 22;
/// The walks' seed (fixed: the same values on every run).
pub const SEED: u64 = 0x5353_4B49_5457_414C;
/// The fine radial table of the fit: log-spaced edges in mean free paths
/// from TABLE_MIN to TABLE_MIN x 10^TABLE_DECADES, TABLE_PER_DECADE a
/// decade (a bin 2.9% wide; linear interpolation of the cumulative mass
/// inside it).
const TABLE_MIN: f64 = 1e-3;
const TABLE_DECADES: usize = 6;
const TABLE_PER_DECADE: usize = 80;
/// The Base Color searched (the remap's whole useful range).
const COLOUR_RANGE: (f64, f64) = (1e-3, 1.0);
/// Extinctions searched, in units of 1 / r99 of the profile: a walk's r99
/// lies between a tenth of a mean free path (alpha at MIN_ALPHA) and a few
/// hundred (alpha near 1, the flight cap).
const SIGMA_T_RANGE_R99: (f64, f64) = (1e-3, 1e4);
const SCAN: usize = 15;

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
    /// Per channel, the grid's edges in mm.
    pub r_edges_mm: Vec<Vec<f64>>,
    /// [half][channel][bin]: R_d per mm^2.
    pub rd_halves: Vec<Vec<Vec<f64>>>,
    /// [half][channel]: total reflectance.
    pub total_halves: Vec<Vec<f64>>,
}

fn table_edges() -> Vec<f64> {
    let n = TABLE_DECADES * TABLE_PER_DECADE;
    std::iter::once(0.0)
        .chain((0..=n).map(|k| TABLE_MIN * 10f64.powf(k as f64 / TABLE_PER_DECADE as f64)))
        .collect()
}

/// A unit walk's exits counted by table bin and scatterings, per walk:
/// the cumulative weight for any alpha without a pass over the exits.
struct Table {
    edges: Vec<f64>,
    /// counts[row * MAX_BOUNCES + n], per walk.
    counts: Vec<f64>,
    walk: UnitWalk,
}

impl Table {
    fn new(walk: UnitWalk) -> Table {
        let edges = table_edges();
        // Row j < edges.len() holds the exits in [e_{j-1}, e_j); the last
        // row those beyond the table.
        let bins = edges.len() + 1;
        let mut counts = vec![0.0; bins * MAX_BOUNCES];
        let per_walk = 1.0 / walk.walks as f64;
        for &(r, n) in &walk.exits {
            let k = edges.partition_point(|e| *e <= r);
            counts[k * MAX_BOUNCES + n as usize] += per_walk;
        }
        Table {
            edges,
            counts,
            walk,
        }
    }
}

/// Cumulative exit weight of a unit walk by radius, for one alpha.
struct Cumulative<'a> {
    edges: &'a [f64],
    /// Weight inside each edge, per walk.
    inside: Vec<f64>,
    total: f64,
}

impl Cumulative<'_> {
    fn new(t: &Table, alpha: f64) -> Cumulative<'_> {
        let w: Vec<f64> = (0..MAX_BOUNCES)
            .map(|n| t.walk.weight(n as u16, alpha))
            .collect();
        let mut acc = 0.0;
        let mut inside: Vec<f64> = t
            .counts
            .chunks(MAX_BOUNCES)
            .map(|row| {
                acc += row.iter().zip(&w).map(|(c, w)| c * w).sum::<f64>();
                acc
            })
            .collect();
        // The last row is the exits beyond the table: in the total only.
        let total = inside.pop().unwrap_or(0.0);
        Cumulative {
            edges: &t.edges,
            inside,
            total,
        }
    }

    /// Weight inside radius u (mean free paths).
    fn at(&self, u: f64) -> f64 {
        let e = self.edges;
        if u >= e[e.len() - 1] {
            return self.total;
        }
        if u < e[1] {
            // Uniform per area inside the first edge.
            return self.inside[1] * (u / e[1]).powi(2);
        }
        let k = e.partition_point(|x| *x <= u);
        let t = (u.ln() - e[k - 1].ln()) / (e[k].ln() - e[k - 1].ln());
        self.inside[k - 1] + t * (self.inside[k] - self.inside[k - 1])
    }
}

/// The residual of r R_d for extinction `sigma_t` and throughput `k`.
fn residual(t: &Target, edges: &[f64], c: &Cumulative, sigma_t: f64, k: f64) -> f64 {
    (0..t.bins)
        .map(|i| {
            let m = c.at(edges[i + 1] * sigma_t) - c.at(edges[i] * sigma_t);
            let rd = k * m / (PI * (edges[i + 1].powi(2) - edges[i].powi(2)));
            t.weight[i] * (rd - t.value[i]).powi(2)
        })
        .sum()
}

/// The best Base Color and extinction (1/mm) of channel `c`.
fn fit_channel(p: &Profile, c: usize, g: f64, table: &Table) -> (f64, f64) {
    let t = Target::new(p, c);
    let r99 = crate::profile::radius_holding(p, c, crate::profile::metrics::SHAPE_HOLD);
    let (lo, hi) = SIGMA_T_RANGE_R99;
    let best_sigma_t = |colour: f64| {
        let ch = cycles_walk::channel(colour, 1.0, g);
        let cum = Cumulative::new(table, ch.alpha);
        let cost = |s: f64| residual(&t, &p.r_edges, &cum, s, ch.throughput);
        let s = minimise_log(cost, lo / r99, hi / r99, SCAN);
        (s, cost(s))
    };
    let (clo, chi) = COLOUR_RANGE;
    let colour = minimise_log(|b| best_sigma_t(b).1, clo, chi, SCAN);
    (colour, best_sigma_t(colour).0)
}

fn anisotropy(p: &Profile) -> Result<f64> {
    let layers = &p.material.layers;
    let g = layers.first().map_or([f64::NAN; 3], |l| l.g);
    if layers.len() != 1 || g.iter().any(|x| *x != g[0]) {
        return Err(Error::Unsupported(
            "Cycles' Random Walk takes one anisotropy for all channels: the profile's \
             material must be one layer with one g"
                .into(),
        ));
    }
    let (lo, hi) = ANISOTROPY_RANGE;
    Ok(g[0].clamp(lo, hi))
}

/// The Random Walk values fitted to `p` (one-layer material: its g and
/// eta are printed as the node's Anisotropy and IOR).
pub fn fit(p: &Profile, scene: Scene) -> Result<EngineFit> {
    super::check(p)?;
    super::check_scene(scene)?;
    let g = anisotropy(p)?;
    let eta = p.material.layers[0].eta;
    // With g > 0 the walk's paths depend on alpha (the similarity medium):
    // the fit reads one walk at the alpha of the profile's mean
    // reflectance, the printed values' profile a walk at their own alpha.
    let mean_total = p.total_rd.iter().sum::<f64>() / 3.0;
    let fit_alpha = cycles_walk::channel(mean_total.min(1.0), 1.0, g).alpha;
    let table = Table::new(UnitWalk::run(WALKS, fit_alpha, g, SEED)?);
    let fitted: [(f64, f64); 3] = std::array::from_fn(|c| fit_channel(p, c, g, &table));
    let params = params(fitted, g, eta, scene);
    let (profile, walk_profile) =
        rendered(&params.params, scene, p, (g == 0.0).then_some(&table.walk))?;
    let error = super::error(&profile, p)?;
    Ok(EngineFit {
        engine: "blender".into(),
        version: format!(
            "Blender 4.0 to 5.0, Cycles: Principled BSDF, {METHOD} (read in Cycles v4.0.0, v5.0.0)"
        ),
        params: params.params,
        units: params.units,
        error,
        error_for: ERROR_FOR.into(),
        requirements: requirements(scene),
        warnings: params.warnings,
        rendered: None,
        walk: Some(walk_profile),
        profile,
    })
}

pub const ERROR_FOR: &str = "Cycles' Random Walk (the walk of subsurface_random_walk.h: entry \
     straight down under a normal view at Roughness 0, exit at the first surface crossing, \
     alpha from Cycles' remap with its 0.2 floor, at most 256 flights), by ssskit's Monte Carlo \
     of that walk; rendered by Cycles 5.0.1 in scripts/engine-cycles";

fn requirements(scene: Scene) -> Vec<String> {
    vec![
        format!(
            "scene units of {} mm (--units-per-mm {}): the radius is a distance in scene units",
            1.0 / scene.units_per_mm,
            scene.units_per_mm
        ),
        "Roughness 0 and a view along the normal: the walk starts along the view ray refracted \
         through a GGX facet of that roughness (subsurface_entry_bounce); elsewhere it starts \
         slanted and the profile differs"
            .into(),
        "Metallic 0, Transmission 0, Coat 0, Sheen 0 and Specular IOR Level 0 (each layer \
         takes its share of the subsurface weight)"
            .into(),
    ]
}

/// The node's values from the fitted colour and extinction per channel.
fn params(fitted: [(f64, f64); 3], g: f64, eta: f64, scene: Scene) -> super::printed::Printed {
    let mut warnings = Vec::new();
    let colour = fitted.map(|(b, _)| typed(b.clamp(0.0, 1.0)));
    // radius (scene units) = 4 pi d, d = 1 / (sigma_t (1 - g)).
    let radius = fitted.map(|(_, s)| 4.0 * PI / (s * (1.0 - g)) * scene.units_per_mm);
    let (scale, per_channel) = scale_and_radius(radius, &mut warnings);
    let mut rows = subsurface_rows(
        colour,
        "scene linear RGB (the picker's RGB fields), in [0, 1]: the walk's alpha through \
         Cycles' remap, fitted (not the total reflectance)",
        per_channel,
        scale,
    );
    rows.extend([
        (
            "Subsurface Anisotropy",
            json!(g),
            "the material's g, in [0, 0.9]",
        ),
        (
            "IOR",
            json!(eta),
            "the material's; at a normal view and Roughness 0 it bends nothing",
        ),
        (
            "Roughness",
            json!(0.0),
            "the entry's GGX roughness (subsurface_entry_bounce)",
        ),
        ("Subsurface Method", json!(METHOD), "the model fitted"),
    ]);
    printed(rows, warnings)
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
    let colour = triple(p, "Base Color")?;
    let r = triple(p, "Subsurface Radius")?;
    let scale = in_range(
        UI,
        "Subsurface Scale",
        number(p, "Subsurface Scale")?,
        SCALE_RANGE,
    )?;
    let g = in_range(
        UI,
        "Subsurface Anisotropy",
        number(p, "Subsurface Anisotropy")?,
        (-1.0, 1.0),
    )?;
    let (glo, ghi) = ANISOTROPY_RANGE;
    let g = g.clamp(glo, ghi);
    for c in 0..3 {
        in_range(UI, "Base Color", colour[c], (0.0, 1.0))?;
        in_range(UI, "Subsurface Radius", r[c], RADIUS_RANGE)?;
    }
    let ch = std::array::from_fn(|c| {
        cycles_walk::channel(colour[c], r[c] * scale / scene.units_per_mm, g)
    });
    Ok((ch, g))
}

/// The profile Cycles renders from the values `p`, on `like`'s grid, and
/// the walk's profile for the script; `walk` is reused when g = 0.
pub fn rendered(
    p: &Map<String, Value>,
    scene: Scene,
    like: &Profile,
    walk: Option<&UnitWalk>,
) -> Result<(Profile, WalkProfile)> {
    let (ch, g) = channels(p, scene)?;
    let own;
    let walk = match walk {
        Some(w) if g == 0.0 => w,
        _ => {
            // g > 0: the paths depend on alpha; one walk per channel.
            own = (0..3)
                .map(|c| UnitWalk::run(WALKS, ch[c].alpha, g, SEED))
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
        r_edges_mm: Vec::new(),
        rd_halves: vec![Vec::new(), Vec::new()],
        total_halves: vec![Vec::new(), Vec::new()],
    };
    for (c, &chan) in ch.iter().enumerate() {
        let w = walk(c);
        let (rd, total) = w.bins(chan, &like.r_edges, 0..w.exits.len(), w.walks);
        p.rd[c] = rd;
        p.total_rd[c] = total;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit reads the walk from its fine table (cumulative weight
    /// interpolated within bins 2.9% wide) and prints 4 digits, where the
    /// profile it fits was binned from the exits themselves; the values it
    /// recovers from a profile the walk itself made differ by less than
    /// this, relative (the same walks: no Monte Carlo noise between them).
    const RECOVER_TOL: f64 = 0.01;

    #[test]
    fn the_fit_recovers_the_values_of_a_walk_profile() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/reference/skin1.json");
        let like = Profile::read(std::path::Path::new(path)).unwrap();
        let scene = Scene::default();
        let values = params([(0.6, 1.2), (0.3, 2.0), (0.05, 3.5)], 0.0, 1.4, scene);
        let (made, _) = rendered(&values.params, scene, &like, None).unwrap();
        let got = fit(&made, scene).unwrap();
        let radius = |p: &Map<String, Value>| {
            let s = number(p, "Subsurface Scale").unwrap();
            triple(p, "Subsurface Radius").unwrap().map(|r| r * s)
        };
        let (want_r, got_r) = (radius(&values.params), radius(&got.params));
        let want_c = triple(&values.params, "Base Color").unwrap();
        let got_c = triple(&got.params, "Base Color").unwrap();
        for c in 0..3 {
            let rel = |a: f64, b: f64| (a - b).abs() / b;
            assert!(
                rel(got_r[c], want_r[c]) < RECOVER_TOL && rel(got_c[c], want_c[c]) < RECOVER_TOL,
                "channel {c}: radius {} for {}, Base Color {} for {}",
                got_r[c],
                want_r[c],
                got_c[c],
                want_c[c]
            );
        }
        assert!(
            got.error.shape.iter().all(|e| *e < RECOVER_TOL),
            "{:?}",
            got.error
        );
    }
}
