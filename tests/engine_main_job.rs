//! From the main job into the engine: `kernels --engine` writes the
//! engine's files beside recommended.json and report.md says how to
//! import them; `engine --material` makes the profile as `kernels` does.
//! The oracle of each file's content is tests/engine_files.rs and
//! tests/engine_unreal_script.rs; here, that the main job writes what
//! `ssskit engine` writes for the same profile.

mod common;
use common::args::engine_args;
use common::*;
use serde_json::Value;

/// The quickest main job: an analytic profile, small signals, no plots.
const MATERIAL: [&str; 4] = ["--material", "skin1", "--profile-model", "burley"];

/// `ssskit cmd` on `MATERIAL`, then `extra`.
fn on_material<'a>(cmd: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&[cmd][..], &MATERIAL, extra].concat()
}

#[test]
fn kernels_writes_the_engines_files_and_says_how_to_import_them() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("k");
    let text = ok(&on_material(
        "kernels",
        &[
            "--signal-size",
            "48",
            "--no-plots",
            "--engine",
            "unreal",
            "--out-dir",
            p(&out),
        ],
    ));
    for f in ["recommended.json", "skin1-unreal.json", "skin1-unreal.py"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(text.contains("skin1-unreal.py"), "{text}");
    // The report's section lists each file (a link) with how to import it.
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let at = md.find("## Into unreal").expect("an engine section");
    let section = &md[at..];
    assert!(section.contains("[skin1-unreal.py](skin1-unreal.py)"));
    assert!(section.contains("Execute Python Script"), "{section}");
    assert!(
        md.find("## Stage times").unwrap() > at,
        "the section is before the stage times"
    );
    // The same values as `ssskit engine` on the profile the job made.
    let job: Value = read_json(&out.join("skin1-unreal.json"));
    let again = tmp.path().join("again.json");
    let profile = out.join("profile.json");
    ok(&engine_args(p(&profile), "unreal", &["--out", p(&again)]));
    assert_eq!(read_json(&again)["params"], job["params"]);
    // And `engine --material` makes that profile as the main job did.
    let made = tmp.path().join("made.json");
    ok(&on_material(
        "engine",
        &["--engine", "unreal", "--out", p(&made)],
    ));
    assert_eq!(read_json(&made)["params"], job["params"]);
}

#[test]
fn kernels_refuses_an_engine_without_files_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("k");
    let args = on_material("kernels", &["--engine", "iryoku", "--out-dir", p(&out)]);
    fails_with(&args, &["--engine", "iryoku"]);
    assert!(!out.exists());
}

#[test]
fn engine_needs_a_profile_or_a_material() {
    fails_with(
        &["engine", "--engine", "unreal"],
        &["--material", "--profile"],
    );
}
