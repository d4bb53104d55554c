//! Field checks of a scene file: each turns a raw TOML value into a
//! validated one (finite, positive, a point or length converted to mm and
//! bounded, a unit vector, a colour) or an error that names the file, the
//! field, the value and what is allowed.

use super::{MAX_COORDINATE_MM, UNIT_TOLERANCE};
use crate::error::{Error, Result};
use crate::material::PerChannel;
use crate::scene::{Unit, V3};

/// The largest light a scene may give (an irradiance, or an environment's
/// radiance): far above any physical light, and far enough below f32's
/// largest value (3.4e38, the EXR's samples) that the sum of the lights,
/// the environment's pi L and a radiance that is irradiance x R_d / pi stay
/// finite; a light above it is refused with the scene, before the render.
pub const MAX_LIGHT: f64 = 1e30;

/// Field checks of one scene file.
pub(super) struct Check<'a> {
    pub(super) context: &'a str,
}

impl Check<'_> {
    pub(super) fn err(
        &self,
        field: &str,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Error {
        Error::invalid(self.context, field, value, reason)
    }

    pub(super) fn need<T>(&self, field: &str, v: Option<T>) -> Result<T> {
        v.ok_or_else(|| self.err(field, "missing", "required"))
    }

    pub(super) fn finite(&self, field: &str, v: f64) -> Result<f64> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, v, "must be finite"))
        }
    }

    pub(super) fn positive(&self, field: &str, v: f64) -> Result<f64> {
        crate::error::finite_positive(self.context, field, v, "")
    }

    /// A point or length vector in scene units, converted to mm.
    pub(super) fn point(&self, field: &str, v: [f64; 3], unit: Unit) -> Result<V3> {
        for (i, x) in v.iter().enumerate() {
            let mm = self.finite(&format!("{field}[{i}]"), *x)? * unit.mm();
            if mm.abs() > MAX_COORDINATE_MM {
                return Err(self.err(
                    &format!("{field}[{i}]"),
                    x,
                    format!(
                        "coordinates are limited to {MAX_COORDINATE_MM} mm ({} {})",
                        MAX_COORDINATE_MM / unit.mm(),
                        unit.name()
                    ),
                ));
            }
        }
        Ok(V3::from(v) * unit.mm())
    }

    /// A length in scene units, > 0, converted to mm.
    pub(super) fn length(&self, field: &str, v: f64, unit: Unit) -> Result<f64> {
        let mm = self.positive(field, v)? * unit.mm();
        if mm > MAX_COORDINATE_MM {
            return Err(self.err(
                field,
                v,
                format!("lengths are limited to {MAX_COORDINATE_MM} mm"),
            ));
        }
        Ok(mm)
    }

    pub(super) fn unit_vector(&self, field: &str, v: [f64; 3]) -> Result<V3> {
        for (i, x) in v.iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), *x)?;
        }
        let u = V3::from(v);
        let n = u.norm();
        if !((n - 1.0).abs() <= UNIT_TOLERANCE) {
            return Err(self.err(
                field,
                format!("{v:?}"),
                format!(
                    "must be a unit vector (length 1 within {UNIT_TOLERANCE}); its length is {n}"
                ),
            ));
        }
        Ok(u / n)
    }

    pub(super) fn rgb(&self, field: &str, v: PerChannel) -> Result<[f64; 3]> {
        let v = v.rgb();
        for (c, x) in v.iter().enumerate() {
            if !(x.is_finite() && *x >= 0.0) {
                return Err(self.err(&format!("{field}[{c}]"), x, "must be finite and >= 0"));
            }
            if *x > MAX_LIGHT {
                return Err(self.err(
                    &format!("{field}[{c}]"),
                    x,
                    format!(
                        "must be at most {MAX_LIGHT:e}: the render is stored as f32 (largest \
                         {:e}), which a brighter light overflows",
                        f32::MAX
                    ),
                ));
            }
        }
        Ok(v)
    }

    /// Refuses fields that the object's shape does not use: `given` says
    /// which fields the object has, `takes` those its shape reads.
    pub(super) fn unused(
        &self,
        prefix: &str,
        shape: &str,
        given: &[(&str, bool)],
        takes: &[&str],
    ) -> Result<()> {
        match given.iter().find(|(n, on)| *on && !takes.contains(n)) {
            Some((name, _)) => Err(self.err(
                &format!("{prefix}.{name}"),
                "given",
                format!("a {shape} has no {name}; it takes {}", takes.join(", ")),
            )),
            None => Ok(()),
        }
    }

    /// A section given `n` times, at least once and at most `max` (plural
    /// `{field}s`); `none` says what to give when it is missing.
    pub(super) fn count(&self, field: &str, n: usize, max: usize, none: &str) -> Result<()> {
        if n == 0 {
            return Err(self.err(field, "none", none));
        }
        if n > max {
            return Err(self.err(field, n, format!("at most {max} {field}s")));
        }
        Ok(())
    }
}
