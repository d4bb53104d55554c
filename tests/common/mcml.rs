//! Reading MCML 1.2.2's output (.mco, Wang et al. 1995) and
//! the JSON arrays of the records it is compared with; shared by the
//! tests and the benches that run MCML (include with
//! `#[path = "../tests/common/mcml.rs"] mod mcml;` from a bench).

/// The numbers of a section of an .mco file (after its tag line up to the
/// next empty line).
pub fn section(text: &str, tag: &str) -> Vec<f64> {
    text.lines()
        .skip_while(|l| !l.starts_with(tag))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .flat_map(|l| l.split_whitespace().filter_map(|v| v.parse().ok()))
        .collect()
}

/// The numbers of a JSON array.
pub fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The benches' `SSSKIT_BENCH_SCALE` (photons and runs scaled by it; 1
/// unset or unreadable).
pub fn bench_scale() -> f64 {
    std::env::var("SSSKIT_BENCH_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0)
}
