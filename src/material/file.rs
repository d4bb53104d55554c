//! The material TOML format. Single layer:
//!
//! ```toml
//! unit = "mm"            # or "cm"; required
//! sigma_a = [0.032, 0.17, 0.48]
//! sigma_s = [0.74, 0.88, 1.01]   # or sigma_s_reduced = [...] (sigma_s')
//! g = [0.0, 0.0, 0.0]    # or one number; default 0
//! eta = 1.3
//! thickness = 0.2        # optional; absent = semi-infinite
//! ```
//!
//! Layered: the same fields inside `[[layer]]` tables, with `eta_above` and
//! `eta_below` (ambient indices, default 1) at the top level.

use super::{Layer, Material};
use crate::error::{Error, Result};
use serde::Deserialize;

/// One value for all channels or three, `[r, g, b]`. Deserialised by hand:
/// an untagged enum would report a 2-value list as "did not match any
/// variant" at line 1, column 1.
pub(crate) struct PerChannel([f64; 3]);

impl<'de> Deserialize<'de> for PerChannel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = PerChannel;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("one number or a list of three numbers [r, g, b]")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> std::result::Result<PerChannel, E> {
                Ok(PerChannel([v; 3]))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> std::result::Result<PerChannel, E> {
                Ok(PerChannel([v as f64; 3]))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> std::result::Result<PerChannel, E> {
                Ok(PerChannel([v as f64; 3]))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<PerChannel, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    v.push(x);
                }
                match v.as_slice() {
                    &[r, g, b] => Ok(PerChannel([r, g, b])),
                    _ => Err(serde::de::Error::invalid_length(v.len(), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

impl PerChannel {
    pub(crate) fn rgb(&self) -> [f64; 3] {
        self.0
    }
}

/// Declares the file's two tables with one list of a layer's fields:
/// `RawLayer` (a `[[layer]]` table) and `RawMaterial` (the file), which
/// spells them at its top level for a single layer. They are spelled out
/// rather than flattened from `RawLayer`: serde's flatten buffers the
/// values and loses their position, so errors would point at line 1,
/// column 1. The order of the fields is the order an unknown-field error
/// lists them in.
macro_rules! raw_tables {
    (layer { $($field:ident: $ty:ty,)* }) => {
        /// One layer: the top-level fields of a single-layer file or a
        /// `[[layer]]` table.
        #[derive(Deserialize, Default)]
        #[serde(deny_unknown_fields)]
        struct RawLayer {
            $($field: Option<$ty>,)*
        }

        /// The file.
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct RawMaterial {
            name: Option<String>,
            unit: Option<String>,
            eta_above: Option<f64>,
            eta_below: Option<f64>,
            $($field: Option<$ty>,)*
            layer: Option<Vec<RawLayer>>,
        }

        impl RawLayer {
            /// Whether no field is given.
            fn is_empty(&self) -> bool {
                true $(&& self.$field.is_none())*
            }
        }

        impl RawMaterial {
            /// The top-level layer fields, taken out as one layer.
            fn take_top_layer(&mut self) -> RawLayer {
                RawLayer {
                    $($field: self.$field.take(),)*
                }
            }
        }
    };
}

raw_tables!(layer {
    sigma_a: PerChannel,
    sigma_s: PerChannel,
    sigma_s_reduced: PerChannel,
    g: PerChannel,
    eta: f64,
    thickness: f64,
});

/// A TOML error as one line naming the line and the field: "line 3, field
/// sigma_a: invalid length 2, expected one number or ...".
pub(crate) fn describe_toml_error(text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim().replace('\n', " ");
    let Some(span) = e.span() else {
        return msg;
    };
    let start = span.start.min(text.len());
    let line_no = text[..start].matches('\n').count() + 1;
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or("");
    let key = line
        .split_once('=')
        .map(|(k, _)| k.trim())
        .filter(|k| !k.is_empty() && !k.starts_with('['));
    match key {
        Some(k) => format!("line {line_no}, field {k}: {msg}"),
        None => format!("line {line_no}: {msg}"),
    }
}

/// Parses and validates a material file. `context` names the file in errors;
/// `default_name` is used when the file has no `name`.
pub fn parse_material_toml(text: &str, context: &str, default_name: &str) -> Result<Material> {
    let mut raw: RawMaterial = toml::from_str(text).map_err(|e| {
        Error::format(
            context,
            format!("malformed material TOML: {}", describe_toml_error(text, &e)),
        )
    })?;
    let single = raw.take_top_layer();
    let scale = unit_scale(raw.unit.as_deref(), context)?;
    let raw_layers = match (raw.layer, single.is_empty()) {
        (Some(_), false) => {
            return Err(Error::invalid(
                context,
                "layer",
                "both",
                "give either top-level coefficients or [[layer]] tables, not both",
            ))
        }
        (Some(ls), true) => ls,
        (None, _) => vec![single],
    };
    let n = raw_layers.len();
    let layers = raw_layers
        .into_iter()
        .enumerate()
        .map(|(i, rl)| {
            let field = |f: &str| {
                if n == 1 {
                    f.to_string()
                } else {
                    format!("layer[{i}].{f}")
                }
            };
            parse_layer(rl, &field, scale, context)
        })
        .collect::<Result<Vec<_>>>()?;
    let m = Material {
        name: raw.name.unwrap_or_else(|| default_name.to_string()),
        eta_above: raw.eta_above.unwrap_or(1.0),
        eta_below: raw.eta_below.unwrap_or(1.0),
        layers,
    };
    m.validate(context)?;
    Ok(m)
}

/// Millimetres per unit of the file's lengths: its coefficients are
/// multiplied by it, its thicknesses divided.
fn unit_scale(unit: Option<&str>, context: &str) -> Result<f64> {
    match unit {
        Some("mm") => Ok(1.0),
        Some("cm") => Ok(0.1),
        Some(u) => Err(Error::invalid(
            context,
            "unit",
            format!("\"{u}\""),
            "expected \"mm\" or \"cm\"",
        )),
        None => Err(Error::invalid(
            context,
            "unit",
            "missing",
            "state the unit of the coefficients: unit = \"mm\" or \"cm\"",
        )),
    }
}

/// One layer in millimetres; `field` names a field of this layer in errors.
fn parse_layer(
    rl: RawLayer,
    field: &dyn Fn(&str) -> String,
    scale: f64,
    context: &str,
) -> Result<Layer> {
    let sigma_a = rl
        .sigma_a
        .ok_or_else(|| Error::invalid(context, field("sigma_a"), "missing", "required"))?
        .rgb();
    let g = rl.g.map(|g| g.rgb()).unwrap_or([0.0; 3]);
    let sigma_s = scattering(rl.sigma_s, rl.sigma_s_reduced, g, field, context)?;
    let eta = rl
        .eta
        .ok_or_else(|| Error::invalid(context, field("eta"), "missing", "required"))?;
    Ok(Layer {
        sigma_a: sigma_a.map(|v| v * scale),
        sigma_s: sigma_s.map(|v| v * scale),
        g,
        eta,
        thickness: rl.thickness.map(|t| t / scale),
    })
}

/// The scattering coefficient, given as sigma_s or as sigma_s' = (1 - g)
/// sigma_s (one of the two).
fn scattering(
    sigma_s: Option<PerChannel>,
    reduced: Option<PerChannel>,
    g: [f64; 3],
    field: &dyn Fn(&str) -> String,
    context: &str,
) -> Result<[f64; 3]> {
    match (sigma_s, reduced) {
        (Some(s), None) => Ok(s.rgb()),
        // sigma_s = sigma_s' / (1 - g); |g| < 1 is checked by the
        // validation, guard here only against the division itself.
        (None, Some(r)) => {
            let r = r.rgb();
            let mut s = [0.0; 3];
            for c in 0..3 {
                if !(g[c].abs() < 1.0) {
                    return Err(Error::invalid(
                        context,
                        format!("{}[{c}]", field("g")),
                        g[c],
                        "anisotropy must satisfy |g| < 1",
                    ));
                }
                s[c] = r[c] / (1.0 - g[c]);
            }
            Ok(s)
        }
        (Some(_), Some(_)) => Err(Error::invalid(
            context,
            field("sigma_s"),
            "both",
            "give sigma_s or sigma_s_reduced, not both",
        )),
        (None, None) => Err(Error::invalid(
            context,
            field("sigma_s"),
            "missing",
            "required (or sigma_s_reduced)",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIMPLE: &str = "unit = \"mm\"\nsigma_a = [0.032, 0.17, 0.48]\nsigma_s = [0.74, 0.88, 1.01]\ng = [0.0, 0.0, 0.0]\neta = 1.3\nthickness = 0.2\n";

    #[test]
    fn simple_form_parses() {
        let m = parse_material_toml(SIMPLE, "t.toml", "t").unwrap();
        assert_eq!(m.layers.len(), 1);
        assert_eq!(m.layers[0].thickness, Some(0.2));
        assert_eq!(m.name, "t");
    }

    #[test]
    fn cm_converts_to_mm() {
        let t = "unit = \"cm\"\nsigma_a = 0.32\nsigma_s = 7.4\neta = 1.3\nthickness = 2\n";
        let m = parse_material_toml(t, "c.toml", "c").unwrap();
        assert!((m.layers[0].sigma_a[0] - 0.032).abs() < 1e-15);
        assert!((m.layers[0].sigma_s[2] - 0.74).abs() < 1e-15);
        assert_eq!(m.layers[0].thickness, Some(20.0));
    }

    #[test]
    fn reduced_scattering_with_g() {
        let t = "unit = \"mm\"\nsigma_a = 0.1\nsigma_s_reduced = 1.0\ng = 0.9\neta = 1.4\n";
        let m = parse_material_toml(t, "x", "x").unwrap();
        assert!((m.layers[0].sigma_s[1] - 10.0).abs() < 1e-12);
    }

    #[test]
    fn layered_form() {
        let t = "unit = \"mm\"\neta_above = 1.0\neta_below = 1.4\n[[layer]]\nsigma_a = 0.1\nsigma_s = 1\neta = 1.4\nthickness = 0.1\n[[layer]]\nsigma_a = 0.01\nsigma_s = 2\ng = 0.8\neta = 1.37\n";
        let m = parse_material_toml(t, "l", "l").unwrap();
        assert_eq!(m.layers.len(), 2);
        assert!(m.layers[1].thickness.is_none());
        assert!(!m.is_half_space());
    }

    fn err(t: &str) -> String {
        parse_material_toml(t, "bad.toml", "b")
            .unwrap_err()
            .to_string()
    }

    /// The single-layer and the layered form take one list of layer
    /// fields: an unknown field names every field its table accepts, in
    /// order, and a file giving any layer field at the top level and
    /// `[[layer]]` tables is refused.
    #[test]
    fn both_forms_take_the_same_layer_fields() {
        let layer = "`sigma_a`, `sigma_s`, `sigma_s_reduced`, `g`, `eta`, `thickness`";
        let e = err("unit = \"mm\"\nsigma_z = 1\n");
        let top =
            format!("expected one of `name`, `unit`, `eta_above`, `eta_below`, {layer}, `layer`");
        assert!(e.contains(&top), "{e}");
        let e = err("unit = \"mm\"\n[[layer]]\nsigma_z = 1\n");
        assert!(e.contains(&format!("expected one of {layer}")), "{e}");
        for field in [
            "sigma_a = 0.1",
            "sigma_s = 1",
            "sigma_s_reduced = 1",
            "g = 0",
            "eta = 1.3",
            "thickness = 1",
        ] {
            let e = err(&format!(
                "unit = \"mm\"\n{field}\n[[layer]]\nsigma_a = 0.1\nsigma_s = 1\neta = 1.3\n"
            ));
            assert!(
                e.contains("layer = both") && e.contains("not both"),
                "{field}: {e}"
            );
        }
    }

    #[test]
    fn invalid_inputs_are_named() {
        let base = |extra: &str, sa: &str, g: &str, eta: &str| {
            format!("unit = \"mm\"\nsigma_a = {sa}\nsigma_s = 1.0\ng = {g}\neta = {eta}\n{extra}")
        };
        let e = err(&base("", "-0.1", "0", "1.3"));
        assert!(
            e.contains("bad.toml") && e.contains("sigma_a[r]") && e.contains("-0.1"),
            "{e}"
        );
        let e = err(&base("", "nan", "0", "1.3"));
        assert!(e.contains("sigma_a[r]") && e.contains("NaN"), "{e}");
        let e = err(&base("", "inf", "0", "1.3"));
        assert!(e.contains("sigma_a[r]") && e.contains("inf"), "{e}");
        let e = err(&base("", "0.1", "1.0", "1.3"));
        assert!(e.contains("g[r]") && e.contains("|g| < 1"), "{e}");
        let e = err(&base("", "0.1", "-1.5", "1.3"));
        assert!(e.contains("g[r]"), "{e}");
        let e = err(&base("", "0.1", "0", "0"));
        assert!(e.contains("eta") && e.contains("> 0"), "{e}");
        let e = err(&base("thickness = 0\n", "0.1", "0", "1.3"));
        assert!(e.contains("thickness"), "{e}");
        let e = err(&base("thickness = -2\n", "0.1", "0", "1.3"));
        assert!(e.contains("thickness") && e.contains("-2"), "{e}");
        let e = err("unit = \"mm\"\nsigma_a = 0\nsigma_s = 0\neta = 1.3\n");
        assert!(e.contains("zero extinction"), "{e}");
        let e = err("unit = \"inch\"\nsigma_a = 0\nsigma_s = 1\neta = 1.3\n");
        assert!(e.contains("unit") && e.contains("inch"), "{e}");
        let e = err("sigma_a = 0\nsigma_s = 1\neta = 1.3\n");
        assert!(e.contains("unit") && e.contains("missing"), "{e}");
        let e = err("unit = \"mm\"\nsigma_a = 0\nsigma_z = 1\neta = 1.3\n");
        assert!(e.contains("sigma_z"), "{e}");
        let e = err("unit = \"mm\"\n[[layer]]\nsigma_a = 0.1\nsigma_s = 1\neta = 1.3\n[[layer]]\nsigma_a = 0.1\nsigma_s = 1\neta = 1.3\n");
        assert!(
            e.contains("layer[0].thickness") && e.contains("semi-infinite"),
            "{e}"
        );
    }
}
