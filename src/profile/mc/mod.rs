//! Monte Carlo photon transport (the MCML scheme; REFERENCE.md section 3):
//! diffuse reflectance profile, totals with standard errors, and an exact
//! energy balance, reproducible whatever the thread count.
//!
//! Reproducibility: photons run in chunks of `CHUNK` packets; chunk k of
//! channel c draws from its own Xoshiro256++ stream seeded from (seed, c, k)
//! by SplitMix64 hashing, and chunk tallies are added in chunk order. Chunks
//! are dispatched in batches of `BATCH` chunks, and the stopping rule of a
//! target-error run is checked only between batches, so the photon count
//! does not depend on the thread count either.

pub mod mci;
mod tally;
mod tracer;

pub use tally::Moments;
pub use tracer::{BoundaryMode, DEFAULT_ROULETTE_THRESHOLD, ROULETTE_CHANCE, ROULETTE_THRESHOLD};

use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::{Profile, RadialGrid, Source, PROFILE_SCHEMA};
use crate::progress::Progress;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use serde_json::json;
use tally::{BinIndex, ChunkTally, PhotonScratch};
use tracer::{Stack, WalkSettings};

/// Photons per chunk (one RNG stream each).
pub const CHUNK: u64 = 8192;
/// Chunks per batch (the granularity of the target-error check).
pub const BATCH: u64 = 16;

/// How many photons to trace.
#[derive(Clone, Debug, PartialEq)]
pub enum PhotonBudget {
    /// Exactly this many per channel.
    Fixed(u64),
    /// Until the relative standard error of the total R_d and of the profile
    /// inside the radius holding 99% of R_d is below `rel` in every channel,
    /// or `max_photons` per channel are spent.
    TargetError { rel: f64, max_photons: u64 },
}

#[derive(Clone, Debug)]
pub struct McConfig {
    pub budget: PhotonBudget,
    pub seed: u64,
    /// Worker threads; None = rayon's default. Results do not depend on it.
    pub threads: Option<usize>,
    pub channels: Vec<Channel>,
    /// Radial tally bins; None = sized from the material.
    pub grid: Option<RadialGrid>,
}

/// Settings beyond the contract of `McConfig`, with MCML-like defaults.
#[derive(Clone, Debug)]
pub struct McOptions {
    /// MCML's all-or-none choice at the ambient boundaries (default: the
    /// more efficient in every case measured, see docs/mc.md) or splitting.
    pub boundary: BoundaryMode,
    /// Events (interactions + boundary hits) after which a packet is
    /// abandoned; its weight is reported as truncated.
    pub max_events: u64,
    /// Also tally reflectance of packets scattered exactly once
    /// (`extra.single_scatter`).
    pub single_scatter: bool,
    /// Work cap of a target-error run: no new batch starts once a channel
    /// has spent this many events (interactions + boundary hits). Keeps
    /// slow media (albedo near 1) bounded; reported when it stops a run.
    pub max_work: u64,
    /// Weight below which Russian roulette plays (default 0.01; MCML: 1e-4).
    /// Any value in (0, 1) is unbiased; higher values trade variance for speed.
    pub roulette_threshold: f64,
}

impl Default for McOptions {
    fn default() -> Self {
        McOptions {
            boundary: BoundaryMode::Classic,
            max_events: DEFAULT_MAX_EVENTS,
            single_scatter: false,
            max_work: DEFAULT_MAX_WORK,
            roulette_threshold: DEFAULT_ROULETTE_THRESHOLD,
        }
    }
}

/// Default work cap: about half a minute per channel on two cores of a
/// 2020s CPU (~2.5e7 events/s per core).
pub const DEFAULT_MAX_WORK: u64 = 1_500_000_000;

/// Default event cap: at albedo 1 the fraction of packets still walking after
/// n events falls like n^-1/2, so 10^6 leaves ~1e-3 of the energy or less.
pub const DEFAULT_MAX_EVENTS: u64 = 1_000_000;

/// Simulates the diffuse reflectance profile of `material`.
pub fn simulate(material: &Material, cfg: &McConfig, progress: &dyn Progress) -> Result<Profile> {
    simulate_with(material, cfg, &McOptions::default(), progress)
}

/// `simulate` with explicit tracer options.
pub fn simulate_with(
    material: &Material,
    cfg: &McConfig,
    opts: &McOptions,
    progress: &dyn Progress,
) -> Result<Profile> {
    let start = std::time::Instant::now();
    material.validate(&format!("material '{}'", material.name))?;
    validate_config(cfg, opts)?;
    let (grid, grid_rule) = match &cfg.grid {
        Some(g) => (g.clone(), json!({"rule": "given"})),
        None => RadialGrid::for_material_rule(material, &cfg.channels, false),
    };
    let e = &grid.edges;
    if e.len() < 2 || e[0] != 0.0 || e.windows(2).any(|w| !(w[1] > w[0] && w[1].is_finite())) {
        return Err(Error::invalid(
            "radial grid",
            "edges",
            format!("{} values", e.len()),
            "need at least 2 edges, starting at 0, finite and strictly increasing",
        ));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Unsupported(format!("cannot start worker threads: {e}")))?;
    let bins = BinIndex::new(&grid);
    let set = WalkSettings {
        mode: opts.boundary,
        max_events: opts.max_events,
        single_scatter: opts.single_scatter,
        roulette_threshold: opts.roulette_threshold,
    };
    let cap = match cfg.budget {
        PhotonBudget::Fixed(n) => n,
        PhotonBudget::TargetError { max_photons, .. } => max_photons,
    };
    progress.start(
        cap.saturating_mul(cfg.channels.len() as u64),
        &format!("{} photons", material.name),
    );
    let mut runs = Vec::with_capacity(cfg.channels.len());
    for &ch in &cfg.channels {
        let stack = Stack::new(material, ch);
        let run = pool
            .install(|| run_channel(&stack, &bins, &grid, &set, opts.max_work, cfg, ch, progress));
        runs.push((run, stack));
    }
    progress.finish();
    Ok(build_profile(
        material,
        cfg,
        opts,
        &grid,
        grid_rule,
        &runs,
        start.elapsed().as_secs_f64(),
    ))
}

fn validate_config(cfg: &McConfig, opts: &McOptions) -> Result<()> {
    match cfg.budget {
        PhotonBudget::Fixed(n) if n == 0 => {
            return Err(Error::invalid("--photons", "photons", n, "must be >= 1"))
        }
        PhotonBudget::TargetError { rel, max_photons } => {
            if !(rel.is_finite() && rel > 0.0 && rel < 1.0) {
                return Err(Error::invalid(
                    "--target-error",
                    "relative error",
                    rel,
                    "must be in (0, 1), e.g. 0.01",
                ));
            }
            if max_photons == 0 {
                return Err(Error::invalid(
                    "--max-photons",
                    "max photons",
                    max_photons,
                    "must be >= 1",
                ));
            }
        }
        _ => {}
    }
    if cfg.channels.is_empty() {
        return Err(Error::invalid("--channels", "channels", "''", "empty"));
    }
    if cfg.threads == Some(0) {
        return Err(Error::invalid("--threads", "threads", 0, "must be >= 1"));
    }
    if opts.max_work == 0 {
        return Err(Error::invalid("--max-work", "max work", 0, "must be >= 1"));
    }
    if !(opts.roulette_threshold > 0.0 && opts.roulette_threshold < 1.0) {
        return Err(Error::invalid(
            "--roulette",
            "roulette threshold",
            opts.roulette_threshold,
            "must be in (0, 1); MCML uses 1e-4",
        ));
    }
    if opts.max_events == 0 {
        return Err(Error::invalid(
            "--max-events",
            "max events",
            0,
            "must be >= 1",
        ));
    }
    Ok(())
}

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): decorrelates stream keys.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The RNG of chunk `chunk` of channel `ch`: a function of (seed, ch, chunk)
/// only.
fn chunk_rng(seed: u64, ch: Channel, chunk: u64) -> Xoshiro256PlusPlus {
    let key = splitmix64(splitmix64(splitmix64(seed) ^ (ch.index() as u64 + 1)) ^ chunk);
    Xoshiro256PlusPlus::seed_from_u64(key)
}

/// A finished channel: its tally and how the run ended.
struct ChannelRun {
    tally: ChunkTally,
    /// Relative standard error of total R_d and of the profile (see
    /// `convergence`), and the radius holding 99% of R_d.
    rel_total: f64,
    rel_profile: f64,
    r99: f64,
    converged: bool,
    /// Stopped by `McOptions::max_work` before the target error.
    work_capped: bool,
}

#[allow(clippy::too_many_arguments)]
fn run_channel(
    stack: &Stack,
    bins: &BinIndex,
    grid: &RadialGrid,
    set: &WalkSettings,
    max_work: u64,
    cfg: &McConfig,
    ch: Channel,
    progress: &dyn Progress,
) -> ChannelRun {
    let (cap, target) = match cfg.budget {
        PhotonBudget::Fixed(n) => (n, None),
        PhotonBudget::TargetError { rel, max_photons } => (max_photons, Some(rel)),
    };
    let n_chunks = cap.div_ceil(CHUNK);
    let mut total = ChunkTally::new(bins.len(), set.single_scatter);
    let mut next = 0u64;
    let mut status = (0.0, 0.0, 0.0);
    let mut converged = false;
    let mut work_capped = false;
    while next < n_chunks {
        let end = (next + BATCH).min(n_chunks);
        let parts: Vec<ChunkTally> = (next..end)
            .into_par_iter()
            .map(|k| {
                let photons = CHUNK.min(cap - k * CHUNK);
                let mut t = ChunkTally::new(bins.len(), set.single_scatter);
                let mut scratch = PhotonScratch::new(bins.len(), set.single_scatter);
                let mut rng = chunk_rng(cfg.seed, ch, k);
                tracer::trace_photons(stack, bins, set, &mut rng, photons, &mut t, &mut scratch);
                progress.advance(photons);
                t
            })
            .collect();
        for p in &parts {
            total.merge(p);
        }
        next = end;
        status = convergence(&total, grid);
        if let Some(rel) = target {
            if status.0 <= rel && status.1 <= rel {
                converged = true;
            }
            if converged || total.events >= max_work {
                work_capped = !converged;
                progress.advance(cap - total.photons);
                break;
            }
        }
    }
    ChannelRun {
        tally: total,
        rel_total: status.0,
        rel_profile: status.1,
        r99: status.2,
        converged: target.is_none() || converged,
        work_capped,
    }
}

/// (relative stderr of total R_d, relative stderr of the profile, r99).
///
/// The profile error is the R_d-weighted mean relative error of the bins
/// up to r99, the radius within which the tally holds 99% of the total R_d
/// (all bins when r_max holds less):
/// sum_i w_i (s_i / W_i) / sum_i w_i with weights w_i = W_i, i.e.
/// sum_i s_i / sum_i W_i, where W_i is the reflectance scored in bin i and
/// s_i its standard error. A zero R_d (nothing comes back) counts as exact.
fn convergence(t: &ChunkTally, grid: &RadialGrid) -> (f64, f64, f64) {
    let n = t.photons;
    let total = t.rd.mean(n);
    if total <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let rel_total = t.rd.stderr(n) / total;
    let goal = 0.99 * t.rd.sum;
    let mut acc = 0.0;
    let mut err = 0.0;
    for i in 0..grid.len() {
        let m = Moments {
            sum: t.rd_bins.sum[i],
            sum_sq: t.rd_bins.sum_sq[i],
        };
        acc += t.rd_bins.sum[i];
        err += m.stderr(n) * n as f64;
        if acc >= goal {
            break;
        }
    }
    let r99 =
        crate::profile::radius::radius_reaching(&grid.edges, t.rd_bins.sum.iter().copied(), goal);
    let rel_profile = if acc > 0.0 { err / acc } else { 0.0 };
    (rel_total, rel_profile, r99)
}

fn build_profile(
    material: &Material,
    cfg: &McConfig,
    opts: &McOptions,
    grid: &RadialGrid,
    grid_rule: serde_json::Value,
    runs: &[(ChannelRun, Stack)],
    elapsed_s: f64,
) -> Profile {
    let areas = grid.areas();
    let per =
        |f: &dyn Fn(&ChannelRun) -> f64| -> Vec<f64> { runs.iter().map(|(r, _)| f(r)).collect() };
    let density = |sums: &tally::BinSums, n: u64| -> (Vec<f64>, Vec<f64>) {
        if sums.sum.is_empty() {
            return (vec![], vec![]);
        }
        (0..grid.len())
            .map(|i| {
                let m = Moments {
                    sum: sums.sum[i],
                    sum_sq: sums.sum_sq[i],
                };
                // REFERENCE 3 step 6: R_d(r_i) = W_i / (N area_i).
                (m.mean(n) / areas[i], m.stderr(n) / areas[i])
            })
            .unzip()
    };
    let mut rd = Vec::new();
    let mut rd_err = Vec::new();
    let mut single = Vec::new();
    let mut warnings: Vec<String> = Vec::new();
    let mut balance = serde_json::Map::new();
    for ((run, _), ch) in runs.iter().zip(&cfg.channels) {
        let t = &run.tally;
        let n = t.photons;
        let (v, e) = density(&t.rd_bins, n);
        rd.push(v);
        rd_err.push(e);
        let nf = n as f64;
        let parts = [
            t.specular,
            t.rd.sum,
            t.transmittance.sum,
            t.absorbed.sum,
            t.residual(),
        ];
        let sum: f64 = parts.iter().sum::<f64>() / nf;
        balance.insert(
            ch.name().into(),
            json!({
                "specular": t.specular / nf,
                "rd": t.rd.sum / nf,
                "transmittance": t.transmittance.sum / nf,
                "absorbed": t.absorbed.sum / nf,
                "roulette_loss": t.roulette_loss / nf,
                "roulette_gain": t.roulette_gain / nf,
                "truncated": t.truncated / nf,
                "sum": sum,
                "sum_minus_1": sum - 1.0,
            }),
        );
        if opts.single_scatter {
            let (v, e) = density(&t.single_bins, n);
            single.push(json!({
                "channel": ch.name(),
                "total": t.single.mean(n),
                "total_stderr": t.single.stderr(n),
                "rd": v,
                "rd_stderr": e,
            }));
        }
        warnings.extend(channel_warnings(run, *ch, opts, cfg));
    }
    if let Some(w) = grid_rule.get("warnings").and_then(|w| w.as_array()) {
        warnings.extend(w.iter().filter_map(|s| s.as_str().map(String::from)));
    }
    let photons: Vec<u64> = runs.iter().map(|(r, _)| r.tally.photons).collect();
    let finite = runs.iter().any(|(_, s)| s.is_finite());
    let budget = match cfg.budget {
        PhotonBudget::Fixed(n) => json!({"fixed": n}),
        PhotonBudget::TargetError { rel, max_photons } => {
            json!({"target_error": rel, "max_photons": max_photons})
        }
    };
    let mut extra = json!({
        "energy_balance": balance,
        "rd_beyond_rmax": per(&|r| r.tally.rd_beyond / r.tally.photons as f64),
        "rel_error_total_rd": per(&|r| r.rel_total),
        "rel_error_profile": per(&|r| r.rel_profile),
        "r99_mm": per(&|r| r.r99),
        "converged": runs.iter().map(|(r, _)| r.converged).collect::<Vec<_>>(),
        "events_per_photon": per(&|r| r.tally.events as f64 / r.tally.photons as f64),
        "truncated_photons": runs.iter().map(|(r, _)| r.tally.truncated_photons).collect::<Vec<_>>(),
        "warnings": warnings,
    });
    if opts.single_scatter {
        extra["single_scatter"] = json!(single);
    }
    Profile {
        schema: PROFILE_SCHEMA.into(),
        material: material.clone(),
        units: "mm".into(),
        source: Source {
            kind: "monte-carlo".into(),
            photons: Some(photons),
            seed: Some(cfg.seed),
            model: Some("mcml".into()),
            params: json!({
                "boundary": opts.boundary.name(),
                "budget": budget,
                "max_events": opts.max_events,
                "max_work": opts.max_work,
                "roulette": {"threshold": opts.roulette_threshold, "survival": ROULETTE_CHANCE},
                "chunk": CHUNK,
                "batch": BATCH,
                "rng": "xoshiro256++ per (seed, channel, chunk), SplitMix64-hashed",
                "grid": grid_rule,
                "profile_error": "R_d-weighted mean relative stderr of bins inside r99 (99% of R_d)",
            }),
        },
        channels: cfg.channels.clone(),
        r_edges: grid.edges.clone(),
        r: grid.centres(),
        rd,
        rd_stderr: Some(rd_err),
        total_rd: per(&|r| r.tally.rd.mean(r.tally.photons)),
        total_rd_stderr: Some(per(&|r| r.tally.rd.stderr(r.tally.photons))),
        specular: per(&|r| r.tally.specular / r.tally.photons as f64),
        transmittance: Some(per(&|r| r.tally.transmittance.mean(r.tally.photons))),
        transmittance_stderr: finite
            .then(|| per(&|r| r.tally.transmittance.stderr(r.tally.photons))),
        absorbed: Some(per(&|r| r.tally.absorbed.mean(r.tally.photons))),
        extra,
        elapsed_s,
    }
}

/// What a user must know about how a channel's run ended.
fn channel_warnings(
    run: &ChannelRun,
    ch: Channel,
    opts: &McOptions,
    cfg: &McConfig,
) -> Vec<String> {
    let t = &run.tally;
    let n = t.photons as f64;
    let c = ch.name();
    let mut w = Vec::new();
    if t.truncated_photons > 0 {
        w.push(format!(
            "channel {c}: {} of {} packets reached the cap of {} events and were abandoned; \
             truncated energy {:.3e} of the launched (reported as 'truncated', not in R_d)",
            t.truncated_photons,
            t.photons,
            opts.max_events,
            t.truncated / n
        ));
    }
    let beyond = t.rd_beyond / n;
    let total = t.rd.sum / n;
    if total > 0.0 && beyond > 1e-3 * total {
        w.push(format!(
            "channel {c}: {:.2}% of R_d left beyond r_max (counted in total_rd, not in the profile)",
            100.0 * beyond / total
        ));
    }
    if total == 0.0 {
        w.push(format!(
            "channel {c}: no diffuse reflectance (no scattering or nothing comes back)"
        ));
    }
    if !run.converged {
        if let PhotonBudget::TargetError { rel, max_photons } = cfg.budget {
            let cap = if run.work_capped {
                format!("the work cap of {} events (--max-work)", opts.max_work)
            } else {
                format!("the cap of {max_photons} photons")
            };
            w.push(format!(
                "channel {c}: target error {rel} not reached within {cap}; \
                 achieved total R_d {:.2e}, profile {:.2e} with {} photons",
                run.rel_total, run.rel_profile, t.photons
            ));
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;

    #[test]
    fn chunk_streams_differ() {
        use rand_core::RngCore;
        let a = chunk_rng(1, Channel::R, 0).next_u64();
        let b = chunk_rng(1, Channel::R, 1).next_u64();
        let c = chunk_rng(1, Channel::G, 0).next_u64();
        let d = chunk_rng(2, Channel::R, 0).next_u64();
        assert!(a != b && a != c && a != d && b != c);
    }

    #[test]
    fn invalid_config_is_rejected() {
        let m = crate::material::preset("skin1").unwrap();
        let mut cfg = McConfig {
            budget: PhotonBudget::Fixed(0),
            seed: 1,
            threads: None,
            channels: vec![Channel::R],
            grid: None,
        };
        let e = simulate(&m, &cfg, &NoProgress).unwrap_err().to_string();
        assert!(e.contains("--photons"), "{e}");
        cfg.budget = PhotonBudget::TargetError {
            rel: f64::NAN,
            max_photons: 10,
        };
        let e = simulate(&m, &cfg, &NoProgress).unwrap_err().to_string();
        assert!(e.contains("--target-error"), "{e}");
        cfg.budget = PhotonBudget::Fixed(10);
        for edges in [
            vec![0.0],
            vec![0.0, 0.1, 0.1],
            vec![0.1, 0.2],
            vec![0.0, f64::NAN],
        ] {
            cfg.grid = Some(RadialGrid { edges });
            let e = simulate(&m, &cfg, &NoProgress).unwrap_err().to_string();
            assert!(e.contains("radial grid"), "{e}");
        }
    }
}
