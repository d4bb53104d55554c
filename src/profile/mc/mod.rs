//! Monte Carlo photon transport (the MCML scheme; Wang et al. 1995):
//! diffuse reflectance profile, totals with standard errors, and an exact
//! energy balance, reproducible whatever the thread count.
//!
//! Reproducibility: photons run in chunks of `CHUNK` packets; chunk k of
//! channel c draws from its own Xoshiro256++ stream (Blackman and Vigna
//! 2021) seeded from (seed, c, k) by SplitMix64 hashing. Each chunk's f64
//! sums are added to exact fixed-point totals (`exact`), so the result does
//! not depend on which thread traced which chunk, in which order, or on
//! which machine (shards).
//! A target-error run traces rounds of chunks whose length depends only on
//! the totals so far, and checks its rule between rounds, so the photon
//! count does not depend on the thread count either.

pub mod angular;
mod balance;
mod consumer;
mod exact;
pub mod gpu;
pub mod mci;
pub mod mco;
mod tally;
pub(crate) mod tracer;

pub use angular::{Angular, AngularOptions};
pub use balance::EnergyBalance;
pub use consumer::{kernel_geometry, KernelGeometry};
pub use tally::Moments;
pub use tracer::{
    BoundaryMode, DEFAULT_EVENT_ROULETTE, DEFAULT_ROULETTE_THRESHOLD, EVENT_ROULETTE_SURVIVAL,
    ROULETTE_CHANCE, ROULETTE_THRESHOLD,
};

use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::{Profile, RadialGrid, Source, PROFILE_SCHEMA};
use crate::progress::Progress;
use consumer::Projection;
use exact::ExactTally;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;
use tally::{BinIndex, ChunkTally, PhotonScratch};
use tracer::{Stack, WalkSettings};

/// Photons per chunk (one RNG stream each).
pub const CHUNK: u64 = 8192;
/// Chunks per channel in the first round of a target-error run.
pub const FIRST_ROUND: u64 = 2;

/// Default target of the kernel-factor rule: 0.5% relative L2 standard error.
pub const DEFAULT_KERNEL_ERROR: f64 = 0.005;

/// Default photon cap per channel of the target-error rules.
pub const DEFAULT_MAX_PHOTONS: u64 = 100_000_000;

/// The one default seed of every Monte Carlo run of the command line (the
/// seed scripts/regen-kernels gives the reference profiles in
/// profiles/reference/).
pub const DEFAULT_SEED: u64 = 20260101;

/// How many photons to trace.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhotonBudget {
    /// Exactly this many per channel.
    Fixed(u64),
    /// Rule "total-and-profile": until the relative standard error of the
    /// total R_d and of the profile inside the radius holding 99% of R_d
    /// (R_d-weighted mean of the bins' relative errors) is below `rel` in
    /// every channel, or `max_photons` per channel are spent.
    TargetError { rel: f64, max_photons: u64 },
    /// Rule "kernel-factor": until the relative L2 standard error of the
    /// pre-integrated 1D kernel factor on the default kernel grid (see
    /// `consumer`) and the relative standard error of the total R_d (the
    /// kernel's colour) are below `rel` in every channel, or `max_photons`
    /// per channel are spent.
    KernelFactor { rel: f64, max_photons: u64 },
}

impl PhotonBudget {
    /// Photons per channel at most.
    pub fn max_photons(&self) -> u64 {
        match *self {
            PhotonBudget::Fixed(n) => n,
            PhotonBudget::TargetError { max_photons, .. }
            | PhotonBudget::KernelFactor { max_photons, .. } => max_photons,
        }
    }

    /// The rule's name as recorded in `source.params.budget.rule`.
    pub fn rule(&self) -> &'static str {
        match self {
            PhotonBudget::Fixed(_) => "fixed",
            PhotonBudget::TargetError { .. } => "total-and-profile",
            PhotonBudget::KernelFactor { .. } => "kernel-factor",
        }
    }
}

/// Part k (1-based) of n disjoint parts of a fixed-budget run: the chunks
/// [(k - 1) C / n, k C / n) of every channel, C the run's chunk count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub k: u64,
    pub n: u64,
}

impl Shard {
    /// The chunk range of this shard among `chunks`.
    pub fn chunks(&self, chunks: u64) -> (u64, u64) {
        let at = |k: u64| ((k as u128 * chunks as u128) / self.n as u128) as u64;
        (at(self.k - 1), at(self.k))
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
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
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct McOptions {
    /// MCML's all-or-none choice at the ambient boundaries (default: the
    /// more efficient in every case measured, see docs/mc.md) or splitting.
    pub boundary: BoundaryMode,
    /// Events (interactions + boundary hits) from which a packet plays the
    /// event-count roulette (unbiased; see `EVENT_ROULETTE_SURVIVAL`).
    pub event_roulette: u64,
    /// Hard cap on events per packet, default none (u64::MAX): a packet
    /// stopped there is abandoned and its weight reported as truncated. The
    /// GPU tracer applies at most `gpu::GPU_MAX_EVENTS`.
    pub max_events: u64,
    /// Also tally reflectance of packets scattered exactly once
    /// (`extra.single_scatter`).
    pub single_scatter: bool,
    /// Work cap of every run, in events (interactions + boundary hits) per
    /// channel: no new round starts once a channel has spent this many.
    /// Keeps slow media (albedo near 1) bounded; reported when it stops a
    /// run. A fixed photon count that would surely exceed it, or whose first
    /// round projects more, is refused (see `check_fixed_work`).
    pub max_work: u64,
    /// Weight below which Russian roulette plays (default 0.01; MCML: 1e-4).
    /// Any value in (0, 1) is unbiased; higher values trade variance for speed.
    pub roulette_threshold: f64,
    /// Trace one part of the run only (fixed budgets); the profile then
    /// carries the exact sums that `merge_shards` combines.
    pub shard: Option<Shard>,
    /// Absolute floor of the kernel-factor rule (see `DEFAULT_ABS_FLOOR`);
    /// 0 turns it off.
    #[serde(default)]
    pub abs_floor: f64,
    /// Angle-resolved tallies (exit angle, oblique incidence); None: the
    /// default walk, which carries none of their code.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular: Option<AngularOptions>,
}

impl Default for McOptions {
    fn default() -> Self {
        McOptions {
            boundary: BoundaryMode::Classic,
            event_roulette: DEFAULT_EVENT_ROULETTE,
            max_events: DEFAULT_MAX_EVENTS,
            single_scatter: false,
            max_work: DEFAULT_MAX_WORK,
            roulette_threshold: DEFAULT_ROULETTE_THRESHOLD,
            shard: None,
            abs_floor: DEFAULT_ABS_FLOOR,
            angular: None,
        }
    }
}

/// Absolute floor of the kernel-factor rule, as a fraction of the incident
/// light: a channel also stops once the noise it brings to a kernel, the
/// standard error of its total R_d and R_d times the relative L2 error of
/// its kernel factor, is below this, after at least `3 / floor` photons.
///
/// Why 2e-6: the smallest non-zero 8-bit sRGB value is 1/(255 x 12.92) =
/// 3.0e-4 in linear light, the step near black of 10-bit sRGB 7.6e-5 and of
/// 12-bit 1.9e-5, and a half float resolves 2^-11 of a value (2e-6 at 4e-3):
/// an error of 2e-6 of the light reaching a surface is 150x below what an
/// 8-bit display shows and 9x below a 12-bit step. Where R_d >= floor /
/// target (4e-4 at the defaults) the floor implies the relative rule, so it
/// never stops such a channel earlier (nor changes its rounds); only wine's
/// and beer's channels stop at the floor (`stopped_by` per preset in
/// docs/records/mc-presets.json). It exists for media that barely scatter
/// back: a return probability p estimated from N photons has a relative
/// error of about (N p)^-1/2, so 0.5% at p = 1e-4 takes 4e8 photons while
/// the kernel is invisible. The photon minimum is the rule of three: with
/// no return in 3/floor photons a return probability above the floor is
/// excluded at 95%, so a channel cannot stop on an error estimated from too
/// few returns.
pub const DEFAULT_ABS_FLOOR: f64 = 2e-6;

/// Default work cap, in events per channel: far above what a default run
/// of any preset spends (photons per preset in docs/records/mc-presets.json)
/// and small enough that an albedo-1 medium ends in minutes, not hours; the
/// time per event on a given machine is measured by `cargo bench --bench
/// mc` (ns per event in docs/records/mc-speed.json).
pub const DEFAULT_MAX_WORK: u64 = 1_500_000_000;

/// Default hard event cap: none. Albedo-1 walks are ended without bias by
/// the event-count roulette instead (a cap at n events leaves ~n^-1/2 of
/// the energy unaccounted, the first-passage law of
/// `EVENT_ROULETTE_SURVIVAL`).
pub const DEFAULT_MAX_EVENTS: u64 = u64::MAX;

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
        // The kernel rule's consumer needs the core resolved and the tail
        // integrated, not every tail bin exact: geometric bins.
        None => RadialGrid::for_material_rule(
            material,
            &cfg.channels,
            matches!(cfg.budget, PhotonBudget::KernelFactor { .. }),
        ),
    };
    grid.check_edges()?;
    if let Some(a) = &opts.angular {
        a.validate(grid.len())?;
    }
    let threads = tally_threads(grid.len(), cfg.channels.len(), cfg.threads)?;
    let pool = crate::limits::thread_pool(threads)?;
    let cap = cfg.budget.max_photons();
    let n_chunks = cap.div_ceil(CHUNK);
    let range = match opts.shard {
        Some(s) => s.chunks(n_chunks),
        None => (0, n_chunks),
    };
    let stacks: Vec<Stack> = cfg
        .channels
        .iter()
        .map(|&ch| Stack::new(material, ch))
        .collect();
    let job = Job {
        material,
        cfg,
        opts,
        grid: &grid,
        bins: BinIndex::new(&grid),
        set: WalkSettings {
            mode: opts.boundary,
            event_roulette: opts.event_roulette,
            max_events: opts.max_events,
            single_scatter: opts.single_scatter,
            roulette_threshold: opts.roulette_threshold,
            chunk_events: u64::MAX,
            angular: opts.angular.as_ref().and_then(|a| a.layout(grid.len())),
        },
        stacks,
        cap,
        range,
    };
    let photons_in = |a: u64, b: u64| (b * CHUNK).min(cap).saturating_sub(a * CHUNK);
    progress.start(
        photons_in(range.0, range.1).saturating_mul(cfg.channels.len() as u64),
        &format!("{} photons", material.name),
    );
    let runs = pool.install(|| job.run(progress));
    progress.finish();
    let runs = runs?;
    let angular = match opts.angular.as_ref() {
        None => None,
        Some(a) => {
            let photons: Vec<u64> = runs.iter().map(|r| r.tally.photons).collect();
            let oblique =
                pool.install(|| angular::trace_incidences(&job, a, &photons, progress))?;
            let tallies: Vec<ExactTally> = runs.iter().map(|r| r.tally.clone()).collect();
            Some((a, angular::results(&grid, a, &tallies, &oblique)))
        }
    };
    let mut p = build_profile(
        material,
        cfg,
        opts,
        &grid,
        grid_rule.clone(),
        &runs,
        start.elapsed().as_secs_f64(),
    );
    if let Some((a, results)) = angular {
        p.source.params["angular"] = json!(a);
        p.extra["angular"] = json!(results);
    }
    if let Some(s) = opts.shard {
        let record = ShardRecord {
            k: s.k,
            n: s.n,
            chunks: range,
            config: McConfig {
                threads: None,
                ..cfg.clone()
            },
            options: McOptions {
                shard: None,
                ..opts.clone()
            },
            grid_rule,
            tallies: runs.into_iter().map(|r| r.tally).collect(),
            sha256: String::new(),
        };
        let record = ShardRecord {
            sha256: record.content_hash(material, &grid.edges)?,
            ..record
        };
        p.source.params["shard"] = json!({"k": s.k, "n": s.n});
        if let Some(w) = p.extra["warnings"].as_array_mut() {
            w.push(json!(format!(
                "partial profile: shard {} of {} ({} of {} photons per channel); merge all {} shards for the run",
                s.k,
                s.n,
                photons_in(range.0, range.1),
                cap,
                s.n
            )));
        }
        p.extra["shard"] = serde_json::to_value(&record)
            .map_err(|e| Error::Unsupported(format!("cannot record the shard: {e}")))?;
    }
    Ok(p)
}

/// What a shard keeps so that `merge_shards` rebuilds the single run exactly.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct ShardRecord {
    k: u64,
    n: u64,
    chunks: (u64, u64),
    config: McConfig,
    options: McOptions,
    grid_rule: serde_json::Value,
    tallies: Vec<ExactTally>,
    /// SHA-256 of everything above with the material and the bin edges
    /// (`content_hash`): a shard changed after it was written is refused.
    #[serde(default)]
    sha256: String,
}

impl ShardRecord {
    /// The SHA-256 (hex) of the record's JSON without its hash, the
    /// material and the bin edges: a function of the values only (the
    /// exact sums serialise canonically, floats round-trip exactly).
    fn content_hash(&self, material: &Material, edges: &[f64]) -> Result<String> {
        use sha2::Digest;
        let bytes = serde_json::to_vec(&(
            self.k,
            self.n,
            self.chunks,
            &self.config,
            &self.options,
            &self.grid_rule,
            &self.tallies,
            material,
            edges,
        ))
        .map_err(|e| Error::Unsupported(format!("cannot hash the shard: {e}")))?;
        Ok(sha2::Sha256::digest(&bytes)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect())
    }
}

/// Tolerance of the energy balance of a merged or shard tally, per photon
/// (scaled by the roulette's gains and losses, which cancel): the exact
/// sums close it to the rounding of each chunk's f64 sums.
pub const MERGE_BALANCE_TOLERANCE: f64 = 1e-9;

/// The context of a bad setting's error; its parameters are the fields of
/// `McConfig`, `PhotonBudget` (the rule's name for its relative error) and
/// `McOptions`.
pub const CONTEXT: &str = "Monte Carlo";

fn validate_config(cfg: &McConfig, opts: &McOptions) -> Result<()> {
    match cfg.budget {
        PhotonBudget::Fixed(n) if n == 0 => {
            return Err(Error::invalid(CONTEXT, "photons", n, "must be >= 1"))
        }
        PhotonBudget::TargetError { rel, max_photons }
        | PhotonBudget::KernelFactor { rel, max_photons } => {
            let field = match cfg.budget {
                PhotonBudget::TargetError { .. } => "target_error",
                _ => "kernel_error",
            };
            if !(rel.is_finite() && rel > 0.0 && rel < 1.0) {
                return Err(Error::invalid(
                    CONTEXT,
                    field,
                    rel,
                    "must be in (0, 1), e.g. 0.01",
                ));
            }
            if max_photons == 0 {
                return Err(Error::invalid(
                    CONTEXT,
                    "max_photons",
                    max_photons,
                    "must be >= 1",
                ));
            }
        }
        _ => {}
    }
    if opts.shard.is_some() && opts.angular.is_some() {
        return Err(Error::invalid(
            CONTEXT,
            "shard",
            opts.shard
                .map_or(String::new(), |s| format!("{}/{}", s.k, s.n)),
            "angle-resolved tallies (exit-angle bins, incidence angles) are not traced in \
             shards: run them in one piece",
        ));
    }
    if let Some(s) = opts.shard {
        if !matches!(cfg.budget, PhotonBudget::Fixed(_)) {
            return Err(Error::invalid(
                CONTEXT,
                "shard",
                format!("{}/{}", s.k, s.n),
                "needs a fixed photon count shared by all shards; \
                 a target-error rule cannot be split",
            ));
        }
        let chunks = cfg.budget.max_photons().div_ceil(CHUNK);
        if s.n == 0 || s.k == 0 || s.k > s.n || s.n > chunks {
            return Err(Error::invalid(
                CONTEXT,
                "shard",
                format!("{}/{}", s.k, s.n),
                format!("need 1 <= K <= N <= {chunks} (the run's chunks of {CHUNK} photons)"),
            ));
        }
    }
    if cfg.channels.is_empty() {
        return Err(Error::invalid(CONTEXT, "channels", "''", "empty"));
    }
    if let Some(n) = cfg.threads {
        crate::limits::check_threads("worker threads", n)?;
    }
    if opts.max_work == 0 {
        return Err(Error::invalid(CONTEXT, "max_work", 0, "must be >= 1"));
    }
    if !(opts.roulette_threshold > 0.0 && opts.roulette_threshold < 1.0) {
        return Err(Error::invalid(
            CONTEXT,
            "roulette_threshold",
            opts.roulette_threshold,
            "must be in (0, 1); MCML uses 1e-4",
        ));
    }
    if !(opts.abs_floor >= 0.0 && opts.abs_floor < 1.0) {
        return Err(Error::invalid(
            CONTEXT,
            "abs_floor",
            opts.abs_floor,
            "must be in [0, 1): a fraction of the incident light, 0 = off",
        ));
    }
    if opts.event_roulette == 0 {
        return Err(Error::invalid(CONTEXT, "event_roulette", 0, "must be >= 1"));
    }
    if opts.max_events == 0 {
        return Err(Error::invalid(CONTEXT, "max_events", 0, "must be >= 1"));
    }
    if let PhotonBudget::Fixed(n) = cfg.budget {
        // Every packet makes at least one event (it enters with weight
        // 1 - R_sp > 0): more photons than the cap surely exceed it.
        let mine = match opts.shard {
            Some(s) => {
                let (a, b) = s.chunks(n.div_ceil(CHUNK));
                (b * CHUNK).min(n) - a * CHUNK
            }
            None => n,
        };
        if mine > opts.max_work {
            return Err(fixed_over_cap(
                n,
                format!("{mine} photons per channel cost at least one event each"),
                opts.max_work,
            ));
        }
    }
    Ok(())
}

/// The refusal of a fixed photon count whose work exceeds the cap.
fn fixed_over_cap(photons: u64, why: String, max_work: u64) -> Error {
    Error::invalid(
        CONTEXT,
        "photons",
        photons,
        format!(
            "{why}, above the work cap of {max_work} events per channel (`max_work`): \
             lower the photon count, raise the work cap, or split the run into shards"
        ),
    )
}

/// A fixed run's check after its first round (`photons_done` of `total`
/// photons per channel, which cost `events`): refused before the rest when
/// the events per photon measured so far project more than `max_work`. An
/// estimate; the run itself also stops at the cap (`Job::run`).
pub(crate) fn check_fixed_work(
    ch: Channel,
    photons_done: u64,
    events: u64,
    total: u64,
    requested: u64,
    max_work: u64,
) -> Result<()> {
    let per_photon = events as f64 / photons_done.max(1) as f64;
    let projected = per_photon * total as f64;
    if projected > max_work as f64 {
        return Err(fixed_over_cap(
            requested,
            format!(
                "channel {}: {per_photon:.1} events per photon over its first {photons_done} \
                 photons project {projected:.2e} events for {total} photons",
                ch.name()
            ),
            max_work,
        ));
    }
    Ok(())
}

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): decorrelates stream keys.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
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

/// How a channel's run ended.
#[derive(Clone, Copy, Debug, Default)]
struct Status {
    /// Relative standard error of total R_d.
    rel_total: f64,
    /// R_d-weighted mean relative error of the bins inside r99 (`convergence`).
    rel_profile: f64,
    /// Radius holding 99% of R_d.
    r99: f64,
    /// Relative L2 standard error of the kernel factor (`consumer`).
    rel_factor: f64,
    /// Total R_d and its standard error.
    rd: f64,
    rd_stderr: f64,
}

/// A finished channel: its tally and how the run ended.
struct ChannelRun {
    tally: ExactTally,
    status: Status,
    converged: bool,
    /// Stopped by `McOptions::max_work` before the target error.
    work_capped: bool,
    /// Converged by the absolute floor, not the relative target.
    by_floor: bool,
}

/// One simulation's fixed inputs, shared by the workers.
struct Job<'a> {
    material: &'a Material,
    cfg: &'a McConfig,
    opts: &'a McOptions,
    grid: &'a RadialGrid,
    bins: BinIndex,
    set: WalkSettings,
    stacks: Vec<Stack>,
    /// Photons per channel at most, and the chunks [a, b) this run may trace.
    cap: u64,
    range: (u64, u64),
}

/// One thread's scratch: a chunk's f64 tally and a packet's scores
/// (allocated on first use, kept across rounds).
struct Scratch {
    chunk: ChunkTally,
    photon: PhotonScratch,
}

/// Bytes per radial bin of a run's tallies: the exact sums of every
/// channel (two per bin, 32 bytes each) held by the run, by the round being
/// traced and by the status check (which also converts them to f64), and
/// each thread's scratch (a chunk's two f64 sums and a packet's one).
const EXACT_BYTES_PER_BIN: u64 = 3 * 64 + 2 * 16;
const SCRATCH_BYTES_PER_BIN: u64 = 3 * 8;

/// The worker threads of a run on `bins` radial bins and `channels`
/// channels: `requested` (or the default count) reduced so that the
/// tallies fit [`crate::limits::MAX_TALLY_BYTES`] (results never depend on
/// the thread count); refused when even one thread's do not.
fn tally_threads(bins: usize, channels: usize, requested: Option<usize>) -> Result<usize> {
    let wanted = crate::limits::worker_threads(requested)?;
    let cap = crate::limits::MAX_TALLY_BYTES;
    let fixed = (bins as u64)
        .saturating_mul(channels as u64)
        .saturating_mul(EXACT_BYTES_PER_BIN);
    let per_thread = (bins as u64).saturating_mul(SCRATCH_BYTES_PER_BIN).max(1);
    let fit = cap.saturating_sub(fixed) / per_thread;
    if fit == 0 {
        return Err(Error::invalid(
            "radial grid",
            "bins",
            bins,
            format!(
                "a Monte Carlo run of {channels} channel(s) on {bins} bins needs more than the \
                 {} MiB its tallies may take: use wider bins or a smaller radius",
                cap >> 20
            ),
        ));
    }
    Ok(wanted.min(fit.min(usize::MAX as u64) as usize))
}

/// Work units of one chunk besides its events: clearing and adding its
/// per-bin sums costs about one event per bin, so a grid of many bins costs
/// work even where few photons land.
fn chunk_overhead(bins: usize) -> u64 {
    bins as u64
}

impl Job<'_> {
    fn photons(&self, k: u64) -> u64 {
        CHUNK.min(self.cap - k * CHUNK)
    }

    /// Traces chunk `k` of channel `c` into `s.chunk` within `budget`
    /// events; false when the chunk needed more (its tally is then unusable).
    fn trace(&self, s: &mut Scratch, c: usize, k: u64, budget: u64) -> bool {
        s.chunk.reset();
        let mut rng = chunk_rng(self.cfg.seed, self.cfg.channels[c], k);
        let set = WalkSettings {
            chunk_events: budget,
            ..self.set
        };
        tracer::trace_photons(
            &self.stacks[c],
            &self.bins,
            &set,
            &mut rng,
            self.photons(k),
            &mut s.chunk,
            &mut s.photon,
        );
        s.chunk.events <= budget
    }

    /// Traces rounds of chunks over all channels at once (any number of
    /// threads share a round), checking the budget's rule and the work cap
    /// between rounds. A fixed run's rounds double (`FIRST_ROUND` chunks,
    /// then as many as traced so far): the sums are the same whatever the
    /// rounds, and the work cap is checked log2(chunks) times.
    ///
    /// Work is bounded inside a round too: each chunk of a channel gets an
    /// equal share of the events the channel has left under `max_work`
    /// (less its overhead, `chunk_overhead`), and a chunk that needs more
    /// stops there. The round of that channel is then discarded whole and
    /// the channel stops on the rounds before (its first round: an error).
    /// Shares and event counts are functions of the seed, so which rounds
    /// count does not depend on the threads either. Chunks add their sums
    /// straight into one exact tally per channel (exact sums do not depend
    /// on the order), so memory does not grow with the threads beyond their
    /// scratch.
    fn run(&self, progress: &dyn Progress) -> Result<Vec<ChannelRun>> {
        use std::sync::atomic::{AtomicBool, Ordering};
        use std::sync::Mutex;
        let nch = self.stacks.len();
        let (nb, single) = (self.bins.len(), self.set.single_scatter);
        fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
            m.lock().unwrap_or_else(|e| e.into_inner())
        }
        let mut runs: Vec<ChannelRun> = (0..nch)
            .map(|_| ChannelRun {
                tally: ExactTally::new(nb, single),
                status: Status::default(),
                converged: false,
                work_capped: false,
                by_floor: false,
            })
            .collect();
        let target = match self.cfg.budget {
            PhotonBudget::Fixed(_) => None,
            PhotonBudget::TargetError { rel, .. } | PhotonBudget::KernelFactor { rel, .. } => {
                Some(rel)
            }
        };
        let scratch: Vec<Mutex<Option<Scratch>>> = (0..rayon::current_num_threads().max(1))
            .map(|_| Mutex::new(None))
            .collect();
        let mut next = vec![self.range.0; nch];
        let mut active = vec![true; nch];
        let mut ratio = vec![f64::INFINITY; nch];
        let mine = (self.range.1 * CHUNK).min(self.cap) - self.range.0 * CHUNK;
        let mut first = true;
        loop {
            let mut units = Vec::new();
            let mut budget = vec![0u64; nch];
            for c in (0..nch).filter(|&c| active[c]) {
                let left = self.range.1 - next[c];
                let len = round_len(next[c] - self.range.0, ratio[c]).min(left);
                let done = next[c] - self.range.0;
                let spent = work_of(&runs[c].tally, done, nb);
                budget[c] = (self.opts.max_work.saturating_sub(spent) / len.max(1))
                    .saturating_sub(chunk_overhead(nb));
                units.extend((next[c]..next[c] + len).map(|k| (c, k)));
                next[c] += len;
            }
            if units.is_empty() {
                break;
            }
            let sums: Vec<Mutex<Option<ExactTally>>> = (0..nch).map(|_| Mutex::new(None)).collect();
            let over: Vec<AtomicBool> = (0..nch).map(|_| AtomicBool::new(false)).collect();
            let failed: Mutex<Option<String>> = Mutex::new(None);
            units.par_iter().for_each(|&(c, k)| {
                // A channel whose round is already void skips the rest of it.
                if over[c].load(Ordering::Relaxed) {
                    return;
                }
                let slot = rayon::current_thread_index().unwrap_or(0) % scratch.len();
                let mut guard = lock(&scratch[slot]);
                let s = guard.get_or_insert_with(|| Scratch {
                    chunk: ChunkTally::new(nb, single),
                    photon: PhotonScratch::new(nb, single),
                });
                if !self.trace(s, c, k, budget[c]) {
                    over[c].store(true, Ordering::Relaxed);
                    return;
                }
                progress.advance(self.photons(k));
                let added = lock(&sums[c])
                    .get_or_insert_with(|| ExactTally::new(nb, single))
                    .add_chunk(&s.chunk);
                if let Err(e) = added {
                    lock(&failed)
                        .get_or_insert(format!("channel {}: {e}", self.cfg.channels[c].name()));
                }
            });
            if let Some(e) = lock(&failed).take() {
                return Err(Error::Unsupported(e));
            }
            for c in 0..nch {
                if over[c].load(Ordering::Relaxed) {
                    if runs[c].tally.photons == 0 {
                        return Err(first_round_over_cap(
                            self.cfg.channels[c],
                            units
                                .iter()
                                .filter(|u| u.0 == c)
                                .map(|u| self.photons(u.1))
                                .sum(),
                            self.opts.max_work,
                        ));
                    }
                    runs[c].work_capped = true;
                    active[c] = false;
                    continue;
                }
                let part = sums[c].lock().unwrap_or_else(|e| e.into_inner()).take();
                if let Some(p) = part {
                    runs[c].tally.add(&p).map_err(|e| {
                        Error::Unsupported(format!("channel {}: {e}", self.cfg.channels[c].name()))
                    })?;
                }
            }
            let tallies: Vec<ExactTally> = runs.iter().map(|r| r.tally.clone()).collect();
            let (status, _) = statuses(self.material, &self.cfg.channels, self.grid, &tallies);
            for c in 0..nch {
                runs[c].status = status[c];
                if !active[c] {
                    continue;
                }
                let work = work_of(&runs[c].tally, next[c] - self.range.0, nb);
                if let Some(rel) = target {
                    // No reflectance yet counts as exact only where nothing
                    // can scatter back; a nearly clear medium must go on.
                    let scatters = self
                        .material
                        .layers
                        .iter()
                        .any(|l| l.sigma_s[self.cfg.channels[c].index()] > 0.0);
                    let err = if scatters && runs[c].tally.totals[1].to_f64() == 0.0 {
                        f64::INFINITY
                    } else {
                        rule_error(&self.cfg.budget, &status[c])
                    };
                    let floor = floor_ratio(
                        &self.cfg.budget,
                        self.opts.abs_floor,
                        &status[c],
                        runs[c].tally.photons,
                    );
                    ratio[c] = (err / rel).min(floor);
                    if err <= rel || floor <= 1.0 {
                        runs[c].converged = true;
                        runs[c].by_floor = err > rel;
                        active[c] = false;
                    } else if work >= self.opts.max_work {
                        runs[c].work_capped = true;
                        active[c] = false;
                    }
                } else if next[c] < self.range.1 {
                    let t = &runs[c].tally;
                    if first {
                        check_fixed_work(
                            self.cfg.channels[c],
                            t.photons,
                            t.events,
                            mine,
                            self.cap,
                            self.opts.max_work,
                        )?;
                    }
                    if work >= self.opts.max_work {
                        runs[c].work_capped = true;
                        active[c] = false;
                    }
                }
                if next[c] >= self.range.1 {
                    active[c] = false;
                }
            }
            first = false;
        }
        if target.is_none() {
            runs.iter_mut().for_each(|r| r.converged = !r.work_capped);
        }
        Ok(runs)
    }
}

/// Work a channel has spent: its events and the overhead of its `chunks`.
fn work_of(t: &ExactTally, chunks: u64, bins: usize) -> u64 {
    t.events
        .saturating_add(chunks.saturating_mul(chunk_overhead(bins)))
}

/// The refusal of a run whose first round of `photons` photons did not
/// finish within the work cap: nothing to stop on.
fn first_round_over_cap(ch: Channel, photons: u64, max_work: u64) -> Error {
    Error::invalid(
        CONTEXT,
        "max_work",
        max_work,
        format!(
            "channel {}: its first {photons} photons needed more than the work cap of \
             {max_work} events (over {:.0} events per photon): this medium's walks are too long \
             for the cap (albedo near 1, g near 1, or many bins); raise the cap, or use wider \
             bins",
            ch.name(),
            max_work as f64 / photons.max(1) as f64
        ),
    )
}

/// How far a channel is from the absolute floor of the kernel-factor rule
/// (<= 1: reached; see `DEFAULT_ABS_FLOOR`) after `photons`; infinite for
/// other rules or with the floor off.
fn floor_ratio(budget: &PhotonBudget, floor: f64, s: &Status, photons: u64) -> f64 {
    if !matches!(budget, PhotonBudget::KernelFactor { .. }) || !(floor > 0.0) {
        return f64::INFINITY;
    }
    // Noise in the un-normalised kernel: R_d times the factor's relative
    // error (nothing back counts as 0 here: the photon minimum covers it).
    let shape = if s.rd > 0.0 { s.rd * s.rel_factor } else { 0.0 };
    let noise = s.rd_stderr.max(shape) / floor;
    // Written as an error ~ N^-1/2 so that round_len aims at it too.
    let minimum = (3.0 / floor / photons.max(1) as f64).sqrt();
    noise.max(minimum)
}

/// Chunks in the next round: `FIRST_ROUND` to start, then for a target-error
/// run what error ~ N^-1/2 predicts is missing (plus 10%), at least one
/// chunk and at most as many as traced so far (a fixed run, `ratio`
/// infinite: as many as traced so far). A function of the totals
/// only, so the photon count does not depend on the thread count.
fn round_len(done: u64, ratio: f64) -> u64 {
    if done == 0 {
        return FIRST_ROUND;
    }
    if !ratio.is_finite() {
        return done;
    }
    let more = (done as f64 * (1.1 * ratio * ratio - 1.0)).ceil();
    (more.max(1.0) as u64).min(done)
}

/// The error a target-error rule compares with its target.
fn rule_error(budget: &PhotonBudget, s: &Status) -> f64 {
    match budget {
        PhotonBudget::Fixed(_) => 0.0,
        PhotonBudget::TargetError { .. } => s.rel_total.max(s.rel_profile),
        PhotonBudget::KernelFactor { .. } => s.rel_total.max(s.rel_factor),
    }
}

/// R_d per bin (mm^-2) of a tally.
fn densities(sum: &[f64], n: u64, areas: &[f64]) -> Vec<f64> {
    let nf = n.max(1) as f64;
    sum.iter().zip(areas).map(|(s, a)| s / (nf * a)).collect()
}

/// The status of every channel and the default kernel grid they imply
/// (all channels together, as `Kernel2D::from_profile` sees them).
fn statuses(
    material: &Material,
    channels: &[Channel],
    grid: &RadialGrid,
    tallies: &[ExactTally],
) -> (Vec<Status>, Option<KernelGeometry>) {
    let t: Vec<ChunkTally> = tallies.iter().map(ExactTally::to_f64).collect();
    let areas = grid.areas();
    let provisional = Profile {
        schema: PROFILE_SCHEMA.into(),
        material: material.clone(),
        units: "mm".into(),
        source: Source {
            kind: "monte-carlo".into(),
            photons: None,
            seed: None,
            model: None,
            params: serde_json::Value::Null,
        },
        channels: channels.to_vec(),
        r_edges: grid.edges.clone(),
        r: grid.centres(),
        rd: t
            .iter()
            .map(|t| densities(&t.rd_bins.sum, t.photons, &areas))
            .collect(),
        rd_stderr: None,
        total_rd: t.iter().map(|t| t.rd.mean(t.photons)).collect(),
        total_rd_stderr: None,
        specular: vec![],
        transmittance: None,
        transmittance_stderr: None,
        absorbed: None,
        extra: serde_json::Value::Null,
        elapsed_s: 0.0,
    };
    let geometry = kernel_geometry(&provisional);
    let projection = geometry.map(|g| Projection::new(&grid.edges, &g));
    let s = t
        .iter()
        .map(|t| {
            let (rel_total, rel_profile, r99) = convergence(t, grid);
            let rel_factor = projection.as_ref().map_or(0.0, |p| {
                p.factor_rel_error(&t.rd_bins.sum, &t.rd_bins.sum_sq, t.photons)
            });
            Status {
                rel_total,
                rel_profile,
                r99,
                rel_factor,
                rd: t.rd.mean(t.photons),
                rd_stderr: t.rd.stderr(t.photons),
            }
        })
        .collect();
    (s, geometry)
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
    runs: &[ChannelRun],
    elapsed_s: f64,
) -> Profile {
    let areas = grid.areas();
    let ts: Vec<ChunkTally> = runs.iter().map(|r| r.tally.to_f64()).collect();
    let tallies: Vec<ExactTally> = runs.iter().map(|r| r.tally.clone()).collect();
    let (_, geometry) = statuses(material, &cfg.channels, grid, &tallies);
    let per = |f: &dyn Fn(&ChunkTally) -> f64| -> Vec<f64> { ts.iter().map(f).collect() };
    let per_run =
        |f: &dyn Fn(&Status) -> f64| -> Vec<f64> { runs.iter().map(|r| f(&r.status)).collect() };
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
                // Wang et al. 1995: R_d(r_i) = W_i / (N area_i).
                (m.mean(n) / areas[i], m.stderr(n) / areas[i])
            })
            .unzip()
    };
    let mut rd = Vec::new();
    let mut rd_err = Vec::new();
    let mut single = Vec::new();
    let mut warnings: Vec<String> = Vec::new();
    let mut balance = serde_json::Map::new();
    for ((t, run), ch) in ts.iter().zip(runs).zip(&cfg.channels) {
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
        let b = EnergyBalance {
            specular: t.specular / nf,
            rd: t.rd.sum / nf,
            transmittance: t.transmittance.sum / nf,
            absorbed: t.absorbed.sum / nf,
            roulette_loss: t.roulette_loss / nf,
            roulette_gain: t.roulette_gain / nf,
            truncated: t.truncated / nf,
            sum,
            sum_minus_1: sum - 1.0,
        };
        balance.insert(ch.name().into(), json!(b));
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
        warnings.extend(channel_warnings(t, run, *ch, opts, cfg));
        warnings.extend(fixed_cap_warning(t, run, *ch, opts, cfg));
    }
    if let Some(w) = grid_rule.get("warnings").and_then(|w| w.as_array()) {
        warnings.extend(w.iter().filter_map(|s| s.as_str().map(String::from)));
    }
    let photons: Vec<u64> = ts.iter().map(|t| t.photons).collect();
    let finite = material
        .layers
        .last()
        .is_some_and(|l| l.thickness.is_some());
    let definition = match cfg.budget {
        PhotonBudget::Fixed(_) => "",
        PhotonBudget::TargetError { .. } => {
            "relative stderr of total R_d and R_d-weighted mean relative stderr of the bins \
             inside r99 (99% of R_d), each <= target_error, in every channel"
        }
        PhotonBudget::KernelFactor { .. } => {
            "relative L2 stderr of the pre-integrated 1D kernel factor (Freude 2014 eq. 5.17) \
             on the default kernel grid, from per-bin second moments, and relative stderr of \
             total R_d, each <= target_error, in every channel"
        }
    };
    let mut budget = match cfg.budget {
        PhotonBudget::Fixed(n) => {
            json!({"rule": "fixed", "photons": n, "max_work": opts.max_work})
        }
        PhotonBudget::TargetError { rel, max_photons }
        | PhotonBudget::KernelFactor { rel, max_photons } => json!({
            "rule": cfg.budget.rule(),
            "target_error": rel,
            "max_photons": max_photons,
            "max_work": opts.max_work,
            "definition": definition,
        }),
    };
    if matches!(cfg.budget, PhotonBudget::KernelFactor { .. }) {
        budget["absolute_floor"] = json!({
            "floor": opts.abs_floor,
            "definition": "or: stderr of total R_d and R_d x relative L2 stderr of the kernel \
                           factor, each <= floor (a fraction of the incident light), after at \
                           least 3 / floor photons; 0 = off",
        });
    }
    let mut extra = json!({
        "energy_balance": balance,
        "rd_beyond_rmax": per(&|t| t.rd_beyond / t.photons as f64),
        "rel_error_total_rd": per_run(&|s| s.rel_total),
        "rel_error_profile": per_run(&|s| s.rel_profile),
        "rel_error_kernel_factor": per_run(&|s| s.rel_factor),
        "kernel_grid": geometry.map(|g| json!({"extent_mm": g.extent_mm, "size": g.size})),
        "r99_mm": per_run(&|s| s.r99),
        "converged": runs.iter().map(|r| r.converged).collect::<Vec<_>>(),
        "stopped_by": runs.iter().map(|r| stop_reason(cfg, r)).collect::<Vec<_>>(),
        "events_per_photon": per(&|t| t.events as f64 / t.photons as f64),
        "truncated_photons": ts.iter().map(|t| t.truncated_photons).collect::<Vec<_>>(),
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
                "event_roulette": {"start": opts.event_roulette, "survival_per_doubling": EVENT_ROULETTE_SURVIVAL},
                "roulette": {"threshold": opts.roulette_threshold, "survival": ROULETTE_CHANCE},
                "chunk": CHUNK,
                "rng": "xoshiro256++ per (seed, channel, chunk), SplitMix64-hashed",
                "sums": "exact fixed-point accumulation of chunk sums (order-free)",
                "grid": grid_rule,
            }),
        },
        channels: cfg.channels.clone(),
        r_edges: grid.edges.clone(),
        r: grid.centres(),
        rd,
        rd_stderr: Some(rd_err),
        total_rd: per(&|t| t.rd.mean(t.photons)),
        total_rd_stderr: Some(per(&|t| t.rd.stderr(t.photons))),
        specular: per(&|t| t.specular / t.photons as f64),
        transmittance: Some(per(&|t| t.transmittance.mean(t.photons))),
        transmittance_stderr: finite.then(|| per(&|t| t.transmittance.stderr(t.photons))),
        absorbed: Some(per(&|t| t.absorbed.mean(t.photons))),
        extra,
        elapsed_s,
    }
}

/// Why a channel's run ended: "photons" (fixed budget or photon cap),
/// "target", "absolute-floor" or "work-cap".
fn stop_reason(cfg: &McConfig, r: &ChannelRun) -> &'static str {
    match (&cfg.budget, r.converged) {
        (PhotonBudget::Fixed(_), _) if r.work_capped => "work-cap",
        (PhotonBudget::Fixed(_), _) => "photons",
        (_, true) if r.by_floor => "absolute-floor",
        (_, true) => "target",
        (_, false) if r.work_capped => "work-cap",
        (_, false) => "photons",
    }
}

/// What a user must know about how a channel's run ended.
fn channel_warnings(
    t: &ChunkTally,
    run: &ChannelRun,
    ch: Channel,
    opts: &McOptions,
    cfg: &McConfig,
) -> Vec<String> {
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
    if total > 1.0 {
        // Unbiased but useless: reflectance is at most the incident light.
        w.push(format!(
            "channel {c}: total R_d {total:.4} +- {:.2e} is above 1, more light than came in: \
             a few packets with boosted weights (long walks that survived the event-count \
             roulette) dominate the estimate; trace more photons",
            t.rd.stderr(t.photons)
        ));
    }
    if !run.converged && !matches!(cfg.budget, PhotonBudget::Fixed(_)) {
        let max_photons = cfg.budget.max_photons();
        let cap = if run.work_capped {
            format!("the work cap of {} events (`max_work`)", opts.max_work)
        } else {
            format!("the cap of {max_photons} photons (`max_photons`)")
        };
        let s = &run.status;
        let achieved = match cfg.budget {
            PhotonBudget::KernelFactor { .. } => format!("kernel factor {:.2e}", s.rel_factor),
            _ => format!("profile {:.2e}", s.rel_profile),
        };
        let rel = match cfg.budget {
            PhotonBudget::TargetError { rel, .. } | PhotonBudget::KernelFactor { rel, .. } => rel,
            PhotonBudget::Fixed(_) => 0.0,
        };
        w.push(format!(
            "channel {c}: target error {rel} ({} rule) not reached within {cap}; \
             achieved total R_d {:.2e}, {achieved} with {} photons",
            cfg.budget.rule(),
            s.rel_total,
            t.photons
        ));
    }
    w
}

/// A fixed run that the work cap stopped short of its photons.
fn fixed_cap_warning(
    t: &ChunkTally,
    run: &ChannelRun,
    ch: Channel,
    opts: &McOptions,
    cfg: &McConfig,
) -> Option<String> {
    let PhotonBudget::Fixed(n) = cfg.budget else {
        return None;
    };
    run.work_capped.then(|| {
        format!(
            "channel {}: the work cap of {} events (`max_work`) stopped this fixed run at {} of \
             {n} photons ({} events; its first round had projected fewer)",
            ch.name(),
            opts.max_work,
            t.photons,
            t.events
        )
    })
}

/// Combines shards of one run (profiles written with `McOptions::shard`,
/// named for errors) into the profile of the single run: bit-identical to it
/// except `elapsed_s`, which is the sum of the shards'. Refuses parts of
/// different runs, duplicates, an incomplete set, and shards that fail the
/// checks of [`ShardMerger::add`].
pub fn merge_shards(parts: &[(String, Profile)]) -> Result<Profile> {
    let mut m = ShardMerger::new();
    for (name, p) in parts {
        m.add(name, p.clone())?;
    }
    m.finish()
}

/// Merges shards one at a time (a merge holds one shard and the running
/// sums, never all the shards).
#[derive(Default)]
pub struct ShardMerger {
    /// The first shard (its `extra.shard` dropped), its name and record
    /// (its tallies moved into `tallies`).
    first: Option<(String, Profile, ShardRecord)>,
    tallies: Vec<ExactTally>,
    seen: std::collections::BTreeMap<u64, String>,
    elapsed: f64,
}

impl ShardMerger {
    pub fn new() -> ShardMerger {
        ShardMerger::default()
    }

    /// Adds one shard, named `name` in errors. Refused, naming the shard and
    /// the field: a profile without a shard record; a record whose content
    /// hash does not match (changed after it was written); a shard of
    /// another run (material, channels, seed, grid, photons, settings) or
    /// one given twice; tallies whose layout, photons or chunks do not fit
    /// the shard, whose energy balance does not close or whose sums of
    /// squares are below their sums squared ([`ExactTally::verify`]); sums
    /// that would overflow.
    pub fn add(&mut self, name: &str, mut p: Profile) -> Result<()> {
        let v = p.extra.get("shard").ok_or_else(|| {
            Error::format(
                name,
                "not a shard: no extra.shard (a complete profile, or not from the Monte Carlo simulator)",
            )
        })?;
        let mut r = ShardRecord::deserialize(v)
            .map_err(|e| Error::format(name, format!("malformed extra.shard: {e}")))?;
        p.extra["shard"] = serde_json::Value::Null;
        if r.sha256.is_empty() {
            return Err(Error::format(
                name,
                "extra.shard.sha256 is missing: the shard cannot be checked (written by an older \
                 ssskit, or edited); trace it again",
            ));
        }
        if r.content_hash(&p.material, &p.r_edges)? != r.sha256 {
            return Err(Error::format(
                name,
                "extra.shard.sha256 does not match the shard's content: its tallies, settings, \
                 material or grid were changed after it was written",
            ));
        }
        if let Some((name0, p0, r0)) = &self.first {
            check_same_run(name, &p, &r, name0, p0, r0)?;
        }
        let n = r.n;
        let cap = r.config.budget.max_photons();
        let chunks = cap.div_ceil(CHUNK);
        let nb = p.r_edges.len().saturating_sub(1);
        let single = r.options.single_scatter;
        if !matches!(r.config.budget, PhotonBudget::Fixed(_))
            || r.k == 0
            || r.k > n
            || n > chunks
            || (Shard { k: r.k, n }).chunks(chunks) != r.chunks
        {
            return Err(Error::format(
                name,
                format!(
                    "extra.shard: part {}/{} with chunks {:?} does not fit a run of {cap} photons",
                    r.k, n, r.chunks
                ),
            ));
        }
        if let Some(other) = self.seen.get(&r.k) {
            return Err(Error::Unsupported(format!(
                "shard {}/{n} given twice ({other} and {name}): shards must not overlap",
                r.k
            )));
        }
        let want = (r.chunks.1 * CHUNK).min(cap) - r.chunks.0 * CHUNK;
        if r.tallies.len() != r.config.channels.len()
            || r.tallies
                .iter()
                .any(|t| !t.has_layout(nb, single) || t.photons != want)
        {
            return Err(Error::format(
                name,
                "extra.shard: tallies do not match the channels, grid or photons of the shard",
            ));
        }
        for (t, ch) in r.tallies.iter().zip(&r.config.channels) {
            t.verify(MERGE_BALANCE_TOLERANCE).map_err(|e| {
                Error::format(name, format!("extra.shard.tallies[{}]: {e}", ch.name()))
            })?;
        }
        let tallies = std::mem::take(&mut r.tallies);
        if self.tallies.is_empty() {
            self.tallies = (0..tallies.len())
                .map(|_| ExactTally::new(nb, single))
                .collect();
        }
        for ((a, t), ch) in self
            .tallies
            .iter_mut()
            .zip(&tallies)
            .zip(&r.config.channels)
        {
            a.add(t).map_err(|e| {
                Error::format(name, format!("extra.shard.tallies[{}]: {e}", ch.name()))
            })?;
        }
        self.seen.insert(r.k, name.to_string());
        self.elapsed += p.elapsed_s;
        if self.first.is_none() {
            self.first = Some((name.to_string(), p, r));
        }
        Ok(())
    }

    /// The profile of the single run, once every shard was added.
    pub fn finish(self) -> Result<Profile> {
        let Some((_, p0, r0)) = self.first else {
            return Err(Error::Unsupported("no shards to merge".into()));
        };
        let n = r0.n;
        if self.seen.len() as u64 != n {
            let missing: Vec<String> = (1..=n)
                .filter(|k| !self.seen.contains_key(k))
                .take(10)
                .map(|k| k.to_string())
                .collect();
            return Err(Error::Unsupported(format!(
                "missing shard(s) {}{} of {n}: a merge needs all {n} parts of the run",
                missing.join(", "),
                if (n - self.seen.len() as u64) > 10 {
                    ", ..."
                } else {
                    ""
                }
            )));
        }
        for (t, ch) in self.tallies.iter().zip(&r0.config.channels) {
            t.verify(MERGE_BALANCE_TOLERANCE).map_err(|e| {
                Error::Unsupported(format!("the merged tally of channel {}: {e}", ch.name()))
            })?;
        }
        let grid = RadialGrid {
            edges: p0.r_edges.clone(),
        };
        let (status, _) = statuses(&p0.material, &r0.config.channels, &grid, &self.tallies);
        let runs: Vec<ChannelRun> = self
            .tallies
            .into_iter()
            .zip(status)
            .map(|(tally, status)| ChannelRun {
                tally,
                status,
                converged: true,
                work_capped: false,
                by_floor: false,
            })
            .collect();
        let mut p = build_profile(
            &p0.material,
            &r0.config,
            &r0.options,
            &grid,
            r0.grid_rule.clone(),
            &runs,
            self.elapsed,
        );
        // Anything the caller added to the parts' parameters (e.g. the .mci
        // origin) is kept, as in the single run.
        p.source.params = shard_params(&p0);
        Ok(p)
    }
}

/// A shard's `source.params` without its part number.
fn shard_params(p: &Profile) -> serde_json::Value {
    let mut q = p.source.params.clone();
    if let Some(o) = q.as_object_mut() {
        o.remove("shard");
    }
    q
}

/// Refuses shard `name` unless it is of the run of the first shard `name0`.
fn check_same_run(
    name: &str,
    p: &Profile,
    r: &ShardRecord,
    name0: &str,
    p0: &Profile,
    r0: &ShardRecord,
) -> Result<()> {
    let differ = |what: String| {
        Err(Error::Unsupported(format!(
            "cannot merge {name} with {name0}: {what}"
        )))
    };
    let settings = |r: &ShardRecord| {
        serde_json::to_value((&r.config.channels, &r.options, &r.grid_rule)).unwrap_or_default()
    };
    if p.material != p0.material {
        return differ(format!(
            "different materials ('{}' vs '{}', or the same name with other coefficients)",
            p.material.name, p0.material.name
        ));
    }
    if p.channels != p0.channels || r.config.channels != r0.config.channels {
        return differ("different channels".into());
    }
    if p.source.seed != p0.source.seed || r.config.seed != r0.config.seed {
        return differ(format!(
            "different seeds ({} vs {})",
            r.config.seed, r0.config.seed
        ));
    }
    if p.r_edges != p0.r_edges {
        return differ("different radial grids".into());
    }
    if r.config.budget != r0.config.budget {
        return differ(format!(
            "different photon totals ({} vs {} per channel)",
            r.config.budget.max_photons(),
            r0.config.budget.max_photons()
        ));
    }
    if r.n != r0.n {
        return differ(format!(
            "split into different numbers of shards ({} vs {})",
            r.n, r0.n
        ));
    }
    let (params, params0) = (shard_params(p), shard_params(p0));
    if params != params0 || settings(r) != settings(r0) {
        let keys: Vec<String> = params0
            .as_object()
            .map(|o| {
                o.iter()
                    .filter(|(k, v)| params.get(k.as_str()) != Some(v))
                    .map(|(k, _)| k.clone())
                    .collect()
            })
            .unwrap_or_default();
        return differ(format!(
            "different simulation settings (source.params: {})",
            keys.join(", ")
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::NoProgress;

    /// Two shards of a small run (channel r, two chunks, one thread).
    fn shard_pair() -> [Profile; 2] {
        let m = crate::material::preset("skin1").unwrap();
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(2 * CHUNK),
            seed: 11,
            threads: Some(1),
            channels: vec![Channel::R],
            grid: Some(RadialGrid::uniform(0.2, 4.0).unwrap()),
        };
        [1, 2].map(|k| {
            let opts = McOptions {
                shard: Some(Shard { k, n: 2 }),
                ..McOptions::default()
            };
            simulate_with(&m, &cfg, &opts, &NoProgress).unwrap()
        })
    }

    /// `p` with its shard record edited by `edit`, the content hash
    /// recomputed when `rehash` (so that the check under test is the one
    /// that fires, not the hash).
    fn tampered(p: &Profile, rehash: bool, edit: impl Fn(&mut ShardRecord)) -> Profile {
        let mut r: ShardRecord = serde_json::from_value(p.extra["shard"].clone()).unwrap();
        edit(&mut r);
        if rehash {
            r.sha256 = r.content_hash(&p.material, &p.r_edges).unwrap();
        }
        let mut q = p.clone();
        q.extra["shard"] = serde_json::to_value(&r).unwrap();
        q
    }

    fn merge_error(a: &Profile, b: &Profile) -> String {
        merge_shards(&[("a.json".into(), a.clone()), ("b.json".into(), b.clone())])
            .unwrap_err()
            .to_string()
    }

    /// Each integrity check of a merge fires on its own, naming the shard
    /// and the field: the content hash, the energy balance (a doubled
    /// tally), a negative variance (zeroed sums of squares), bins that do
    /// not add up to R_d, truncated photons beyond the photons, and counts
    /// that would overflow (they used to wrap).
    #[test]
    fn merge_verifies_each_shard() {
        let [a, b] = shard_pair();
        let clean = merge_shards(&[("a".into(), a.clone()), ("b".into(), b.clone())]).unwrap();
        assert_eq!(clean.source.photons, Some(vec![2 * CHUNK]));
        let e = merge_error(&a, &tampered(&b, false, |r| r.tallies[0].events += 1));
        assert!(
            e.contains("b.json") && e.contains("sha256 does not match"),
            "{e}"
        );
        let e = merge_error(&a, &tampered(&b, false, |r| r.sha256.clear()));
        assert!(
            e.contains("b.json") && e.contains("sha256 is missing"),
            "{e}"
        );
        let double = |r: &mut ShardRecord| {
            let t = &mut r.tallies[0];
            for x in t.totals.iter_mut().chain(&mut t.rd_bins.sum) {
                let y = *x;
                assert!(x.add(&y));
            }
        };
        let e = merge_error(&a, &tampered(&b, true, double));
        assert!(
            e.contains("b.json") && e.contains("tallies[r]") && e.contains("energy balance"),
            "{e}"
        );
        let e = merge_error(
            &a,
            &tampered(&b, true, |r| {
                r.tallies[0].totals[2] = Default::default();
            }),
        );
        assert!(e.contains("rd: sum of squares"), "{e}");
        let e = merge_error(
            &tampered(&a, true, |r| {
                let t = &mut r.tallies[0];
                let i = t.rd_bins.sum.iter().position(|x| x.to_f64() > 0.0).unwrap();
                t.rd_bins.sum_sq[i] = Default::default();
            }),
            &b,
        );
        assert!(e.contains("a.json") && e.contains("rd_bins["), "{e}");
        let e = merge_error(
            &a,
            &tampered(&b, true, |r| {
                let t = &mut r.tallies[0];
                let i = t.rd_bins.sum.iter().position(|x| x.to_f64() > 0.0).unwrap();
                t.rd_bins.sum[i] = Default::default();
                t.rd_bins.sum_sq[i] = Default::default();
            }),
        );
        assert!(e.contains("rd_bins and rd beyond"), "{e}");
        let e = merge_error(
            &a,
            &tampered(&b, true, |r| r.tallies[0].truncated_photons = u64::MAX),
        );
        assert!(e.contains("truncated_photons"), "{e}");
        let big = |r: &mut ShardRecord| r.tallies[0].events = u64::MAX - 1;
        let e = merge_error(&tampered(&a, true, big), &tampered(&b, true, big));
        assert!(
            e.contains("b.json") && e.contains("event count overflows"),
            "{e}"
        );
    }

    /// A round that a chunk cannot finish within its share of the work cap
    /// is discarded whole: the run keeps its earlier rounds, whatever the
    /// thread count; a first round that cannot finish is refused.
    #[test]
    fn work_is_bounded_inside_a_round_for_any_thread_count() {
        let m = crate::material::preset("marble").unwrap();
        let run = |threads: usize, max_work: u64| {
            let cfg = McConfig {
                budget: PhotonBudget::TargetError {
                    rel: 1e-6,
                    max_photons: 1 << 30,
                },
                seed: 5,
                threads: Some(threads),
                channels: vec![Channel::G],
                grid: Some(RadialGrid::uniform(0.5, 20.0).unwrap()),
            };
            let opts = McOptions {
                max_work,
                ..McOptions::default()
            };
            simulate_with(&m, &cfg, &opts, &NoProgress)
        };
        // The first round alone (2 chunks) costs E events.
        let one = |threads| {
            let cfg = McConfig {
                budget: PhotonBudget::Fixed(2 * CHUNK),
                seed: 5,
                threads: Some(threads),
                channels: vec![Channel::G],
                grid: Some(RadialGrid::uniform(0.5, 20.0).unwrap()),
            };
            simulate_with(&m, &cfg, &McOptions::default(), &NoProgress).unwrap()
        };
        let first = one(1);
        let e = first.extra["events_per_photon"][0].as_f64().unwrap() * (2 * CHUNK) as f64;
        // Rounds of 2, 2 and 4 chunks: the third needs 2 E, a cap of 2.5 E
        // leaves it 0.5 E.
        let cap = (2.5 * e) as u64;
        let p1 = run(1, cap).unwrap();
        let p2 = run(2, cap).unwrap();
        assert_eq!(p1.source.photons, Some(vec![4 * CHUNK]));
        assert_eq!(p1.rd, p2.rd, "the stop depends on the threads");
        assert_eq!(p1.extra["stopped_by"][0], "work-cap");
        let spent = p1.extra["events_per_photon"][0].as_f64().unwrap() * (4 * CHUNK) as f64;
        assert!(spent <= cap as f64, "{spent} > {cap}");
        let e = run(2, (0.5 * e) as u64).unwrap_err().to_string();
        assert!(
            e.contains("invalid max_work") && e.contains("first 16384 photons"),
            "{e}"
        );
    }

    /// Tallies that would not fit the memory cap are refused before any
    /// allocation, and fewer threads are used where only they do not fit.
    #[test]
    fn tally_memory_is_capped() {
        assert_eq!(tally_threads(1000, 3, Some(1)).unwrap(), 1);
        // 1.5e6 bins of three channels leave room for one thread's scratch.
        assert_eq!(tally_threads(1_500_000, 3, Some(2)).unwrap(), 1);
        let bins = crate::limits::MAX_RADIAL_BINS;
        let t = tally_threads(bins, 3, Some(crate::limits::max_threads())).unwrap();
        let bytes = bins as u64 * (3 * EXACT_BYTES_PER_BIN + t as u64 * SCRATCH_BYTES_PER_BIN);
        assert!(
            t >= 1 && bytes <= crate::limits::MAX_TALLY_BYTES,
            "{t} threads, {bytes}"
        );
        let e = tally_threads(10 * bins, 3, Some(1))
            .unwrap_err()
            .to_string();
        assert!(e.contains("bins") && e.contains("MiB"), "{e}");
    }

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
    fn a_fixed_count_above_the_work_cap_is_refused_per_shard() {
        // One event per photon at the least: 10 chunks exceed a cap of 5
        // chunks' photons, a tenth of them (one shard) does not.
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(10 * CHUNK),
            seed: 1,
            threads: None,
            channels: vec![Channel::R],
            grid: None,
        };
        let mut opts = McOptions {
            max_work: 5 * CHUNK,
            ..McOptions::default()
        };
        let e = validate_config(&cfg, &opts).unwrap_err().to_string();
        assert!(
            e.contains("invalid photons = 81920") && e.contains("work cap of 40960"),
            "{e}"
        );
        opts.shard = Some(Shard { k: 3, n: 10 });
        assert!(validate_config(&cfg, &opts).is_ok());
        opts.max_work = CHUNK - 1;
        let e = validate_config(&cfg, &opts).unwrap_err().to_string();
        assert!(e.contains("8192 photons per channel"), "{e}");
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
        assert!(e.contains("invalid photons = 0"), "{e}");
        cfg.budget = PhotonBudget::TargetError {
            rel: f64::NAN,
            max_photons: 10,
        };
        let e = simulate(&m, &cfg, &NoProgress).unwrap_err().to_string();
        assert!(e.contains("invalid target_error = NaN"), "{e}");
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
