//! The angle-resolved Monte Carlo tallies (exit angle, oblique incidence)
//! against exact half-space values: Chandrasekhar's H-function for an
//! isotropically scattering medium without a boundary (Chandrasekhar 1960,
//! "Radiative Transfer"), and the same medium under a Fresnel boundary of
//! index 1.5 by adding the interface to it (tests/common/half_space.rs).
//! Tolerances are 4 reported standard errors, two-sided; the oracle is
//! itself checked against Chandrasekhar's table and identities, and against
//! the exact totals the other Monte Carlo tests use.

use ssskit::material::{Channel, Material};
use ssskit::profile::mc::{
    angular, simulate_with, Angular, AngularOptions, McConfig, McOptions, PhotonBudget,
};
use ssskit::profile::Profile;
use ssskit::progress::NoProgress;
use std::f64::consts::PI;

mod common;
use common::half_space::{gauss, graded, h_closed, h_iterated, HalfSpace};
use common::mc::{self, within};
use common::EXACT;

const ALBEDO: f64 = 0.9;
const INCIDENCES: [f64; 3] = [30.0, 60.0, 80.0];
const BINS: usize = 9;

fn options(bins: usize, incidence: &[f64]) -> McOptions {
    McOptions {
        angular: Some(AngularOptions {
            angle_bins: bins,
            incidence_deg: incidence.to_vec(),
        }),
        ..McOptions::default()
    }
}

fn run(m: &Material, photons: u64, threads: Option<usize>, o: &McOptions) -> Profile {
    let cfg = McConfig {
        threads,
        ..mc::cfg(photons, Channel::R, None)
    };
    simulate_with(m, &cfg, o, &NoProgress).unwrap()
}

fn angular_of(p: &Profile) -> Angular {
    p.angular().unwrap().expect("angular tables recorded")
}

/// A value published to 4 decimals is exact to half a unit of its last
/// digit.
const FOUR_DECIMALS: f64 = 5e-5;

/// `mc::ALBEDO_09` is printed to 5 decimals: the exact totals are within
/// half a unit of their last digit of it (at n = 1 the adding solution is
/// the H-function's plane albedo, 2.5e-6 from the printed 0.41495).
const FIVE_DECIMALS: f64 = 5e-6;

/// Under the n = 1.5 Fresnel boundary the adding solution gives 0.219919,
/// 1.1e-5 from the printed 0.21993: more than the printing's 5e-6, so the
/// two differ beyond rounding (the adding method's angular quadrature or
/// the printed value's own source); the check holds them to the 4 decimals
/// they share.
const FRESNEL_ADDING: f64 = FOUR_DECIMALS;

/// Six Lambertian shares that sum to 1: six roundings of half an ulp
/// (6.7e-16) at most.
const SIX_TERMS: f64 = 1e-15;

/// MCML's text writes five significant digits: each printed value is within
/// half a unit of its fifth digit, 5e-5 of itself, and so is a sum of
/// positive printed values.
const FIVE_SIGNIFICANT: f64 = 5e-5;

#[test]
fn the_oracle_reproduces_chandrasekhar_and_the_known_totals() {
    // Conservative scattering: Chandrasekhar 1960 tabulates H(1) = 2.9078,
    // and the moments int H = 2, int mu H = 2 / sqrt 3.
    let h1 = h_closed(1.0, 1.0);
    assert!((h1 - 2.9078).abs() < FOUR_DECIMALS, "H(1) = {h1}");
    let rule = graded(0.0, 1.0, 8);
    let m0: f64 = rule.iter().map(|&(m, w)| w * h_closed(1.0, m)).sum();
    let m1: f64 = rule.iter().map(|&(m, w)| w * m * h_closed(1.0, m)).sum();
    assert!((m0 - 2.0).abs() < 1e-6, "alpha_0 = {m0}");
    assert!((m1 - 2.0 / 3f64.sqrt()).abs() < 1e-6, "alpha_1 = {m1}");
    // The closed form agrees with the iteration, and int H = 2 (1 -
    // sqrt(1 - a)) / a, for a < 1.
    for a in [0.5, 0.9, 0.99] {
        let (rule, h) = h_iterated(a);
        for (&(m, _), hv) in rule.iter().zip(&h).step_by(17) {
            let c = h_closed(a, m);
            assert!((c - hv).abs() < 1e-9 * hv, "a = {a}, mu = {m}: {c} vs {hv}");
        }
        let m0: f64 = graded(0.0, 1.0, 8)
            .iter()
            .map(|&(m, w)| w * h_closed(a, m))
            .sum();
        let want = 2.0 * (1.0 - (1.0 - a).sqrt()) / a;
        assert!((m0 - want).abs() < 1e-9, "a = {a}: {m0} vs {want}");
    }
    // The totals of tests/mc_physics.rs, and at eta = 1 the adding solution
    // equals the plane albedo at every incidence.
    for (eta, rd, spec) in mc::ALBEDO_09 {
        let hs = HalfSpace::new(ALBEDO, eta, 1.0);
        let tol = if eta == 1.0 {
            FIVE_DECIMALS
        } else {
            FRESNEL_ADDING
        };
        assert!((hs.total() - rd).abs() < tol, "eta {eta}: {}", hs.total());
        assert!((hs.specular() - spec).abs() < EXACT);
    }
    for t in [0.0f64, 45.0, 80.0] {
        let mu0 = t.to_radians().cos();
        let plane = 1.0 - (1.0 - ALBEDO).sqrt() * h_closed(ALBEDO, mu0);
        let hs = HalfSpace::new(ALBEDO, 1.0, mu0);
        assert!(
            (hs.total() - plane).abs() < 1e-10,
            "{t}: {} vs {plane}",
            hs.total()
        );
    }
    // The Gauss rule integrates x^(2n-1) exactly.
    let s: f64 = gauss(5, 0.0, 2.0).iter().map(|(x, w)| w * x.powi(9)).sum();
    assert!((s - 102.4).abs() < 1e-10, "{s}");
}

/// Every angle-resolved number of a run of `photons` on the albedo-0.9
/// half-space of index `eta` against the oracle, within 4 sigma.
fn check_against_oracle(eta: f64, photons: u64) {
    let m = mc::albedo_09(eta);
    let p = run(&m, photons, None, &options(BINS, &INCIDENCES));
    let a = angular_of(&p);
    let x = a.exit.as_ref().unwrap();
    let e = a.entry.as_ref().unwrap();
    assert_eq!(e.incidence_deg, [0.0, 30.0, 60.0, 80.0]);
    let edges: Vec<f64> = a.theta_edges_deg.iter().map(|d| d.to_radians()).collect();
    let mut zs: Vec<f64> = vec![];
    let mut z = |what: String, v: f64, truth: f64, se: f64| {
        within(v, truth, se, &what);
        zs.push((v - truth) / se);
    };
    let oracles: Vec<HalfSpace> = e
        .incidence_deg
        .iter()
        .map(|t| HalfSpace::new(ALBEDO, eta, t.to_radians().cos()))
        .collect();
    let total0 = oracles[0].total();
    for (k, hs) in oracles.iter().enumerate() {
        let t = e.incidence_deg[k];
        let total = hs.total();
        z(
            format!("eta {eta}, {t} deg: R_d"),
            e.total_rd[0][k],
            total,
            e.total_rd_stderr[0][k],
        );
        assert!((e.specular[0][k] - hs.specular()).abs() < EXACT);
        assert!(e.energy_balance_minus_1[0][k].abs() < 1e-9);
        if k > 0 {
            z(
                format!("eta {eta}, {t} deg: entry factor"),
                e.factor[0][k],
                total / total0,
                e.factor_stderr[0][k],
            );
        }
        for b in 0..BINS {
            let f = hs.fraction(edges[b], edges[b + 1]);
            let share = a.lambert_share[b];
            z(
                format!("eta {eta}, {t} deg, exit bin {b}: exit factor"),
                e.exit_factor[0][k][b],
                f / (total * share),
                e.exit_factor_stderr[0][k][b],
            );
            if k == 0 {
                z(
                    format!("eta {eta}, normal, exit bin {b}: fraction"),
                    x.fraction[0][b],
                    f,
                    x.fraction_stderr[0][b],
                );
            }
        }
    }
    // The standard errors are honest, not only large enough: the mean
    // square deviation in sigma is near 1 (0.25 if they were twice too
    // large, 4 if half).
    let worst = zs.iter().fold(0.0f64, |a, z| a.max(z.abs()));
    let chi2 = zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64;
    eprintln!(
        "eta {eta}: {} checks, largest deviation {worst:.2} sigma, mean square {chi2:.2}",
        zs.len()
    );
    assert!((0.5..2.0).contains(&chi2), "mean square deviation {chi2}");
    // The normal run's table and the exit table are one tally.
    assert_eq!(e.exit_factor[0][0], x.factor[0]);
    assert_eq!(e.total_rd[0][0], p.total_rd[0]);
}

#[test]
fn exit_and_entry_match_the_h_function_without_a_boundary() {
    check_against_oracle(1.0, 400_000);
}

#[test]
fn exit_and_entry_match_the_adding_solution_under_a_fresnel_boundary() {
    check_against_oracle(1.5, 300_000);
}

/// The radius x angle table sums to the radial profile and to the angle
/// bins (every escape is in exactly one cell); the view profile is one
/// column of it; the angular option leaves the normal run untouched, and
/// nothing depends on the thread count.
#[test]
fn the_tables_add_up_and_the_default_run_is_untouched() {
    let m = mc::albedo_09(1.5);
    let o = options(6, &[45.0]);
    let p = run(&m, 40_000, Some(1), &o);
    let a = angular_of(&p);
    let x = a.exit.as_ref().unwrap();
    let areas: Vec<f64> = p
        .r_edges
        .windows(2)
        .map(|w| PI * (w[1] * w[1] - w[0] * w[0]))
        .collect();
    for (i, rd) in p.rd[0].iter().enumerate() {
        let s: f64 = (0..6)
            .map(|b| x.radiance[0][i][b] * a.lambert_share[b])
            .sum();
        assert!(
            (s - rd).abs() <= EXACT * rd.max(f64::MIN_POSITIVE),
            "bin {i}: {s} vs {rd}"
        );
    }
    for b in 0..6 {
        let s: f64 = (0..p.r.len())
            .map(|i| x.radiance[0][i][b] * a.lambert_share[b] * areas[i])
            .sum::<f64>()
            + x.beyond_rmax[0][b];
        assert!((s - x.fraction[0][b]).abs() <= EXACT, "angle bin {b}");
    }
    let total: f64 = x.fraction[0].iter().sum();
    assert!((total - p.total_rd[0]).abs() <= EXACT);
    let shares: f64 = a.lambert_share.iter().sum();
    assert!((shares - 1.0).abs() < SIX_TERMS);
    // pi L / M averages to 1 with the Lambertian weights.
    let mean: f64 = (0..6).map(|b| x.factor[0][b] * a.lambert_share[b]).sum();
    assert!((mean - 1.0).abs() < EXACT, "{mean}");
    // The profile seen along the normal: the first column, and its total
    // R_d x the exit factor of that bin.
    let v = angular::view_profile(&p, 0.0).unwrap();
    v.validate("view").unwrap();
    for i in 0..p.r.len() {
        assert_eq!(v.rd[0][i], x.radiance[0][i][0]);
    }
    let want = p.total_rd[0] * x.factor[0][0];
    assert!((v.total_rd[0] - want).abs() < EXACT * want);
    assert_eq!(
        angular::view_profile(&p, 89.9).unwrap().rd[0][3],
        x.radiance[0][3][5]
    );
    // Same seed: the normal run's numbers do not move when angles are
    // tallied, and two thread counts give the same file.
    let plain = run(&m, 40_000, Some(1), &McOptions::default());
    assert_eq!(plain.rd, p.rd);
    assert_eq!(plain.total_rd, p.total_rd);
    assert_eq!(plain.rd_stderr, p.rd_stderr);
    assert_eq!(plain.extra["energy_balance"], p.extra["energy_balance"]);
    let mut p2 = run(&m, 40_000, Some(2), &o);
    let mut p1 = p.clone();
    p1.elapsed_s = 0.0;
    p2.elapsed_s = 0.0;
    assert_eq!(
        serde_json::to_string(&p1).unwrap(),
        serde_json::to_string(&p2).unwrap()
    );
}

#[test]
fn bad_angular_options_are_refused_naming_the_parameter() {
    let m = mc::albedo_09(1.0);
    let cfg = mc::cfg(1000, Channel::R, None);
    let err = |bins: usize, inc: &[f64]| {
        simulate_with(&m, &cfg, &options(bins, inc), &NoProgress)
            .unwrap_err()
            .to_string()
    };
    assert!(err(0, &[]).contains("angle_bins"));
    assert!(err(901, &[]).contains("invalid angle_bins = 901"));
    assert!(err(1, &[90.0]).contains("invalid incidence_deg = 90"));
    assert!(err(1, &[f64::NAN]).contains("incidence_deg = NaN"));
    assert!(err(1, &[-5.0]).contains("incidence_deg = -5"));
    assert!(err(1, &[30.0, 30.0]).contains("given twice"));
    assert!(err(0, &[1.0; 17]).contains("at most 16"));
    // The radiance table is capped: 640 radial bins x 900 angles is not.
    assert!(err(900, &[]).contains("cells of the radiance table"));
    let sharded = McOptions {
        shard: Some(ssskit::profile::mc::Shard { k: 1, n: 2 }),
        ..options(3, &[])
    };
    let e = simulate_with(
        &m,
        &McConfig {
            budget: PhotonBudget::Fixed(20_000),
            ..cfg.clone()
        },
        &sharded,
        &NoProgress,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not traced in shards"), "{e}");
    // A profile without the tables has no view.
    let plain = simulate_with(&m, &cfg, &McOptions::default(), &NoProgress).unwrap();
    assert!(plain.angular().unwrap().is_none());
    let e = angular::view_profile(&plain, 0.0).unwrap_err().to_string();
    assert!(e.contains("no angle-resolved tallies"), "{e}");
}

/// `simulate` from an .mci file with MCML's na = 6: Rd_a and Rd_ra in the
/// .mco as MCML writes them (MCML 1.2.2 mcmlio.c: WriteRd_a one value a
/// line, WriteRd_ra `%12.4E ` five a line; mcmlgo.c ScaleRdTt: Rd_a over
/// 2 pi da sin(a), Rd_ra over 2 pi (i + 1/2) dr^2 4 pi sin(a) sin(da/2)
/// cos(a)), the view profile and the printed factors; bad values name their
/// flag.
#[test]
fn simulate_writes_the_angular_tables_and_mcml_arrays() {
    // Albedo 0.9 half-space of index 1.5 in MCML units (cm, 1/cm), a grid
    // of 30 x 0.01 cm that loses part of R_d beyond it.
    let mci = "1.0\n1\nh.mco A\n30000\n0.01 0.01\n1 30 6\n1\n1.0\n1.5 1 9 0 1E8\n1.0\n";
    let dir = common::temp_with(&[("h.mci", mci)]);
    let d = dir.path();
    let args = common::args::words(concat!(
        "simulate --mci h.mci --incidence 40,70 --out h.json",
        " --mco h.mco --view-profile v.json"
    ));
    let out = common::ok_in(d, &args);
    assert!(
        out.contains("exit factor pi L / M") && out.contains("entry factor"),
        "{out}"
    );
    let p = Profile::read(&d.join("h.json")).unwrap();
    let a = angular_of(&p);
    assert_eq!(a.angle_bins, 6);
    assert_eq!(a.entry.as_ref().unwrap().incidence_deg, [0.0, 40.0, 70.0]);
    let v = Profile::read(&d.join("v.json")).unwrap();
    assert_eq!(v.rd[0][2], a.exit.as_ref().unwrap().radiance[0][2][0]);
    let text = std::fs::read_to_string(d.join("h.mco")).unwrap();
    assert!(text.contains("1\t30\t6\t# No. of dz, dr, da."), "{text}");
    let section = |tag: &str| -> Vec<String> {
        let start = text.lines().position(|l| l.starts_with(tag)).unwrap();
        text.lines()
            .skip(start + 1)
            .take_while(|l| !l.trim().is_empty())
            .map(String::from)
            .collect()
    };
    let rd_a: Vec<f64> = section("Rd_a")
        .iter()
        .map(|l| l.trim().parse().unwrap())
        .collect();
    let lines = section("Rd_ra");
    assert!(lines.iter().all(|l| l.len() == 5 * 13), "{lines:?}");
    assert_eq!(lines.len(), 30 * 6 / 5);
    let rd_ra: Vec<f64> = lines
        .iter()
        .flat_map(|l| l.split_whitespace().map(|x| x.parse::<f64>().unwrap()))
        .collect();
    assert_eq!((rd_a.len(), rd_ra.len()), (6, 180));
    // MCML's own normalisation: Rd = sum Rd_a 2 pi da sin(a), and Rd_a is
    // the sum over r of Rd_ra x annulus x 4 pi sin(a) sin(da/2) cos(a) /
    // (2 pi da sin(a)); five significant digits are written.
    let (dr, da) = (0.01, PI / 12.0);
    let a_mid = |ia: usize| (ia as f64 + 0.5) * da;
    let total: f64 = (0..6)
        .map(|ia| rd_a[ia] * 2.0 * PI * da * a_mid(ia).sin())
        .sum();
    assert!((total - p.total_rd[0]).abs() < FIVE_SIGNIFICANT * p.total_rd[0]);
    for ia in 0..6 {
        let t = a_mid(ia);
        let s: f64 = (0..30)
            .map(|ir| {
                rd_ra[ir * 6 + ia]
                    * 2.0
                    * PI
                    * (ir as f64 + 0.5)
                    * dr
                    * dr
                    * 4.0
                    * PI
                    * t.sin()
                    * (da / 2.0).sin()
                    * t.cos()
            })
            .sum();
        let want = rd_a[ia] * 2.0 * PI * da * t.sin();
        assert!(
            (s - want).abs() < FIVE_SIGNIFICANT * want,
            "angle {ia}: {s} vs {want}"
        );
    }
    let beyond = p.rd_beyond_rmax().unwrap().unwrap()[0];
    assert!(
        beyond > 0.01 * p.total_rd[0],
        "the grid should lose some R_d"
    );
    // Bad values name their flag; nothing is written.
    let fails = |extra: &[&str], needle: &str| {
        let mut args = vec![
            "simulate",
            "--material",
            "skin1",
            "--photons",
            "1000",
            "--out",
            "bad.json",
        ];
        args.extend(extra);
        common::fails_with_in(d, &args, &[needle]);
        assert!(!d.join("bad.json").exists());
    };
    fails(&["--angle-bins", "901"], "--angle-bins: invalid value 901");
    fails(&["--incidence", "30,95"], "--incidence: invalid value 95");
    fails(
        &["--view-profile", "v2.json"],
        "--view-profile needs exit-angle bins",
    );
    fails(
        &[
            "--angle-bins",
            "3",
            "--view-profile",
            "v2.json",
            "--view-angle",
            "91",
        ],
        "--view-angle: invalid value 91",
    );
    fails(
        &["--angle-bins", "3", "--shard", "1/2"],
        "angle-resolved tallies",
    );
    std::fs::write(d.join("z.mci"), mci.replace("1 30 6", "1 30 0")).unwrap();
    common::fails_with_in(d, &["simulate", "--mci", "z.mci"], &["na", "must be >= 1"]);
}
