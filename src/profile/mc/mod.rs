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
mod build;
mod config;
mod consumer;
mod exact;
pub mod gpu;
pub mod mci;
pub mod mco;
mod merge;
mod rounds;
mod status;
mod streams;
mod tally;
pub(crate) mod tracer;
pub mod transmit;

pub use angular::{Angular, AngularOptions};
pub use balance::EnergyBalance;
pub use consumer::{kernel_geometry, KernelGeometry};
pub use tally::Moments;
pub use tracer::{
    BoundaryMode, DEFAULT_EVENT_ROULETTE, DEFAULT_ROULETTE_THRESHOLD, EVENT_ROULETTE_SURVIVAL,
    ROULETTE_CHANCE, ROULETTE_THRESHOLD,
};
pub use transmit::{require_finite, TransmittanceProfile, TransmittedAngles};

use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::{Profile, RadialGrid, Source, PROFILE_SCHEMA};
use crate::progress::Progress;
use build::*;
pub use config::*;
use consumer::Projection;
use exact::ExactTally;
pub use merge::*;
use rayon::prelude::*;
use rounds::*;
use serde::{Deserialize, Serialize};
use serde_json::json;
use status::*;
pub(crate) use streams::splitmix64;
use streams::*;
use tally::{BinIndex, ChunkTally, PhotonScratch};
use tracer::{Stack, WalkSettings};

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
    material.validate_named()?;
    validate_config(cfg, opts)?;
    let (grid, grid_rule) = run_grid(material, cfg);
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
    progress.start(
        job.announced_photons(),
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
        let shard = ShardRun {
            shard: s,
            range,
            grid: &grid,
            grid_rule,
        };
        record_shard(&mut p, material, cfg, opts, shard, runs)?;
    }
    Ok(p)
}

/// Photons of chunks [a, b) of a run of `cap` photons per channel.
fn photons_in(cap: u64, (a, b): (u64, u64)) -> u64 {
    (b * CHUNK).min(cap).saturating_sub(a * CHUNK)
}

/// The shard a run traced: its chunks and grid.
struct ShardRun<'a> {
    shard: Shard,
    range: (u64, u64),
    grid: &'a RadialGrid,
    grid_rule: serde_json::Value,
}

/// Records a shard's exact tallies in its partial profile (`extra.shard`,
/// hashed for the merge) and warns that the profile is partial.
fn record_shard(
    p: &mut Profile,
    material: &Material,
    cfg: &McConfig,
    opts: &McOptions,
    run: ShardRun,
    runs: Vec<ChannelRun>,
) -> Result<()> {
    let (s, range) = (run.shard, run.range);
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
        grid_rule: run.grid_rule,
        tallies: runs.into_iter().map(|r| r.tally).collect(),
        sha256: String::new(),
    };
    let record = ShardRecord {
        sha256: record.content_hash(material, &run.grid.edges)?,
        ..record
    };
    p.source.params["shard"] = json!({"k": s.k, "n": s.n});
    let cap = cfg.budget.max_photons();
    if let Some(w) = p.extra["warnings"].as_array_mut() {
        w.push(json!(format!(
            "partial profile: shard {} of {} ({} of {} photons per channel); merge all {} shards for the run",
            s.k,
            s.n,
            photons_in(cap, range),
            cap,
            s.n
        )));
    }
    p.extra["shard"] = serde_json::to_value(&record)
        .map_err(|e| Error::Unsupported(format!("cannot record the shard: {e}")))?;
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

    #[test]
    fn too_few_photons_carry_a_noise_warning() {
        let m = crate::material::preset("skin1").unwrap();
        let noise = |photons: u64| -> Vec<String> {
            let cfg = McConfig {
                budget: PhotonBudget::Fixed(photons),
                seed: 1,
                threads: None,
                channels: vec![Channel::R],
                grid: None,
            };
            let p = simulate(&m, &cfg, &NoProgress).unwrap();
            let w = p.warnings().unwrap();
            w.into_iter()
                .filter(|w| w.contains("photon") && w.contains("noise"))
                .collect()
        };
        // One photon: no variance, so no error estimate at all.
        let one = noise(1);
        assert!(one.len() == 1 && one[0].contains("no estimate"), "{one:?}");
        // Sixteen: the estimated error is well above the 10% line.
        let few = noise(16);
        assert!(
            few.len() == 1 && few[0].contains("relative standard error"),
            "{few:?}"
        );
        // A real run is quiet.
        assert!(noise(2 * CHUNK).is_empty());
    }
}
