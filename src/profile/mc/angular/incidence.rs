//! The oblique runs of the entry table: for each incidence but the normal,
//! as many photons as the normal run's, on streams of their own, each run
//! bounded by the work cap, summed exactly whatever the thread count.

use super::super::exact::ExactTally;
use super::super::tally::{AngleLayout, ChunkTally, PhotonScratch};
use super::super::tracer::{self, Stack, WalkSettings};
use super::super::{chunk_key, splitmix64, Job, CHUNK};
use super::AngularOptions;
use crate::error::{Error, Result};
use crate::material::Channel;
use crate::progress::Progress;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// The RNG of chunk `chunk` of the oblique run `k` (>= 1) of channel `ch`:
/// the normal run's key hashed once more with k, so its streams are its own.
fn incidence_rng(seed: u64, ch: Channel, chunk: u64, k: usize) -> Xoshiro256PlusPlus {
    let key = chunk_key(seed, ch, chunk);
    Xoshiro256PlusPlus::seed_from_u64(splitmix64(key ^ splitmix64(k as u64)))
}

/// Exact sums per (channel, incidence), or the first error met.
type IncidenceSums = std::result::Result<Vec<Option<ExactTally>>, String>;

/// One worker's sums and scratch over the oblique runs' chunks.
struct IncidenceWorker {
    sums: IncidenceSums,
    chunk: Option<ChunkTally>,
    scratch: Option<PhotonScratch>,
}

/// Two workers' sums added (exact sums: the order chunks are added in does
/// not change them).
fn add_incidence_sums(a: IncidenceSums, b: IncidenceSums) -> IncidenceSums {
    let (mut a, b) = (a?, b?);
    for (x, y) in a.iter_mut().zip(b) {
        match (x.as_mut(), y) {
            (Some(x), Some(y)) => x.add(&y)?,
            (None, y) => *x = y,
            _ => {}
        }
    }
    Ok(a)
}

/// The oblique runs' fixed inputs.
struct Incidences<'a> {
    job: &'a Job<'a>,
    angles: Vec<f64>,
    /// `[channel][incidence]`.
    stacks: Vec<Vec<Stack>>,
    set: WalkSettings,
    photons: &'a [u64],
    /// Events per chunk of each channel.
    budget: Vec<u64>,
    progress: &'a dyn Progress,
}

impl Incidences<'_> {
    /// Traces chunk `chunk` of incidence `k` of channel `c` into the
    /// worker's sums; an error (over the chunk's events, a sum that does not
    /// fit) ends the worker's sums.
    fn trace_chunk(
        &self,
        mut w: IncidenceWorker,
        (c, k, chunk): (usize, usize, u64),
    ) -> IncidenceWorker {
        let (job, nk) = (self.job, self.angles.len());
        let (nb, single) = (job.bins.len(), job.set.single_scatter);
        let Ok(sums) = w.sums.as_mut() else {
            return w;
        };
        let n = CHUNK.min(self.photons[c] - chunk * CHUNK);
        let t = w.chunk.get_or_insert_with(|| ChunkTally::new(nb, single));
        t.reset();
        let sc = w
            .scratch
            .get_or_insert_with(|| PhotonScratch::new(nb, single));
        let mut rng = incidence_rng(job.cfg.seed, job.cfg.channels[c], chunk, k);
        let set = WalkSettings {
            chunk_events: self.budget[c],
            ..self.set
        };
        tracer::trace_photons(&self.stacks[c][k], &job.bins, &set, &mut rng, n, t, sc);
        if t.events > self.budget[c] {
            w.sums = Err(format!(
                "channel {}, incidence {} degrees: the oblique run needs more than \
                 max_work = {} events (the normal run's photons, {}); lower the photons \
                 or raise max_work",
                job.cfg.channels[c].name(),
                self.angles[k],
                job.opts.max_work,
                self.photons[c]
            ));
            return w;
        }
        let added = sums[c * nk + k]
            .get_or_insert_with(|| ExactTally::new(nb, single))
            .add_chunk(t);
        if let Err(e) = added {
            w.sums = Err(format!(
                "channel {}, incidence {} degrees: {e}",
                job.cfg.channels[c].name(),
                self.angles[k]
            ));
        }
        self.progress.advance(n);
        w
    }
}

/// Traces the oblique runs: for every channel `c` and every incidence but
/// the normal, `photons[c]` photons (the normal run's). Returns the exact
/// sums per channel and incidence (the normal one left empty). Work is the
/// normal run's again per incidence, each run under `max_work` (an error
/// when a chunk would need more than its share); the sums are order-free,
/// so the result does not depend on the thread count.
pub(in crate::profile::mc) fn trace_incidences(
    job: &Job,
    opts: &AngularOptions,
    photons: &[u64],
    progress: &dyn Progress,
) -> Result<Vec<Vec<ExactTally>>> {
    let angles = opts.incidences();
    let nk = angles.len();
    let nch = job.stacks.len();
    let nb = job.bins.len();
    let mut units = Vec::new();
    for (c, &n) in photons.iter().enumerate() {
        for k in 1..nk {
            units.extend((0..n.div_ceil(CHUNK)).map(|chunk| (c, k, chunk)));
        }
    }
    let total: u64 = photons.iter().sum::<u64>() * (nk as u64 - 1);
    if total == 0 {
        return Ok((0..nch).map(|_| vec![ExactTally::default(); nk]).collect());
    }
    let stacks = job
        .cfg
        .channels
        .iter()
        .map(|&ch| {
            angles
                .iter()
                .map(|t| Stack::oblique(job.material, ch, t.to_radians()))
                .collect()
        })
        .collect();
    let runs = Incidences {
        job,
        stacks,
        set: WalkSettings {
            angular: (opts.angle_bins > 0).then_some(AngleLayout {
                angle_bins: opts.angle_bins,
                radial: 0,
            }),
            ..job.set
        },
        photons,
        // Each oblique run is bounded like the normal one: an equal share of
        // --max-work per chunk, a chunk that needs more stops the whole run.
        budget: photons
            .iter()
            .map(|&n| {
                (job.opts.max_work / n.div_ceil(CHUNK).max(1))
                    .saturating_sub(super::super::chunk_overhead(nb))
            })
            .collect(),
        angles,
        progress,
    };
    progress.start(total, "oblique incidence");
    let sums = units
        .par_iter()
        .fold(
            || IncidenceWorker {
                sums: Ok(vec![None; nch * nk]),
                chunk: None,
                scratch: None,
            },
            |w, &unit| runs.trace_chunk(w, unit),
        )
        .map(|w| w.sums)
        .reduce(|| Ok(vec![None; nch * nk]), add_incidence_sums);
    progress.finish();
    let sums = sums.map_err(Error::Unsupported)?;
    let mut out: Vec<Vec<ExactTally>> = (0..nch).map(|_| Vec::with_capacity(nk)).collect();
    for (i, s) in sums.into_iter().enumerate() {
        out[i / nk].push(s.unwrap_or_default());
    }
    Ok(out)
}
