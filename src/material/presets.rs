//! Built-in materials, embedded from `profiles/materials/*.toml` so that
//! presets work from any directory while staying readable on disk.

use super::{parse_material_toml, Material};

/// (name, TOML text) of every preset.
pub const PRESETS: &[(&str, &str)] = &[
    ("apple", include_str!("../../profiles/materials/apple.toml")),
    (
        "chicken1",
        include_str!("../../profiles/materials/chicken1.toml"),
    ),
    (
        "chicken2",
        include_str!("../../profiles/materials/chicken2.toml"),
    ),
    ("cream", include_str!("../../profiles/materials/cream.toml")),
    (
        "ketchup",
        include_str!("../../profiles/materials/ketchup.toml"),
    ),
    (
        "marble",
        include_str!("../../profiles/materials/marble.toml"),
    ),
    (
        "potato",
        include_str!("../../profiles/materials/potato.toml"),
    ),
    (
        "skimmilk",
        include_str!("../../profiles/materials/skimmilk.toml"),
    ),
    ("skin1", include_str!("../../profiles/materials/skin1.toml")),
    ("skin2", include_str!("../../profiles/materials/skin2.toml")),
    (
        "spectralon",
        include_str!("../../profiles/materials/spectralon.toml"),
    ),
    (
        "wholemilk",
        include_str!("../../profiles/materials/wholemilk.toml"),
    ),
    (
        "coffee",
        include_str!("../../profiles/materials/coffee.toml"),
    ),
    (
        "soymilk",
        include_str!("../../profiles/materials/soymilk.toml"),
    ),
    ("wine", include_str!("../../profiles/materials/wine.toml")),
    ("beer", include_str!("../../profiles/materials/beer.toml")),
    (
        "grapefruit",
        include_str!("../../profiles/materials/grapefruit.toml"),
    ),
];

pub fn preset_names() -> Vec<&'static str> {
    PRESETS.iter().map(|(n, _)| *n).collect()
}

/// The preset called `name` (case-insensitive), parsed and validated.
pub fn preset(name: &str) -> Option<Material> {
    let lower = name.to_ascii_lowercase();
    PRESETS.iter().find(|(n, _)| *n == lower).map(|(n, text)| {
        parse_material_toml(text, &format!("preset {n}"), n)
            .expect("built-in presets are valid (checked by tests)")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_parses_and_validates() {
        for (n, text) in PRESETS {
            let m = parse_material_toml(text, n, n).unwrap();
            assert_eq!(&m.name, n);
            assert!(m.is_half_space());
        }
    }

    #[test]
    fn preset_values_match_reference_table() {
        // Jensen et al. 2001 (in mm^-1 as Livermore 2012, fig. 40).
        let m = preset("marble").unwrap();
        assert_eq!(m.layers[0].sigma_s, [2.19, 2.62, 3.00]);
        assert_eq!(m.layers[0].sigma_a, [0.0021, 0.0041, 0.0071]);
        assert_eq!(m.layers[0].eta, 1.5);
        let c = preset("coffee").unwrap();
        assert_eq!(c.layers[0].g, [0.907, 0.896, 0.88]);
        assert_eq!(preset("spectralon").unwrap().layers[0].sigma_a, [0.0; 3]);
        assert_eq!(preset("apple").unwrap().layers[0].sigma_a[2], 0.046);
    }
}
