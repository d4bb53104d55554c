//! IEC 61966-2-1's sRGB transfer curve, as the engines apply it to a
//! colour typed in sRGB (Unity's Color.gamma / Color.linear, Godot's
//! `source_color`): the oracle the engine file tests read printed colours
//! through.

/// The sRGB encoding of a linear value.
pub fn encode(l: f64) -> f64 {
    if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// The sRGB decoding of a value to linear light.
pub fn decode(s: f64) -> f64 {
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// An sRGB value typed to 4 significant digits (5e-4 relative) moves its
/// linear value by at most 2.4 times that (d ln L / d ln S <= 2.4 on the
/// sRGB curve), with margin.
pub const TYPED_REL: f64 = 1.3e-3;
