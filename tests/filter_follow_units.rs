//! The depth-aware lerp (Freude 2014, eq. 4.12) does not depend on the
//! scene's length unit: the same scene in millimetres and in metres gives
//! the same image with `FollowSurface::InMetres` (`--follow-surface`), and
//! Jimenez's C = 300 for a scene in metres keeps its meaning. The old rate
//! (`InSceneUnits`, `--follow-surface-scene-units`) stays available and
//! equals the new one in metres.

mod filter_support;
use filter_support::*;
use ssskit::filter::image::PngDepth;
use ssskit::filter::{cpu, taps_for, FollowSurface, Image, Plane, Scale, Setup, Which};

/// A bright disc on a dimmer wall, the disc nearer: `depth_m` in metres,
/// given in scene units of `unit_m` metres each.
fn scene(unit_m: f64) -> (Image, Plane) {
    let (w, h) = (40, 32);
    let mut img = Image::new(w, h);
    let mut depth = Plane {
        width: w,
        height: h,
        data: vec![0.0; w * h],
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (dx, dy) = (x as f64 - 20.0, y as f64 - 16.0);
            let disc = dx * dx + dy * dy < 100.0;
            // Depth varies across the wall too, so that small differences
            // are lerped by part, not all or nothing.
            let depth_m = if disc { 0.5 } else { 0.52 + 0.002 * x as f64 };
            depth.data[i] = depth_m / unit_m;
            for c in 0..3 {
                img.rgb[c][i] = if disc { 1.0 } else { 0.2 + 0.05 * c as f64 };
            }
        }
    }
    (img, depth)
}

fn setup(unit_m: f64, depth: Plane, follow: FollowSurface) -> Setup {
    let k = gaussian_kernel(2, 17);
    let passes = taps_for(&k, Which::stored(&k), None).unwrap();
    // A kernel millimetre is a millimetre of the scene.
    perspective_setup(passes, (30.0, 0.001 / unit_m), depth, follow)
}

#[test]
fn the_lerp_does_not_depend_on_the_scene_unit() {
    let run = |unit_m: f64, f: FollowSurface| {
        let (img, depth) = scene(unit_m);
        cpu::apply(&img, &setup(unit_m, depth, f)).unwrap()
    };
    // Metres, millimetres, inches: one image with the unit-safe constant.
    for c in [300.0, 3e5] {
        let metres = run(1.0, FollowSurface::InMetres(c));
        for unit in [0.001, 0.0254] {
            let other = run(unit, FollowSurface::InMetres(c));
            let e = max_rel(&metres, &other);
            assert!(e < F64_REL, "C {c}, unit {unit} m: {e}");
        }
        // In metres the old rate is the same lerp.
        let old_m = run(1.0, FollowSurface::InSceneUnits(c));
        assert!(max_rel(&metres, &old_m) < F64_REL);
    }
    // In millimetres the old rate is not (a million times faster:
    // everything off the disc's depth snaps back).
    let metres = run(1.0, FollowSurface::InMetres(300.0));
    let old_mm = run(0.001, FollowSurface::InSceneUnits(300.0));
    assert!(
        max_rel(&metres, &old_mm) > 1e-2,
        "{}",
        max_rel(&metres, &old_mm)
    );
    // Jimenez's 300 at the kernel's physical size lerps by 1.1e-3 per mm of
    // depth at this field of view (t = 0.022 across the disc's 2 cm step):
    // almost no change; C = 3e5 (1.1 per mm) keeps the disc apart.
    let none = {
        let (img, depth) = scene(1.0);
        let mut s = setup(1.0, depth, FollowSurface::InMetres(0.0));
        s.follow_surface = None;
        cpu::apply(&img, &s).unwrap()
    };
    let weak = max_rel(&metres, &none);
    let strong = max_rel(&run(1.0, FollowSurface::InMetres(3e5)), &none);
    eprintln!("change by the lerp: {weak:.2e} (C = 300), {strong:.2e} (C = 3e5)");
    assert!(
        weak > 0.0 && weak < 1e-3 && strong > 1e-2,
        "{weak} {strong}"
    );
}

/// The rates themselves: Freude 2014, eq. 4.12 (k = C sss_width /
/// tan(fov_y / 2), orthographic k = C) for the old reading; for the new one
/// the same with lengths in metres.
#[test]
fn the_rates_are_eq_4_12_in_metres() {
    let tan = (15f64).to_radians().tan();
    let persp = |w: f64| Scale::Perspective {
        fov_y_deg: 30.0,
        sss_width: w,
    };
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(close(
        FollowSurface::InSceneUnits(300.0).rate(&persp(0.02)),
        300.0 * 0.02 / tan
    ));
    // Scene in mm (sss_width 1): a depth difference of 1 mm is 0.001 m.
    assert!(close(
        FollowSurface::InMetres(300.0).rate(&persp(1.0)),
        300.0 * 0.001 * 0.001 / tan
    ));
    assert!(close(
        FollowSurface::InMetres(300.0).rate(&persp(0.001)),
        FollowSurface::InSceneUnits(300.0).rate(&persp(0.001))
    ));
    let ortho = Scale::MmPerPixel(0.1);
    assert!(close(
        FollowSurface::InSceneUnits(300.0).rate(&ortho),
        300.0
    ));
    assert!(close(FollowSurface::InMetres(300.0).rate(&ortho), 0.3));
}

/// The CLI: `--follow-surface` is the unit-safe constant (same output for
/// the scene in metres and in millimetres), `--follow-surface-scene-units`
/// the old one; they exclude each other and bad values name their flag.
#[test]
fn apply_follow_surface_is_unit_safe() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let k = d.join("k.json");
    gaussian_kernel(1, 11).write(&k).unwrap();
    let mut outs = vec![];
    for (unit, width, flag) in [
        (1.0, "0.001", "--follow-surface"),
        (0.001, "1", "--follow-surface"),
        (1.0, "0.001", "--follow-surface-scene-units"),
        (0.001, "1", "--follow-surface-scene-units"),
    ] {
        let (img, depth) = scene(unit);
        let input = d.join("in.exr");
        let depth_file = d.join("z.exr");
        ssskit::filter::image::write_image(&input, &img, PngDepth::Eight).unwrap();
        let dimg = Image {
            width: depth.width,
            height: depth.height,
            rgb: [depth.data.clone(), depth.data.clone(), depth.data.clone()],
            alpha: None,
        };
        ssskit::filter::image::write_image(&depth_file, &dimg, PngDepth::Eight).unwrap();
        let out = d.join(format!("o{}.exr", outs.len()));
        let args = [
            "apply",
            "--kernel",
            p(&k),
            "--input",
            p(&input),
            "--depth",
            p(&depth_file),
            "--depth-channel",
            "R",
            "--fov-y",
            "30",
            "--units-per-mm",
            width,
            flag,
            "300",
            "--backend",
            "cpu",
            "--out",
            p(&out),
        ];
        let o = run(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        outs.push(ssskit::filter::image::read_image(&out, None).unwrap().0);
    }
    assert!(
        max_rel(&outs[0], &outs[1]) < F32_OUTPUT,
        "{}",
        max_rel(&outs[0], &outs[1])
    );
    assert!(max_rel(&outs[0], &outs[2]) < F32_OUTPUT);
    assert!(max_rel(&outs[0], &outs[3]) > 1e-2);
    let (input, z, x) = (d.join("in.exr"), d.join("z.exr"), d.join("x.exr"));
    let base = apply_args(p(&k), p(&input), p(&x), "0.1", &[]);
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let args = with(&["--follow-surface", "1", "--follow-surface-scene-units", "1"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    assert_fails(&run(&args), &args, &["--follow-surface"]);
    for flag in ["--follow-surface", "--follow-surface-scene-units"] {
        let a = with(&[
            &format!("{flag}=-1"),
            "--depth",
            p(&z),
            "--depth-channel",
            "R",
        ]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        assert_fails(
            &run(&a),
            &a,
            &[&format!("{flag}: invalid value -1: must be")],
        );
    }
}
