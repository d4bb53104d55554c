//! `ssskit engine --engine blender` against Blender's own chains,
//! re-implemented here from Blender's source, not from ssskit's code:
//!
//! - Cycles 4.x (blender/cycles at v4.5.0): src/kernel/svm/closure.h, the
//!   principled BSDF: bssrdf weight = min(base_color, 1) x
//!   subsurface_weight x weight, radius = max(subsurface_radius x
//!   subsurface_scale, 0); src/kernel/closure/bssrdf.h,
//!   bssrdf_setup_radius: radius *= 0.25 x M_1_PI_F for
//!   CLOSURE_BSSRDF_BURLEY_ID, then bssrdf_burley_eval(d = radius, r),
//!   the albedo already in the weight;
//! - Cycles 2.93 (v2.93.0): src/kernel/svm/svm_closure.h, radius =
//!   subsurface_radius x subsurface, albedo = subsurface_color (mixed with
//!   the base colour by subsurface, all of it at 1); bssrdf.h
//!   bssrdf_burley_setup: d = 0.25 x M_1_PI_F x radius /
//!   bssrdf_burley_fitting(A), fitting = 1.9 - A + 3.5 (A - 0.8)^2;
//! - EEVEE (blender/blender, draw/engines/eevee_next):
//!   gpu_shader_material_principled.glsl, sss_radius = subsurface_radius x
//!   subsurface_scale and colour = weight x clamped base colour;
//!   eevee_subsurface_convolve_comp.glsl, albedo = colour / max(colour),
//!   d = burley_setup(radius, albedo) (eevee_shader_shared.hh: 0.25 x
//!   m_1_pi x radius / (1.9 - A + 3.5 (A - 0.8)^2)).

mod engine_support;
use engine_support::*;

/// The Christensen-Burley chain is what this file checks; the default for
/// Cycles is Random Walk (tests/engine_blender_walk.rs).
const BURLEY: [&str; 2] = ["--subsurface-method", "christensen-burley"];
use serde_json::{Map, Value};
use std::f64::consts::PI;

fn burley_fitting(a: f64) -> f64 {
    1.9 - a + 3.5 * (a - 0.8) * (a - 0.8)
}

#[derive(Clone, Copy, PartialEq)]
enum Convention {
    Cycles4,
    Cycles293,
    Eevee,
}

fn blender_chain(p: &Map<String, Value>, units_per_mm: f64, conv: Convention) -> Rendered {
    let (albedo, radius, s) = match conv {
        Convention::Cycles293 => {
            assert_eq!(num(p, "Subsurface"), 1.0);
            let colour = rgb(p, "Subsurface Color");
            let radius = rgb(p, "Subsurface Radius").map(|r| r * num(p, "Subsurface"));
            (colour, radius, colour.map(burley_fitting))
        }
        _ => {
            assert_eq!(num(p, "Subsurface Weight"), 1.0);
            let base = rgb(p, "Base Color").map(|b| b.clamp(0.0, 1.0));
            let scale = num(p, "Subsurface Scale");
            let radius = rgb(p, "Subsurface Radius").map(|r| (r * scale).max(0.0));
            let s = if conv == Convention::Eevee {
                let max = base.into_iter().fold(1e-6, f64::max);
                base.map(|b| burley_fitting(b / max))
            } else {
                [1.0; 3]
            };
            (base, radius, s)
        }
    };
    Rendered {
        albedo,
        d_mm: std::array::from_fn(|c| 0.25 * (1.0 / PI) * radius[c] / s[c] / units_per_mm),
    }
}

fn assert_inside_the_sockets(what: &str, p: &Map<String, Value>) {
    for (k, hi) in [
        ("Base Color", 1.0),
        ("Subsurface Color", 1.0),
        ("Subsurface Radius", 100.0),
    ] {
        if p.contains_key(k) {
            for x in rgb(p, k) {
                assert!((0.0..=hi).contains(&x), "{what}: {k} = {:?}", rgb(p, k));
            }
        }
    }
    if p.contains_key("Subsurface Scale") {
        let s = num(p, "Subsurface Scale");
        assert!((0.0..=10.0).contains(&s), "{what}: Subsurface Scale {s}");
    }
    assert_eq!(p["Subsurface Method"], "Christensen-Burley");
}

#[test]
fn printed_values_through_cycles_4_reproduce_the_reported_error() {
    for m in MATERIALS {
        let file = format!("profiles/reference/{m}.json");
        let (fit, _) = engine_json(&file, "blender", &BURLEY);
        assert!(fit["version"]
            .as_str()
            .unwrap()
            .starts_with("Blender 4.0 to 5.0, Cycles"));
        let p = params(&fit);
        assert_inside_the_sockets(m, p);
        // The hex field is the linear Base Color in sRGB.
        let from_hex = hex_decode(p["Base Color hex"].as_str().unwrap());
        for c in 0..3 {
            assert!(
                (from_hex[c] - rgb(p, "Base Color")[c]).abs() < 0.01,
                "{m}: {from_hex:?}"
            );
        }
        check_against_report(
            &format!("blender 4 {m}"),
            &fit,
            &blender_chain(p, 0.001, Convention::Cycles4),
            &reference(m),
        );
    }
}

#[test]
fn printed_values_through_cycles_2_93_and_eevee_reproduce_the_reported_error() {
    for (version, conv) in [
        ("2.93", Convention::Cycles293),
        ("eevee", Convention::Eevee),
    ] {
        for m in MATERIALS {
            let file = format!("profiles/reference/{m}.json");
            let (fit, _) = engine_json(
                &file,
                "blender",
                &[BURLEY[0], BURLEY[1], "--engine-version", version],
            );
            let p = params(&fit);
            assert_inside_the_sockets(m, p);
            check_against_report(
                &format!("blender {version} {m}"),
                &fit,
                &blender_chain(p, 0.001, conv),
                &reference(m),
            );
        }
    }
}

/// The same values typed into Cycles 4 and 2.93 give different profiles:
/// 4.x dropped the albedo fit s(A), so the 4.x radius is s(A) times
/// shorter for the same d.
#[test]
fn cycles_4_and_2_93_radii_differ_by_the_albedo_fit() {
    let (new, _) = engine_json("profiles/reference/skin1.json", "blender", &BURLEY);
    let (old, _) = engine_json(
        "profiles/reference/skin1.json",
        "blender",
        &[BURLEY[0], BURLEY[1], "--engine-version", "2.93"],
    );
    let (pn, po) = (params(&new), params(&old));
    let radius_new = rgb(pn, "Subsurface Radius").map(|r| r * num(pn, "Subsurface Scale"));
    let radius_old = rgb(po, "Subsurface Radius");
    let colour = rgb(po, "Subsurface Color");
    for c in 0..3 {
        let ratio = radius_old[c] / radius_new[c];
        assert!(
            (ratio / burley_fitting(colour[c]) - 1.0).abs() < 2e-3,
            "channel {c}: ratio {ratio}, s(A) {}",
            burley_fitting(colour[c])
        );
    }
}

/// A scene in millimetres: Subsurface Scale would exceed its socket's 10,
/// so 10 is printed and the radius scaled up instead.
#[test]
fn subsurface_scale_above_its_socket_moves_into_the_radius() {
    let (fit, text) = engine_json(
        "profiles/reference/marble.json",
        "blender",
        &[BURLEY[0], BURLEY[1], "--units-per-mm", "1"],
    );
    let p = params(&fit);
    assert_inside_the_sockets("marble mm", p);
    assert_eq!(num(p, "Subsurface Scale"), 10.0);
    assert!(rgb(p, "Subsurface Radius")[0] > 1.0);
    assert!(text.contains("warning: Subsurface Scale"), "{text}");
    check_against_report(
        "blender marble mm",
        &fit,
        &blender_chain(p, 1.0, Convention::Cycles4),
        &reference("marble"),
    );
}

/// A Base Color above 1 (9.9 was written) prints as 1, the most Cycles
/// uses (`clamped_base_color`).
#[test]
fn params_clamp_the_base_color() {
    use ssskit::engine::{blender, Engine, Scene};
    let b = burley::with_albedo([9.9, 0.5, 0.2]);
    for v in blender::VERSIONS {
        let printed = blender::params(&b, Scene::native(Engine::Blender), v);
        assert_inside_the_sockets(v.key, &printed.params);
    }
}

/// Cycles' Christensen-Burley closure renders the profile cut off at 16 d
/// and renormalised: blender/cycles v5.0.0, src/kernel/closure/bssrdf.h,
/// `bssrdf_eval` returns `bssrdf_burley_pdf(d, r)` =
/// `bssrdf_burley_eval(d, r)` / BURLEY_TRUNCATE_CDF, and
/// `bssrdf_burley_eval` is 0 for r >= BURLEY_TRUNCATE d (16 d); the
/// constant BURLEY_TRUNCATE_CDF = 0.9963790093708328 is copied from there.
/// EEVEE's pass has no such cut. Cycles 5.0.1's render agrees with the cut
/// profile, not with the whole one (docs/engines.md, scripts/engine-cycles).
#[test]
fn cycles_burley_is_cut_at_16_d_and_renormalised() {
    use ssskit::engine::burley::Burley;
    use ssskit::profile::RadialGrid;
    const BURLEY_TRUNCATE_CDF: f64 = 0.9963790093708328;
    // Sums of bin averages times areas: quadrature to about 1e-9.
    const SUM_TOL: f64 = 1e-7;
    for (version, cut) in [("4", Some(16.0)), ("2.93", Some(16.0)), ("eevee", None)] {
        let (fit, _) = engine_json(
            "profiles/reference/skin1.json",
            "blender",
            &[BURLEY[0], BURLEY[1], "--engine-version", version],
        );
        assert_eq!(
            fit["rendered"]["truncate_d"].as_f64(),
            cut,
            "blender {version}: {}",
            fit["rendered"]
        );
    }
    let b = Burley {
        albedo: [0.4, 0.4, 0.4],
        d_mm: [1.0, 1.0, 1.0],
        truncate_d: Some(16.0),
    };
    let whole = Burley {
        truncate_d: None,
        ..b.clone()
    };
    // The cut (16 mm) falls inside a bin, 0.07 mm wide.
    let grid = RadialGrid {
        edges: (0..=600).map(|i| i as f64 * 0.07).collect(),
    };
    let (cut, all) = (b.bins(0, &grid), whole.bins(0, &grid));
    let mass = |v: &[f64]| -> f64 {
        v.iter()
            .zip(grid.edges.windows(2))
            .map(|(x, e)| x * PI * (e[1] * e[1] - e[0] * e[0]))
            .sum()
    };
    assert!((mass(&cut) - 0.4).abs() < SUM_TOL * 0.4, "{}", mass(&cut));
    for (i, e) in grid.edges.windows(2).enumerate() {
        if e[0] >= 16.0 {
            assert_eq!(cut[i], 0.0, "bin {i} at {} mm", e[0]);
        } else if e[1] <= 16.0 {
            let ratio = cut[i] / all[i] * BURLEY_TRUNCATE_CDF;
            assert!((ratio - 1.0).abs() < 1e-9, "bin {i}: {ratio}");
        }
    }
}
