//! Tracing a run in rounds of chunks (each on its own stream,
//! [`super::streams`]): the work cap inside a round, the budget rules
//! checked between rounds (each channel's convergence: [`super::status`]).

use super::status::{channel_ratio, rule_error, statuses, Status};
use super::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// A finished channel: its tally and how the run ended.
pub(super) struct ChannelRun {
    pub(super) tally: ExactTally,
    pub(super) status: Status,
    pub(super) converged: bool,
    /// Stopped by `McOptions::max_work` before the target error.
    pub(super) work_capped: bool,
    /// Converged by the absolute floor, not the relative target.
    pub(super) by_floor: bool,
}

/// One simulation's fixed inputs, shared by the workers.
pub(super) struct Job<'a> {
    pub(super) material: &'a Material,
    pub(super) cfg: &'a McConfig,
    pub(super) opts: &'a McOptions,
    pub(super) grid: &'a RadialGrid,
    pub(super) bins: BinIndex,
    pub(super) set: WalkSettings,
    pub(super) stacks: Vec<Stack>,
    /// Photons per channel at most, and the chunks [a, b) this run may trace.
    pub(super) cap: u64,
    pub(super) range: (u64, u64),
}

/// One thread's scratch: a chunk's f64 tally and a packet's scores
/// (allocated on first use, kept across rounds).
pub(super) struct Scratch {
    pub(super) chunk: ChunkTally,
    pub(super) photon: PhotonScratch,
}

/// Bytes per radial bin of a run's tallies: the exact sums of every
/// channel (two per bin, 32 bytes each) held by the run, by the round being
/// traced and by the status check (which also converts them to f64), and
/// each thread's scratch (a chunk's two f64 sums and a packet's one).
pub(super) const EXACT_BYTES_PER_BIN: u64 = 3 * 64 + 2 * 16;
pub(super) const SCRATCH_BYTES_PER_BIN: u64 = 3 * 8;

/// The worker threads of a run on `bins` radial bins and `channels`
/// channels: `requested` (or the default count) reduced so that the
/// tallies fit [`crate::limits::MAX_TALLY_BYTES`] (results never depend on
/// the thread count); refused when even one thread's do not.
pub(super) fn tally_threads(
    bins: usize,
    channels: usize,
    requested: Option<usize>,
) -> Result<usize> {
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
pub(super) fn chunk_overhead(bins: usize) -> u64 {
    bins as u64
}

impl Job<'_> {
    pub(super) fn photons(&self, k: u64) -> u64 {
        CHUNK.min(self.cap - k * CHUNK)
    }

    /// Traces chunk `k` of channel `c` into `s.chunk` within `budget`
    /// events; false when the chunk needed more (its tally is then unusable).
    pub(super) fn trace(&self, s: &mut Scratch, c: usize, k: u64, budget: u64) -> bool {
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
    pub(super) fn run(&self, progress: &dyn Progress) -> Result<Vec<ChannelRun>> {
        let nch = self.stacks.len();
        let (nb, single) = (self.bins.len(), self.set.single_scatter);
        let mut runs: Vec<ChannelRun> = (0..nch)
            .map(|_| ChannelRun {
                tally: ExactTally::new(nb, single),
                status: Status::default(),
                converged: false,
                work_capped: false,
                by_floor: false,
            })
            .collect();
        let scratch: Vec<Mutex<Option<Scratch>>> = (0..rayon::current_num_threads().max(1))
            .map(|_| Mutex::new(None))
            .collect();
        let mut state = RoundState {
            next: vec![self.range.0; nch],
            active: vec![true; nch],
            ratio: vec![f64::INFINITY; nch],
            first: true,
        };
        loop {
            let round = self.plan_round(&mut state, &runs);
            if round.units.is_empty() {
                break;
            }
            let traced = self.trace_round(&round, &scratch, progress);
            self.add_round(&round, traced, &mut runs, &mut state.active)?;
            self.check_rounds_rule(&mut runs, &mut state)?;
            state.first = false;
            if self.target().is_some() {
                progress.set_total(self.projected_photons(&state));
            }
        }
        if self.target().is_none() {
            runs.iter_mut().for_each(|r| r.converged = !r.work_capped);
        }
        Ok(runs)
    }

    /// The photons of every channel a run announces before it starts
    /// (`Progress::start`): a fixed run's all, a target-error run's first
    /// round (the work it can see before an error is measured).
    pub(super) fn announced_photons(&self) -> u64 {
        let chunks = match self.target() {
            None => self.range.1 - self.range.0,
            Some(_) => round_len(0, f64::INFINITY),
        };
        let end = (self.range.0 + chunks).min(self.range.1);
        super::photons_in(self.cap, (self.range.0, end)).saturating_mul(self.stacks.len() as u64)
    }

    /// The photons a target-error run now expects to trace in all, every
    /// channel (`Progress::set_total`): a stopped channel's traced, a going
    /// one's traced times what error ~ N^-1/2 says it needs (the rule of
    /// `round_len`, here not limited to doubling), within its chunks.
    fn projected_photons(&self, state: &RoundState) -> u64 {
        (0..self.stacks.len())
            .map(|c| {
                let done = state.next[c] - self.range.0;
                let chunks = if !state.active[c] {
                    done
                } else if state.ratio[c].is_finite() {
                    let r = state.ratio[c];
                    ((done as f64 * 1.1 * r * r).ceil() as u64).max(done + 1)
                } else {
                    done + round_len(done, f64::INFINITY)
                };
                let end = self.range.0.saturating_add(chunks).min(self.range.1);
                super::photons_in(self.cap, (self.range.0, end))
            })
            .sum()
    }

    /// The target error of the budget's rule (None: a fixed run).
    fn target(&self) -> Option<f64> {
        match self.cfg.budget {
            PhotonBudget::Fixed(_) => None,
            PhotonBudget::TargetError { rel, .. } | PhotonBudget::KernelFactor { rel, .. } => {
                Some(rel)
            }
        }
    }

    /// The next round of every active channel (`round_len` chunks from
    /// where it stands) and each chunk's share of the events the channel has
    /// left.
    fn plan_round(&self, state: &mut RoundState, runs: &[ChannelRun]) -> Round {
        let nch = self.stacks.len();
        let nb = self.bins.len();
        let mut units = Vec::new();
        let mut budget = vec![0u64; nch];
        for c in (0..nch).filter(|&c| state.active[c]) {
            let next = state.next[c];
            let left = self.range.1 - next;
            let len = round_len(next - self.range.0, state.ratio[c]).min(left);
            let done = next - self.range.0;
            let spent = work_of(&runs[c].tally, done, nb);
            budget[c] = (self.opts.max_work.saturating_sub(spent) / len.max(1))
                .saturating_sub(chunk_overhead(nb));
            units.extend((next..next + len).map(|k| (c, k)));
            state.next[c] += len;
        }
        Round { units, budget }
    }

    /// Traces a round's chunks on the pool, each channel's into one exact
    /// sum; a chunk over its share voids its channel's round.
    fn trace_round(
        &self,
        round: &Round,
        scratch: &[Mutex<Option<Scratch>>],
        progress: &dyn Progress,
    ) -> RoundSums {
        let nch = self.stacks.len();
        let (nb, single) = (self.bins.len(), self.set.single_scatter);
        let out = RoundSums {
            sums: (0..nch).map(|_| Mutex::new(None)).collect(),
            over: (0..nch).map(|_| AtomicBool::new(false)).collect(),
            failed: Mutex::new(None),
        };
        round.units.par_iter().for_each(|&(c, k)| {
            // A channel whose round is already void skips the rest of it.
            if out.over[c].load(Ordering::Relaxed) {
                return;
            }
            if progress.cancelled() {
                lock(&out.failed).get_or_insert(crate::progress::INTERRUPTED.into());
                return;
            }
            let slot = rayon::current_thread_index().unwrap_or(0) % scratch.len();
            let mut guard = lock(&scratch[slot]);
            let s = guard.get_or_insert_with(|| Scratch {
                chunk: ChunkTally::new(nb, single),
                photon: PhotonScratch::new(nb, single),
            });
            if !self.trace(s, c, k, round.budget[c]) {
                out.over[c].store(true, Ordering::Relaxed);
                return;
            }
            progress.advance(self.photons(k));
            let added = lock(&out.sums[c])
                .get_or_insert_with(|| ExactTally::new(nb, single))
                .add_chunk(&s.chunk);
            if let Err(e) = added {
                lock(&out.failed)
                    .get_or_insert(format!("channel {}: {e}", self.cfg.channels[c].name()));
            }
        });
        out
    }

    /// Adds a round's sums to the channels' tallies; a channel whose round
    /// went over its work stops on the rounds before (an error on its
    /// first).
    fn add_round(
        &self,
        round: &Round,
        traced: RoundSums,
        runs: &mut [ChannelRun],
        active: &mut [bool],
    ) -> Result<()> {
        if let Some(e) = lock(&traced.failed).take() {
            return Err(Error::Unsupported(e));
        }
        for (c, run) in runs.iter_mut().enumerate() {
            if traced.over[c].load(Ordering::Relaxed) {
                if run.tally.photons == 0 {
                    return Err(first_round_over_cap(
                        self.cfg.channels[c],
                        round
                            .units
                            .iter()
                            .filter(|u| u.0 == c)
                            .map(|u| self.photons(u.1))
                            .sum(),
                        self.opts.max_work,
                    ));
                }
                run.work_capped = true;
                active[c] = false;
                continue;
            }
            if let Some(p) = lock(&traced.sums[c]).take() {
                run.tally.add(&p).map_err(|e| {
                    Error::Unsupported(format!("channel {}: {e}", self.cfg.channels[c].name()))
                })?;
            }
        }
        Ok(())
    }

    /// The budget's rule after a round: every channel's status, and which
    /// channels converged, ran out of work or of chunks.
    fn check_rounds_rule(&self, runs: &mut [ChannelRun], state: &mut RoundState) -> Result<()> {
        let nb = self.bins.len();
        let tallies: Vec<ExactTally> = runs.iter().map(|r| r.tally.clone()).collect();
        let (status, _) = statuses(self.material, &self.cfg.channels, self.grid, &tallies);
        for (c, run) in runs.iter_mut().enumerate() {
            run.status = status[c];
            if !state.active[c] {
                continue;
            }
            let work = work_of(&run.tally, state.next[c] - self.range.0, nb);
            let go_on = match self.target() {
                Some(rel) => self.check_target(c, run, rel, work, &mut state.ratio[c]),
                None if state.next[c] < self.range.1 => {
                    self.check_fixed(c, run, work, state.first)?
                }
                None => true,
            };
            state.active[c] = go_on && state.next[c] < self.range.1;
        }
        Ok(())
    }

    /// A target-error channel after a round: converged (by its relative
    /// target or the absolute floor), out of work, or going on (false when
    /// it stops). Sets `ratio`, how far it is from its target.
    fn check_target(
        &self,
        c: usize,
        run: &mut ChannelRun,
        rel: f64,
        work: u64,
        ratio: &mut f64,
    ) -> bool {
        // No reflectance yet counts as exact only where nothing can scatter
        // back; a nearly clear medium must go on.
        let scatters = self
            .material
            .layers
            .iter()
            .any(|l| l.sigma_s[self.cfg.channels[c].index()] > 0.0);
        let err = if scatters && run.tally.totals[1].to_f64() == 0.0 {
            f64::INFINITY
        } else {
            rule_error(&self.cfg.budget, &run.status)
        };
        let (r, by_floor) = channel_ratio(
            &self.cfg.budget,
            self.opts.abs_floor,
            rel,
            &run.status,
            err,
            run.tally.photons,
        );
        *ratio = r;
        if r <= 1.0 {
            run.converged = true;
            run.by_floor = by_floor;
            false
        } else if work >= self.opts.max_work {
            run.work_capped = true;
            false
        } else {
            true
        }
    }

    /// A fixed channel with chunks left after a round: its projected work
    /// checked after the first round, then stopped at the work cap (false
    /// when it stops).
    fn check_fixed(&self, c: usize, run: &mut ChannelRun, work: u64, first: bool) -> Result<bool> {
        if first {
            let t = &run.tally;
            let mine = (self.range.1 * CHUNK).min(self.cap) - self.range.0 * CHUNK;
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
            run.work_capped = true;
            return Ok(false);
        }
        Ok(true)
    }
}

/// Where each channel of a run stands between rounds.
struct RoundState {
    /// The next chunk of each channel.
    next: Vec<u64>,
    /// Channels still tracing.
    active: Vec<bool>,
    /// How far each channel is from its target (`round_len`).
    ratio: Vec<f64>,
    /// The first round is being checked.
    first: bool,
}

/// One round: the (channel, chunk) units to trace and each channel's event
/// share per chunk.
struct Round {
    units: Vec<(usize, u64)>,
    budget: Vec<u64>,
}

/// What a round traced: each channel's exact sum, whether its round went
/// over its work, and the first sum that did not fit.
struct RoundSums {
    sums: Vec<Mutex<Option<ExactTally>>>,
    over: Vec<AtomicBool>,
    failed: Mutex<Option<String>>,
}

/// Locks `m`, also after a holder panicked.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Work a channel has spent: its events and the overhead of its `chunks`.
pub(super) fn work_of(t: &ExactTally, chunks: u64, bins: usize) -> u64 {
    t.events
        .saturating_add(chunks.saturating_mul(chunk_overhead(bins)))
}

/// The refusal of a run whose first round of `photons` photons did not
/// finish within the work cap: nothing to stop on.
pub(super) fn first_round_over_cap(ch: Channel, photons: u64, max_work: u64) -> Error {
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

/// Chunks in the next round: `FIRST_ROUND` to start, then for a target-error
/// run what error ~ N^-1/2 predicts is missing (plus 10%), at least one
/// chunk and at most as many as traced so far (a fixed run, `ratio`
/// infinite: as many as traced so far). A function of the totals
/// only, so the photon count does not depend on the thread count.
pub(super) fn round_len(done: u64, ratio: f64) -> u64 {
    if done == 0 {
        return FIRST_ROUND;
    }
    if !ratio.is_finite() {
        return done;
    }
    let more = (done as f64 * (1.1 * ratio * ratio - 1.0)).ceil();
    (more.max(1.0) as u64).min(done)
}
