//! Analytic models against the Monte Carlo reference (same grid), with
//! small photon counts so the whole file runs in seconds. Totals are
//! compared as (model - mc) / mc with the reference's standard error;
//! profile shapes by the relative L2 error of r R_d(r) over the range
//! holding 99% of R_d with the reference's own noise removed
//! (`rel_l2_model`). What the physics predicts is asserted (photon beam
//! diffusion, with single scattering, has the best shape; diffusion fails
//! at low albedo); the measured numbers themselves are pinned in the
//! record `analytic-vs-mc` (docs/analytic.md shows it), so a change that
//! moved them fails too.

use ssskit::material::{preset, Channel};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::progress::NoProgress;
use ssskit::report::eval::compare::profile::{compare, Row};

mod common;
use common::measured;

const PHOTONS: u64 = 10_000;

fn rows(material: &str) -> Vec<Row> {
    rows_with(material, PHOTONS)
}

fn rows_with(material: &str, photons: u64) -> Vec<Row> {
    let mat = preset(material).unwrap();
    let grid = analytic::default_grid(&mat, &Channel::ALL).unwrap();
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(photons),
        seed: 7,
        threads: None,
        channels: Channel::ALL.to_vec(),
        grid: Some(grid.clone()),
    };
    let reference = simulate(&mat, &cfg, &NoProgress).unwrap();
    let mut out = Vec::new();
    for model in Model::ALL {
        let p = analytic::profile(&mat, model, &grid, &Options::default()).unwrap();
        out.extend(compare(&p, &reference, 0.0).unwrap());
    }
    out
}

fn row(rows: &[Row], model: Model, ch: Channel) -> &Row {
    rows.iter()
        .find(|r| r.model == model.name() && r.channel == ch)
        .unwrap()
}

/// |model - mc| / mc within `tol` plus 4 reference standard errors.
fn total_within(r: &Row, tol: f64) {
    let sigma = r.total_mc_stderr / r.total_mc;
    assert!(
        r.rel_total_error.abs() <= tol + 4.0 * sigma,
        "{} {} {}: total error {:.4} > {tol} + 4 x {sigma:.4}",
        r.material,
        r.channel.name(),
        r.model,
        r.rel_total_error
    );
}

fn l2_below(r: &Row, tol: f64) {
    assert!(
        r.rel_l2_model <= tol,
        "{} {} {}: L2 {:.3} (noise {:.3}, noise removed {:.3}) > {tol}",
        r.material,
        r.channel.name(),
        r.model,
        r.rel_l2_error,
        r.mc_noise_l2,
        r.rel_l2_model
    );
}

/// (model - mc) / mc in standard errors of the reference.
fn sigmas(r: &Row) -> f64 {
    (r.total_model - r.total_mc) / r.total_mc_stderr
}

/// One record row: material, model, channel, total error (in reference
/// standard errors), shape error with the reference's noise removed.
fn record_row(r: &Row) -> Vec<String> {
    vec![
        r.material.clone(),
        r.model.clone(),
        r.channel.name().to_string(),
        format!(
            "{:+.1}% ({:+.1} sigma)",
            100.0 * r.rel_total_error,
            sigmas(r)
        ),
        format!("{:.1}%", 100.0 * r.rel_l2_model),
    ]
}

fn record_data(r: &Row) -> serde_json::Value {
    serde_json::json!({
        "material": r.material,
        "model": r.model,
        "channel": r.channel.name(),
        "total_model": r.total_model,
        "total_mc": r.total_mc,
        "total_mc_stderr": r.total_mc_stderr,
        "rel_l2_model": r.rel_l2_model,
    })
}

const HEADER: [&str; 5] = [
    "material",
    "model",
    "channel",
    "total, (model - MC) / MC",
    "shape, L2 (MC noise removed)",
];

/// Where diffusion holds (marble and whole milk, reduced albedo > 0.996):
/// photon beam diffusion, the only model with single scattering, has the
/// best shape of the four in every channel; the directional dipole, whose
/// real source sits at depth D with no albedo factor, overshoots the total
/// by more than 4 standard errors. Every number is pinned in the record.
#[test]
fn models_agree_where_diffusion_holds() {
    let (mut table, mut data) = (Vec::new(), Vec::new());
    for material in ["marble", "wholemilk"] {
        let rows = rows(material);
        for ch in Channel::ALL {
            let pbd = row(&rows, Model::Pbd, ch);
            let dip = row(&rows, Model::Dipole, ch);
            let bur = row(&rows, Model::Burley, ch);
            let dd = row(&rows, Model::DirectionalDipole, ch);
            assert!(
                pbd.rel_l2_model < dip.rel_l2_model.min(bur.rel_l2_model).min(dd.rel_l2_model),
                "{material} {ch:?}: PBD is not the best shape: {pbd:?}"
            );
            assert!(
                sigmas(dd) > 4.0,
                "directional dipole overshoot went away: {dd:?}"
            );
            for r in [dip, pbd, bur, dd] {
                table.push(record_row(r));
                data.push(record_data(r));
            }
        }
    }
    let mut ketchup_table = Vec::new();
    for r in rows("ketchup").iter().filter(|r| r.channel != Channel::R) {
        ketchup_table.push(record_row(r));
        data.push(record_data(r));
    }
    let beer = beer_rows();
    let mut beer_table = Vec::new();
    for r in &beer {
        beer_table.push(record_row(r));
        data.push(record_data(r));
    }
    measured::check(
        "analytic-vs-mc",
        "analytic_vs_mc",
        "Monte Carlo references of 1e4 photons per channel (beer: 4e6), seed 7, on \
         the default grid; no closed form gives these errors, so they are pinned: a \
         change of a model, of the tracer or of the comparison moves them",
        [
            ("diffusion".to_string(), measured::table(&HEADER, table)),
            (
                "ketchup".to_string(),
                measured::table(&HEADER, ketchup_table),
            ),
            ("beer".to_string(), measured::table(&HEADER, beer_table)),
        ]
        .into_iter()
        .collect(),
        serde_json::Value::Array(data),
    );
}

const BEER_PHOTONS: u64 = 4_000_000;

/// Beer's dipole and Burley rows against a reference long enough that its
/// 4 standard errors are below half its total in every channel.
fn beer_rows() -> Vec<Row> {
    let b = rows_with("beer", BEER_PHOTONS);
    b.into_iter()
        .filter(|r| r.model == Model::Dipole.name() || r.model == Model::Burley.name())
        .collect()
}

#[test]
fn diffusion_fails_at_low_albedo_and_the_numbers_show_it() {
    // Ketchup green and blue (reduced albedo 0.07 and 0.02): the dipole
    // misses the shape and overestimates the total; photon beam diffusion,
    // whose single-scattering term carries most of the light here, stays
    // within 10% in total and 20% in shape; the directional dipole, without
    // an albedo factor, is off by more than 10x (the record analytic-vs-mc
    // holds the numbers).
    let k = rows("ketchup");
    for ch in [Channel::G, Channel::B] {
        let dip = row(&k, Model::Dipole, ch);
        assert!(dip.rel_l2_model > 0.8, "{dip:?}");
        assert!(dip.rel_total_error > 0.05, "{dip:?}");
        let pbd = row(&k, Model::Pbd, ch);
        total_within(pbd, 0.1);
        l2_below(pbd, 0.2);
        let dd = row(&k, Model::DirectionalDipole, ch);
        assert!(dd.rel_total_error > 10.0, "{dd:?}");
    }
    // Wine green/blue do not scatter at all: Monte Carlo returns nothing,
    // the diffusion models give exactly 0, the directional dipole ~0.14.
    let w = rows("wine");
    for ch in [Channel::G, Channel::B] {
        assert_eq!(row(&w, Model::Pbd, ch).total_mc, 0.0);
        for model in [Model::Dipole, Model::Pbd, Model::Burley] {
            assert_eq!(row(&w, model, ch).total_model, 0.0);
        }
        assert!(row(&w, Model::DirectionalDipole, ch)
            .rel_total_error
            .is_infinite());
    }
    // Beer (reduced albedo <= 0.002): the dipole and Burley overestimate
    // the (tiny) total (the record holds by how much). The reference is
    // long enough that the claim can fail: its 4 standard errors are below
    // half its total, and the model must exceed 1.5x the largest total the
    // reference allows.
    let beer = beer_rows();
    assert_eq!(beer.len(), 6);
    for r in &beer {
        assert!(
            4.0 * r.total_mc_stderr < 0.5 * r.total_mc,
            "reference too noisy: {r:?}"
        );
        assert!(
            r.total_model > 1.5 * (r.total_mc + 4.0 * r.total_mc_stderr),
            "{r:?}"
        );
    }
}
