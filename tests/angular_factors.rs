//! The angular entry and exit factors: their node values against the exact
//! half-space (Chandrasekhar's H-function without a boundary, the adding
//! solution under a Fresnel boundary; tests/common/half_space.rs), the
//! shader header's lookups run on the GPU against the library's, the
//! kernel file carrying them, and their effect on a path-traced sphere.

mod common;

use common::half_space::HalfSpace;
use common::mc::{material, within};
use common::{fails_with, ok, p, read_json};
use ssskit::kernel::angular::{lookup, node_mu, simulate_factors, AngularFactors, NODES};
use ssskit::kernel::emit::{emit, Lang};
use ssskit::kernel::KernelFile;
use ssskit::progress::NoProgress;

const ALBEDOS: [f64; 3] = [0.95, 0.8, 0.5];

fn half_space(eta: f64) -> ssskit::material::Material {
    material(&format!(
        "unit = \"mm\"\nsigma_a = [{}, {}, {}]\nsigma_s = [{}, {}, {}]\neta = {eta}\n",
        1.0 - ALBEDOS[0],
        1.0 - ALBEDOS[1],
        1.0 - ALBEDOS[2],
        ALBEDOS[0],
        ALBEDOS[1],
        ALBEDOS[2]
    ))
}

/// Upper bound of the mean square deviation (standard errors squared) of
/// the real tables: not twice too small errors (0.25 would be half).
const MAX_CHI2: f64 = 2.5;
/// Mean square deviation a broken table (a factor left at 1, or inverted)
/// must reach for the oracle to tell it from the real one: four times
/// [`MAX_CHI2`], so that the check below fails it whatever the run's
/// noise (the exit table without a boundary, the nearest to Lambertian,
/// is the hardest case).
const BROKEN_MIN_CHI2: f64 = 4.0 * MAX_CHI2;

/// Every node of both tables within 4 standard errors of the exact value:
/// entry R(mu) / R(1) at the node's incidence (89 degrees for mu = 0), exit
/// the Lambertian-weighted mean of pi L / M over mu +- 1/16, i.e. the
/// interval's share of R_d over its Lambertian share. The same oracle
/// tells a factor left at 1 or inverted (1 / f) from the real one, in each
/// table: their mean square deviations are [`BROKEN_MIN_CHI2`] or more.
fn check_against_half_space(eta: f64) {
    let f = simulate_factors(&half_space(eta), 50_000, 7, None, &NoProgress).unwrap();
    let mut zs = Vec::new();
    // [table][left at 1, inverted]: squared deviations of broken tables.
    let mut broken = [[0.0f64; 2]; 2];
    let mut nodes = [0usize; 2];
    let mut note = |t: usize, got: f64, want: f64, se: f64| {
        broken[t][0] += ((1.0 - want) / se).powi(2);
        broken[t][1] += ((1.0 / got - want) / se).powi(2);
        nodes[t] += 1;
    };
    for (c, &a) in ALBEDOS.iter().enumerate() {
        let normal = HalfSpace::new(a, eta, 1.0);
        let total0 = normal.total();
        for k in 0..NODES {
            let m = node_mu(k);
            let m_in = if k == 0 { 89f64.to_radians().cos() } else { m };
            let want = HalfSpace::new(a, eta, m_in).total() / total0;
            let what = format!("eta {eta}, albedo {a}, entry node {k}");
            if k == NODES - 1 {
                assert_eq!(f.entry[k][c], 1.0, "{what}");
            } else {
                within(f.entry[k][c], want, f.entry_stderr[k][c], &what);
                zs.push((f.entry[k][c] - want) / f.entry_stderr[k][c]);
                note(0, f.entry[k][c], want, f.entry_stderr[k][c]);
            }
            let (lo, hi) = ((m - 1.0 / 16.0).max(0.0), (m + 1.0 / 16.0).min(1.0));
            let share = normal.fraction(hi.acos(), lo.acos()) / total0;
            let want = share / (hi * hi - lo * lo);
            let what = format!("eta {eta}, albedo {a}, exit node {k}");
            within(f.exit[k][c], want, f.exit_stderr[k][c], &what);
            zs.push((f.exit[k][c] - want) / f.exit_stderr[k][c]);
            note(1, f.exit[k][c], want, f.exit_stderr[k][c]);
        }
    }
    let chi2 = zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64;
    eprintln!(
        "eta {eta}: {} nodes, mean square deviation {chi2:.2} sigma^2",
        zs.len()
    );
    // Honest errors: not twice too large (0.25) nor half (4).
    assert!(
        (0.4..MAX_CHI2).contains(&chi2),
        "mean square deviation {chi2}"
    );
    for (t, name) in ["entry", "exit"].iter().enumerate() {
        let [one, inv] = broken[t].map(|b| b / nodes[t] as f64);
        eprintln!("eta {eta}: {name} left at 1: {one:.0} sigma^2, inverted: {inv:.0} sigma^2");
        assert!(
            one >= BROKEN_MIN_CHI2,
            "eta {eta}: {name} left at 1 is {one}"
        );
        assert!(
            inv >= BROKEN_MIN_CHI2,
            "eta {eta}: {name} inverted is {inv}"
        );
    }
}

#[test]
fn the_nodes_match_the_h_function_without_a_boundary() {
    check_against_half_space(1.0);
}

#[test]
fn the_nodes_match_the_adding_solution_under_a_fresnel_boundary() {
    check_against_half_space(1.5);
}

/// Water's index, the boundary of milk, ketchup and the wine presets.
#[test]
fn the_nodes_match_the_adding_solution_at_eta_1_33() {
    check_against_half_space(1.33);
}

/// Skin's index (the skin presets).
#[test]
fn the_nodes_match_the_adding_solution_at_eta_1_4() {
    check_against_half_space(1.4);
}

/// A kernel file of the committed reference profile with angular tables
/// attached (their values from a small run: the lookups are what is tested).
fn kernel_with_tables() -> (KernelFile, AngularFactors) {
    let f = simulate_factors(&half_space(1.3), 2_000, 3, None, &NoProgress).unwrap();
    let text = std::fs::read_to_string("kernels/skin1-svd3.json").unwrap();
    let mut k: KernelFile = serde_json::from_str(&text).unwrap();
    k.angular = Some(f.clone());
    (k, f)
}

/// The mus the lookups are probed at: outside [0, 1], the nodes, between.
fn probes() -> Vec<f32> {
    let mut v: Vec<f32> = (0..=200).map(|i| -0.25 + 1.5 * i as f32 / 200.0).collect();
    v.extend((0..NODES).map(|k| node_mu(k) as f32));
    v
}

/// The emitted WGSL's sss_entry_factor and sss_exit_factor, compiled by
/// wgpu and run on the GPU (lavapipe in CI), against [`lookup`] in f64:
/// within f32 rounding (1e-6 relative).
#[test]
fn the_shader_lookups_compute_the_library_lookup() {
    ssskit::gpu::use_software_vulkan_if_unset();
    let g = ssskit::gpu::GpuContext::open().expect("GPU test needs an adapter (lavapipe in CI)");
    let (k, f) = kernel_with_tables();
    let header = emit(&k, Lang::Wgsl).unwrap();
    let src = format!(
        "{header}\n@group(0) @binding(0) var<storage, read> mus: array<f32>;\n\
         @group(0) @binding(1) var<storage, read_write> out: array<f32>;\n\
         @compute @workgroup_size(64)\nfn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
         let i = id.x;\n    if (i >= arrayLength(&mus)) {{ return; }}\n\
         let e = sss_entry_factor(mus[i]);\n    let x = sss_exit_factor(mus[i]);\n\
         for (var c = 0u; c < 3u; c++) {{ out[6u * i + c] = e[c]; out[6u * i + 3u + c] = x[c]; }}\n}}\n"
    );
    let pipeline = g.compute_pipeline("angular lookups", &src, "main").unwrap();
    let mus = probes();
    let n = mus.len();
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input = g.buffer("mus", bytemuck::cast_slice(&mus), usage);
    let output = g.buffer("out", bytemuck::cast_slice(&vec![0f32; 6 * n]), usage);
    let bind = g.bind_group(&pipeline, &[&input, &output]);
    let mut enc = g.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(n.div_ceil(64) as u32, 1, 1);
    }
    let got: Vec<f32> = g.read_back(enc, &output, (24 * n) as u64).unwrap();
    let mut checked = 0;
    for (i, &mu) in mus.iter().enumerate() {
        let want = [lookup(&f.entry, mu as f64), lookup(&f.exit, mu as f64)];
        for (t, w) in want.iter().enumerate() {
            for c in 0..3 {
                let v = got[6 * i + 3 * t + c] as f64;
                assert!(
                    (v - w[c]).abs() <= 1e-6 * w[c].abs().max(1.0),
                    "mu {mu}, table {t}, channel {c}: shader {v} vs {}",
                    w[c]
                );
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 6 * n);
    // The probes reach both clamps and the interior.
    assert!(f.entry[0] != f.entry[NODES - 1]);
}

/// GLSL's lookups validate with naga; HLSL carries the same arrays.
#[test]
fn the_glsl_and_hlsl_headers_carry_the_tables() {
    let (k, f) = kernel_with_tables();
    let glsl = emit(&k, Lang::Glsl).unwrap();
    let src = format!(
        "#version 450\n{glsl}\nlayout(location = 0) out vec4 o;\nvoid main() {{ o = \
         vec4(sss_entry_factor(0.3) + sss_exit_factor(0.7), 1.0); }}\n"
    );
    let mut front = naga::front::glsl::Frontend::default();
    let module = front
        .parse(
            &naga::front::glsl::Options::from(naga::ShaderStage::Fragment),
            &src,
        )
        .unwrap_or_else(|e| panic!("GLSL parse: {e:?}\n{src}"));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap();
    let hlsl = emit(&k, Lang::Hlsl).unwrap();
    for name in ["sss_entry", "sss_exit"] {
        assert!(hlsl.contains(&format!("static const float3 {name}[{NODES}] = {{")));
        assert!(hlsl.contains(&format!("float3 {name}_factor(float mu) {{")));
    }
    // The first entry row is written as the f32 it is.
    let first = format!("{:.9e}", f.entry[0][0] as f32);
    assert!(hlsl.contains(&first), "{first}");
    // Without tables, none of it.
    let mut plain = k.clone();
    plain.angular = None;
    assert!(!emit(&plain, Lang::Hlsl).unwrap().contains("sss_entry"));
}

/// `simulate` of skin1 (3000 photons, `extra` flags) to `DIR/PROFILE.json`,
/// then `fit --model svd` of it to `DIR/KERNEL.json`.
fn simulate_and_fit(dir: &std::path::Path, profile: &str, kernel: &str, extra: &[&str]) {
    let (pj, kj) = (
        dir.join(format!("{profile}.json")),
        dir.join(format!("{kernel}.json")),
    );
    let mut args = vec!["simulate", "--material", "skin1", "--photons", "3000"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", p(&pj)]);
    ok(&args);
    ok(&common::fit_args(p(&pj), "svd", p(&kj), &[]));
}

/// `simulate` with exit bins and oblique incidences, then `fit`: the kernel
/// file carries the tables the profile's record gives, reads back, and a
/// corrupted table is refused naming its field.
#[test]
fn fit_carries_the_tables_of_an_angular_profile() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let angular = common::args::words("--angle-bins 30 --incidence 30,60,80");
    simulate_and_fit(d, "p", "k", &angular);
    let prof = ssskit::profile::Profile::read(&d.join("p.json")).unwrap();
    let want = AngularFactors::from_profile(&prof).unwrap().unwrap();
    let k = read_json(&d.join("k.json"));
    let got: AngularFactors = serde_json::from_value(k["angular"].clone()).unwrap();
    assert_eq!(got, want);
    // Nodes between the runs interpolate them linearly in mu (node 4,
    // mu = 0.5, is the 60 degree run itself).
    let a = prof.angular().unwrap().unwrap();
    let e = a.entry.unwrap();
    for c in 0..3 {
        assert!((got.entry[4][c] - e.factor[c][2]).abs() < 1e-12);
        assert_eq!(got.entry[NODES - 1][c], 1.0);
    }
    let text = std::fs::read_to_string(d.join("k.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["angular"]["exit"][2][1] = serde_json::json!(-1.0);
    std::fs::write(d.join("bad.json"), serde_json::to_string(&v).unwrap()).unwrap();
    fails_with(
        &["fit", "--kernel", p(&d.join("bad.json"))],
        &["angular.exit[2][1]"],
    );
    // A profile without the tables gives a kernel without them.
    simulate_and_fit(d, "q", "l", &[]);
    assert!(read_json(&d.join("l.json")).get("angular").is_none());
}

/// How far the exit factor may move red's grazing bias on the sphere below:
/// the claim stated there (red's factor is near 1), checked as stated; not
/// derived from the factor's deviation from 1 and its Monte Carlo error
/// (2e4 angular photons), which the scene's report does not give.
const RED_EXIT_SHIFT: f64 = 0.02;

/// The least lift of green's and blue's grazing bias by the exit factor
/// (pi L / M up to 1.2 there): the claim stated above (5 points or more),
/// checked as stated; not derived from a bound either.
const GRAZING_LIFT: f64 = 0.05;

/// The sphere of the path-traced comparison (skin1, eta = 1, light 60
/// degrees from the view), small: `compare --scene` with the angular factors
/// around the pass removes most of the lit side's bias of every model (the
/// pass without them is 10-17% too dark there: oblique light returns more,
/// Chandrasekhar's plane albedo) and lowers the RMS over the object, the
/// exit factor lifts what is seen at grazing angles; a
/// scene with an environment light gets no angular rows and says why.
#[test]
fn the_factors_remove_the_lit_sides_bias_on_a_path_traced_sphere() {
    let scene = common::scenes::small_sphere_eta1();
    let dir = common::temp_with(&[("s.toml", scene.as_str())]);
    let d = dir.path();
    let (toml, exr, cmp) = (d.join("s.toml"), d.join("s.exr"), d.join("cmp"));
    common::render_scene(&toml, &exr, "64", "1e5", &[]);
    let flags =
        common::args::words("--models preintegrate,jimenez --angular-photons 2e4 --no-plots");
    common::compare_scene(&toml, &exr, &cmp, &flags);
    let j = read_json(&cmp.join("scene.json"));
    let rows = j["rows"].as_array().unwrap();
    let region = |label: &str, variant: &str, name: &str| -> serde_json::Value {
        let r = rows
            .iter()
            .find(|r| r["label"] == label && r["variant"] == variant)
            .unwrap_or_else(|| panic!("no row {label} {variant}"));
        r["regions"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["region"] == name)
            .unwrap()
            .clone()
    };
    let three =
        |v: &serde_json::Value| -> [f64; 3] { std::array::from_fn(|c| v[c].as_f64().unwrap()) };
    let mut checked = 0;
    for (label, plain, with) in [
        ("preintegrate", "depth+follow", "depth+follow+angular"),
        ("jimenez", "depth+follow", "depth+follow+angular"),
        ("exact-2d", "baseline", "entry+exit"),
    ] {
        let (b0, b1) = (
            three(&region(label, plain, "lit")["bias"]),
            three(&region(label, with, "lit")["bias"]),
        );
        let (r0, r1) = (
            three(&region(label, plain, "all")["rel_rms"]),
            three(&region(label, with, "all")["rel_rms"]),
        );
        eprintln!("{label}: lit bias {b0:?} -> {b1:?}, RMS {r0:?} -> {r1:?}");
        for c in 0..3 {
            // Without: the lit side too dark by 10% or more.
            assert!(b0[c] < -0.08, "{label} channel {c}: bias {}", b0[c]);
            assert!(
                r1[c] < r0[c],
                "{label} channel {c}: RMS {} -> {}",
                r0[c],
                r1[c]
            );
            if label != "exact-2d" {
                assert!(
                    b1[c].abs() < b0[c].abs() / 3.0,
                    "{label} {c}: {} -> {}",
                    b0[c],
                    b1[c]
                );
            } else {
                assert!(
                    b1[c].abs() < b0[c].abs(),
                    "{label} {c}: {} -> {}",
                    b0[c],
                    b1[c]
                );
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 9);
    // Seen at grazing angles the medium is brighter than a Lambertian
    // exit in green and blue (pi L / M up to 1.2 there): the exit factor
    // alone lifts the exact convolution's grazing bias by 5 points or more
    // in those channels and leaves red's (factor near 1) within 2 points.
    let (g0, g1) = (
        three(&region("exact-2d", "baseline", "grazing")["bias"]),
        three(&region("exact-2d", "exit", "grazing")["bias"]),
    );
    eprintln!("exact-2d grazing bias {g0:?} -> with the exit factor {g1:?}");
    assert!(
        (g1[0] - g0[0]).abs() < RED_EXIT_SHIFT,
        "red: {} -> {}",
        g0[0],
        g1[0]
    );
    for c in 1..3 {
        assert!(
            g1[c] - g0[c] > GRAZING_LIFT,
            "channel {c}: {} -> {}",
            g0[c],
            g1[c]
        );
    }
    // An environment light besides the sun: the irradiance is no longer
    // one light's N.L, so no angular rows, and the reason is given.
    let lit = scene.replace(
        "[[object]]",
        "[[light]]\ntype = \"environment\"\nradiance = 0.1\n[[object]]",
    );
    std::fs::write(d.join("e.toml"), &lit).unwrap();
    let (toml, exr, cmp) = (d.join("e.toml"), d.join("e.exr"), d.join("cmp-e"));
    common::render_scene(&toml, &exr, "4", "1e4", &[]);
    let flags = ["--models", "preintegrate", "--no-plots"];
    let (_, err) = common::compare_scene(&toml, &exr, &cmp, &flags);
    assert!(err.contains("one directional light and no other"), "{err}");
    let j = read_json(&cmp.join("scene.json"));
    assert!(j["angular"].is_null());
    assert!(j["angular_note"]
        .as_str()
        .unwrap()
        .contains("2 light(s), 1 directional"));
    assert!(!j["rows"]
        .as_array()
        .unwrap()
        .iter()
        .any(|r| r["variant"].as_str().unwrap().contains("angular")));
}

/// Photons per channel and incidence of the grid check below: it compares
/// runs of the same streams, so few photons suffice (enough that every node
/// pools some escapes: a factor of 0 is refused).
const GRID_CHECK_PHOTONS: u64 = 5_000;

/// Every preset's factor run is accepted: its coarse radial grid keeps the
/// radiance table under the cell cap even for marble and ketchup, whose own
/// grids (5894 bins x 90 angles) exceed it; and within the work the main job
/// allows, the slowest preset's run still has photons enough.
#[test]
fn every_preset_gets_a_factor_run() {
    use ssskit::kernel::angular::{factor_grid, photons_within_work, run_options};
    use ssskit::profile::RadialGrid;
    let mut refused_on_own_grid = Vec::new();
    for name in ssskit::material::preset_names() {
        let m = ssskit::material::Material::load(name).unwrap();
        let grid = factor_grid(&m).unwrap();
        run_options()
            .validate(grid.len())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let own = RadialGrid::for_material(&m, &ssskit::material::Channel::ALL);
        assert!((grid.r_max() - own.r_max()).abs() <= 1e-12 * own.r_max());
        if run_options().validate(own.len()).is_err() {
            refused_on_own_grid.push(name);
        }
    }
    // The blocker the coarse grid removes is real.
    for name in ["marble", "ketchup"] {
        assert!(
            refused_on_own_grid.contains(&name),
            "{refused_on_own_grid:?}"
        );
    }
    // The work budget: skin1's slowest channel (about 42 events per photon)
    // keeps the full count, spectralon's (about 1000) gets the floor.
    use ssskit::kernel::angular::{DEFAULT_PHOTONS, FACTOR_MAX_WORK, MIN_PHOTONS};
    assert_eq!(photons_within_work(None), DEFAULT_PHOTONS);
    assert_eq!(
        photons_within_work(Some(&[20.0, 10.0, 5.0])),
        DEFAULT_PHOTONS
    );
    let n = photons_within_work(Some(&[10.0, 400.0, 50.0]));
    assert_eq!(n, FACTOR_MAX_WORK / (NODES as u64 * 400));
    assert_eq!(
        photons_within_work(Some(&[1e4, f64::NAN, 1.0])),
        MIN_PHOTONS
    );
}

/// The factors use the whole-plane tallies only: the coarse grid of the
/// factor run gives bit for bit the tables of a run of the same streams on
/// the material's own grid (skin1's fits under the cap).
#[test]
fn the_coarse_grid_changes_no_factor() {
    use ssskit::profile::mc::{self, McConfig, McOptions, PhotonBudget};
    let m = ssskit::material::Material::load("skin1").unwrap();
    let coarse = simulate_factors(&m, GRID_CHECK_PHOTONS, 5, None, &NoProgress).unwrap();
    let cfg = McConfig {
        budget: PhotonBudget::Fixed(GRID_CHECK_PHOTONS),
        seed: 5,
        threads: None,
        channels: ssskit::material::Channel::ALL.to_vec(),
        grid: None,
    };
    let opts = McOptions {
        angular: Some(ssskit::kernel::angular::run_options()),
        ..McOptions::default()
    };
    let p = mc::simulate_with(&m, &cfg, &opts, &NoProgress).unwrap();
    let fine =
        ssskit::kernel::angular::from_angular(&p.angular().unwrap().unwrap(), GRID_CHECK_PHOTONS)
            .unwrap();
    assert!(p.r.len() > 4 * ssskit::kernel::angular::FACTOR_RADIAL_BINS);
    assert_eq!(coarse, fine);
}
