//! Analytic profile models: totals, energy, stability at the edges of the
//! parameter space (library level; the CLI is in analytic_cli.rs).

use proptest::prelude::*;
use ssskit::material::{preset, Channel, Layer, Material, Medium};
use ssskit::numerics::plane_total;
use ssskit::profile::analytic::{self, ChannelModel, Model, Options};
use ssskit::profile::fresnel::FresnelMode;
use ssskit::profile::RadialGrid;

fn half_space(sigma_a: f64, sigma_s: f64, g: f64, eta: f64) -> Material {
    Material {
        name: "test".into(),
        eta_above: 1.0,
        eta_below: 1.0,
        layers: vec![Layer {
            sigma_a: [sigma_a; 3],
            sigma_s: [sigma_s; 3],
            g: [g; 3],
            eta,
            thickness: None,
        }],
    }
}

fn scale(m: &Medium) -> f64 {
    m.mfp().min(1.0 / m.sigma_t())
}

/// Small grid in units of the medium's MFP so every case stays fast.
fn small_grid(mat: &Material) -> RadialGrid {
    let mfp = mat.top(Channel::R).mfp();
    RadialGrid::uniform(mfp / 5.0, 20.0 * mfp).unwrap()
}

fn assert_valid(p: &ssskit::profile::Profile, what: &str) {
    p.validate(what).unwrap();
    for row in &p.rd {
        assert!(row.iter().all(|v| v.is_finite() && *v >= 0.0), "{what}");
    }
    assert!(
        p.total_rd.iter().all(|v| v.is_finite() && *v >= 0.0),
        "{what}"
    );
}

#[test]
fn closed_form_totals_equal_quadrature_of_the_profile() {
    // Dipole (Jensen eq. 8) and normalized diffusion (normalised to A) have
    // closed-form totals; `plane_total` of their profiles must give the same
    // number to 1e-6, including spectralon (sigma_a = 0: an r^-3 tail that
    // the quadrature's tail term must capture).
    for name in ["marble", "skin1", "ketchup", "spectralon", "coffee"] {
        let mat = preset(name).unwrap();
        for ch in Channel::ALL {
            let m = mat.top(ch);
            for mode in [FresnelMode::Fit, FresnelMode::Exact] {
                for model in [Model::Dipole, Model::Burley] {
                    let cm = ChannelModel::new(model, &m, mode, 0.97).unwrap();
                    let (exact, _) = cm.total(&m);
                    let num = plane_total(|r| cm.rd(r), scale(&m), 1.0 / m.sigma_tr());
                    assert!(
                        (num - exact).abs() < 1e-6 * exact.max(1e-3),
                        "{name} {ch:?} {model:?} {mode:?}: {num} vs {exact}"
                    );
                }
            }
        }
    }
}

#[test]
fn diffusion_models_conserve_energy_without_absorption() {
    // Spectralon (sigma_a = 0): every photon that enters comes back, so the
    // total per entering photon is 1. The dipole's closed form gives exactly
    // 1; PBD's beam quadrature overshoots by 3.5% (measured 1.035); the
    // directional dipole at normal incidence overshoots by 24% (measured
    // 1.240), a property of the published model, which places the real
    // source at depth D and has no albedo factor.
    let mat = preset("spectralon").unwrap();
    let m = mat.top(Channel::G);
    let total = |model| {
        let cm = ChannelModel::new(model, &m, FresnelMode::Exact, 1.0).unwrap();
        cm.total(&m).0
    };
    assert!((total(Model::Dipole) - 1.0).abs() < 1e-12);
    assert!((total(Model::Burley) - 1.0).abs() < 1e-12);
    let pbd = total(Model::Pbd);
    assert!((pbd - 1.035).abs() < 0.01, "pbd {pbd}");
    let dd = total(Model::DirectionalDipole);
    assert!((dd - 1.24).abs() < 0.02, "directional dipole {dd}");
}

#[test]
fn entry_transmission_scales_every_model() {
    let m = preset("skin1").unwrap().top(Channel::R);
    for model in Model::ALL {
        let a = ChannelModel::new(model, &m, FresnelMode::Fit, 1.0).unwrap();
        let b = ChannelModel::new(model, &m, FresnelMode::Fit, 0.5).unwrap();
        for r in [0.01, 0.3, 3.0] {
            // Burley's shape depends on A, so only its total scales exactly.
            if model != Model::Burley {
                assert!(
                    (b.rd(r) - 0.5 * a.rd(r)).abs() <= 1e-12 * a.rd(r),
                    "{model:?}"
                );
            }
        }
        assert!((b.total(&m).0 - 0.5 * a.total(&m).0).abs() < 1e-9 * a.total(&m).0.max(1e-9));
    }
}

#[test]
fn profile_records_source_and_keeps_singular_bins_finite() {
    let mat = preset("marble").unwrap();
    let grid = analytic::default_grid(&mat, &Channel::ALL).unwrap();
    for model in Model::ALL {
        let p = analytic::profile(&mat, model, &grid, &Options::default()).unwrap();
        assert_valid(&p, model.name());
        assert_eq!(p.source.kind, "analytic");
        assert_eq!(p.source.model.as_deref(), Some(model.name()));
        assert!(p.rd_stderr.is_none());
        assert!((p.specular[0] - 0.04).abs() < 1e-12);
        assert!(p.source.params["channels"]["g"].is_object());
        // The tabulated part can not exceed the whole-plane total.
        for c in 0..3 {
            assert!(
                p.tabulated_total(c) <= p.total_rd[c] * (1.0 + 1e-6),
                "{model:?}"
            );
        }
    }
}

#[test]
fn layered_and_finite_materials_are_refused() {
    let mut mat = half_space(0.1, 1.0, 0.0, 1.3);
    mat.layers[0].thickness = Some(1.0);
    let grid = small_grid(&mat);
    let e = analytic::profile(&mat, Model::Dipole, &grid, &Options::default()).unwrap_err();
    assert!(e.to_string().contains("semi-infinite"), "{e}");
}

#[test]
fn fresnel_fit_outside_its_range_is_a_clear_error() {
    // eta = 3: the fit gives a negative C_phi. Exact moments work.
    let mat = half_space(0.01, 1.0, 0.0, 3.0);
    let grid = small_grid(&mat);
    let e = analytic::profile(&mat, Model::Pbd, &grid, &Options::default()).unwrap_err();
    assert!(e.to_string().contains("exact moments"), "{e}");
    let opts = Options {
        fresnel: FresnelMode::Exact,
        ..Options::default()
    };
    for model in Model::ALL {
        assert_valid(
            &analytic::profile(&mat, model, &grid, &opts).unwrap(),
            "eta 3",
        );
    }
}

#[test]
fn edge_cases_give_finite_non_negative_profiles() {
    let cases = [
        ("albedo -> 0", half_space(1.0, 1e-9, 0.0, 1.3)),
        ("albedo = 0", half_space(1.0, 0.0, 0.0, 1.3)),
        ("albedo -> 1", half_space(1e-9, 1.0, 0.0, 1.3)),
        ("sigma_a = 0", half_space(0.0, 1.0, 0.0, 1.3)),
        ("g = 0.99", half_space(0.01, 10.0, 0.99, 1.3)),
        ("g = -0.99", half_space(0.01, 10.0, -0.99, 1.3)),
        ("eta = 1", half_space(0.01, 1.0, 0.0, 1.0)),
        ("eta < 1", half_space(0.01, 1.0, 0.5, 0.7)),
    ];
    for (what, mat) in cases {
        let grid = small_grid(&mat);
        for mode in [FresnelMode::Fit, FresnelMode::Exact] {
            let opts = Options {
                fresnel: mode,
                channels: vec![Channel::R],
            };
            for model in Model::ALL {
                match analytic::profile(&mat, model, &grid, &opts) {
                    Ok(p) => assert_valid(&p, &format!("{what} {model:?} {mode:?}")),
                    // Below eta = 1 Jensen's F_dr fit is -1.2 (A < 0): the
                    // dipole, and normalized diffusion built on its total,
                    // refuse it. Nothing else here may refuse (eta = 1 is
                    // inside every fit's range).
                    Err(e)
                        if what == "eta < 1"
                            && mode == FresnelMode::Fit
                            && matches!(model, Model::Dipole | Model::Burley) =>
                    {
                        assert!(e.to_string().contains("F_dr"), "{e}");
                        continue;
                    }
                    Err(e) => panic!("{what} {model:?} {mode:?}: {e}"),
                }
                let m = mat.top(Channel::R);
                let cm = ChannelModel::new(model, &m, mode, 1.0).unwrap();
                for r in [0.0, 1e-12, 1e9] {
                    let v = cm.rd(r);
                    assert!(v.is_finite() && v >= 0.0, "{what} {model:?} r={r}: {v}");
                }
                // sigma_a = 0 leaves an r^-3 tail: tiny, not zero.
                assert!(cm.rd(1e9) < 1e-20, "{what} {model:?}");
            }
        }
    }
}

#[test]
fn no_scattering_gives_zero_except_the_directional_dipole() {
    // Wine green/blue has sigma_s = 0: nothing can come back. Dipole, PBD
    // and Burley give 0; the directional dipole has no albedo factor and
    // keeps its real source as alpha' -> 0 (d_e -> inf), giving ~0.14: the
    // documented failure. Its alpha' = 0 value is the limit of small alpha'.
    let wine = preset("wine").unwrap();
    let m = wine.top(Channel::G);
    for model in [Model::Dipole, Model::Pbd, Model::Burley] {
        let cm = ChannelModel::new(model, &m, FresnelMode::Fit, 1.0).unwrap();
        assert_eq!(cm.total(&m).0, 0.0, "{model:?}");
    }
    let dd = |ss: f64| {
        let m = Medium { sigma_s: ss, ..m };
        let cm = ChannelModel::new(Model::DirectionalDipole, &m, FresnelMode::Fit, 1.0).unwrap();
        cm.total(&m).0
    };
    assert!(dd(0.0) > 0.1);
    assert!((dd(0.0) - dd(1e-10)).abs() < 1e-3 * dd(0.0));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn any_valid_half_space_gives_finite_output_or_a_clear_error(
        sigma_a in prop_oneof![Just(0.0), 1e-6f64..10.0],
        sigma_s in prop_oneof![Just(0.0), 1e-6f64..100.0],
        g in -0.99f64..0.99,
        eta in 0.5f64..2.5,
        exact in any::<bool>(),
    ) {
        prop_assume!(sigma_a + sigma_s > 0.0);
        let mat = half_space(sigma_a, sigma_s, g, eta);
        let grid = small_grid(&mat);
        let opts = Options {
            fresnel: if exact { FresnelMode::Exact } else { FresnelMode::Fit },
            channels: vec![Channel::G],
        };
        for model in Model::ALL {
            match analytic::profile(&mat, model, &grid, &opts) {
                Ok(p) => {
                    p.validate("proptest").unwrap();
                    // Physically <= 1, but outside diffusion's domain the
                    // models overshoot (PBD reaches 1.22 at eta = 0.5,
                    // g = -0.94, no absorption: its single scattering is
                    // counted on top of diffusion). 2 only catches blow-ups.
                    prop_assert!(p.total_rd[0] <= 2.0, "{model:?} total {}", p.total_rd[0]);
                }
                Err(e) => {
                    // Only the fits refuse, and they say what to do.
                    prop_assert!(!exact, "exact mode failed: {e}");
                    prop_assert!(e.to_string().contains("exact moments"), "{e}");
                }
            }
        }
    }
}
