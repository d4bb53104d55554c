//! The profile a run's exact tallies give: per-bin R_d with standard
//! errors, the totals, the energy balance, why the run stopped and its
//! warnings.

use super::*;
use crate::numerics::Bounded;

pub(super) fn build_profile(
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
    let mut rd = Vec::new();
    let mut rd_err = Vec::new();
    let mut single = Vec::new();
    let mut warnings: Vec<String> = Vec::new();
    let mut balance = serde_json::Map::new();
    for ((t, run), ch) in ts.iter().zip(runs).zip(&cfg.channels) {
        let (v, e) = bin_density(&t.rd_bins, t.photons, &areas);
        rd.push(v);
        rd_err.push(e);
        balance.insert(ch.name().into(), json!(energy_balance(t)));
        if opts.single_scatter {
            single.push(single_scatter_record(t, *ch, &areas));
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
    let mut extra = json!({
        "energy_balance": balance,
        "rd_beyond_rmax": per(&|t| t.rd_beyond / t.photons as f64),
        "rel_error_total_rd": per_run(&|s| s.rd.rel_total),
        "rel_error_profile": per_run(&|s| s.rd.rel_profile),
        "rel_error_kernel_factor": per_run(&|s| s.rd.rel_factor),
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
    let tr_status: Vec<_> = runs.iter().map(|r| r.status.tr).collect();
    if let Some(t) = transmit::record(&ts, &tr_status, &areas) {
        extra["transmittance_profile"] = json!(t);
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
            params: run_params(cfg, opts, grid_rule),
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

/// Per bin of `n` photons' sums: R_d(r_i) = W_i / (N area_i) (Wang et al.
/// 1995) and its standard error; empty for a tally that was not kept.
fn bin_density(sums: &tally::BinSums, n: u64, areas: &[f64]) -> (Vec<f64>, Vec<f64>) {
    if sums.sum.is_empty() {
        return (vec![], vec![]);
    }
    (0..areas.len())
        .map(|i| {
            let m = Moments {
                sum: sums.sum[i],
                sum_sq: sums.sum_sq[i],
            };
            (m.mean(n) / areas[i], m.stderr(n) / areas[i])
        })
        .unzip()
}

/// Where a channel's launched light went, per photon.
fn energy_balance(t: &ChunkTally) -> EnergyBalance {
    let nf = t.photons as f64;
    let parts = [
        t.specular,
        t.rd.sum,
        t.transmittance.sum,
        t.absorbed.sum,
        t.residual(),
    ];
    let sum: f64 = parts.iter().sum::<f64>() / nf;
    EnergyBalance {
        specular: t.specular / nf,
        rd: t.rd.sum / nf,
        transmittance: t.transmittance.sum / nf,
        absorbed: t.absorbed.sum / nf,
        roulette_loss: t.roulette_loss / nf,
        roulette_gain: t.roulette_gain / nf,
        truncated: t.truncated / nf,
        sum,
        sum_minus_1: sum - 1.0,
    }
}

/// The single-scattering part of a channel's R_d: total and profile.
fn single_scatter_record(t: &ChunkTally, ch: Channel, areas: &[f64]) -> serde_json::Value {
    let n = t.photons;
    let (v, e) = bin_density(&t.single_bins, n, areas);
    json!({
        "channel": ch.name(),
        "total": t.single.mean(n),
        "total_stderr": t.single.stderr(n),
        "rd": v,
        "rd_stderr": e,
    })
}

/// The budget of a run as recorded: its rule, targets, caps and what the
/// target error means.
fn budget_record(cfg: &McConfig, opts: &McOptions) -> serde_json::Value {
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
    budget
}

/// The tracer's settings as `source.params` records them.
fn run_params(cfg: &McConfig, opts: &McOptions, grid_rule: serde_json::Value) -> serde_json::Value {
    json!({
        "boundary": opts.boundary.name(),
        "budget": budget_record(cfg, opts),
        "max_events": opts.max_events,
        "event_roulette": {"start": opts.event_roulette, "survival_per_doubling": EVENT_ROULETTE_SURVIVAL},
        "roulette": {"threshold": opts.roulette_threshold, "survival": ROULETTE_CHANCE},
        "chunk": CHUNK,
        "rng": "xoshiro256++ per (seed, channel, chunk), SplitMix64-hashed",
        "sums": "exact fixed-point accumulation of chunk sums (order-free)",
        "grid": grid_rule,
    })
}

/// Why a channel's run ended: "photons" (fixed budget or photon cap),
/// "target", "absolute-floor" or "work-cap".
pub(super) fn stop_reason(cfg: &McConfig, r: &ChannelRun) -> &'static str {
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
pub(super) fn channel_warnings(
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
            Bounded(100.0 * beyond / total)
        ));
    }
    if total == 0.0 {
        w.push(format!(
            "channel {c}: no diffuse reflectance (no scattering or nothing comes back)"
        ));
    } else if let Some(text) = noise_warning(t, &run.status) {
        w.push(format!("channel {c}: {text}"));
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
            PhotonBudget::KernelFactor { .. } => format!("kernel factor {:.2e}", s.rd.rel_factor),
            _ => format!("profile {:.2e}", s.rd.rel_profile),
        };
        let rel = match cfg.budget {
            PhotonBudget::TargetError { rel, .. } | PhotonBudget::KernelFactor { rel, .. } => rel,
            PhotonBudget::Fixed(_) => 0.0,
        };
        w.push(format!(
            "channel {c}: target error {rel} ({} rule) not reached within {cap}; \
             achieved total R_d {:.2e}, {achieved} with {} photons",
            cfg.budget.rule(),
            s.rd.rel_total,
            t.photons
        ));
    }
    w
}

/// Largest relative standard error of a channel's total R_d that a
/// profile reports without a warning. A profile scales every kernel and
/// image made from it by its total R_d; an error above 10% is a visible
/// change of brightness and hue (twenty times the default target of the
/// kernel-factor rule, `DEFAULT_KERNEL_ERROR`, 0.5%), so such a profile is
/// noise rather than a measurement.
pub const NOISY_REL_TOTAL: f64 = 0.1;

/// Photons below which a total's standard error cannot be estimated: the
/// sample variance needs two.
const MIN_PHOTONS_FOR_ERROR: u64 = 2;

/// A channel whose total R_d is too noisy to mean anything (or whose noise
/// is unknown), whatever the budget that asked for so few photons.
fn noise_warning(t: &ChunkTally, s: &Status) -> Option<String> {
    if t.photons < MIN_PHOTONS_FOR_ERROR {
        return Some(format!(
            "{} photon(s) give no estimate of the noise: the total R_d is one packet's \
             weight, not a measurement; trace more photons",
            t.photons
        ));
    }
    (!(s.rd.rel_total <= NOISY_REL_TOTAL)).then(|| {
        format!(
            "total R_d has a relative standard error of {:.1}% with {} photons, above \
             {:.0}%: the profile is noise; trace more photons",
            Bounded(100.0 * s.rd.rel_total),
            t.photons,
            Bounded(100.0 * NOISY_REL_TOTAL)
        )
    })
}

/// A fixed run that the work cap stopped short of its photons.
pub(super) fn fixed_cap_warning(
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
