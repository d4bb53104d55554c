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
    // Jensen et al. 2001, "A Practical Model for Subsurface Light
    // Transport", Table 1, marble: sigma_s' and sigma_a in 1/mm, eta 1.5.
    // The derived quantities from their definitions (sigma_t' = sigma_s' +
    // sigma_a, alpha' = sigma_s' / sigma_t', sigma_tr = sqrt(3 sigma_a
    // sigma_t'), eq. 4 of the same paper), not from ssskit's code.
    const SIGMA_S: [f64; 3] = [2.19, 2.62, 3.00];
    const SIGMA_A: [f64; 3] = [0.0021, 0.0041, 0.0071];
    /// Printed with 15+ digits; the formulas are a few flops each.
    const REL: f64 = 1e-12;
    let layer = &v[0]["material"]["layers"][0];
    assert_eq!(layer["eta"], 1.5);
    let close = |got: &serde_json::Value, want: f64, what: &str| {
        let got = got.as_f64().unwrap_or_else(|| panic!("{what}: {got}"));
        assert!(
            (got - want).abs() <= REL * want.abs(),
            "{what}: {got} against {want}"
        );
    };
    for c in 0..3 {
        let (s, a) = (SIGMA_S[c], SIGMA_A[c]);
        let t = s + a;
        close(&layer["sigma_s"][c], s, "sigma_s");
        close(&layer["sigma_a"][c], a, "sigma_a");
        close(&v[0]["reduced_albedo"][c], s / t, "reduced albedo");
        close(&v[0]["mfp_mm"][c], 1.0 / t, "mean free path");
        close(
            &v[0]["inv_sigma_tr_mm"][c],
            1.0 / (3.0 * a * t).sqrt(),
            "1 / sigma_tr",
        );
    }
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
