//! The pipeline's default Monte Carlo (`ProfileSource::monte_carlo`, the
//! kernel-factor rule of `simulate`) against its former default (the
//! total-and-profile rule at 2%), on skin1 and marble: the new rule reaches
//! its target in every channel, and what each costs (photons and events,
//! both fixed by the seed at any thread count) is recorded in
//! docs/records/pipeline-mc.json, shown in docs/kernels.md.

mod common;
use common::measured::{check, table};
use ssskit::material::Material;
use ssskit::profile::mc::PhotonBudget;
use ssskit::profile::source::{make_profile, ProfileSource, MC_MAX_PHOTONS, MC_SEED};
use ssskit::profile::Profile;
use ssskit::progress::NoProgress;

/// The pipeline's former default: 2% relative standard error of total R_d
/// and profile, at most 2e6 photons per channel, under the same work cap.
const FORMER_REL: f64 = 0.02;
const FORMER_MAX_PHOTONS: u64 = 2_000_000;

fn extra_f64s(p: &Profile, key: &str) -> Vec<f64> {
    serde_json::from_value(p.extra[key].clone()).unwrap_or_else(|e| panic!("{key}: {e}"))
}

fn events(p: &Profile) -> Vec<f64> {
    let photons = p.source.photons.clone().unwrap();
    photons
        .iter()
        .zip(extra_f64s(p, "events_per_photon"))
        .map(|(&n, e)| n as f64 * e)
        .collect()
}

fn triple(v: &[String]) -> String {
    v.join(", ")
}

#[test]
fn the_default_rule_reaches_its_target_and_its_cost_is_recorded() {
    let default = ProfileSource::monte_carlo(MC_MAX_PHOTONS, MC_SEED);
    let ProfileSource::MonteCarlo {
        budget: PhotonBudget::KernelFactor { rel, .. },
        ..
    } = default
    else {
        panic!("the default is not the kernel-factor rule: {default:?}")
    };
    let former = ProfileSource::target_error(FORMER_REL, FORMER_MAX_PHOTONS, MC_SEED);
    let mut rows = Vec::new();
    let mut data = serde_json::Map::new();
    for name in ["skin1", "marble"] {
        let m = Material::load(name).unwrap();
        let (new, _) = make_profile(&m, &default, &NoProgress).unwrap();
        let (old, _) = make_profile(&m, &former, &NoProgress).unwrap();
        // The rule's promise: stopped by its target (not a cap) with the
        // kernel factor's relative error at most the target, every channel.
        let stopped: Vec<String> = serde_json::from_value(new.extra["stopped_by"].clone()).unwrap();
        assert!(stopped.iter().all(|s| s == "target"), "{name}: {stopped:?}");
        for (c, e) in extra_f64s(&new, "rel_error_kernel_factor")
            .iter()
            .enumerate()
        {
            assert!(
                *e <= rel,
                "{name} channel {c}: kernel factor error {e} > {rel}"
            );
        }
        let (ev_new, ev_old) = (events(&new), events(&old));
        let total = |v: &[f64]| v.iter().sum::<f64>();
        for (label, p, ev) in [("former", &old, &ev_old), ("default", &new, &ev_new)] {
            let stopped: Vec<String> =
                serde_json::from_value(p.extra["stopped_by"].clone()).unwrap();
            let count = |v: &[f64]| {
                v.iter()
                    .map(|x| format!("{:.3}M", x / 1e6))
                    .collect::<Vec<_>>()
            };
            let photons: Vec<f64> = p
                .source
                .photons
                .clone()
                .unwrap()
                .iter()
                .map(|&n| n as f64)
                .collect();
            let pct = |key: &str| {
                extra_f64s(p, key)
                    .iter()
                    .map(|e| format!("{:.2}", 100.0 * e))
                    .collect::<Vec<_>>()
            };
            rows.push(vec![
                name.to_string(),
                if label == "former" {
                    format!("total-and-profile {FORMER_REL}")
                } else {
                    format!("kernel-factor {rel}")
                },
                triple(&count(&photons)),
                triple(&count(ev)),
                format!("{:.2}", total(ev) / total(&ev_old)),
                triple(&pct("rel_error_kernel_factor")),
                triple(&pct("rel_error_profile")),
                triple(&stopped),
            ]);
            data.insert(
                format!("{name}/{label}"),
                serde_json::json!({
                    "photons": p.source.photons, "events": ev, "stopped_by": stopped,
                    "rel_error_kernel_factor": extra_f64s(p, "rel_error_kernel_factor"),
                    "rel_error_profile": extra_f64s(p, "rel_error_profile"),
                    "total_rd": p.total_rd,
                }),
            );
        }
    }
    check(
        "pipeline-mc",
        "pipeline_mc",
        "the profile stage of kernels and advise for skin1 and marble under the default rule \
         and the former one: photons and events are fixed by the seed; they depend on the \
         tracer and the stopping rules, which no oracle fixes, so they are pinned",
        [(
            "rules".to_string(),
            table(
                &[
                    "material",
                    "rule, target",
                    "photons (r, g, b)",
                    "events (r, g, b)",
                    "events / former",
                    "kernel factor error % (r, g, b)",
                    "profile error % (r, g, b)",
                    "stopped by (r, g, b)",
                ],
                rows,
            ),
        )]
        .into_iter()
        .collect(),
        serde_json::Value::Object(data),
    );
}
