//! One channel's run on the device: its buffers, the batches of a round
//! (one dispatch each, checked and added exactly), and the budget's rule
//! between rounds, as the CPU tracer checks it.

use super::shader::{gpu_layers, WORKGROUP};
use super::sums::{exact_tally, tally_words, Sums, INCOMPLETE, TRACED};
use super::{GpuDispatch, Layer, McGpu, Params, CHECKPOINT, GPU_MAX_EVENTS};
use crate::error::{Error, Result};
use crate::material::{Channel, Material};
use crate::profile::mc::tally::ChunkTally;
use crate::profile::mc::tracer::Stack;
use crate::profile::mc::transmit::LightStatus;
use crate::profile::mc::{
    check_fixed_work, floor_ratio, rule_error, statuses, ChannelRun, McConfig, McOptions,
    PhotonBudget, Status,
};
use crate::profile::RadialGrid;
use crate::progress::Progress;

/// The device buffers of one channel's run, bound for mc_trace.wgsl.
struct ChannelBuffers {
    params: wgpu::Buffer,
    acc: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// Words of the tally buffer `acc`.
    words: usize,
}

/// Where a channel's run stands between rounds.
struct RunState {
    sums: Sums,
    tally: ChunkTally,
    status: Status,
    converged: bool,
    by_floor: bool,
    work_capped: bool,
}

/// One channel's fixed inputs.
struct ChannelJob<'a> {
    material: &'a Material,
    ch: Channel,
    grid: &'a RadialGrid,
    cfg: &'a McConfig,
    opts: &'a McOptions,
    dispatch: GpuDispatch,
    progress: &'a dyn Progress,
    /// Photons at most, and the target error (None: a fixed run).
    cap: u64,
    target: Option<f64>,
}

impl McGpu {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run_channel(
        &self,
        material: &Material,
        ch: Channel,
        grid: &RadialGrid,
        cfg: &McConfig,
        opts: &McOptions,
        dispatch: GpuDispatch,
        progress: &dyn Progress,
    ) -> Result<ChannelRun> {
        let (cap, target) = match cfg.budget {
            PhotonBudget::Fixed(n) => (n, None),
            PhotonBudget::TargetError { rel, max_photons }
            | PhotonBudget::KernelFactor { rel, max_photons } => (max_photons, Some(rel)),
        };
        let job = ChannelJob {
            material,
            ch,
            grid,
            cfg,
            opts,
            dispatch,
            progress,
            cap,
            target,
        };
        let stack = Stack::new(material, ch);
        let n_bins = grid.len();
        let layers = gpu_layers(material, ch);
        let bufs = self.channel_buffers(&layers, grid);
        let mut params = channel_params(&job, &stack, layers.len());
        let mut run = RunState {
            sums: Sums::new(n_bins),
            tally: ChunkTally::new(n_bins, false),
            status: Status {
                rd: LightStatus {
                    rel_total: f64::INFINITY,
                    rel_profile: f64::INFINITY,
                    rel_factor: f64::INFINITY,
                    total: 0.0,
                    stderr: f64::INFINITY,
                },
                r99: 0.0,
                tr: None,
            },
            converged: false,
            by_floor: false,
            work_capped: false,
        };
        while run.sums.photons < cap {
            let stop = match target {
                Some(_) => cap.min((run.sums.photons / CHECKPOINT + 1) * CHECKPOINT),
                None => cap.min(CHECKPOINT.max(2 * run.sums.photons)),
            };
            self.trace_round(&job, &bufs, &mut params, &mut run.sums, stop)?;
            check_saturation(&run.sums, ch, opts)?;
            run.tally = run.sums.tally(stack.specular);
            let exact = exact_tally(&run.tally, n_bins)?;
            run.status = statuses(material, &[ch], grid, &[exact]).0.swap_remove(0);
            if round_ends_run(&job, &mut run)? {
                break;
            }
        }
        Ok(ChannelRun {
            tally: exact_tally(&run.tally, n_bins)?,
            status: run.status,
            converged: (target.is_none() && !run.work_capped) || run.converged,
            work_capped: run.work_capped,
            by_floor: run.by_floor,
        })
    }

    /// The layers, edges, tally and uniform buffers of a channel's run.
    fn channel_buffers(&self, layers: &[Layer], grid: &RadialGrid) -> ChannelBuffers {
        let layer_buf = self.ctx.buffer(
            "layers",
            bytemuck::cast_slice(layers),
            wgpu::BufferUsages::STORAGE,
        );
        let edges: Vec<f32> = grid.edges.iter().map(|&e| e as f32).collect();
        let edge_buf = self.ctx.buffer(
            "edges",
            bytemuck::cast_slice(&edges),
            wgpu::BufferUsages::STORAGE,
        );
        let words = tally_words(grid.len());
        let acc = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tally"),
            size: (words * 4) as u64,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let params = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = self
            .ctx
            .bind_group(&self.trace, &[&params, &layer_buf, &edge_buf, &acc]);
        ChannelBuffers {
            params,
            acc,
            group,
            words,
        }
    }

    /// Traces batches until `stop` photons (or the work cap), adding each
    /// batch's words to `sums`.
    fn trace_round(
        &self,
        job: &ChannelJob,
        bufs: &ChannelBuffers,
        params: &mut Params,
        sums: &mut Sums,
        stop: u64,
    ) -> Result<()> {
        while sums.photons < stop {
            let count = job.dispatch.batch.min(stop - sums.photons);
            let batch = self.trace_batch(job, bufs, params, sums.photons, count)?;
            sums.add(&batch, count);
            job.progress.advance(count);
            // Work is bounded inside a round too: a batch's work is at
            // most its packets x GPU_MAX_EVENTS, and no batch starts
            // past the cap (batches are fixed per adapter: the stop is
            // reproducible).
            if sums.events >= job.opts.max_work as u128 {
                break;
            }
        }
        Ok(())
    }

    /// One dispatch: packets `base..base + count`, their tally words read
    /// back, refused where the adapter did not trace them all.
    fn trace_batch(
        &self,
        job: &ChannelJob,
        bufs: &ChannelBuffers,
        params: &mut Params,
        base: u64,
        count: u64,
    ) -> Result<Vec<u32>> {
        params.base_lo = base as u32;
        params.base_hi = (base >> 32) as u32;
        params.count = count as u32;
        let inv = (job.dispatch.invocations as u64).min(count) as u32;
        params.dynamic = job.dispatch.dynamic as u32;
        params.stride = inv.div_ceil(WORKGROUP) * WORKGROUP;
        self.ctx
            .queue
            .write_buffer(&bufs.params, 0, bytemuck::bytes_of(params));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&bufs.acc, 0, None);
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.trace);
            pass.set_bind_group(0, &bufs.group, &[]);
            pass.dispatch_workgroups(inv.div_ceil(WORKGROUP), 1, 1);
        }
        let batch: Vec<u32> = self
            .ctx
            .read_back(enc, &bufs.acc, (bufs.words * 4) as u64)?;
        if batch[TRACED] as u64 != count || batch[INCOMPLETE] != 0 {
            return Err(Error::Unsupported(format!(
                "channel {}: the adapter ({}) traced {} of {count} packets and cut {} \
                 walks short: a driver limit on shader loops (llvmpipe allows 65535 \
                 iterations per invocation); use fewer packets per invocation or the \
                 CPU tracer",
                job.ch.name(),
                self.describe(),
                batch[TRACED],
                batch[INCOMPLETE]
            )));
        }
        Ok(batch)
    }
}

/// The uniform block of a channel's run (the batch fields set per dispatch).
fn channel_params(job: &ChannelJob, stack: &Stack, n_layers: usize) -> Params {
    let uniform_dr = uniform_bin_width(job.grid);
    Params {
        seed_lo: job.cfg.seed as u32,
        seed_hi: (job.cfg.seed >> 32) as u32,
        channel: job.ch.index() as u32,
        n_layers: n_layers as u32,
        base_lo: 0,
        base_hi: 0,
        count: 0,
        n_bins: job.grid.len() as u32,
        max_events: gpu_max_events(job.opts),
        uniform_bins: uniform_dr.is_some() as u32,
        dynamic: 0,
        stride: 0,
        w0: (1.0 - stack.specular) as f32,
        n_above: job.material.eta_above as f32,
        n_below: job.material.eta_below as f32,
        roulette: job.opts.roulette_threshold as f32,
        r_max: job.grid.r_max() as f32,
        inv_dr: uniform_dr.map_or(0.0, |dr| (1.0 / dr) as f32),
        _pad0: 0.0,
        _pad1: 0.0,
    }
}

/// A per-packet value beyond the fixed-point range stops the run.
fn check_saturation(sums: &Sums, ch: Channel, opts: &McOptions) -> Result<()> {
    if sums.saturated {
        return Err(Error::Unsupported(format!(
            "channel {}: a photon's reflectance, transmittance or absorbed weight \
             reached 256, beyond the GPU tally's fixed-point range (roulette \
             threshold {} lets weights grow); use the CPU tracer",
            ch.name(),
            opts.roulette_threshold
        )));
    }
    Ok(())
}

/// The budget's rule after a round, as the CPU tracer's rounds apply it:
/// true when the run ends here (converged or out of work), with the
/// remaining photons counted as done.
fn round_ends_run(job: &ChannelJob, run: &mut RunState) -> Result<bool> {
    let (cap, opts, t) = (job.cap, job.opts, &run.tally);
    if let Some(rel) = job.target {
        let relative = rule_error(&job.cfg.budget, &run.status) <= rel;
        run.by_floor = !relative
            && floor_ratio(&job.cfg.budget, opts.abs_floor, &run.status, t.photons) <= 1.0;
        run.converged = relative || run.by_floor;
        if run.converged || t.events >= opts.max_work {
            run.work_capped = !run.converged;
            job.progress.advance(cap - t.photons);
            return Ok(true);
        }
    } else if t.photons < cap {
        if t.photons <= CHECKPOINT {
            check_fixed_work(job.ch, t.photons, t.events, cap, cap, opts.max_work)?;
        }
        if t.events >= opts.max_work {
            run.work_capped = true;
            job.progress.advance(cap - t.photons);
            return Ok(true);
        }
    }
    Ok(false)
}

fn gpu_max_events(opts: &McOptions) -> u32 {
    opts.max_events.min(GPU_MAX_EVENTS) as u32
}

/// The bin width when the grid is uniform (same test as the CPU's
/// `BinIndex`), for the shader's direct bin index.
fn uniform_bin_width(grid: &RadialGrid) -> Option<f64> {
    let dr = grid.edges[1] - grid.edges[0];
    grid.edges
        .iter()
        .enumerate()
        .all(|(i, &e)| (e - i as f64 * dr).abs() <= 1e-9 * dr.max(e))
        .then_some(grid.r_max() / grid.len() as f64)
}
