//! Optical description of a material: coefficients per RGB channel, indices of
//! refraction, and an optional stack of layers. Everything inside the library
//! is in millimetres (coefficients in mm^-1); files state their unit.

mod file;
mod presets;

pub use file::parse_material_toml;
pub(crate) use file::{describe_toml_error, PerChannel};
pub use presets::{preset, preset_names, PRESETS};

use crate::error::{finite_non_negative, finite_positive, Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One colour channel. Each is simulated and fitted independently.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    R,
    G,
    B,
}

impl Channel {
    pub const ALL: [Channel; 3] = [Channel::R, Channel::G, Channel::B];

    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        ["r", "g", "b"][self.index()]
    }

    /// Parses "rgb", "r", "gb", ... into channels in R, G, B order.
    pub fn parse_list(s: &str) -> Result<Vec<Channel>> {
        let mut out = Vec::new();
        for c in s.chars() {
            let ch = match c.to_ascii_lowercase() {
                'r' => Channel::R,
                'g' => Channel::G,
                'b' => Channel::B,
                _ => {
                    return Err(Error::invalid(
                        "channels",
                        "channel",
                        c,
                        "expected letters among r, g, b",
                    ))
                }
            };
            if !out.contains(&ch) {
                out.push(ch);
            }
        }
        if out.is_empty() {
            return Err(Error::invalid("channels", "channels", "''", "empty"));
        }
        out.sort();
        Ok(out)
    }
}

/// One homogeneous layer. `thickness: None` means semi-infinite (only allowed
/// for the last layer).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layer {
    /// Absorption coefficient per channel, mm^-1.
    pub sigma_a: [f64; 3],
    /// Scattering coefficient per channel, mm^-1 (not reduced).
    pub sigma_s: [f64; 3],
    /// Henyey-Greenstein anisotropy per channel.
    pub g: [f64; 3],
    /// Refractive index of the layer.
    pub eta: f64,
    /// Thickness in mm; `None` is semi-infinite.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thickness: Option<f64>,
}

/// A material: a stack of layers between two ambient media.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub name: String,
    /// Refractive index of the medium light comes from (air = 1).
    pub eta_above: f64,
    /// Refractive index below the last layer (used only for finite stacks).
    pub eta_below: f64,
    pub layers: Vec<Layer>,
}

/// The scalar optical properties of one layer in one channel, with the
/// derived quantities of Jensen et al. 2001.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    pub sigma_a: f64,
    pub sigma_s: f64,
    pub g: f64,
    /// Relative index n_medium / n_outside.
    pub eta: f64,
}

impl Medium {
    pub fn sigma_t(&self) -> f64 {
        self.sigma_a + self.sigma_s
    }
    /// sigma_s' = (1 - g) sigma_s
    pub fn sigma_s_reduced(&self) -> f64 {
        (1.0 - self.g) * self.sigma_s
    }
    /// sigma_t' = sigma_a + sigma_s'
    pub fn sigma_t_reduced(&self) -> f64 {
        self.sigma_a + self.sigma_s_reduced()
    }
    /// Single-scattering albedo sigma_s / sigma_t.
    pub fn albedo(&self) -> f64 {
        self.sigma_s / self.sigma_t()
    }
    /// Reduced albedo alpha' = sigma_s' / sigma_t'.
    pub fn reduced_albedo(&self) -> f64 {
        self.sigma_s_reduced() / self.sigma_t_reduced()
    }
    /// Transport mean free path 1 / sigma_t' (mm).
    pub fn mfp(&self) -> f64 {
        1.0 / self.sigma_t_reduced()
    }
    /// Classical diffusion coefficient D = 1 / (3 sigma_t').
    pub fn diffusion_coefficient(&self) -> f64 {
        1.0 / (3.0 * self.sigma_t_reduced())
    }
    /// Effective transport coefficient sigma_tr = sqrt(3 sigma_a sigma_t').
    pub fn sigma_tr(&self) -> f64 {
        (3.0 * self.sigma_a * self.sigma_t_reduced()).sqrt()
    }
}

impl Material {
    /// Loads a preset by name, or a TOML file when `spec` is a path that
    /// exists (or ends in .toml).
    pub fn load(spec: &str) -> Result<Material> {
        let path = Path::new(spec);
        // A folder is never a material: a preset's name resolves to the
        // preset even where a folder of that name (an output folder named
        // after the material, say) sits in the working directory.
        if path.is_dir() {
            return preset(spec).ok_or_else(|| {
                Error::Unsupported(format!(
                    "'{spec}' is a folder, not a material TOML file or preset (presets: {})",
                    preset_names().join(", ")
                ))
            });
        }
        if path.exists() || spec.ends_with(".toml") {
            let text = crate::io::read_text_capped(
                path,
                crate::limits::MAX_MATERIAL_BYTES,
                "material TOML file",
            )?;
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "material".into());
            return parse_material_toml(&text, &path.display().to_string(), &stem);
        }
        preset(spec).ok_or_else(|| {
            Error::Unsupported(format!(
                "unknown material preset or missing file '{spec}' (presets: {})",
                preset_names().join(", ")
            ))
        })
    }

    /// The optical properties of layer `layer` in channel `ch`, with eta
    /// relative to the ambient medium above the stack.
    pub fn medium(&self, layer: usize, ch: Channel) -> Medium {
        let l = &self.layers[layer];
        let c = ch.index();
        Medium {
            sigma_a: l.sigma_a[c],
            sigma_s: l.sigma_s[c],
            g: l.g[c],
            eta: l.eta / self.eta_above,
        }
    }

    /// The top layer's medium: what half-space models (dipole, ...) use.
    pub fn top(&self, ch: Channel) -> Medium {
        self.medium(0, ch)
    }

    /// True for one semi-infinite layer: the case analytic models describe.
    pub fn is_half_space(&self) -> bool {
        self.layers.len() == 1 && self.layers[0].thickness.is_none()
    }

    /// The name as part of a file name: see [`crate::io::file_stem`]. A
    /// name is a label, never a path.
    pub fn file_stem(&self) -> String {
        crate::io::file_stem(&self.name)
    }

    /// [`Material::validate`] with the material named in the errors
    /// ("material 'NAME'").
    pub fn validate_named(&self) -> Result<()> {
        self.validate(&format!("material '{}'", self.name))
    }

    /// Checks every parameter; `context` names the file or preset in errors.
    pub fn validate(&self, context: &str) -> Result<()> {
        check_name(context, &self.name)?;
        finite_positive(context, "eta_above", self.eta_above, "")?;
        finite_positive(context, "eta_below", self.eta_below, "")?;
        if self.layers.is_empty() {
            return Err(Error::invalid(
                context,
                "layers",
                "[]",
                "at least one layer is required",
            ));
        }
        let n = self.layers.len();
        for (i, l) in self.layers.iter().enumerate() {
            let lname = |f: &str| {
                if n == 1 {
                    f.to_string()
                } else {
                    format!("layer[{i}].{f}")
                }
            };
            for c in Channel::ALL {
                let k = c.index();
                let sa = l.sigma_a[k];
                let ss = l.sigma_s[k];
                let g = l.g[k];
                finite_non_negative(context, &format!("{}[{}]", lname("sigma_a"), c.name()), sa)?;
                finite_non_negative(context, &format!("{}[{}]", lname("sigma_s"), c.name()), ss)?;
                if !g.is_finite() || g.abs() >= 1.0 {
                    return Err(Error::invalid(
                        context,
                        format!("{}[{}]", lname("g"), c.name()),
                        g,
                        "anisotropy must satisfy |g| < 1",
                    ));
                }
                if sa + ss <= 0.0 {
                    return Err(Error::invalid(
                        context,
                        format!("{}[{}]", lname("sigma_t"), c.name()),
                        sa + ss,
                        "zero extinction: sigma_a + sigma_s must be > 0",
                    ));
                }
                for (f, v) in [("sigma_a", sa), ("sigma_s", ss)] {
                    if v > MAX_COEFFICIENT {
                        return Err(Error::invalid(
                            context,
                            format!("{}[{}]", lname(f), c.name()),
                            v,
                            format!(
                                "above {MAX_COEFFICIENT:.0e} per mm (a mean free path under a \
                                 picometre): check the unit"
                            ),
                        ));
                    }
                }
                let st = sa + (1.0 - g) * ss;
                if !(st >= 1.0 / MAX_MFP) {
                    return Err(Error::invalid(
                        context,
                        format!("{}[{}]", lname("sigma_t'"), c.name()),
                        st,
                        format!(
                            "sigma_a + (1 - g) sigma_s is below {:.0e} per mm: a transport mean \
                             free path over {MAX_MFP:.0e} mm, too long for any radial grid; \
                             check the unit",
                            1.0 / MAX_MFP
                        ),
                    ));
                }
            }
            finite_positive(context, &lname("eta"), l.eta, "")?;
            match l.thickness {
                Some(t) => {
                    finite_positive(context, &lname("thickness"), t, "")?;
                }
                None if i + 1 < n => {
                    return Err(Error::invalid(
                        context,
                        lname("thickness"),
                        "none",
                        "only the last layer may be semi-infinite",
                    ))
                }
                None => {}
            }
        }
        Ok(())
    }
}

/// Largest scattering or absorption coefficient, mm^-1 (a mean free path
/// of a picometre): beyond it the radial grid (MFP / 20) and its bin areas
/// underflow.
pub const MAX_COEFFICIENT: f64 = 1e9;
/// Longest transport mean free path 1 / sigma_t', mm: beyond it the grid's
/// radius (thousands of MFP) and its bin areas overflow.
pub const MAX_MFP: f64 = 1e9;

/// Longest material name, in bytes.
pub const MAX_NAME_BYTES: usize = 200;

/// The characters of Unicode's general category Cf (format): invisible,
/// they change how the text around them is shown or joined (direction
/// overrides and marks, zero-width spaces and joiners, the soft hyphen,
/// invisible operators, interlinear annotation, tags), so that two names
/// that look alike differ. The code points of category Cf in the Unicode
/// Character Database as Python's `unicodedata` (Unicode 14.0) lists
/// them, with U+13439..U+1343F, the Egyptian hieroglyph format controls
/// Unicode 15.0 added; the tag block U+E0000..U+E007F is taken whole (its
/// unassigned points included).
const FORMAT_CHARACTERS: &[(u32, u32)] = &[
    (0x00AD, 0x00AD),
    (0x0600, 0x0605),
    (0x061C, 0x061C),
    (0x06DD, 0x06DD),
    (0x070F, 0x070F),
    (0x0890, 0x0891),
    (0x08E2, 0x08E2),
    (0x180E, 0x180E),
    (0x200B, 0x200F),
    (0x202A, 0x202E),
    (0x2060, 0x2064),
    (0x2066, 0x206F),
    (0xFEFF, 0xFEFF),
    (0xFFF9, 0xFFFB),
    (0x110BD, 0x110BD),
    (0x110CD, 0x110CD),
    (0x13430, 0x1343F),
    (0x1BCA0, 0x1BCA3),
    (0x1D173, 0x1D17A),
    (0xE0000, 0xE007F),
];

/// What makes `c` unfit for a label: a control character (Cc: an escape
/// sequence would drive the terminal), a format character (Cf,
/// [`FORMAT_CHARACTERS`]) or a line or paragraph separator (Zl, Zp: they
/// break the line a label is printed on).
fn unprintable(c: char) -> Option<&'static str> {
    let u = c as u32;
    if c.is_control() {
        Some("the control character")
    } else if FORMAT_CHARACTERS.iter().any(|&(a, b)| (a..=b).contains(&u)) {
        Some("the invisible format character (Unicode category Cf)")
    } else if matches!(c, '\u{2028}' | '\u{2029}') {
        Some("the line or paragraph separator")
    } else {
        None
    }
}

/// A name is a label printed on terminals, in reports and plots: no
/// control, format or separator characters ([`unprintable`]), at most
/// [`MAX_NAME_BYTES`].
fn check_name(context: &str, name: &str) -> Result<()> {
    let shown = || {
        format!(
            "\"{}\"",
            name.chars().take(60).collect::<String>().escape_debug()
        )
    };
    if let Some((c, what)) = name.chars().find_map(|c| unprintable(c).map(|w| (c, w))) {
        return Err(Error::invalid(
            context,
            "name",
            shown(),
            format!(
                "holds {what} U+{:04X}: a name is a label for screens and file names, printable \
                 text only",
                c as u32
            ),
        ));
    }
    if name.len() > MAX_NAME_BYTES {
        return Err(Error::invalid(
            context,
            "name",
            shown(),
            format!("is {} bytes long, more than {MAX_NAME_BYTES}", name.len()),
        ));
    }
    if name.trim().is_empty() {
        return Err(Error::invalid(context, "name", shown(), "is empty"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_quantities_skin1_red() {
        let m = preset("skin1").unwrap().top(Channel::R);
        assert!((m.sigma_t_reduced() - 0.772).abs() < 1e-12);
        assert!((m.reduced_albedo() - 0.74 / 0.772).abs() < 1e-12);
        assert!((m.sigma_tr() - (3.0f64 * 0.032 * 0.772).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn names_are_printable_labels() {
        let mut m = preset("skin1").unwrap();
        for ok in ["../x", "/etc/passwd", "peau claire", "crème (dark)"] {
            m.name = ok.into();
            assert!(m.validate("m").is_ok(), "{ok}");
        }
        assert_eq!(m.file_stem(), "crème__dark_");
        for (bad, needle) in [
            ("a\u{1b}[31mRED", "U+001B"),
            ("tab\there", "U+0009"),
            ("new\nline", "U+000A"),
            ("rtl\u{202e}txt", "U+202E"),
            // Format characters beyond the zero-width block (Cf).
            ("a\u{061c}b", "character (Unicode category Cf) U+061C"),
            ("soft\u{00ad}hyphen", "U+00AD"),
            ("word\u{2060}joiner", "U+2060"),
            ("mongolian\u{180e}", "U+180E"),
            ("anchor\u{fff9}", "U+FFF9"),
            ("tag\u{e0041}", "U+E0041"),
            ("tag\u{e0000}", "U+E0000"),
            ("line\u{2028}sep", "U+2028"),
            ("", "empty"),
            ("  ", "empty"),
        ] {
            m.name = bad.into();
            let e = m.validate("m.toml").unwrap_err().to_string();
            assert!(
                e.contains("m.toml") && e.contains("name") && e.contains(needle),
                "{e}"
            );
            assert!(!e.contains('\u{1b}'), "the message carries the escape: {e}");
        }
        m.name = "x".repeat(MAX_NAME_BYTES + 1);
        assert!(m.validate("m").is_err());
    }

    #[test]
    fn channel_list_parsing() {
        assert_eq!(
            Channel::parse_list("bR").unwrap(),
            vec![Channel::R, Channel::B]
        );
        assert!(Channel::parse_list("x").is_err());
        assert!(Channel::parse_list("").is_err());
    }
}
