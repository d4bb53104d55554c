//! `ssskit materials` and material-file errors, through the real binary.

mod common;
use common::run as ssskit;

#[test]
fn lists_every_preset_with_derived_quantities() {
    let out = ssskit(&["materials"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for name in ssskit::material::preset_names() {
        assert_eq!(
            text.lines()
                .filter(|l| l.starts_with(&format!("{name} ")))
                .count(),
            3,
            "{name}"
        );
    }
    // skin1 red: albedo' = 0.74 / 0.772, MFP = 1/0.772 mm (Jensen et al. 2001).
    let row = text
        .lines()
        .find(|l| l.starts_with("skin1 ") && l.contains(" r "))
        .unwrap();
    assert!(row.contains("0.95855") && row.contains("1.2953"), "{row}");
}

#[test]
fn json_output_parses() {
    let out = ssskit(&["materials", "--json", "marble"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v[0]["material"]["layers"][0]["eta"], 1.5);
}

#[test]
fn bad_material_file_names_file_field_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("wax.toml");
    std::fs::write(
        &p,
        "unit = \"mm\"\nsigma_a = [0.1, -0.2, 0.1]\nsigma_s = 1\neta = 1.4\n",
    )
    .unwrap();
    let out = ssskit(&["materials", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("wax.toml") && err.contains("sigma_a[g]") && err.contains("-0.2"),
        "{err}"
    );
}

#[test]
fn unknown_preset_lists_the_known_ones() {
    let out = ssskit(&["materials", "jade"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("jade") && err.contains("marble"), "{err}");
}
