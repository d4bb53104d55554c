//! The MCML walk of `tracer.rs` as a wgpu compute shader
//! (shaders/mc_trace.wgsl): same physics, f32 transport, the same profile
//! schema, standard errors and energy balance as the CPU tracer.
//!
//! Reproducibility: packet i of channel c draws from Philox4x32-10 (Salmon
//! et al. 2011) keyed by the seed with counter (draw, c, i), and
//! every tally is an exact integer sum of per-packet values rounded to the
//! fixed point 2^-24 (sums 64-bit, sums of squares 96-bit, built from u32
//! atomics with carries; the host adds batches in u128). Integer addition
//! does not depend on order, so the output is bit-identical for any batch
//! size, invocation count or scheduling on a given adapter.
//!
//! Precision: positions, directions and weights are f32 (relative rounding
//! 6e-8 per operation; directions are renormalised after every scattering);
//! free paths come from a 24-bit uniform on (0, 1), which cuts the exponential
//! tail at 17.3 optical depths (probability 3e-8); per-packet values are
//! tallied to 2^-24 = 6e-8 (round to nearest). docs/mc_gpu.md reports the
//! measured difference from the f64 CPU tracer.

use super::exact::ExactTally;
use super::tally::{BinSums, ChunkTally, Moments};
use super::tracer::Stack;
use super::{
    build_profile, check_fixed_work, floor_ratio, rule_error, statuses, validate_config,
    BoundaryMode, ChannelRun, McConfig, McOptions, PhotonBudget, Status, CHUNK,
};
use crate::error::{Error, Result};
use crate::gpu::{wgsl_struct, wgsl_u32_consts, GpuContext, WGSL_WIDE_MUL};
use crate::material::{Channel, Material};
use crate::profile::{Profile, RadialGrid};
use crate::progress::Progress;
use serde_json::json;

const PHILOX: &str = include_str!("../../../shaders/mc_philox.wgsl");
const TRACE: &str = include_str!("../../../shaders/mc_trace.wgsl");
const KAT: &str = include_str!("../../../shaders/mc_kat.wgsl");

/// Fixed point of the tallies: per-packet values are integers in units of
/// 2^-24.
pub const TALLY_RESOLUTION: f64 = 1.0 / (1u64 << 24) as f64;
/// Largest batch: keeps every 64-bit sum (packets x 2^32) and 96-bit sum of
/// squares (packets x 2^64) of one batch from overflowing.
pub const MAX_BATCH: u64 = 1 << 24;
/// Photons between two checks of a target-error run: the CPU tracer's
/// granularity, and independent of the batch size, so the stopping point is
/// too. A fixed run checks its work after one checkpoint, then after rounds
/// that double the photons traced.
pub const CHECKPOINT: u64 = CHUNK * 16;

// Word layout of the tally buffer, given to mc_trace.wgsl by `shader_consts`:
// 64-bit sums take 2 words, 96-bit sums of squares 3, least significant
// first.
/// Reflectance: sum at 0..2, squares at 2..5 (likewise T_TR, T_ABS).
const T_RD: usize = 0;
const T_TR: usize = 5;
const T_ABS: usize = 10;
/// Sums only (likewise T_LOSS to T_EVENTS).
const T_BEYOND: usize = 15;
const T_LOSS: usize = 17;
const T_GAIN: usize = 19;
const T_TRUNC: usize = 21;
/// Packet count.
const T_TRUNC_N: usize = 23;
const T_EVENTS: usize = 25;
/// One word: a value beyond the fixed-point range was met.
const T_SATURATED: usize = 27;
/// The next packet to trace (the shared work counter).
const WORK: usize = 28;
/// Packets whose walk stopped with weight left (a driver's loop limit), and
/// packets traced: both checked by the host.
const INCOMPLETE: usize = 29;
const TRACED: usize = 30;
/// Per bin from here: sum (2 words), sum of squares (3 words).
const BINS: usize = 32;
/// Threads per workgroup in mc_trace.wgsl.
const WORKGROUP: u32 = 64;
/// Invocations of one dispatch: 65535 workgroups of 64 (wgpu's default limit
/// per dimension).
pub const MAX_INVOCATIONS: u32 = 65535 * WORKGROUP;

/// How a run is cut into GPU submissions. The result does not depend on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuDispatch {
    /// Photons per submission (1..=MAX_BATCH).
    pub batch: u64,
    /// Invocations per submission.
    pub invocations: u32,
    /// Invocations take packets from a shared counter until the batch is
    /// done (load balance on GPUs), or invocation t traces packets t,
    /// t + invocations, ... (software rasterisers; see `for_adapter`).
    pub dynamic: bool,
}

impl GpuDispatch {
    /// Enough invocations to fill a large GPU (an H100/H200 holds about
    /// 270k resident threads), each taking packets until the batch is done.
    /// On a software rasteriser one invocation per packet, statically:
    /// llvmpipe runs the lanes of a workgroup one after another and cuts an
    /// invocation's loops after 65535 iterations in all, so with a shared
    /// counter its first lanes would take every packet and hit that limit.
    pub fn for_adapter(software: bool) -> GpuDispatch {
        if software {
            GpuDispatch {
                batch: 1 << 16,
                invocations: 1 << 16,
                dynamic: false,
            }
        } else {
            GpuDispatch {
                batch: 1 << 22,
                invocations: 1 << 18,
                dynamic: true,
            }
        }
    }
}

wgsl_struct! {
    /// The uniform block of one dispatch.
    struct Params {
        seed_lo: u32,
        seed_hi: u32,
        channel: u32,
        n_layers: u32,
        base_lo: u32,
        base_hi: u32,
        count: u32,
        n_bins: u32,
        max_events: u32,
        uniform_bins: u32,
        /// 1: invocations take packets from a shared counter; 0: invocation
        /// t traces packets t, t + stride, ...
        dynamic: u32,
        stride: u32,
        w0: f32,
        n_above: f32,
        n_below: f32,
        roulette: f32,
        r_max: f32,
        inv_dr: f32,
        _pad0: f32,
        _pad1: f32,
    }
}

wgsl_struct! {
    /// One layer of the stack for one channel.
    struct Layer {
        z_top: f32,
        /// `SEMI_INFINITE` for a semi-infinite layer.
        z_bottom: f32,
        sigma_t: f32,
        inv_sigma_t: f32,
        albedo: f32,
        g: f32,
        n: f32,
        _pad: f32,
    }
}

/// z_bottom of a semi-infinite layer: beyond any reachable depth, finite so
/// that no comparison meets an infinity.
const SEMI_INFINITE: f32 = 3.0e38;

/// The tracer compiled on an opened adapter.
pub struct McGpu {
    ctx: GpuContext,
    trace: wgpu::ComputePipeline,
    kat: wgpu::ComputePipeline,
}

impl McGpu {
    /// Opens the adapter (see `GpuContext::open`) and compiles the shaders.
    pub fn new() -> Result<McGpu> {
        let ctx = GpuContext::open()?;
        let trace = ctx.compute_pipeline("mc_trace", &shader_source(TRACE), "trace")?;
        let kat = ctx.compute_pipeline("mc_kat", &shader_source(KAT), "kat")?;
        Ok(McGpu { ctx, trace, kat })
    }

    pub fn is_software(&self) -> bool {
        self.ctx.is_software()
    }

    pub fn describe(&self) -> String {
        self.ctx.describe()
    }

    /// The dispatch shape suited to this adapter.
    pub fn default_dispatch(&self) -> GpuDispatch {
        GpuDispatch::for_adapter(self.is_software())
    }

    /// Philox4x32-10 of each (counter, key) on the device, to check the
    /// shader's generator against `philox4x32_10`.
    pub fn philox(&self, inputs: &[([u32; 4], [u32; 2])]) -> Result<Vec<[u32; 4]>> {
        let words: Vec<u32> = inputs
            .iter()
            .flat_map(|(c, k)| c.iter().chain(k).copied())
            .collect();
        let input = self.ctx.buffer(
            "kat in",
            bytemuck::cast_slice(&words),
            wgpu::BufferUsages::STORAGE,
        );
        let size = (inputs.len() * 16) as u64;
        let out = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kat out"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = self.ctx.bind_group(&self.kat, &[&input, &out]);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.kat);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(inputs.len() as u32, 1, 1);
        }
        let words: Vec<u32> = self.ctx.read_back(enc, &out, size)?;
        Ok(words
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect())
    }

    /// `simulate_with` on this adapter. Supports fixed and target-error
    /// budgets with classic boundaries; refuses what it does not implement.
    pub fn simulate(
        &self,
        material: &Material,
        cfg: &McConfig,
        opts: &McOptions,
        dispatch: GpuDispatch,
        progress: &dyn Progress,
    ) -> Result<Profile> {
        let start = std::time::Instant::now();
        material.validate(&format!("material '{}'", material.name))?;
        validate_config(cfg, opts)?;
        check_gpu_options(opts, dispatch)?;
        let requested_events = opts.max_events;
        // What the shader applies, so that the recorded cap and the
        // truncation warning name it.
        let opts = &McOptions {
            max_events: requested_events.min(GPU_MAX_EVENTS),
            ..opts.clone()
        };
        let (grid, grid_rule) = match &cfg.grid {
            Some(g) => (g.clone(), json!({"rule": "given"})),
            // The CPU tracer's grid for the same rule.
            None => RadialGrid::for_material_rule(
                material,
                &cfg.channels,
                matches!(cfg.budget, PhotonBudget::KernelFactor { .. }),
            ),
        };
        check_grid(&grid)?;
        let cap = cfg.budget.max_photons();
        progress.start(
            cap.saturating_mul(cfg.channels.len() as u64),
            &format!("{} photons (GPU)", material.name),
        );
        let mut runs = Vec::with_capacity(cfg.channels.len());
        for &ch in &cfg.channels {
            let run = self.run_channel(material, ch, &grid, cfg, opts, dispatch, progress)?;
            runs.push(run);
        }
        progress.finish();
        let mut p = build_profile(
            material,
            cfg,
            opts,
            &grid,
            grid_rule,
            &runs,
            start.elapsed().as_secs_f64(),
        );
        let params = &mut p.source.params;
        if let Some(m) = params.as_object_mut() {
            m.remove("chunk");
            m.remove("batch");
        }
        params["backend"] = json!("gpu");
        params["adapter"] = json!(self.describe());
        params["software_adapter"] = json!(self.is_software());
        params["rng"] = json!("philox4x32-10, key = seed, counter = (draw, channel, photon)");
        params["transport"] = json!("f32");
        params["tally"] = json!({
            "fixed_point": TALLY_RESOLUTION,
            "sums": "exact integer sums of per-photon values, independent of scheduling",
        });
        params["checkpoint"] = json!(CHECKPOINT);
        params["event_roulette"] = json!(
            "none: the GPU tracer ends walks at max_events, booking what is left as truncated"
        );
        note_event_clamp(&mut p, requested_events);
        Ok(p)
    }

    #[allow(clippy::too_many_arguments)]
    fn run_channel(
        &self,
        material: &Material,
        ch: Channel,
        grid: &RadialGrid,
        cfg: &McConfig,
        opts: &McOptions,
        dispatch: GpuDispatch,
        progress: &dyn Progress,
    ) -> Result<ChannelRun> {
        let stack = Stack::new(material, ch);
        let (cap, target) = match cfg.budget {
            PhotonBudget::Fixed(n) => (n, None),
            PhotonBudget::TargetError { rel, max_photons }
            | PhotonBudget::KernelFactor { rel, max_photons } => (max_photons, Some(rel)),
        };
        let n_bins = grid.len();
        let layers = gpu_layers(material, ch);
        let layer_buf = self.ctx.buffer(
            "layers",
            bytemuck::cast_slice(&layers),
            wgpu::BufferUsages::STORAGE,
        );
        let edges: Vec<f32> = grid.edges.iter().map(|&e| e as f32).collect();
        let edge_buf = self.ctx.buffer(
            "edges",
            bytemuck::cast_slice(&edges),
            wgpu::BufferUsages::STORAGE,
        );
        let words = BINS + 5 * n_bins;
        let acc = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tally"),
            size: (words * 4) as u64,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let param_buf = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = self
            .ctx
            .bind_group(&self.trace, &[&param_buf, &layer_buf, &edge_buf, &acc]);
        let uniform_dr = uniform_bin_width(grid);
        let mut params = Params {
            seed_lo: cfg.seed as u32,
            seed_hi: (cfg.seed >> 32) as u32,
            channel: ch.index() as u32,
            n_layers: layers.len() as u32,
            base_lo: 0,
            base_hi: 0,
            count: 0,
            n_bins: n_bins as u32,
            max_events: gpu_max_events(opts),
            uniform_bins: uniform_dr.is_some() as u32,
            dynamic: 0,
            stride: 0,
            w0: (1.0 - stack.specular) as f32,
            n_above: material.eta_above as f32,
            n_below: material.eta_below as f32,
            roulette: opts.roulette_threshold as f32,
            r_max: grid.r_max() as f32,
            inv_dr: uniform_dr.map_or(0.0, |dr| (1.0 / dr) as f32),
            _pad0: 0.0,
            _pad1: 0.0,
        };
        let mut sums = Sums::new(n_bins);
        let mut status = Status {
            rel_total: f64::INFINITY,
            rel_profile: f64::INFINITY,
            r99: 0.0,
            rel_factor: f64::INFINITY,
            rd: 0.0,
            rd_stderr: f64::INFINITY,
        };
        let mut converged = false;
        let mut by_floor = false;
        let mut work_capped = false;
        let mut tally = ChunkTally::new(n_bins, false);
        while sums.photons < cap {
            let stop = match target {
                Some(_) => cap.min((sums.photons / CHECKPOINT + 1) * CHECKPOINT),
                None => cap.min(CHECKPOINT.max(2 * sums.photons)),
            };
            while sums.photons < stop {
                let count = dispatch.batch.min(stop - sums.photons);
                params.base_lo = sums.photons as u32;
                params.base_hi = (sums.photons >> 32) as u32;
                params.count = count as u32;
                let inv = (dispatch.invocations as u64).min(count) as u32;
                params.dynamic = dispatch.dynamic as u32;
                params.stride = inv.div_ceil(WORKGROUP) * WORKGROUP;
                self.ctx
                    .queue
                    .write_buffer(&param_buf, 0, bytemuck::bytes_of(&params));
                let mut enc = self.ctx.device.create_command_encoder(&Default::default());
                enc.clear_buffer(&acc, 0, None);
                {
                    let mut pass = enc.begin_compute_pass(&Default::default());
                    pass.set_pipeline(&self.trace);
                    pass.set_bind_group(0, &group, &[]);
                    pass.dispatch_workgroups(inv.div_ceil(WORKGROUP), 1, 1);
                }
                let batch: Vec<u32> = self.ctx.read_back(enc, &acc, (words * 4) as u64)?;
                if batch[TRACED] as u64 != count || batch[INCOMPLETE] != 0 {
                    return Err(Error::Unsupported(format!(
                        "channel {}: the adapter ({}) traced {} of {count} packets and cut {} \
                         walks short: a driver limit on shader loops (llvmpipe allows 65535 \
                         iterations per invocation); use fewer packets per invocation or the \
                         CPU tracer",
                        ch.name(),
                        self.describe(),
                        batch[TRACED],
                        batch[INCOMPLETE]
                    )));
                }
                sums.add(&batch, count);
                progress.advance(count);
                // Work is bounded inside a round too: a batch's work is at
                // most its packets x GPU_MAX_EVENTS, and no batch starts
                // past the cap (batches are fixed per adapter: the stop is
                // reproducible).
                if sums.events >= opts.max_work as u128 {
                    break;
                }
            }
            if sums.saturated {
                return Err(Error::Unsupported(format!(
                    "channel {}: a photon's reflectance, transmittance or absorbed weight \
                     reached 256, beyond the GPU tally's fixed-point range (roulette \
                     threshold {} lets weights grow); use the CPU tracer",
                    ch.name(),
                    opts.roulette_threshold
                )));
            }
            tally = sums.tally(stack.specular);
            let exact = exact_tally(&tally, n_bins)?;
            status = statuses(material, &[ch], grid, &[exact]).0.swap_remove(0);
            if let Some(rel) = target {
                let relative = rule_error(&cfg.budget, &status) <= rel;
                by_floor = !relative
                    && floor_ratio(&cfg.budget, opts.abs_floor, &status, tally.photons) <= 1.0;
                converged = relative || by_floor;
                if converged || tally.events >= opts.max_work {
                    work_capped = !converged;
                    progress.advance(cap - tally.photons);
                    break;
                }
            } else if tally.photons < cap {
                if tally.photons <= CHECKPOINT {
                    check_fixed_work(ch, tally.photons, tally.events, cap, cap, opts.max_work)?;
                }
                if tally.events >= opts.max_work {
                    work_capped = true;
                    progress.advance(cap - tally.photons);
                    break;
                }
            }
        }
        Ok(ChannelRun {
            tally: exact_tally(&tally, n_bins)?,
            status,
            converged: (target.is_none() && !work_capped) || converged,
            work_capped,
            by_floor,
        })
    }
}

/// The WGSL of `body` (mc_trace.wgsl or mc_kat.wgsl) after what it shares
/// with this file: the constants, the structs, the wide product and the
/// generator (mc_philox.wgsl).
fn shader_source(body: &str) -> String {
    [
        &shader_consts(),
        Params::WGSL,
        Layer::WGSL,
        WGSL_WIDE_MUL,
        PHILOX,
        body,
    ]
    .join("\n")
}

/// The constants the shaders share with this file: Philox's, the tally
/// layout, the workgroup size.
fn shader_consts() -> String {
    let word = |name, i: usize| (name, i as u32);
    wgsl_u32_consts(&[
        ("PHILOX_M0", PHILOX_M[0]),
        ("PHILOX_M1", PHILOX_M[1]),
        ("PHILOX_W0", PHILOX_W[0]),
        ("PHILOX_W1", PHILOX_W[1]),
        word("T_RD", T_RD),
        word("T_TR", T_TR),
        word("T_ABS", T_ABS),
        word("T_BEYOND", T_BEYOND),
        word("T_LOSS", T_LOSS),
        word("T_GAIN", T_GAIN),
        word("T_TRUNC", T_TRUNC),
        word("T_TRUNC_N", T_TRUNC_N),
        word("T_EVENTS", T_EVENTS),
        word("T_SATURATED", T_SATURATED),
        word("WORK", WORK),
        word("INCOMPLETE", INCOMPLETE),
        word("TRACED", TRACED),
        word("BINS", BINS),
        ("WORKGROUP", WORKGROUP),
    ])
}

/// Events per packet on the GPU: a hard cap whatever `max_events` asks
/// (the smaller of the two applies), since the shader has no event-count
/// roulette and one invocation's walk loop must end: a driver watchdog stops
/// a long-running shader (and llvmpipe cuts an invocation's loops after
/// 65535 iterations, see `INCOMPLETE`). A packet stopped there is abandoned
/// and its weight booked as truncated, counted in `truncated_photons` and
/// warned about, as on the CPU. 10^6 is the cap the CPU tracer had before
/// its roulette; at albedo 1 it leaves ~n^-1/2 of the energy behind (see
/// `DEFAULT_MAX_EVENTS`).
pub const GPU_MAX_EVENTS: u64 = 1_000_000;

/// Records the event cap asked for where the GPU's own was lower, and warns
/// where packets were cut there.
fn note_event_clamp(p: &mut Profile, requested_events: u64) {
    if requested_events <= GPU_MAX_EVENTS {
        return;
    }
    let (asked, text) = match requested_events {
        u64::MAX => (json!("none"), "none".to_string()),
        n => (json!(n), n.to_string()),
    };
    let capped: Vec<&str> = runs_truncated(p);
    if !capped.is_empty() {
        if let Some(w) = p.extra["warnings"].as_array_mut() {
            w.push(json!(format!(
                "channel(s) {}: the GPU tracer stops every walk at {GPU_MAX_EVENTS} events (a \
                 shader invocation's loop must end: drivers stop long-running shaders), below \
                 the cap asked for (`max_events`: {text}); the CPU tracer's event-count \
                 roulette ends long walks without bias",
                capped.join(", ")
            )));
        }
    }
    p.source.params["max_events_requested"] = asked;
}

/// Channels of a profile where packets were truncated.
fn runs_truncated(p: &Profile) -> Vec<&'static str> {
    p.channels
        .iter()
        .enumerate()
        .filter(|(i, _)| p.extra["truncated_photons"][*i].as_u64().unwrap_or(0) > 0)
        .map(|(_, c)| c.name())
        .collect()
}

fn gpu_max_events(opts: &McOptions) -> u32 {
    opts.max_events.min(GPU_MAX_EVENTS) as u32
}

/// The GPU's per-channel sums as the exact tally `build_profile` reads.
fn exact_tally(t: &ChunkTally, bins: usize) -> Result<ExactTally> {
    let mut e = ExactTally::new(bins, false);
    e.add_chunk(t)
        .map_err(|e| Error::Unsupported(format!("the GPU tally: {e}")))?;
    Ok(e)
}

/// What the GPU tracer does not implement, refused before any work.
fn check_gpu_options(opts: &McOptions, dispatch: GpuDispatch) -> Result<()> {
    if opts.boundary != BoundaryMode::Classic {
        return Err(Error::Unsupported(format!(
            "the GPU tracer implements the classic boundary only, not '{}' \
             (one escape per packet keeps its per-bin second moment a single square)",
            opts.boundary.name()
        )));
    }
    if opts.single_scatter {
        return Err(Error::Unsupported(
            "the GPU tracer has no single-scattering tally; use the CPU tracer".into(),
        ));
    }
    if opts.angular.is_some() {
        return Err(Error::Unsupported(
            "the GPU tracer has no angle-resolved tallies (exit-angle bins, oblique \
             incidence); use the CPU tracer (--backend cpu)"
                .into(),
        ));
    }
    if opts.shard.is_some() {
        return Err(Error::Unsupported(
            "the GPU tracer does not trace shards (its sums are not the CPU's exact chunk \
             sums); use the CPU tracer for shards and merge"
                .into(),
        ));
    }
    if !(1..=MAX_BATCH).contains(&dispatch.batch)
        || !(1..=MAX_INVOCATIONS).contains(&dispatch.invocations)
    {
        return Err(Error::Unsupported(format!(
            "GPU dispatch of {} photons x {} invocations: need 1..={MAX_BATCH} photons and \
             1..={MAX_INVOCATIONS} invocations",
            dispatch.batch, dispatch.invocations
        )));
    }
    Ok(())
}

/// `RadialGrid::check_edges`, and edges distinct in f32 too, or bins would
/// be empty by rounding alone.
fn check_grid(grid: &RadialGrid) -> Result<()> {
    grid.check_edges()?;
    let e = &grid.edges;
    if e.windows(2).any(|w| !((w[1] as f32) > (w[0] as f32))) {
        return Err(Error::invalid(
            "radial grid",
            "edges",
            format!("{} values", e.len()),
            "the GPU tracer needs edges distinct in f32 (relative spacing above 1e-7)",
        ));
    }
    Ok(())
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

/// The layer stack of one channel, as `tracer::Stack` builds it.
fn gpu_layers(m: &Material, ch: Channel) -> Vec<Layer> {
    let c = ch.index();
    let mut z = 0.0f64;
    m.layers
        .iter()
        .map(|l| {
            let sigma_t = l.sigma_a[c] + l.sigma_s[c];
            let z_top = z;
            z = l.thickness.map_or(f64::INFINITY, |t| z + t);
            Layer {
                z_top: z_top as f32,
                z_bottom: if z.is_finite() {
                    z as f32
                } else {
                    SEMI_INFINITE
                },
                sigma_t: sigma_t as f32,
                inv_sigma_t: (1.0 / sigma_t) as f32,
                albedo: (l.sigma_s[c] / sigma_t) as f32,
                g: l.g[c] as f32,
                n: l.eta as f32,
                _pad: 0.0,
            }
        })
        .collect()
}

/// Exact integer tallies of a channel, in units of `TALLY_RESOLUTION`
/// (squares in its square).
struct Sums {
    photons: u64,
    rd: [u128; 2],
    tr: [u128; 2],
    absorbed: [u128; 2],
    beyond: u128,
    loss: u128,
    gain: u128,
    truncated: u128,
    truncated_photons: u128,
    events: u128,
    bins: Vec<[u128; 2]>,
    saturated: bool,
}

impl Sums {
    fn new(n_bins: usize) -> Sums {
        Sums {
            photons: 0,
            rd: [0; 2],
            tr: [0; 2],
            absorbed: [0; 2],
            beyond: 0,
            loss: 0,
            gain: 0,
            truncated: 0,
            truncated_photons: 0,
            events: 0,
            bins: vec![[0; 2]; n_bins],
            saturated: false,
        }
    }

    /// Adds one batch's words.
    fn add(&mut self, w: &[u32], photons: u64) {
        let wide =
            |i: usize, n: usize| -> u128 { (0..n).map(|k| (w[i + k] as u128) << (32 * k)).sum() };
        let moments = |m: &mut [u128; 2], i: usize| {
            m[0] += wide(i, 2);
            m[1] += wide(i + 2, 3);
        };
        self.photons += photons;
        moments(&mut self.rd, T_RD);
        moments(&mut self.tr, T_TR);
        moments(&mut self.absorbed, T_ABS);
        self.beyond += wide(T_BEYOND, 2);
        self.loss += wide(T_LOSS, 2);
        self.gain += wide(T_GAIN, 2);
        self.truncated += wide(T_TRUNC, 2);
        self.truncated_photons += wide(T_TRUNC_N, 2);
        self.events += wide(T_EVENTS, 2);
        self.saturated |= w[T_SATURATED] != 0;
        for (i, b) in self.bins.iter_mut().enumerate() {
            moments(b, BINS + 5 * i);
        }
    }

    fn tally(&self, specular: f64) -> ChunkTally {
        let v = |x: u128| x as f64 * TALLY_RESOLUTION;
        let m = |x: &[u128; 2]| Moments {
            sum: v(x[0]),
            sum_sq: x[1] as f64 * TALLY_RESOLUTION * TALLY_RESOLUTION,
        };
        let bins = self.bins.iter().map(m);
        let (sum, sum_sq) = bins.map(|b| (b.sum, b.sum_sq)).unzip();
        ChunkTally {
            photons: self.photons,
            events: self.events as u64,
            specular: specular * self.photons as f64,
            rd: m(&self.rd),
            transmittance: m(&self.tr),
            absorbed: m(&self.absorbed),
            rd_bins: BinSums { sum, sum_sq },
            rd_beyond: v(self.beyond),
            roulette_loss: v(self.loss),
            roulette_gain: v(self.gain),
            truncated: v(self.truncated),
            truncated_photons: self.truncated_photons as u64,
            ..ChunkTally::new(0, false)
        }
    }
}

/// The round multipliers of Philox4x32 (Salmon et al. 2011; Random123's
/// PHILOX_M4x32_0 and _1), for the CPU twin and the shader.
const PHILOX_M: [u32; 2] = [0xD251_1F53, 0xCD9E_8D57];
/// The key increments (Weyl sequence) of Philox4x32: 2^32 / golden ratio
/// and 2^32 (sqrt(3) - 1) (Random123's PHILOX_W32_0 and _1).
const PHILOX_W: [u32; 2] = [0x9E37_79B9, 0xBB67_AE85];

/// Philox4x32-10 on the CPU (Salmon et al. 2011, Random123's
/// `philox4x32_R` with R = 10): the reference for the shader's generator.
pub fn philox4x32_10(ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let (mut c, mut k) = (ctr, key);
    for _ in 0..10 {
        let p0 = PHILOX_M[0] as u64 * c[0] as u64;
        let p1 = PHILOX_M[1] as u64 * c[2] as u64;
        c = [
            (p1 >> 32) as u32 ^ c[1] ^ k[0],
            p1 as u32,
            (p0 >> 32) as u32 ^ c[3] ^ k[1],
            p0 as u32,
        ];
        k = [
            k[0].wrapping_add(PHILOX_W[0]),
            k[1].wrapping_add(PHILOX_W[1]),
        ];
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The angle-resolved tallies exist on the CPU only: refused before any
    /// work, saying so.
    #[test]
    fn angular_options_are_refused() {
        let opts = McOptions {
            angular: Some(crate::profile::mc::AngularOptions {
                angle_bins: 9,
                incidence_deg: vec![],
            }),
            ..McOptions::default()
        };
        let e = check_gpu_options(&opts, GpuDispatch::for_adapter(false))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no angle-resolved tallies"), "{e}");
        assert!(check_gpu_options(&McOptions::default(), GpuDispatch::for_adapter(false)).is_ok());
    }

    #[test]
    fn philox_matches_random123_known_answers() {
        // Random123 tests/kat_vectors, the three "philox4x32 10" lines.
        let kat = [
            (
                [0u32; 4],
                [0u32; 2],
                [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8],
            ),
            (
                [u32::MAX; 4],
                [u32::MAX; 2],
                [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd],
            ),
            (
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0],
                [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1],
            ),
        ];
        for (c, k, want) in kat {
            assert_eq!(philox4x32_10(c, k), want);
        }
    }

    #[test]
    fn the_assembled_shaders_are_valid_wgsl() {
        crate::gpu::tests::assert_valid_wgsl(&shader_source(TRACE), "mc_trace");
        crate::gpu::tests::assert_valid_wgsl(&shader_source(KAT), "mc_kat");
    }

    #[test]
    fn a_clamped_event_cap_is_recorded_and_warned_where_it_cut() {
        // lavapipe cannot run a walk to 10^6 events: the note is checked on a
        // profile whose red channel reports truncated packets.
        let m = crate::material::preset("skin1").unwrap();
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(100),
            seed: 1,
            threads: Some(1),
            channels: vec![Channel::R, Channel::B],
            grid: None,
        };
        let mut p = super::super::simulate(&m, &cfg, &crate::progress::NoProgress).unwrap();
        note_event_clamp(&mut p, GPU_MAX_EVENTS);
        assert!(p.source.params.get("max_events_requested").is_none());
        p.extra["truncated_photons"][0] = json!(3);
        note_event_clamp(&mut p, u64::MAX);
        assert_eq!(p.source.params["max_events_requested"], "none");
        let w = p.extra["warnings"].to_string();
        assert!(
            w.contains("channel(s) r: the GPU tracer stops every walk at 1000000 events")
                && w.contains("`max_events`: none"),
            "{w}"
        );
        note_event_clamp(&mut p, 5_000_000);
        assert_eq!(p.source.params["max_events_requested"], 5_000_000);
    }

    #[test]
    fn wide_sums_carry_across_words() {
        let mut s = Sums::new(1);
        let mut w = vec![0u32; BINS + 5];
        w[T_RD] = u32::MAX;
        w[T_RD + 1] = 2;
        w[T_RD + 4] = 1;
        s.add(&w, 3);
        s.add(&w, 3);
        assert_eq!(s.rd[0], 2 * ((2u128 << 32) + u32::MAX as u128));
        assert_eq!(s.rd[1], 2u128 << 64);
        assert_eq!(s.photons, 6);
    }
}
