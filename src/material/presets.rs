//! Built-in materials, embedded from `profiles/materials/*.toml` so that
//! presets work from any directory while staying readable on disk.

use super::{parse_material_toml, Material};

/// `(name, TOML text)` of presets named by their file in
/// `profiles/materials/`.
macro_rules! presets {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!("../../profiles/materials/", $name, ".toml")))),*]
    };
}

/// (name, TOML text) of every preset.
pub const PRESETS: &[(&str, &str)] = presets![
    "apple",
    "chicken1",
    "chicken2",
    "cream",
    "ketchup",
    "marble",
    "potato",
    "skimmilk",
    "skin1",
    "skin2",
    "spectralon",
    "wholemilk",
    "coffee",
    "soymilk",
    "wine",
    "beer",
    "grapefruit",
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
