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

mod channel;
mod philox;
mod shader;
mod sums;

pub use philox::{philox4x32_10, philox_wgsl_constants, PHILOX_WGSL};
pub use sums::TALLY_RESOLUTION;

use super::{build_profile, run_grid, validate_config, BoundaryMode, McConfig, McOptions, CHUNK};
use crate::error::{Error, Result};
use crate::gpu::{wgsl_struct, GpuContext};
use crate::material::Material;
use crate::profile::{Profile, RadialGrid};
use crate::progress::Progress;
use serde_json::json;
use shader::{shader_source, KAT, TRACE, WORKGROUP};
/// Largest batch: keeps every 64-bit sum (packets x 2^32) and 96-bit sum of
/// squares (packets x 2^64) of one batch from overflowing.
pub const MAX_BATCH: u64 = 1 << 24;
/// Photons between two checks of a target-error run: the CPU tracer's
/// granularity, and independent of the batch size, so the stopping point is
/// too. A fixed run checks its work after one checkpoint, then after rounds
/// that double the photons traced.
pub const CHECKPOINT: u64 = CHUNK * 16;

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
        material.validate_named()?;
        validate_config(cfg, opts)?;
        check_gpu_options(opts, dispatch)?;
        let requested_events = opts.max_events;
        // What the shader applies, so that the recorded cap and the
        // truncation warning name it.
        let opts = &McOptions {
            max_events: requested_events.min(GPU_MAX_EVENTS),
            ..opts.clone()
        };
        // The CPU tracer's grid for the same rule.
        let (grid, grid_rule) = run_grid(material, cfg);
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
        return Err(grid.edges_error(
            "the GPU tracer needs edges distinct in f32 (relative spacing above 1e-7)",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Channel;
    use crate::profile::mc::PhotonBudget;

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
}
