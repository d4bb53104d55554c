//! The GPU Monte Carlo tracer (wgpu compute, f32) against the same truths
//! as the CPU tracer in mc_physics.rs, against the CPU tracer itself bin by
//! bin, and for bit-identical output whatever the dispatch shape. Runs on
//! whatever adapter wgpu finds (lavapipe in CI); fails, never skips, when
//! there is none.

use ssskit::material::{preset, Channel, Material};
use ssskit::profile::mc::gpu::{philox4x32_10, GpuDispatch, McGpu, CHECKPOINT, GPU_MAX_EVENTS};
use ssskit::profile::mc::{
    simulate_with, BoundaryMode, EnergyBalance, McConfig, McOptions, PhotonBudget,
    DEFAULT_ABS_FLOOR, DEFAULT_KERNEL_ERROR,
};
use ssskit::profile::Profile;
use ssskit::progress::NoProgress;
use std::sync::OnceLock;

mod common;
use common::mc::{self, cfg, material, within};

/// One device for the whole file: opening lavapipe and compiling the shader
/// costs about a second.
fn gpu() -> &'static McGpu {
    static GPU: OnceLock<McGpu> = OnceLock::new();
    GPU.get_or_init(|| {
        ssskit::gpu::use_software_vulkan_if_unset();
        let g = McGpu::new().expect("a wgpu adapter (lavapipe: scripts/setup)");
        eprintln!("adapter: {}", g.describe());
        g
    })
}

fn run(m: &Material, c: &McConfig) -> Profile {
    let g = gpu();
    g.simulate(
        m,
        c,
        &McOptions::default(),
        g.default_dispatch(),
        &NoProgress,
    )
    .expect("GPU simulation")
}

/// The energy balance closes to f32 rounding: each packet's absorbed weight
/// is an f32 running sum over its events (relative rounding ~1e-7 per event,
/// unbiased), and its tallies are rounded to 2^-24 (each test prints its
/// |sum - 1|); 2e-6 leaves room without hiding a lost term (the smallest
/// terms, roulette gain and loss, are ~1e-3).
fn assert_balance(p: &Profile) {
    common::mc::assert_balance(p, 2e-6);
}

#[test]
fn philox_on_the_device_matches_the_reference() {
    let mut inputs = vec![
        ([0u32; 4], [0u32; 2]),
        ([u32::MAX; 4], [u32::MAX; 2]),
        (
            [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
            [0xa4093822, 0x299f31d0],
        ),
    ];
    // Counters as the tracer forms them: (draw, channel, photon lo, hi).
    for i in 0..61u32 {
        let x = i.wrapping_mul(0x9E37_79B9);
        inputs.push(([i, i % 3, x, x.rotate_left(7)], [x ^ 0xdead_beef, !x]));
    }
    let got = gpu().philox(&inputs).expect("kat dispatch");
    for ((c, k), g) in inputs.iter().zip(&got) {
        assert_eq!(*g, philox4x32_10(*c, *k), "ctr {c:x?} key {k:x?}");
    }
    assert_eq!(got[0], [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8]);
}

#[test]
fn van_de_hulst_slab() {
    let m = material(mc::SLAB);
    let p = run(&m, &cfg(200_000, Channel::R, None));
    within(
        p.total_rd[0],
        mc::SLAB_RD,
        p.total_rd_stderr.as_ref().unwrap()[0],
        "R_d",
    );
    within(
        p.transmittance.as_ref().unwrap()[0],
        mc::SLAB_T,
        p.transmittance_stderr.as_ref().unwrap()[0],
        "T",
    );
    assert_eq!(p.specular[0], 0.0);
    assert_balance(&p);
    assert_eq!(p.source.params["backend"], "gpu");
}

#[test]
fn semi_infinite_isotropic_albedo_09() {
    for (eta, truth, spec) in mc::ALBEDO_09 {
        let m = mc::albedo_09(eta);
        let p = run(&m, &cfg(100_000, Channel::G, None));
        let se = p.total_rd_stderr.as_ref().unwrap()[0];
        within(p.total_rd[0], truth, se, &format!("eta {eta} R_d"));
        assert!((p.specular[0] - spec).abs() < 1e-12);
        assert_eq!(p.transmittance.as_ref().unwrap()[0], 0.0);
        assert_balance(&p);
        // Tabulated plus beyond r_max is the total: the same integers.
        let beyond = p.extra["rd_beyond_rmax"][0].as_f64().unwrap();
        assert!((p.tabulated_total(0) + beyond - p.total_rd[0]).abs() < 1e-12);
    }
}

/// chi^2 per bin of GPU against CPU over the bins where both scored, with
/// both standard errors, and the totals within 4 combined sigma.
fn assert_compatible(name: &str, m: &Material, ch: Channel, photons: u64) {
    let c = cfg(photons, ch, None);
    let cpu = simulate_with(m, &c, &McOptions::default(), &NoProgress).unwrap();
    let gpu = run(m, &McConfig { seed: 99, ..c });
    assert_eq!(cpu.r_edges, gpu.r_edges);
    assert_balance(&gpu);
    let (ec, eg) = (
        &cpu.rd_stderr.as_ref().unwrap()[0],
        &gpu.rd_stderr.as_ref().unwrap()[0],
    );
    let (mut chi2, mut n) = (0.0, 0);
    for i in 0..cpu.r.len() {
        if ec[i] > 0.0 && eg[i] > 0.0 {
            chi2 += (cpu.rd[0][i] - gpu.rd[0][i]).powi(2) / (ec[i].powi(2) + eg[i].powi(2));
            n += 1;
        }
    }
    let per_bin = chi2 / n as f64;
    eprintln!("{name}: chi^2 per bin {per_bin:.3} over {n} bins");
    assert!(n >= 20, "{name}: only {n} bins scored");
    assert!(per_bin < 2.0, "{name}: chi^2 per bin {per_bin}");
    let sigma = (cpu.total_rd_stderr.as_ref().unwrap()[0].powi(2)
        + gpu.total_rd_stderr.as_ref().unwrap()[0].powi(2))
    .sqrt();
    within(
        gpu.total_rd[0],
        cpu.total_rd[0],
        sigma,
        &format!("{name} R_d"),
    );
    if let (Some(tc), Some(tg)) = (&cpu.transmittance_stderr, &gpu.transmittance_stderr) {
        let s = (tc[0].powi(2) + tg[0].powi(2)).sqrt();
        let (a, b) = (
            cpu.transmittance.as_ref().unwrap()[0],
            gpu.transmittance.as_ref().unwrap()[0],
        );
        within(b, a, s, &format!("{name} T"));
    }
}

#[test]
fn skin1_profile_matches_the_cpu_tracer() {
    assert_compatible("skin1 R", &preset("skin1").unwrap(), Channel::R, 40_000);
}

#[test]
fn marble_profile_matches_the_cpu_tracer() {
    assert_compatible("marble B", &preset("marble").unwrap(), Channel::B, 10_000);
}

#[test]
fn layered_tissue_profile_matches_the_cpu_tracer() {
    // Three layers with index steps (Fresnel and total internal reflection
    // at every interface) and g up to 0.9.
    let m = material(
        "unit = \"mm\"\neta_above = 1.0\n\
         [[layer]]\nsigma_a = 0.5\nsigma_s = 5.0\ng = 0.8\neta = 1.37\nthickness = 0.1\n\
         [[layer]]\nsigma_a = 0.2\nsigma_s = 20.0\ng = 0.9\neta = 1.5\nthickness = 0.4\n\
         [[layer]]\nsigma_a = 0.05\nsigma_s = 2.0\ng = -0.5\neta = 1.33\nthickness = 1.0\n",
    );
    assert_compatible("layered g 0.9", &m, Channel::R, 40_000);
}

#[test]
fn output_does_not_depend_on_the_dispatch_shape() {
    let m = preset("skin1").unwrap();
    let g = gpu();
    let shapes = [
        // Batches that do and do not divide the budget, static with several
        // packets per invocation, and dynamic (few invocations: on llvmpipe
        // that stays under its loop limit only for short walks like skin1).
        GpuDispatch {
            batch: 7_000,
            invocations: 1_024,
            dynamic: false,
        },
        GpuDispatch {
            batch: 1 << 16,
            invocations: 1 << 16,
            dynamic: false,
        },
        GpuDispatch {
            batch: 500,
            invocations: 64,
            dynamic: true,
        },
    ];
    for budget in [
        PhotonBudget::Fixed(30_000),
        PhotonBudget::TargetError {
            rel: 0.2,
            max_photons: 400_000,
        },
    ] {
        let c = McConfig {
            budget,
            seed: 7,
            threads: None,
            channels: vec![Channel::R, Channel::B],
            grid: None,
        };
        let out: Vec<String> = shapes
            .iter()
            .map(|&d| {
                let mut p = g
                    .simulate(&m, &c, &McOptions::default(), d, &NoProgress)
                    .unwrap();
                p.elapsed_s = 0.0;
                serde_json::to_string(&p).unwrap()
            })
            .collect();
        for o in &out[1..] {
            // Not assert_eq: the JSON is megabytes.
            assert!(*o == out[0], "dispatch shape changed the output");
        }
        // A different seed does change it.
        let mut p = g
            .simulate(
                &m,
                &McConfig { seed: 8, ..c },
                &McOptions::default(),
                shapes[0],
                &NoProgress,
            )
            .unwrap();
        p.elapsed_s = 0.0;
        assert!(out[0] != serde_json::to_string(&p).unwrap());
    }
}

#[test]
fn unsupported_settings_are_refused() {
    let m = preset("skin1").unwrap();
    let g = gpu();
    let c = cfg(1000, Channel::R, None);
    for (o, needle) in [
        (
            McOptions {
                boundary: BoundaryMode::Split,
                ..McOptions::default()
            },
            "classic",
        ),
        (
            McOptions {
                single_scatter: true,
                ..McOptions::default()
            },
            "single",
        ),
        (
            McOptions {
                shard: Some(ssskit::profile::mc::Shard { k: 1, n: 2 }),
                ..McOptions::default()
            },
            "shard",
        ),
    ] {
        let e = g
            .simulate(&m, &c, &o, g.default_dispatch(), &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{e}");
    }
    let e = g
        .simulate(
            &m,
            &c,
            &McOptions::default(),
            GpuDispatch {
                batch: 0,
                invocations: 64,
                dynamic: false,
            },
            &NoProgress,
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("dispatch"), "{e}");
}

#[test]
fn cli_backend_choice_is_printed_and_recorded() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let dir = tempfile::tempdir().unwrap();
    let sim = |backend: &str, extra: &[&str]| {
        let out = dir.path().join(format!("{backend}.json"));
        let o = common::bin()
            .args(["simulate", "--material", "skin1", "--channels", "b"])
            .args(["--photons", "2000", "--backend", backend, "--out"])
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        (o.status.success(), err, out)
    };
    let (ok, err, out) = sim("gpu", &[]);
    assert!(ok, "{err}");
    assert!(err.contains("backend: gpu, adapter"), "{err}");
    let p = ssskit::profile::Profile::read(&out).unwrap();
    assert_eq!(p.source.params["backend"], "gpu");
    assert!(p.source.params["adapter"].as_str().unwrap().len() > 3);
    // auto never picks a software rasteriser; on lavapipe it is the CPU.
    let (ok, err, out) = sim("auto", &[]);
    assert!(ok, "{err}");
    let p = ssskit::profile::Profile::read(&out).unwrap();
    if gpu().is_software() {
        assert!(err.contains("backend: cpu (auto"), "{err}");
        assert!(p.source.params.get("backend").is_none());
    } else {
        assert_eq!(p.source.params["backend"], "gpu");
    }
    let (ok, err, _) = sim("gpu", &["--boundary", "split"]);
    assert!(!ok && err.contains("classic"), "{err}");
}

fn stopped_by(p: &Profile) -> Vec<String> {
    serde_json::from_value(p.extra["stopped_by"].clone()).unwrap()
}

fn kernel_rule(rel: f64, ch: Vec<Channel>, seed: u64) -> McConfig {
    McConfig {
        budget: PhotonBudget::KernelFactor {
            rel,
            max_photons: 100_000_000,
        },
        seed,
        threads: None,
        channels: ch,
        grid: None,
    }
}

/// The absolute floor of the kernel-factor rule on the GPU (the CPU side:
/// tests/mc_abs_floor.rs): beer red (R_d ~1e-5) stops at the floor just
/// past its photon minimum, with the claimed noise, and agrees with the CPU
/// tracer's run under the same rule within 4 combined standard errors.
#[test]
fn beer_stops_at_the_absolute_floor_and_agrees_with_the_cpu() {
    let m = preset("beer").unwrap();
    let floor = DEFAULT_ABS_FLOOR;
    let c = kernel_rule(DEFAULT_KERNEL_ERROR, vec![Channel::R], 5);
    let g = gpu()
        .simulate(
            &m,
            &c,
            &McOptions::default(),
            gpu().default_dispatch(),
            &NoProgress,
        )
        .unwrap();
    assert_eq!(stopped_by(&g), ["absolute-floor"]);
    assert_eq!(g.extra["converged"][0], true);
    assert_eq!(g.source.params["budget"]["absolute_floor"]["floor"], floor);
    // The photon minimum, reached at the first checkpoint past it.
    let n = g.source.photons.as_ref().unwrap()[0];
    let min = (3.0 / floor) as u64;
    assert!(n >= min && n < min + CHECKPOINT, "{n} photons");
    let se = g.total_rd_stderr.as_ref().unwrap()[0];
    let rel_f = g.extra["rel_error_kernel_factor"][0].as_f64().unwrap();
    assert!(
        se <= floor && g.total_rd[0] * rel_f <= floor,
        "{se} {rel_f}"
    );
    // The relative target is far: the floor, not the target, stopped it.
    assert!(se / g.total_rd[0] > DEFAULT_KERNEL_ERROR);
    assert_balance(&g);
    let cpu = simulate_with(&m, &c, &McOptions::default(), &NoProgress).unwrap();
    assert_eq!(stopped_by(&cpu), ["absolute-floor"]);
    assert_eq!(cpu.r_edges, g.r_edges, "the kernel rule's grid on both");
    let s = (se.powi(2) + cpu.total_rd_stderr.as_ref().unwrap()[0].powi(2)).sqrt();
    eprintln!(
        "beer R: GPU {n} photons, R_d {:.4e} +- {se:.2e}; CPU {:?} photons, R_d {:.4e}; {:.2} sigma",
        g.total_rd[0],
        cpu.source.photons.as_ref().unwrap(),
        cpu.total_rd[0],
        (g.total_rd[0] - cpu.total_rd[0]) / s
    );
    within(g.total_rd[0], cpu.total_rd[0], s, "beer R R_d, GPU vs CPU");
}

/// Where R_d >= floor / target (4e-4 at the defaults) the floor never stops
/// a channel before the relative rule: the GPU run is bit-identical with the
/// floor off. Ketchup's blue channel is the darkest preset channel above
/// that bound (tests/mc_abs_floor.rs makes the same claim on the CPU).
#[test]
fn the_floor_never_stops_a_visible_channel_early_on_the_gpu() {
    let m = preset("ketchup").unwrap();
    let c = kernel_rule(DEFAULT_KERNEL_ERROR, Channel::ALL.to_vec(), 2);
    let run = |floor: f64| {
        let o = McOptions {
            abs_floor: floor,
            ..McOptions::default()
        };
        let mut p = gpu()
            .simulate(&m, &c, &o, gpu().default_dispatch(), &NoProgress)
            .unwrap();
        p.elapsed_s = 0.0;
        p
    };
    let with = run(DEFAULT_ABS_FLOOR);
    assert!(with
        .total_rd
        .iter()
        .all(|&r| r >= DEFAULT_ABS_FLOOR / DEFAULT_KERNEL_ERROR));
    assert!(stopped_by(&with).iter().all(|s| s == "target"));
    let without = run(0.0);
    assert_eq!(with.source.photons, without.source.photons);
    assert_eq!(with.rd, without.rd);
    assert_eq!(with.total_rd, without.total_rd);
}

/// Packets cut at a small event cap: the GPU books their weight as
/// truncated, counts and warns about them as the CPU does, and both
/// tracers play the same (biased) game, so the truncated fraction, the
/// truncated energy and R_d agree within 4 combined standard errors.
#[test]
fn the_event_cap_truncates_as_on_the_cpu() {
    let m = preset("skin1").unwrap();
    let n = 40_000;
    let c = cfg(n, Channel::R, None);
    // skin1 red walks ~40 events on average: a cap of 20 cuts many.
    let o = McOptions {
        max_events: 20,
        ..McOptions::default()
    };
    let g = gpu()
        .simulate(&m, &c, &o, gpu().default_dispatch(), &NoProgress)
        .unwrap();
    let cpu = simulate_with(&m, &McConfig { seed: 99, ..c }, &o, &NoProgress).unwrap();
    assert_eq!(g.source.params["max_events"], 20);
    assert_balance(&g);
    let nf = n as f64;
    let truncated = |p: &Profile| {
        let k = p.extra["truncated_photons"][0].as_u64().unwrap();
        let b = EnergyBalance::of(p, Channel::R).unwrap().unwrap();
        (k as f64 / nf, b.truncated)
    };
    let ((fg, eg), (fc, ec)) = (truncated(&g), truncated(&cpu));
    eprintln!("truncated photons GPU {fg:.4} CPU {fc:.4}; energy GPU {eg:.4e} CPU {ec:.4e}");
    assert!(fg > 0.05 && eg > 0.0, "the cap cut nothing");
    // A fraction's binomial error; a weight in [0, 1] has variance at
    // most its mean.
    let s = ((fg * (1.0 - fg) + fc * (1.0 - fc)) / nf).sqrt();
    within(fg, fc, s, "truncated fraction");
    within(eg, ec, ((eg + ec) / nf).sqrt(), "truncated energy");
    let s = (g.total_rd_stderr.as_ref().unwrap()[0].powi(2)
        + cpu.total_rd_stderr.as_ref().unwrap()[0].powi(2))
    .sqrt();
    within(g.total_rd[0], cpu.total_rd[0], s, "R_d under the cap");
    for p in [&g, &cpu] {
        let w = p.extra["warnings"].to_string();
        assert!(w.contains("reached the cap of 20 events"), "{w}");
    }
    // Without a cap asked for, the GPU's own is recorded, not "none".
    let p = run(&m, &cfg(2000, Channel::R, None));
    assert_eq!(p.source.params["max_events"], GPU_MAX_EVENTS);
    assert_eq!(p.source.params["max_events_requested"], "none");
    let o = McOptions {
        max_events: 5 * GPU_MAX_EVENTS,
        ..McOptions::default()
    };
    let p = gpu()
        .simulate(
            &m,
            &cfg(2000, Channel::R, None),
            &o,
            gpu().default_dispatch(),
            &NoProgress,
        )
        .unwrap();
    assert_eq!(p.source.params["max_events"], GPU_MAX_EVENTS);
    assert_eq!(p.source.params["max_events_requested"], 5 * GPU_MAX_EVENTS);
}

/// A fixed count on the GPU obeys the work cap as on the CPU: refused up
/// front when surely above it, and after its first checkpoint when the
/// events per photon measured there project more.
#[test]
fn fixed_counts_beyond_the_work_cap_are_refused_on_the_gpu() {
    let m = preset("skin1").unwrap();
    let o = McOptions {
        max_work: 1_000_000,
        ..McOptions::default()
    };
    let refusal = |photons: u64| {
        let g = gpu();
        g.simulate(
            &m,
            &cfg(photons, Channel::R, None),
            &o,
            g.default_dispatch(),
            &NoProgress,
        )
        .unwrap_err()
        .to_string()
    };
    let e = refusal(2_000_000);
    assert!(
        e.contains("photons") && e.contains("at least one event"),
        "{e}"
    );
    // Refused after the first round, or the first batches of it that
    // reached the cap (no batch starts past it).
    let e = refusal(900_000);
    assert!(
        e.contains("events per photon over its first") && e.contains("work cap"),
        "{e}"
    );
}

/// The work cap stops a fixed GPU run whose first checkpoint underestimated
/// its cost (tests/mc_cli.rs has the CPU twin): the rounds trace
/// `CHECKPOINT` photons, then as many again, then the rest; with a seed
/// where the second round costs more than the first and a cap at the first
/// round's projection for one photon more than two rounds, the run passes
/// its first check and stops after the second, one photon short.
#[test]
fn a_fixed_gpu_run_stops_at_the_work_cap() {
    let m = preset("skin1").unwrap();
    let g = gpu();
    let sim = |photons: u64, seed: u64, max_work: u64| {
        let o = McOptions {
            max_work,
            ..McOptions::default()
        };
        let c = McConfig {
            seed,
            ..cfg(photons, Channel::B, None)
        };
        g.simulate(&m, &c, &o, g.default_dispatch(), &NoProgress)
            .unwrap()
    };
    let events = |p: &Profile| {
        let per = p.extra["events_per_photon"][0].as_f64().unwrap();
        (per * p.source.photons.as_ref().unwrap()[0] as f64).round() as u64
    };
    for seed in 1..=20 {
        let first = events(&sim(CHECKPOINT, seed, u64::MAX));
        let both = events(&sim(2 * CHECKPOINT, seed, u64::MAX));
        let n = 2 * CHECKPOINT + 1;
        let cap = (first as f64 / CHECKPOINT as f64 * n as f64).ceil() as u64;
        if both < cap {
            continue;
        }
        let p = sim(n, seed, cap);
        assert_eq!(p.source.photons, Some(vec![2 * CHECKPOINT]));
        assert_eq!(p.extra["stopped_by"][0], "work-cap");
        assert_eq!(p.extra["converged"][0], false);
        let w = p.extra["warnings"].to_string();
        assert!(
            w.contains(&format!("{} of {n} photons", 2 * CHECKPOINT)),
            "{w}"
        );
        return;
    }
    panic!("no seed in 1..=20 where the second round costs more than the first");
}
