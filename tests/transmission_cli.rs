//! `ssskit transmission`: the thickness table of a material (each row the
//! run `simulate` makes of the slab, so its T is `simulate`'s bit for
//! bit; total T against adding-doubling), its outputs, the engines' fits
//! scored at every thickness, the shaders' thickness function (naga), its
//! record (docs/records/transmission.json: skin1 at a small photon count,
//! pinned), and every bad input refused before any work.

mod common;

use common::adding_doubling::slab_totals;
use common::{fails_with, fails_with_in, ok_in, p};
use ssskit::profile::transmission::ThicknessTable;
use ssskit::profile::Profile;

/// Photons per slab of these tests: standard errors of about 0.5% of T on
/// the thin slabs, each run well under a second.
const PHOTONS: &str = "2e4";

#[test]
fn rows_are_simulates_slabs_and_the_outputs_follow() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = ok_in(
        d,
        &[
            "transmission",
            "--material",
            "skin1",
            "--thickness",
            "0.5,2,8",
            "--photons",
            PHOTONS,
            "--seed",
            "3",
            "--out",
            "t.json",
            "--csv",
            "t.csv",
            "--plot",
            "t.png",
        ],
    );
    assert!(
        out.contains("unreal transmission") && out.contains("RMS of ln"),
        "{out}"
    );
    let t = ThicknessTable::read(&d.join("t.json")).unwrap();
    assert_eq!(t.thicknesses(), [0.5, 2.0, 8.0]);
    // Row 2 mm is simulate's run of the 2 mm slab with the same seed.
    std::fs::write(
        d.join("slab.toml"),
        "unit = \"mm\"\nsigma_a = [0.032, 0.17, 0.48]\nsigma_s = [0.74, 0.88, 1.01]\ng = 0.0\n\
         eta = 1.3\nthickness = 2.0\n",
    )
    .unwrap();
    ok_in(
        d,
        &[
            "simulate",
            "--material",
            "slab.toml",
            "--photons",
            PHOTONS,
            "--seed",
            "3",
            "--out",
            "s.json",
        ],
    );
    let s = Profile::read(&d.join("s.json")).unwrap();
    assert_eq!(
        Some(t.rows[1].transmittance.clone()),
        s.transmittance.clone()
    );
    let tp = s.transmittance_profile().unwrap().unwrap();
    assert_eq!(t.rows[1].diffuse, tp.diffuse);
    assert_eq!(t.rows[1].td, tp.td);
    for r in &t.rows {
        for c in 0..3 {
            assert!(r.diffuse[c] <= r.transmittance[c] && r.r50_mm[c] <= r.r90_mm[c]);
        }
    }
    // Thicker slabs pass less light, in every channel.
    for w in t.rows.windows(2) {
        assert!((0..3).all(|c| w[1].transmittance[c] < w[0].transmittance[c]));
    }
    let engines = t.engines.as_array().unwrap();
    let names: Vec<&str> = engines
        .iter()
        .map(|e| e["engine"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["unreal", "unity-hdrp", "godot"]);
    let csv = std::fs::read_to_string(d.join("t.csv")).unwrap();
    assert_eq!(csv.lines().count(), 4);
    assert!(csv.starts_with("thickness_mm,t_r,t_r_stderr,t_scattered_r"));
    let png = image::open(d.join("t.png")).unwrap();
    assert!(png.width() > 600 && png.height() > 400);
}

/// Standard errors a table's T may stand from adding-doubling's: the
/// solver's own error is below 1e-5 (tests/mc_transmission.rs), far under
/// one standard error at these photon counts.
const AD_SIGMAS: f64 = 4.0;

/// Photons per slab of the adding-doubling check: standard errors of about
/// 0.2% of T, the whole table in a few seconds.
const AD_PHOTONS: &str = "1e5";

/// The table's numbers themselves: total T of an index-matched slab
/// (`--eta 1`) at every thickness against adding-doubling (an independent
/// solver of the radiative transfer equation, van de Hulst 1980), in every
/// channel (three albedos, one forward-scattering phase function).
#[test]
fn table_t_matches_adding_doubling() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // sigma_a, sigma_s per channel in mm^-1; g 0.8.
    let (sa, ss, g) = ([0.02, 0.1, 0.5], [1.98, 1.9, 4.5], 0.8);
    std::fs::write(
        d.join("m.toml"),
        format!("unit = \"mm\"\nsigma_a = {sa:?}\nsigma_s = {ss:?}\ng = {g}\neta = 1.4\n"),
    )
    .unwrap();
    ok_in(
        d,
        &[
            "transmission",
            "--material",
            "m.toml",
            "--thickness",
            "0.3,1,3",
            "--eta",
            "1",
            "--photons",
            AD_PHOTONS,
            "--seed",
            "5",
            "--engines",
            "none",
            "--out",
            "t.json",
        ],
    );
    let t = ThicknessTable::read(&d.join("t.json")).unwrap();
    let mut lines = Vec::new();
    for r in &t.rows {
        for c in 0..3 {
            let mu_t = sa[c] + ss[c];
            let (_, want) = slab_totals(ss[c] / mu_t, mu_t * r.thickness_mm, g);
            let (got, se) = (r.transmittance[c], r.transmittance_stderr[c]);
            lines.push(format!(
                "{} mm ch {c}: T {got:.5} +- {se:.5}, AD {want:.5}",
                r.thickness_mm
            ));
            assert!(
                (got - want).abs() <= AD_SIGMAS * se,
                "{} mm, channel {c}: the table's T {got} +- {se}, adding-doubling {want}",
                r.thickness_mm
            );
        }
    }
    eprintln!("{}", lines.join("\n"));
}

/// Each bad value is refused, naming its flag, before any slab is traced.
#[test]
fn bad_input_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = ["transmission", "--material", "skin1", "--photons", "1e3"];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        base.iter().chain(extra.iter()).copied().collect()
    };
    // A half-space has no unlit face.
    fails_with(&with(&[]), &["--thickness", "semi-infinite"]);
    for (t, why) in [
        ("0", "finite and > 0"),
        ("-1", "finite and > 0"),
        ("nan", "finite and > 0"),
        ("2000", "at most 1000 mm"),
        ("2,1", "must increase"),
        ("0..5", "0 < lo <= hi"),
        ("5..1", "0 < lo <= hi"),
        ("1..x", "not a number"),
    ] {
        fails_with(&with(&["--thickness", t]), &["--thickness", why]);
    }
    // The other flags, each on a valid thickness: the flags, then the words.
    #[rustfmt::skip] // one case a line: the table reads as a list
    let flags: [(&[&'static str], &[&str]); 4] = [
        (&["--thickness", "1..2", "--steps", "1"], &["--thickness", "between 2 and 64"]),
        (&["--thickness", "1", "--eta", "0"], &["--eta", "eta"]),
        (&["--thickness", "1", "--channels", "r"], &["--channels", "RGB"]),
        (&["--thickness", "1", "--engines", "blender"], &["--engines", "no thickness-based transmission"]),
    ];
    for (extra, needles) in flags {
        fails_with(&with(extra), needles);
    }
    // A stack whose upper layers already make the slab.
    std::fs::write(
        d.join("two.toml"),
        "unit = \"mm\"\n[[layer]]\nsigma_a = 0.1\nsigma_s = 1.0\neta = 1.4\nthickness = 2.0\n\
         [[layer]]\nsigma_a = 0.1\nsigma_s = 1.0\neta = 1.4\n",
    )
    .unwrap();
    fails_with_in(
        d,
        &[
            "transmission",
            "--material",
            "two.toml",
            "--thickness",
            "1.5",
        ],
        &["--thickness", "layers above the last"],
    );
    fails_with_in(
        d,
        &[
            "transmission",
            "--material",
            "two.toml",
            "--thickness",
            "3",
            "--eta",
            "1",
        ],
        &["--eta", "one-layer"],
    );
    for (flag, file) in [("--out", "t.txt"), ("--csv", "t.json"), ("--plot", "t.jpg")] {
        fails_with_in(
            d,
            &[
                "transmission",
                "--material",
                "skin1",
                "--thickness",
                "1",
                flag,
                file,
            ],
            &[flag],
        );
    }
    assert!(
        std::fs::read_dir(d).unwrap().count() == 1,
        "nothing written"
    );
    // A table without the finite stack, given to a command that reads one.
    std::fs::write(
        d.join("bad.json"),
        "{\"schema\": \"ssskit.transmission/1\"}",
    )
    .unwrap();
    fails_with_in(
        d,
        &[
            "engine",
            "--profile",
            p(&std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("profiles/reference/skin1.json")),
            "--engine",
            "unreal",
            "--transmission",
            "bad.json",
        ],
        &["bad.json", "not a transmission table"],
    );
}

/// skin1's table (`common::skin1_table` with `extra`) in a temporary
/// folder, read back.
fn read_skin1_table(extra: &[&str]) -> (tempfile::TempDir, ThicknessTable) {
    let dir = tempfile::tempdir().unwrap();
    let t = ThicknessTable::read(&common::skin1_table(dir.path(), extra)).unwrap();
    (dir, t)
}

/// A finite stack without --thickness gives the table of its own thickness.
#[test]
fn a_finite_stack_gives_its_own_thickness() {
    let slab = "unit = \"mm\"\nsigma_a = 0.05\nsigma_s = 2.0\neta = 1.3\nthickness = 1.5\n";
    let dir = common::temp_with(&[("slab.toml", slab)]);
    let d = dir.path();
    ok_in(
        d,
        &[
            "transmission",
            "--material",
            "slab.toml",
            "--photons",
            "1e4",
            "--engines",
            "none",
            "--out",
            "t.json",
        ],
    );
    let t = ThicknessTable::read(&d.join("t.json")).unwrap();
    assert_eq!(t.thicknesses(), [1.5]);
    assert!(t.engines.is_null());
}

/// The numbers README.md shows, pinned in the record
/// `transmission`: skin1's table (index-matched, as the back-lit scenes'
/// objects) and each engine's fit to it with its error at every
/// thickness, from one seeded run.
#[test]
fn record_skin1_table_and_engine_fits() {
    use common::measured;
    let (_dir, t) = read_skin1_table(&["--photons", PHOTONS, "--seed", "1"]);
    let rgb = |v: &[f64], f: &dyn Fn(f64) -> String| -> String {
        v.iter().map(|x| f(*x)).collect::<Vec<_>>().join(" / ")
    };
    let sci = |x: f64| format!("{x:.3e}");
    let mm = |x: f64| format!("{x:.2}");
    let pct = |x: f64| format!("{:+.0}%", 100.0 * x);
    let rows: Vec<Vec<String>> = t
        .rows
        .iter()
        .map(|r| {
            vec![
                format!("{:.2}", r.thickness_mm),
                rgb(&r.transmittance, &sci),
                rgb(&r.transmittance_stderr, &sci),
                rgb(&r.diffuse, &sci),
                rgb(&r.r50_mm, &mm),
                rgb(&r.r90_mm, &mm),
            ]
        })
        .collect();
    let engines = t.engines.as_array().unwrap();
    let mut fits = Vec::new();
    for e in engines {
        let name = e["engine"].as_str().unwrap();
        let rms = common::mcml::floats(&e["rms_log_error"]);
        for (i, th) in e["thickness_mm"].as_array().unwrap().iter().enumerate() {
            let errs: Vec<String> = e["rel_error"][i]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().map_or("-".into(), pct))
                .collect();
            fits.push(vec![
                name.to_string(),
                format!("{:.2}", th.as_f64().unwrap()),
                errs.join(" / "),
                if i == 0 {
                    rgb(&rms, &|x| format!("{x:.3}"))
                } else {
                    String::new()
                },
            ]);
        }
    }
    let data = serde_json::json!({
        "rows": t.rows.iter().map(|r| serde_json::json!({
            "thickness_mm": r.thickness_mm,
            "t": r.transmittance,
            "t_stderr": r.transmittance_stderr,
            "scattered": r.diffuse,
            "r50_mm": r.r50_mm,
            "r90_mm": r.r90_mm,
        })).collect::<Vec<_>>(),
        "engines": engines.iter().map(|e| serde_json::json!({
            "engine": e["engine"],
            "params": e["params"],
            "rel_error": e["rel_error"],
            "rms_log_error": e["rms_log_error"],
        })).collect::<Vec<_>>(),
    });
    measured::check(
        "transmission",
        "transmission_cli",
        "skin1 index-matched (--eta 1), 6 slabs from 0.5 to 10 mm, 2e4 photons per channel, \
         seed 1; no closed form gives the table or the engines' errors, so they are pinned: a \
         change of the tracer, of the table or of an engine's fit moves them",
        [
            (
                "table".to_string(),
                measured::table(
                    &[
                        "thickness mm",
                        "T (r / g / b)",
                        "standard error",
                        "scattered part of T",
                        "r50 mm",
                        "r90 mm",
                    ],
                    rows,
                ),
            ),
            (
                "engines".to_string(),
                measured::table(
                    &[
                        "engine",
                        "thickness mm",
                        "engine / table - 1 (r / g / b)",
                        "RMS of ln(engine / table) (r / g / b)",
                    ],
                    fits,
                ),
            ),
        ]
        .into_iter()
        .collect(),
        data,
    );
}

/// Standard errors a row's scattered T must stand above 0 to enter the
/// shader fit (the rule of `kernel::transmission::fit_table`).
const SIGNIFICANT: f64 = 4.0;

/// The shaders' thickness function (`fit --transmission`): the kernel
/// file's `sss_transmittance` parses and validates with naga in WGSL and
/// GLSL (HLSL through GLSL's grammar, its types mapped), and its stated
/// fit error is what its terms give against the table's scattered T.
#[test]
fn shader_thickness_function_validates_and_states_its_error() {
    use ssskit::kernel::emit::{emit, Lang};
    use ssskit::kernel::transmission::fit_table;
    use ssskit::kernel::KernelFile;
    let (_dir, table) = read_skin1_table(&["--photons", PHOTONS, "--engines", "none"]);
    let f = fit_table(&table).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut k = KernelFile::read(&root.join("kernels/skin1-svd1.json")).unwrap();
    k.transmission = Some(f.clone());
    let validate = |m: &naga::Module, what: &str| {
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(m)
        .unwrap_or_else(|e| panic!("{what}: naga validation failed: {e:?}"));
    };
    let wgsl = emit(&k, Lang::Wgsl).unwrap();
    assert!(wgsl.contains("fn sss_transmittance(thickness_mm: f32) -> vec3<f32>"));
    let m = naga::front::wgsl::parse_str(&wgsl)
        .unwrap_or_else(|e| panic!("WGSL: {}", e.emit_to_string(&wgsl)));
    validate(&m, "WGSL");
    assert!(m
        .functions
        .iter()
        .any(|(_, f)| f.name.as_deref() == Some("sss_transmittance")));
    let glsl_of = |src: &str| {
        let text = format!(
            "#version 450\n{src}\nlayout(location = 0) out vec4 o;\nvoid main() {{\n    \
             o = vec4(sss_transmittance(1.0), 1.0);\n}}\n"
        );
        let mut front = naga::front::glsl::Frontend::default();
        let opts = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
        front
            .parse(&opts, &text)
            .unwrap_or_else(|e| panic!("GLSL parse failed: {e:?}\n{text}"))
    };
    let glsl = emit(&k, Lang::Glsl).unwrap();
    assert!(glsl.contains("vec3 sss_transmittance(float thickness_mm)"));
    validate(&glsl_of(&glsl), "GLSL");
    let hlsl = emit(&k, Lang::Hlsl).unwrap();
    assert!(hlsl.contains("float3 sss_transmittance(float thickness_mm)"));
    let mapped = hlsl
        .replace("static const float4", "const vec4")
        .replace("static const uint", "const uint")
        .replace("float4(", "vec4(")
        .replace("float3", "vec3");
    validate(&glsl_of(&mapped), "HLSL");
    // The stated error, recomputed from the terms over the rows fitted.
    for c in 0..3 {
        let [a1, b1, a2, b2] = f.terms[c];
        let errs: Vec<f64> = table
            .rows
            .iter()
            .filter(|r| r.diffuse[c] > 0.0 && r.diffuse[c] > SIGNIFICANT * r.diffuse_stderr[c])
            .map(|r| {
                let t = r.thickness_mm;
                (a1 * (-b1 * t).exp() + a2 * (-b2 * t).exp()) / r.diffuse[c] - 1.0
            })
            .collect();
        assert_eq!(errs.len(), f.rows[c], "channel {c}: rows fitted");
        let max = errs.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        assert!(
            (max - f.max_rel_error[c]).abs() < 1e-9,
            "channel {c}: {max} against {:?}",
            f.max_rel_error
        );
        assert!(
            wgsl.contains(&format!("{:.1}%", 100.0 * f.max_rel_error[c])),
            "{wgsl}"
        );
    }
}
