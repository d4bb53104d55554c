//! The `[[light]]` sections: directional, environment and point lights.

use super::check::Check;
use crate::error::Result;
use crate::material::PerChannel;
use crate::scene::{Light, Unit};
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLight {
    #[serde(rename = "type")]
    kind: Option<String>,
    toward: Option<[f64; 3]>,
    irradiance: Option<PerChannel>,
    radiance: Option<PerChannel>,
    position: Option<[f64; 3]>,
    intensity: Option<PerChannel>,
}

pub(super) fn parse_light(ck: &Check, i: usize, l: RawLight, unit: Unit) -> Result<Light> {
    let p = format!("light[{i}]");
    let kind = ck.need(&format!("{p}.type"), l.kind)?;
    let given = [
        ("toward", l.toward.is_some()),
        ("irradiance", l.irradiance.is_some()),
        ("radiance", l.radiance.is_some()),
        ("position", l.position.is_some()),
        ("intensity", l.intensity.is_some()),
    ];
    match kind.as_str() {
        "directional" => {
            ck.unused(&p, "directional light", &given, &["toward", "irradiance"])?;
            Ok(Light::Directional {
                toward: ck.unit_vector(
                    &format!("{p}.toward"),
                    ck.need(&format!("{p}.toward"), l.toward)?,
                )?,
                irradiance: ck.rgb(
                    &format!("{p}.irradiance"),
                    ck.need(&format!("{p}.irradiance"), l.irradiance)?,
                )?,
            })
        }
        "environment" => {
            ck.unused(&p, "environment light", &given, &["radiance"])?;
            Ok(Light::Environment {
                radiance: ck.rgb(
                    &format!("{p}.radiance"),
                    ck.need(&format!("{p}.radiance"), l.radiance)?,
                )?,
            })
        }
        "point" => {
            ck.unused(&p, "point light", &given, &["position", "intensity"])?;
            let position = ck.point(
                &format!("{p}.position"),
                ck.need(&format!("{p}.position"), l.position)?,
                unit,
            )?;
            // Intensity per square scene unit, stored per square mm.
            let intensity = ck.rgb(
                &format!("{p}.intensity"),
                ck.need(&format!("{p}.intensity"), l.intensity)?,
            )?;
            Ok(Light::Point {
                position,
                intensity: intensity.map(|v| v * unit.mm() * unit.mm()),
            })
        }
        other => Err(ck.err(
            &format!("{p}.type"),
            format!("\"{other}\""),
            "expected \"directional\", \"environment\" or \"point\"",
        )),
    }
}
