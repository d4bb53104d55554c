//! `ssskit scene` and `compare --scene` through the binary: the EXR's
//! channels and the G-buffer against the camera and the sphere recomputed
//! here, the record beside the image, the comparison's rows; meshes and
//! heightfields against the analytic box they describe; every bad value
//! of a scene file refused with its field named.

mod common;

use common::{fails_with, p, read_json};
use ssskit::filter::image::{read_exr_channels, read_image};
use ssskit::progress::NoProgress;
use ssskit::scene::{parse_scene_toml, render, RenderConfig, SampleBudget};
use std::path::Path;

const SPHERE: &str = "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 60]\n\
look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 30\nsize = [16, 12]\n[[light]]\ntype = \
\"directional\"\ntoward = [0.6, 0, 0.8]\nirradiance = 2\n[[object]]\nshape = \"sphere\"\n\
center = [0, 0, 0]\nradius = 10\nmaterial = \"skin1\"\neta = 1.0\n";

fn channel<'a>(planes: &'a [(String, Vec<f64>)], name: &str) -> &'a [f64] {
    &planes
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no channel {name}"))
        .1
}

/// The G-buffer at a pixel, recomputed from the camera's definition (row 0
/// at the top, square pixels, 4 x 4 positions at the cells' centres) and
/// the ray-sphere intersection: (irradiance / pi / R_d, depth, coverage).
fn expected_gbuffer(x: usize, y: usize) -> (f64, f64, f64) {
    let (w, h, t) = (16.0, 12.0, (15f64).to_radians().tan());
    let l = [0.6, 0.0, 0.8];
    let (mut e, mut z, mut hits) = (0.0, 0.0, 0);
    for j in 0..4 {
        for i in 0..4 {
            let px = x as f64 + (i as f64 + 0.5) / 4.0;
            let py = y as f64 + (j as f64 + 0.5) / 4.0;
            let d = [
                (2.0 * px / w - 1.0) * t * w / h,
                (1.0 - 2.0 * py / h) * t,
                -1.0,
            ];
            let n = (d[0] * d[0] + d[1] * d[1] + 1.0f64).sqrt();
            let d = d.map(|v| v / n);
            // |o + s d|^2 = 100, o = (0, 0, 60).
            let b = 60.0 * d[2];
            let disc = b * b - (3600.0 - 100.0);
            if disc < 0.0 {
                continue;
            }
            let s = -b - disc.sqrt();
            let q = [s * d[0], s * d[1], 60.0 + s * d[2]];
            let cos = (q[0] * l[0] + q[2] * l[2]) / 10.0;
            e += 2.0 * cos.max(0.0) / std::f64::consts::PI;
            z += 60.0 - q[2];
            hits += 1;
        }
    }
    (e / 16.0, z / hits.max(1) as f64, hits as f64 / 16.0)
}

#[test]
fn scene_writes_radiance_gbuffer_and_record() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SPHERE).unwrap();
    let (toml, exr) = (d.join("s.toml"), d.join("s.exr"));
    let out = common::render_scene(
        &toml,
        &exr,
        "8",
        "20000",
        &[
            "--irradiance-out",
            p(&d.join("irr.exr")),
            "--preview",
            p(&d.join("s.png")),
        ],
    );
    assert!(
        out.contains("16x12 pixels, 8 / 8 / 8 samples per pixel"),
        "{out}"
    );
    let ((w, h), planes) = read_exr_channels(&d.join("s.exr")).unwrap();
    assert_eq!((w, h), (16, 12));
    for name in ssskit::scene::channel_names() {
        channel(&planes, name);
    }
    let rec = read_json(&d.join("s.json"));
    assert_eq!(rec["info"]["schema"], "ssskit.render/1");
    assert_eq!(rec["info"]["spp"], serde_json::json!([8, 8, 8]));
    assert_eq!(rec["scene"], SPHERE);
    let rd: Vec<f64> = (0..3)
        .map(|c| rec["info"]["rd"][0][c].as_f64().unwrap())
        .collect();
    assert_eq!(rd[0], rec["profiles"][0]["total_rd"][0].as_f64().unwrap());
    let (irr, cov, z) = (
        [
            channel(&planes, "irradiance.R"),
            channel(&planes, "irradiance.G"),
            channel(&planes, "irradiance.B"),
        ],
        channel(&planes, "coverage"),
        channel(&planes, "Z"),
    );
    let mut checked = 0;
    for y in 0..12 {
        for x in 0..16 {
            let i = y * 16 + x;
            let (e, depth, coverage) = expected_gbuffer(x, y);
            assert!((cov[i] - coverage).abs() < 1e-7, "({x}, {y})");
            for c in 0..3 {
                let want = e * rd[c];
                assert!(
                    (irr[c][i] - want).abs() <= 1e-6 * want.max(1e-3),
                    "({x}, {y}) channel {c}: {} vs {want}",
                    irr[c][i]
                );
            }
            if coverage > 0.0 {
                assert!(
                    (z[i] - depth).abs() < 1e-4,
                    "({x}, {y}): {} vs {depth}",
                    z[i]
                );
                checked += 1;
            } else {
                // Behind everything.
                assert!(z[i] > 100.0);
            }
        }
    }
    assert!(checked > 40, "{checked}");
    // The irradiance file reads as `apply` reads its input, with depth.
    let (img, extras) = read_image(&d.join("irr.exr"), Some("Z")).unwrap();
    assert_eq!(img.rgb[0], irr[0].to_vec());
    assert_eq!(extras.depth.unwrap().data, z.to_vec());
    assert!(d.join("s.png").exists());

    // compare --scene on it: every model, both variants, the baselines.
    let cmp = d.join("cmp");
    let models = common::args::words("--models svd,preintegrate --ranks 1 --angular-photons 1e4");
    let (text, _) = common::compare_scene(&toml, &exr, &cmp, &models);
    assert!(text.contains("Best kernel model on the scene"), "{text}");
    assert!(
        text.contains("With the angular entry and exit factors"),
        "{text}"
    );
    let j = read_json(&cmp.join("scene.json"));
    let labels: Vec<String> = j["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            format!(
                "{} {}",
                r["label"].as_str().unwrap(),
                r["variant"].as_str().unwrap()
            )
        })
        .collect();
    assert_eq!(
        labels,
        [
            "no-blur baseline",
            "exact-2d baseline",
            "exact-2d entry",
            "exact-2d exit",
            "exact-2d entry+exit",
            "svd1 depth",
            "svd1 depth+follow",
            "svd1 depth+follow+angular",
            "svd1-renorm depth",
            "svd1-renorm depth+follow",
            "svd1-renorm depth+follow+angular",
            "preintegrate depth",
            "preintegrate depth+follow",
            "preintegrate depth+follow+angular",
        ]
    );
    for r in j["rows"].as_array().unwrap() {
        let regions: Vec<&str> = r["regions"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["region"].as_str().unwrap())
            .collect();
        assert_eq!(regions, ["all", "lit", "unlit", "terminator", "grazing"]);
    }
    assert_eq!(j["angular"]["entry"].as_array().unwrap().len(), 9);
    // The headline opens stdout and scene.md: the unblurred irradiance,
    // the best depth+follow pass and the best with the factors, lowest
    // first, each the worst channel of its row over all seen pixels.
    let worst = |r: &serde_json::Value| {
        r["regions"][0]["rel_rms"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .fold(0.0, f64::max)
    };
    let best = |variant: &str| {
        j["rows"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|r| r["variant"] == variant)
            .map(worst)
            .fold(f64::INFINITY, f64::min)
    };
    let no_blur = j["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["label"] == "no-blur")
        .map(worst)
        .unwrap();
    let mut want = [no_blur, best("depth+follow"), best("depth+follow+angular")];
    want.sort_by(f64::total_cmp);
    // The light-space method's verdict opens stdout (which method the
    // scene needs, docs/directional.md); the ranking follows it.
    assert!(
        text.starts_with("Screen-space scattering is enough")
            || text.starts_with("This scene needs"),
        "{text}"
    );
    let at = text.find("\nRanking").expect("a ranking after the verdict") + 1;
    let ranking = &text[at..];
    let shown = common::ranked_fractions(ranking.lines().skip(1).take(3));
    assert_eq!(shown.len(), 3, "{text}");
    for (s, w) in shown.iter().zip(want) {
        // Shown with two decimals of a percent.
        assert!((s - w).abs() <= 0.5e-4, "{shown:?} vs {want:?}\n{text}");
    }
    assert!(
        ranking.lines().nth(4).unwrap().starts_with("What it means"),
        "{text}"
    );
    let md = std::fs::read_to_string(cmp.join("scene.md")).unwrap();
    assert!(md.contains("```text\nRanking"), "{md}");
    assert!(md.contains("<!-- BEGIN compare:summary -->"));
    assert!(md.contains("<!-- BEGIN compare:angular -->"));
    ssskit::report::present::record::Record::read(&cmp.join("record.json")).unwrap();
    assert!(cmp.join("contact-sheet.png").exists());

    // A render of another scene is refused.
    std::fs::write(
        d.join("t.toml"),
        SPHERE.replace("radius = 10", "radius = 9"),
    )
    .unwrap();
    fails_with(
        &[
            "compare",
            "--scene",
            p(&d.join("t.toml")),
            "--render",
            p(&d.join("s.exr")),
            "--out-dir",
            p(&cmp),
        ],
        &["--render", "another scene"],
    );
}

/// The mean radiance of a scene under a uniform environment at `spp`,
/// with its standard error.
fn mean_radiance(dir: &Path, text: &str, spp: u64) -> (f64, f64) {
    let s = parse_scene_toml(text, "test", dir).unwrap();
    let cfg = RenderConfig {
        budget: SampleBudget::Fixed(spp),
        seed: 5,
        ..RenderConfig::default()
    };
    let r = render(&s, &vec![[1.0; 3]; s.objects.len()], &cfg, &NoProgress).unwrap();
    let n = (3 * r.width * r.height) as f64;
    let m = r.radiance.iter().flatten().sum::<f64>() / n;
    let v: f64 = r.stderr.iter().flatten().map(|e| e * e).sum();
    (m, v.sqrt() / n)
}

fn view(object: &str) -> String {
    format!(
        "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [1, 2, 9]\nlook_at = [0, 0, \
         0]\nup = [0, 1, 0]\nfov_y = 40\nsize = [6, 6]\n[[light]]\ntype = \"environment\"\n\
         radiance = 1\n[[object]]\n{object}\nmaterial = \"m.toml\"\n"
    )
}

/// A closed OBJ cube and a flat heightfield render as the box they
/// describe (the same mean within 4 standard errors; the tracer meets
/// their triangles where it meets the box's faces).
#[test]
fn meshes_and_heightfields_render_as_their_box() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("m.toml"),
        "unit = \"mm\"\nsigma_a = 0.3\nsigma_s = 1.5\ng = 0.3\neta = 1.4\n",
    )
    .unwrap();
    // A cube from -2 to 2, wound counter-clockwise seen from outside.
    let obj = common::backlit_meshes::cube_obj(2.0);
    std::fs::write(d.join("cube.obj"), obj).unwrap();
    // A constant grey image: a flat top 1 mm above the base, the solid
    // 3 mm below it: the box from y = -3 to 1.
    let img = image::GrayImage::from_pixel(5, 4, image::Luma([255]));
    img.save(d.join("flat.png")).unwrap();
    let spp = 400;
    let (b, be) = mean_radiance(
        d,
        &view("shape = \"box\"\ncenter = [0, 0, 0]\nsize = [4, 4, 4]"),
        spp,
    );
    let (m, me) = mean_radiance(d, &view("shape = \"mesh\"\nfile = \"cube.obj\""), spp);
    eprintln!("box {b:.5} +- {be:.5}, mesh {m:.5} +- {me:.5}");
    assert!((b - m).abs() <= common::SIGMAS * (be * be + me * me).sqrt());
    let (hb, hbe) = mean_radiance(
        d,
        &view("shape = \"box\"\ncenter = [0, -1, 0]\nsize = [4, 4, 3]"),
        spp,
    );
    let (hf, hfe) = mean_radiance(
        d,
        &view(
            "shape = \"heightfield\"\nimage = \"flat.png\"\ncenter = [0, 0, 0]\nsize = [4, 3]\n\
             height = 1\ndepth = 3",
        ),
        spp,
    );
    eprintln!("box {hb:.5} +- {hbe:.5}, heightfield {hf:.5} +- {hfe:.5}");
    assert!((hb - hf).abs() <= common::SIGMAS * (hbe * hbe + hfe * hfe).sqrt());
    // Different shapes differ: the check can fail.
    assert!((b - hb).abs() > common::SIGMAS * (be * be + hbe * hbe).sqrt());
}

/// Each bad value is refused before anything is rendered, naming the field
/// and what is allowed.
#[test]
fn bad_scene_files_name_the_field() {
    let open_obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n";
    let dir = common::temp_with(&[("open.obj", open_obj), ("h.txt", "not an image")]);
    let d = dir.path();
    // One bad value a row: the text replaced in SPHERE, by what, and the
    // words the refusal must contain.
    #[rustfmt::skip] // one case a line: the table reads as a list
    let table: [(&str, &str, &[&str]); 20] = [
        ("unit = \"mm\"\n", "", &["unit", "state the scene's length unit"]),
        ("fov_y = 30", "fov_y = 180", &["camera.fov_y", "(0, 180)"]),
        ("fov_y = 30", "fov_y = nan", &["camera.fov_y"]),
        ("toward = [0.6, 0, 0.8]", "toward = [0.6, 0, 0.7]", &["light[0].toward", "unit vector"]),
        ("irradiance = 2", "irradiance = -1", &["light[0].irradiance[0]", ">= 0"]),
        ("size = [16, 12]", "size = [0, 12]", &["camera.size[0]"]),
        ("size = [16, 12]", "size = [100000, 100000]", &["camera.size[0]"]),
        ("size = [16, 12]", "size = [16]", &["camera.size", "[width, height]"]),
        ("look_at = [0, 0, 0]", "look_at = [0, 0, 60]", &["camera.up", "position != look_at"]),
        ("radius = 10", "radius = -1", &["object[0].radius", "> 0"]),
        ("radius = 10", "radius = 1e9", &["object[0].radius", "limited"]),
        ("shape = \"sphere\"", "shape = \"torus\"", &["object[0].shape", "\"box\""]),
        ("radius = 10", "radius = 10\nsize = [1, 2, 3]", &["object[0].size", "a sphere has no size"]),
        ("material = \"skin1\"", "material = \"nope\"", &["object[0].material", "nope"]),
        // Two changes in one: the sphere made a cylinder, eta 1.0 made 1.3.
        ("shape = \"sphere\"\ncenter = [0, 0, 0]\nradius = 10\nmaterial = \"skin1\"\neta = 1.0",
         "shape = \"cylinder\"\ncenter = [0, 0, 0]\nradius = 3\nheight = 4\nmaterial = \"skin1\"\neta = 1.3",
         &["object[0].eta", "environment light"]),
        ("eta = 1.0", "eta = 2.5", &["object[0].eta", "1 < eta <= 2"]),
        ("shape = \"sphere\"\ncenter = [0, 0, 0]\nradius = 10", "shape = \"mesh\"\nfile = \"open.obj\"",
         &["object[0].file", "not closed"]),
        ("shape = \"sphere\"\ncenter = [0, 0, 0]\nradius = 10",
         "shape = \"heightfield\"\nimage = \"h.txt\"\ncenter = [0, 0, 0]\nsize = [1, 1]\nheight = 1\ndepth = 1",
         &["grey PNG"]),
        ("[[light]]", "[[lamp]]", &["unknown field", "lamp"]),
        ("[[light]]\ntype = \"directional\"\ntoward = [0.6, 0, 0.8]\nirradiance = 2\n", "",
         &["light", "at least one"]),
    ];
    let cases: Vec<(String, &[&str])> = table
        .iter()
        .map(|&(from, to, needles)| (SPHERE.replace(from, to), needles))
        .collect();
    for (text, needles) in &cases {
        let e = match parse_scene_toml(text, "bad.toml", d) {
            Ok(_) => panic!("accepted: {needles:?}\n{text}"),
            Err(e) => e.to_string(),
        };
        for n in *needles {
            assert!(e.contains(n), "{needles:?}: {e}");
        }
    }
    // Through the binary: the message names the field, nothing is written.
    std::fs::write(d.join("bad.toml"), &cases[1].0).unwrap();
    fails_with(
        &[
            "scene",
            p(&d.join("bad.toml")),
            "--out",
            p(&d.join("x.exr")),
        ],
        &["camera.fov_y", "(0, 180)"],
    );
    assert!(!d.join("x.exr").exists());
    std::fs::write(d.join("s.toml"), SPHERE).unwrap();
    fails_with(
        &[
            "scene",
            p(&d.join("s.toml")),
            "--out",
            p(&d.join("x.exr")),
            "--spp",
            "0",
        ],
        &["--spp", "must be >= 2"],
    );
    fails_with(
        &["scene", p(&d.join("s.toml")), "--out", p(&d.join("x.png"))],
        &["x.png"],
    );
}
