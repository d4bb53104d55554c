//! The run's settings: photon budget rules, shards, the configuration and
//! options with their defaults, and their validation before any work.

use super::*;

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

/// The context of a bad setting's error; its parameters are the fields of
/// `McConfig`, `PhotonBudget` (the rule's name for its relative error) and
/// `McOptions`.
pub const CONTEXT: &str = "Monte Carlo";

/// The radial grid of a run and how it was chosen: the given one, or the
/// budget rule's default for the material (the kernel rule's consumer needs
/// the core resolved and the tail integrated, not every tail bin exact:
/// geometric bins). Both tracers use it.
pub(super) fn run_grid(material: &Material, cfg: &McConfig) -> (RadialGrid, serde_json::Value) {
    match &cfg.grid {
        Some(g) => (g.clone(), json!({"rule": "given"})),
        None => RadialGrid::for_material_rule(
            material,
            &cfg.channels,
            matches!(cfg.budget, PhotonBudget::KernelFactor { .. }),
        ),
    }
}

pub(super) fn validate_config(cfg: &McConfig, opts: &McOptions) -> Result<()> {
    validate_budget(&cfg.budget)?;
    validate_shard(cfg, opts)?;
    if cfg.channels.is_empty() {
        return Err(Error::invalid(CONTEXT, "channels", "''", "empty"));
    }
    if let Some(n) = cfg.threads {
        crate::limits::check_threads("worker threads", n)?;
    }
    validate_options(opts)?;
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

/// The photon budget: at least one photon, a target in (0, 1).
fn validate_budget(budget: &PhotonBudget) -> Result<()> {
    match *budget {
        PhotonBudget::Fixed(n) if n == 0 => {
            return Err(Error::invalid(CONTEXT, "photons", n, "must be >= 1"))
        }
        PhotonBudget::TargetError { rel, max_photons }
        | PhotonBudget::KernelFactor { rel, max_photons } => {
            let field = match *budget {
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
    Ok(())
}

/// A shard K/N: of a fixed count, not angle-resolved, within the chunks.
fn validate_shard(cfg: &McConfig, opts: &McOptions) -> Result<()> {
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
    Ok(())
}

/// The work and roulette options.
fn validate_options(opts: &McOptions) -> Result<()> {
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
    Ok(())
}

/// The refusal of a fixed photon count whose work exceeds the cap.
pub(super) fn fixed_over_cap(photons: u64, why: String, max_work: u64) -> Error {
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
