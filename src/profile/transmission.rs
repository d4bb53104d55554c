//! The light through a slab of a material as a function of its thickness
//! (the thin parts of an object lit from behind: ears, fingers, leaves, a
//! candle's rim): per thickness and channel, the total transmittance T of
//! a slab lit by a normal pencil beam on one face (what leaves the other
//! face, per incident photon), its radial spread T_d(r) and the radii
//! holding half and 90% of it, by the Monte Carlo of `mc` (Wang et al.
//! 1995) on the material with its last layer cut to the thickness.
//!
//! Work is bounded per thickness: each slab runs its own budget (a target
//! error on T and T_d, or a photon count) under its own work cap, and a
//! table holds at most `MAX_THICKNESSES` slabs of at most `MAX_SLAB_MM`.

use super::mc::{self, McConfig, McOptions, PhotonBudget, CONTEXT};
use super::radius::radius_reaching;
use crate::error::{finite_positive, Error, Result};
use crate::material::{Channel, Material};
use crate::numerics::annulus_area;
use crate::progress::Progress;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const TABLE_SCHEMA: &str = "ssskit.transmission/1";
/// Most slabs in one table (each a Monte Carlo run of its own).
pub const MAX_THICKNESSES: usize = 64;
/// Thickest slab, mm: a metre of any medium this crate simulates is
/// opaque (beyond it T is below the absolute floor for every preset), and
/// a scattering walk's length grows like the square of the thickness in
/// mean free paths.
pub const MAX_SLAB_MM: f64 = 1000.0;
/// Default target of a table's rule (relative error of T and of T_d's 1D
/// factor): 2%, a quarter of what separates two 8-bit levels of a dim
/// colour, at a small part of a reflectance profile's cost per slab.
pub const DEFAULT_TABLE_ERROR: f64 = 0.02;
/// Default work cap per slab and channel, events (about 5 s of one core):
/// a thick slab whose transmitted light is below the absolute floor stops
/// there long before it.
pub const DEFAULT_TABLE_MAX_WORK: u64 = 300_000_000;
/// Thicknesses of a range when no count is given: geometric steps, about
/// five per decade over 0.2 to 20 mm.
pub const DEFAULT_STEPS: usize = 11;

/// What a table runs: the slabs and the Monte Carlo settings of each.
#[derive(Clone, Debug)]
pub struct TableOptions {
    /// Slab thicknesses, mm, increasing.
    pub thicknesses: Vec<f64>,
    pub budget: PhotonBudget,
    /// Tracer options of every slab (the work cap is per slab).
    pub mc: McOptions,
    pub seed: u64,
    pub threads: Option<usize>,
    pub channels: Vec<Channel>,
}

/// One slab's transmitted light.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThicknessRow {
    pub thickness_mm: f64,
    /// Total transmittance per channel (per incident photon, the specular
    /// reflection at entry excluded from the light that enters) and its
    /// standard error.
    pub transmittance: Vec<f64>,
    pub transmittance_stderr: Vec<f64>,
    /// The part of T that scattered on its way (what a camera behind the
    /// slab sees; the rest leaves unscattered along the beam) and its
    /// standard error.
    pub diffuse: Vec<f64>,
    pub diffuse_stderr: Vec<f64>,
    /// The slab's diffuse reflectance, for the balance of the light.
    pub rd: Vec<f64>,
    pub rd_stderr: Vec<f64>,
    /// Radii (mm) around the beam's axis holding 50% and 90% of T per
    /// channel (light beyond the grid counted in T; its last edge where the
    /// grid holds less).
    pub r50_mm: Vec<f64>,
    pub r90_mm: Vec<f64>,
    pub photons: Vec<u64>,
    /// Why each channel's run stopped (`simulate`'s `stopped_by`).
    pub stopped_by: Vec<String>,
    /// T_d(r) on this slab's radial grid, mm^-2, with standard errors.
    pub r_edges: Vec<f64>,
    pub td: Vec<Vec<f64>>,
    pub td_stderr: Vec<Vec<f64>>,
}

/// A material's transmitted light over a range of slab thicknesses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThicknessTable {
    pub schema: String,
    /// The material the slabs are cut from (its last layer's thickness
    /// replaced by each row's).
    pub material: Material,
    pub channels: Vec<Channel>,
    pub rows: Vec<ThicknessRow>,
    /// The budget rule every slab ran (`simulate`'s `source.params.budget`).
    pub budget: serde_json::Value,
    pub seed: u64,
    pub elapsed_s: f64,
    /// Scores of other systems against the table (the engines' thin-object
    /// formulas), filled by whoever computed them; plain data.
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub engines: serde_json::Value,
}

/// `steps` thicknesses from `lo` to `hi` mm in geometric steps (one for
/// `lo == hi`).
pub fn thickness_range(lo: f64, hi: f64, steps: usize) -> Result<Vec<f64>> {
    let bad = |v: String, why: &str| Error::invalid(CONTEXT, "thickness", v, why);
    if !(lo > 0.0 && lo.is_finite() && hi.is_finite() && hi >= lo) {
        return Err(bad(
            format!("{lo}..{hi}"),
            "a range lo..hi of finite thicknesses with 0 < lo <= hi",
        ));
    }
    if !(1..=MAX_THICKNESSES).contains(&steps) || (steps == 1 && hi > lo) {
        return Err(Error::invalid(
            CONTEXT,
            "thickness steps",
            steps,
            format!("between 2 and {MAX_THICKNESSES} for a range (1 when lo = hi)"),
        ));
    }
    if steps == 1 || hi == lo {
        return Ok(vec![lo]);
    }
    let k = (hi / lo).ln() / (steps - 1) as f64;
    Ok((0..steps)
        .map(|i| {
            if i + 1 == steps {
                hi
            } else {
                lo * (k * i as f64).exp()
            }
        })
        .collect())
}

/// The thicker layers above the last one of `m`, mm (what a slab must
/// exceed).
fn upper_thickness(m: &Material) -> f64 {
    m.layers[..m.layers.len() - 1]
        .iter()
        .map(|l| l.thickness.unwrap_or(0.0))
        .sum()
}

/// Checks a table's thicknesses for `material` before any work: finite,
/// increasing, at most `MAX_THICKNESSES`, each above the layers over the
/// last one and at most `MAX_SLAB_MM`.
pub fn check_thicknesses(material: &Material, t: &[f64]) -> Result<()> {
    if t.is_empty() || t.len() > MAX_THICKNESSES {
        return Err(Error::invalid(
            CONTEXT,
            "thickness",
            format!("{} values", t.len()),
            format!("between 1 and {MAX_THICKNESSES} thicknesses"),
        ));
    }
    let above = upper_thickness(material);
    for (i, &x) in t.iter().enumerate() {
        finite_positive(CONTEXT, "thickness", x, " mm")?;
        if x > MAX_SLAB_MM {
            return Err(Error::invalid(
                CONTEXT,
                "thickness",
                x,
                format!("at most {MAX_SLAB_MM} mm (a slab that thick transmits nothing)"),
            ));
        }
        if x <= above {
            return Err(Error::invalid(
                CONTEXT,
                "thickness",
                x,
                format!(
                    "the slab is the whole stack: thicker than its layers above the last ({above} \
                     mm), which keep their thickness"
                ),
            ));
        }
        if i > 0 && x <= t[i - 1] {
            return Err(Error::invalid(
                CONTEXT,
                "thickness",
                x,
                "thicknesses must increase",
            ));
        }
    }
    Ok(())
}

/// `material` as a slab `t` mm thick: its last layer cut to `t` less the
/// layers above it.
pub fn slab(material: &Material, t: f64) -> Result<Material> {
    check_thicknesses(material, &[t])?;
    let mut m = material.clone();
    let above = upper_thickness(material);
    if let Some(last) = m.layers.last_mut() {
        last.thickness = Some(t - above);
    }
    Ok(m)
}

/// The table of `material` over `opts.thicknesses`.
pub fn thickness_table(
    material: &Material,
    opts: &TableOptions,
    progress: &dyn Progress,
) -> Result<ThicknessTable> {
    let start = std::time::Instant::now();
    material.validate_named()?;
    check_thicknesses(material, &opts.thicknesses)?;
    let cfg = McConfig {
        budget: opts.budget.clone(),
        seed: opts.seed,
        threads: opts.threads,
        channels: opts.channels.clone(),
        grid: None,
    };
    let mut rows = Vec::with_capacity(opts.thicknesses.len());
    let mut budget = serde_json::Value::Null;
    for &t in &opts.thicknesses {
        if progress.cancelled() {
            return Err(Error::Unsupported(crate::progress::INTERRUPTED.into()));
        }
        let p = mc::simulate_with(&slab(material, t)?, &cfg, &opts.mc, progress)?;
        budget = p.source.params["budget"].clone();
        rows.push(row_of(t, &p)?);
    }
    Ok(ThicknessTable {
        schema: TABLE_SCHEMA.into(),
        material: material.clone(),
        channels: opts.channels.clone(),
        rows,
        budget,
        seed: opts.seed,
        elapsed_s: start.elapsed().as_secs_f64(),
        engines: serde_json::Value::Null,
    })
}

/// The row of a slab `t` mm thick from its simulated profile.
fn row_of(t: f64, p: &super::Profile) -> Result<ThicknessRow> {
    let tp = p
        .transmittance_profile()?
        .ok_or_else(|| Error::Unsupported("the slab's run kept no transmittance profile".into()))?;
    let tt = p.transmittance.clone().unwrap_or_default();
    let spread = |q: f64| -> Vec<f64> {
        (0..p.channels.len())
            .map(|c| {
                let amounts = tp.td[c]
                    .iter()
                    .zip(p.r_edges.windows(2))
                    .map(|(v, e)| v * annulus_area(e[0], e[1]));
                radius_reaching(&p.r_edges, amounts, q * tt[c])
            })
            .collect()
    };
    let strings = |key: &str| -> Vec<String> {
        p.extra[key]
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|s| s.as_str().unwrap_or("").to_string())
                    .collect()
            })
            .unwrap_or_default()
    };
    let (r50_mm, r90_mm) = (spread(0.5), spread(0.9));
    Ok(ThicknessRow {
        thickness_mm: t,
        diffuse: tp.diffuse.clone(),
        diffuse_stderr: tp.diffuse_stderr.clone(),
        transmittance_stderr: p.transmittance_stderr.clone().unwrap_or_default(),
        transmittance: tt,
        rd: p.total_rd.clone(),
        rd_stderr: p.total_rd_stderr.clone().unwrap_or_default(),
        r50_mm,
        r90_mm,
        photons: p.source.photons.clone().unwrap_or_default(),
        stopped_by: strings("stopped_by"),
        r_edges: p.r_edges.clone(),
        td: tp.td,
        td_stderr: tp.td_stderr,
    })
}

impl ThicknessTable {
    /// Reads and checks a table written by `ssskit transmission --out`.
    pub fn read(path: &Path) -> Result<ThicknessTable> {
        let text =
            crate::io::read_text_capped(path, crate::limits::MAX_JSON_BYTES, "transmission table")?;
        let t: ThicknessTable = serde_json::from_str(&text)
            .map_err(|e| Error::format(path, format!("not a transmission table: {e}")))?;
        t.validate().map_err(|e| Error::format(path, e))?;
        Ok(t)
    }

    /// What every table satisfies, the first violation named.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.schema != TABLE_SCHEMA {
            return Err(format!(
                "schema '{}', expected '{TABLE_SCHEMA}'",
                self.schema
            ));
        }
        let n = self.channels.len();
        if n == 0 || self.rows.is_empty() || self.rows.len() > MAX_THICKNESSES {
            return Err(format!(
                "{} channels and {} rows: expected at least one of each, at most \
                 {MAX_THICKNESSES} rows",
                n,
                self.rows.len()
            ));
        }
        for (i, r) in self.rows.iter().enumerate() {
            let ok = |v: &[f64]| v.len() == n && v.iter().all(|x| x.is_finite() && *x >= 0.0);
            if !(r.thickness_mm > 0.0 && r.thickness_mm <= MAX_SLAB_MM)
                || (i > 0 && r.thickness_mm <= self.rows[i - 1].thickness_mm)
                || ![
                    &r.transmittance,
                    &r.transmittance_stderr,
                    &r.rd,
                    &r.r50_mm,
                    &r.r90_mm,
                ]
                .iter()
                .all(|v| ok(v))
                || r.td.len() != n
                || r.td.iter().any(|v| v.len() + 1 != r.r_edges.len())
            {
                return Err(format!(
                    "rows[{i}] (thickness {} mm): expected increasing thicknesses in (0, \
                     {MAX_SLAB_MM}] and one finite value >= 0 per channel",
                    r.thickness_mm
                ));
            }
        }
        Ok(())
    }

    pub fn thicknesses(&self) -> Vec<f64> {
        self.rows.iter().map(|r| r.thickness_mm).collect()
    }

    /// Index of channel `ch` in the table.
    pub fn channel_index(&self, ch: Channel) -> Option<usize> {
        self.channels.iter().position(|&c| c == ch)
    }

    /// The scattered part of T (`diffuse`) of channel index `c` at
    /// thickness `t` mm: linear in its log between the rows (it falls about
    /// exponentially with thickness), constant outside them; None where a
    /// neighbouring row holds no light.
    pub fn interpolate(&self, c: usize, t: f64) -> Option<f64> {
        let rows = &self.rows;
        let at = |i: usize| rows[i].diffuse[c];
        if t <= rows[0].thickness_mm {
            return Some(at(0));
        }
        let last = rows.len() - 1;
        if t >= rows[last].thickness_mm {
            return Some(at(last));
        }
        let i = rows.partition_point(|r| r.thickness_mm <= t) - 1;
        let (t0, t1) = (rows[i].thickness_mm, rows[i + 1].thickness_mm);
        let (a, b) = (at(i), at(i + 1));
        if !(a > 0.0 && b > 0.0) {
            return None;
        }
        let f = (t - t0) / (t1 - t0);
        Some((a.ln() * (1.0 - f) + b.ln() * f).exp())
    }
}
