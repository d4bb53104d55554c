//! What a user types into an engine's UI: the printed parameter table
//! with its units, values rounded as typed, sRGB hex colours, and the
//! readers that take a printed table back with the engine's ranges.

use super::Scene;
use crate::error::{Error, Result};
use crate::filter::image::{linear_to_srgb, srgb_to_linear};
use serde_json::{Map, Value};

/// Parameter name (the engine's) -> its unit and meaning.
pub type Units = std::collections::BTreeMap<String, String>;

/// What a Burley engine's UI takes, as printed: parameter name -> value,
/// name -> unit and meaning, and the values moved to fit the UI.
pub struct Printed {
    pub params: Map<String, Value>,
    pub units: Units,
    pub warnings: Vec<String>,
}

fn rgb(v: [f64; 3]) -> Value {
    serde_json::json!(v)
}

/// Reads a number parameter.
pub(crate) fn number(params: &Map<String, Value>, name: &str) -> Result<f64> {
    params
        .get(name)
        .and_then(Value::as_f64)
        .filter(|v| v.is_finite())
        .ok_or_else(|| Error::Unsupported(format!("parameter '{name}' is missing or not a number")))
}

/// Reads an [r, g, b] parameter.
pub(crate) fn triple(params: &Map<String, Value>, name: &str) -> Result<[f64; 3]> {
    let v = params
        .get(name)
        .and_then(Value::as_array)
        .filter(|a| a.len() == 3)
        .ok_or_else(|| Error::Unsupported(format!("parameter '{name}' is not [r, g, b]")))?;
    let mut out = [0.0; 3];
    for c in 0..3 {
        out[c] = v[c].as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            Error::Unsupported(format!("parameter '{name}'[{c}] is not a number"))
        })?;
    }
    Ok(out)
}

/// What a Burley engine's UI takes, from (name, value, unit) rows and the
/// warnings of the values moved to fit it.
pub(crate) fn printed(rows: Vec<(&str, Value, &str)>, warnings: Vec<String>) -> Printed {
    let (params, units) = table(rows);
    Printed {
        params,
        units,
        warnings,
    }
}

/// A parameter map from (name, value, unit) rows.
pub(crate) fn table(rows: Vec<(&str, Value, &str)>) -> (Map<String, Value>, Units) {
    let mut p = Map::new();
    let mut u = Units::new();
    for (name, v, unit) in rows {
        p.insert(name.into(), v);
        u.insert(name.into(), unit.into());
    }
    (p, u)
}

pub(crate) fn color(v: [f64; 3]) -> Value {
    rgb(v)
}

/// The most `typed` moves a value, relative: half a unit in the 4th
/// significant digit of a mantissa of at least 1.000.
pub(crate) const TYPED_REL: f64 = 5e-4;

/// `x` to 4 significant digits, as ssskit prints a value to type: the
/// error is computed from this value, not from the unrounded fit.
pub(crate) fn typed(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.3e}").parse().unwrap_or(x)
}

/// A linear colour as an 8-bit sRGB hex code ("#RRGGBB"), the form the
/// colour pickers' hex fields take.
pub(crate) fn srgb_hex(linear: [f64; 3]) -> String {
    let byte = |v: f64| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0).round() as u8;
    format!(
        "#{:02X}{:02X}{:02X}",
        byte(linear[0]),
        byte(linear[1]),
        byte(linear[2])
    )
}

/// The linear colour an "#RRGGBB" sRGB hex code stands for.
pub(crate) fn from_srgb_hex(hex: &str) -> Option<[f64; 3]> {
    let h = hex.strip_prefix('#')?;
    if h.len() != 6 || !h.is_ascii() {
        return None;
    }
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let b = u8::from_str_radix(&h[2 * c..2 * c + 2], 16).ok()?;
        *o = srgb_to_linear(b as f64 / 255.0);
    }
    Some(out)
}

/// Reads a string parameter.
pub(crate) fn text<'a>(params: &'a Map<String, Value>, name: &str) -> Result<&'a str> {
    params
        .get(name)
        .and_then(Value::as_str)
        .ok_or_else(|| Error::Unsupported(format!("parameter '{name}' is missing or not text")))
}

/// `x` if it lies in [lo, hi], the range `ui` (the engine's UI) takes for
/// parameter `name`; an error naming both otherwise.
pub(crate) fn in_range(ui: &str, name: &str, x: f64, (lo, hi): (f64, f64)) -> Result<f64> {
    if !(lo..=hi).contains(&x) {
        return Err(Error::invalid(
            "engine",
            name,
            x,
            format!("{ui} takes [{lo}, {hi}]"),
        ));
    }
    Ok(x)
}

/// Refuses the value `x` of parameter `name` with `why` unless `ok`.
pub(crate) fn check(
    ok: bool,
    name: &str,
    x: impl std::fmt::Display,
    why: impl Into<String>,
) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::invalid("engine", name, x, why))
    }
}

/// Refuses a parameter that is not the one value the fit assumes.
pub(crate) fn require(
    params: &Map<String, Value>,
    name: &str,
    want: &Value,
    why: &str,
) -> Result<()> {
    match params.get(name) {
        Some(v) if v == want => Ok(()),
        Some(v) => Err(Error::invalid(
            "engine",
            name,
            v,
            format!("must be {want}: {why}"),
        )),
        None => Err(Error::Unsupported(format!("parameter '{name}' is missing"))),
    }
}

/// The scene line of every engine: the unit its printed lengths are in,
/// and `what` depends on it.
pub(crate) fn units_line(scene: Scene, what: &str) -> String {
    format!(
        "scene units of {} mm (--units-per-mm {}): {what}",
        1.0 / scene.units_per_mm,
        scene.units_per_mm
    )
}
