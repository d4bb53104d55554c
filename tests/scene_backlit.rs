//! Scenes lit from behind: the committed meshes of docs/scenes/backlit-*
//! are the generator's (tests/common/backlit_meshes.rs); the scenes load;
//! a mesh that crosses itself or is open is refused before any work; the
//! path tracer's light through a flat slab lit from behind matches the
//! slab's Monte Carlo transmittance; `compare --scene --transmission` on a
//! small back-lit render gives the back-lit rows with their first lines.

mod common;

use common::backlit_meshes::{shell, wedge};
use common::{fails_with_in, p, read_json};
use ssskit::scene::parse_scene_toml;
use std::path::Path;

fn scenes_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/scenes")
}

#[test]
fn committed_meshes_are_the_generators() {
    for (name, text) in [
        ("backlit-wedge.obj", wedge()),
        ("backlit-shell.obj", shell()),
    ] {
        let path = scenes_dir().join(name);
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        // Rewritten only when it differs: the other tests read these files.
        if common::bless() && committed != text {
            std::fs::write(&path, &text).unwrap();
            continue;
        }
        assert!(
            committed == text,
            "{name} is not the generator's: SSSKIT_BLESS=1 to rewrite"
        );
    }
}

/// A cube of side 10 mm with its lowest corner at `o`, its vertices
/// numbered from `first`: 12 triangles wound outward, `skip` of them left
/// out.
fn cube(o: [f64; 3], first: usize, skip: usize) -> String {
    let mut s = String::new();
    for k in 0..8 {
        let v = [(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64];
        s += &format!(
            "v {} {} {}\n",
            o[0] + 10.0 * v[0],
            o[1] + 10.0 * v[1],
            o[2] + 10.0 * v[2]
        );
    }
    // Vertex k + 1 at bits (x, y, z) of k.
    let tris = common::backlit_meshes::CUBE_QUADS
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
    for t in tris.skip(skip) {
        let t = t.map(|i| i + first - 1);
        s += &format!("f {} {} {}\n", t[0], t[1], t[2]);
    }
    s
}

/// Every back-lit scene of docs/scenes loads; a back-lit scene whose mesh
/// crosses itself (two closed cubes through each other) or is open (a
/// cube less one triangle) is refused by `scene` before any work, naming
/// the object's file, and nothing is written.
#[test]
fn backlit_scenes_load_and_bad_meshes_are_refused() {
    for name in [
        "backlit-sphere.toml",
        "backlit-wedge.toml",
        "backlit-shell.toml",
    ] {
        let text = std::fs::read_to_string(scenes_dir().join(name)).unwrap();
        if let Err(e) = parse_scene_toml(&text, name, &scenes_dir()) {
            panic!("{name}: {e}");
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let wedge_toml = std::fs::read_to_string(scenes_dir().join("backlit-wedge.toml")).unwrap();
    for (obj, mesh, why) in [
        (
            "crossed.obj",
            cube([0.0; 3], 1, 0) + &cube([3.0, 4.0, 2.5], 9, 0),
            "crosses itself",
        ),
        ("open.obj", cube([0.0; 3], 1, 1), "not closed"),
    ] {
        std::fs::write(d.join(obj), mesh).unwrap();
        let toml = wedge_toml.replace("backlit-wedge.obj", obj);
        std::fs::write(d.join("bad.toml"), toml).unwrap();
        fails_with_in(
            d,
            &["scene", "bad.toml", "--out", "o.exr", "--spp", "2"],
            &["object[0].file", why],
        );
        assert!(!d.join("o.exr").exists(), "{obj}: nothing is written");
    }
    // The two cubes apart are a valid scene: the refusal is the crossing's.
    std::fs::write(
        d.join("apart.obj"),
        cube([0.0; 3], 1, 0) + &cube([20.0; 3], 9, 0),
    )
    .unwrap();
    let toml = wedge_toml.replace("backlit-wedge.obj", "apart.obj");
    parse_scene_toml(&toml, "apart.toml", d).unwrap();
}

/// Photons of the back-lit test's table: its T within about 1% at the
/// thin end, a second of work.
const TABLE_PHOTONS: &str = "2e4";

/// `compare --scene --transmission` on a small render of the back-lit
/// wedge: its first line says what is lost without transmission (all of
/// it: the camera sees only the face away from the light) and names the
/// engine approximation with the lowest error and the exact table's; the
/// printed table follows it; every transmission row beats screen-space
/// SSS alone against the path tracer.
#[test]
fn compare_states_what_transmission_adds_on_the_backlit_wedge() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(scenes_dir().join("backlit-wedge.toml"), d.join("w.toml")).unwrap();
    std::fs::copy(
        scenes_dir().join("backlit-wedge.obj"),
        d.join("backlit-wedge.obj"),
    )
    .unwrap();
    common::skin1_table(d, &["--photons", TABLE_PHOTONS]);
    let (toml, exr, cmp) = (d.join("w.toml"), d.join("w.exr"), d.join("cmp"));
    common::render_scene(&toml, &exr, "4", "1e4", &[]);
    let table = d.join("t.json");
    let flags = [
        "--models",
        "preintegrate",
        "--no-plots",
        "--transmission",
        p(&table),
    ];
    let (out, _) = common::compare_scene(&toml, &exr, &cmp, &flags);
    let first = out.lines().next().unwrap();
    assert!(
        first.starts_with("Without transmission, screen-space SSS misses 100%, 100%, 100%"),
        "{out}"
    );
    let j = read_json(&cmp.join("scene.json"));
    let t = &j["transmission"];
    // The headline's measure: the relative RMS, mean of the channels.
    let mean = |r: &serde_json::Value| {
        common::mcml::floats(&r["regions"][0]["rel_rms"])
            .iter()
            .sum::<f64>()
            / 3.0
    };
    let rows = t["rows"].as_array().unwrap();
    let label = |r: &serde_json::Value| r["label"].as_str().unwrap().to_string();
    assert_eq!(label(&rows[0]), "screen-space SSS alone");
    for c in 0..3 {
        assert!(t["lost"][c].as_f64().unwrap() > 0.99, "{}", t["lost"]);
    }
    let alone = mean(&rows[0]);
    for r in &rows[1..] {
        assert!(mean(r) < alone, "{}: {} against {alone}", label(r), mean(r));
    }
    let engines: Vec<&serde_json::Value> = rows[1..]
        .iter()
        .filter(|r| !label(r).contains("exact"))
        .collect();
    assert_eq!(engines.len(), 3, "unreal, unity-hdrp and godot rows");
    let best = engines
        .iter()
        .min_by(|a, b| mean(a).total_cmp(&mean(b)))
        .unwrap();
    let named = format!(
        "Of the engines' approximations, {} (thickness from the {})",
        label(best).trim_start_matches("+ "),
        best["thickness"].as_str().unwrap()
    );
    assert!(
        first.contains(&named) && first.contains("The exact table"),
        "{first}"
    );
    assert!(out.contains("| + exact table | shadow map |"), "{out}");
    record(t, first);
}

/// The back-lit wedge's rows as docs/scene.md shows them, pinned in the
/// record `scene-backlit`.
fn record(t: &serde_json::Value, headline: &str) {
    use common::measured;
    let three = |v: &serde_json::Value| -> String {
        (0..3)
            .map(|c| {
                v[c].as_f64()
                    .map_or("-".into(), |x| format!("{:+.1}", 100.0 * x))
            })
            .collect::<Vec<_>>()
            .join(" / ")
    };
    let plain = |v: &serde_json::Value| three(v).replace('+', "");
    let rows: Vec<Vec<String>> = t["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            let all = &r["regions"][0];
            vec![
                r["label"].as_str().unwrap().to_string(),
                r["thickness"].as_str().unwrap().to_string(),
                three(&all["bias"]),
                plain(&all["rel_rms"]),
                plain(&all["noise"]),
            ]
        })
        .collect();
    measured::check(
        "scene-backlit",
        "scene_backlit",
        "docs/scenes/backlit-wedge.toml at 4 samples per pixel, skin1's table at \
         2e4 photons per slab, default seeds; the path tracer's noise is in every RMS (its own column), the \
         bias is the mean over 12800 pixels; pinned: a change of the tracer, the table, a fit \
         or the comparison moves them",
        [(
            "wedge".to_string(),
            measured::table(
                &[
                    "back-lit wedge: what the camera gets",
                    "thickness from",
                    "bias % (r / g / b)",
                    "RMS % of peak (r / g / b)",
                    "path tracer's noise % (r / g / b)",
                ],
                rows,
            ),
        )]
        .into_iter()
        .collect(),
        serde_json::json!({ "headline": headline, "transmission": t }),
    );
}
