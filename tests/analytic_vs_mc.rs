//! Analytic models against the Monte Carlo reference (same grid), with
//! small photon counts so the whole file runs in seconds. Totals are
//! compared within a stated model tolerance plus 4 reference standard
//! errors; profile shapes by the relative L2 error of r R_d(r) over the
//! range holding 99% of R_d with the reference's own noise removed
//! (`rel_l2_model`). The tolerances state what each model achieves where
//! diffusion holds, and the failures where it does not are asserted too, so
//! a change that hid them would fail.

use ssskit::material::{preset, Channel};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::progress::NoProgress;
use ssskit::report::compare::{compare, Row};

const PHOTONS: u64 = 10_000;

fn rows(material: &str) -> Vec<Row> {
    let mat = preset(material).unwrap();
    let grid = analytic::default_grid(&mat, &Channel::ALL).unwrap();
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(PHOTONS),
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

#[test]
fn models_agree_where_diffusion_holds() {
    // Marble and whole milk: reduced albedo > 0.996. Measured at 1e5
    // photons: dipole totals -0.6..-1.5%, PBD +1.8..+4.5%, Burley = dipole
    // total; L2 (noise removed) PBD < 10%, dipole ~40% (it misses the
    // single-scattering peak at r -> 0 and sits low near the source),
    // Burley 40-70% (its searchlight shape decays far faster than the
    // sigma_tr tail), directional dipole ~40% with totals +21..+29% (its
    // real source at depth D overshoots at normal incidence).
    for material in ["marble", "wholemilk"] {
        let rows = rows(material);
        for ch in Channel::ALL {
            let dip = row(&rows, Model::Dipole, ch);
            total_within(dip, 0.03);
            l2_below(dip, 0.5);
            let pbd = row(&rows, Model::Pbd, ch);
            total_within(pbd, 0.05);
            l2_below(pbd, 0.12);
            let bur = row(&rows, Model::Burley, ch);
            total_within(bur, 0.03);
            l2_below(bur, 0.8);
            let dd = row(&rows, Model::DirectionalDipole, ch);
            total_within(dd, 0.35);
            assert!(
                dd.rel_total_error > 0.15,
                "directional dipole overshoot went away: {dd:?}"
            );
            l2_below(dd, 0.55);
            // PBD, with single scattering, is the best shape of the four.
            assert!(pbd.rel_l2_model < dip.rel_l2_model.min(bur.rel_l2_model));
        }
    }
}

#[test]
fn diffusion_fails_at_low_albedo_and_the_numbers_show_it() {
    // Ketchup green and blue (reduced albedo 0.07 and 0.02): the dipole
    // misses the shape entirely (measured L2 92-94%) and overestimates the
    // total by 15-20%; PBD, whose single-scattering term carries most of
    // the light here, stays within 10% in total and 20% in shape; the
    // directional dipole, without an albedo factor, is off by 25x-90x.
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
    // the (tiny) total by 2.6x-3.5x (measured +165..+254%). The shapes are
    // not asserted: at this photon count the reference's own noise (60-98%
    // L2) dominates.
    // At this photon count only a handful of packets come back from beer
    // (the reference's own standard error is 30-100% of its total), so the
    // claim is checked as "not contradicted at 4 standard errors": the model
    // exceeds 1.5x every total the reference allows.
    let b = rows("beer");
    for ch in Channel::ALL {
        for model in [Model::Dipole, Model::Burley] {
            let r = row(&b, model, ch);
            assert!(
                r.total_model > 1.5 * (r.total_mc - 4.0 * r.total_mc_stderr),
                "{r:?}"
            );
        }
    }
}
