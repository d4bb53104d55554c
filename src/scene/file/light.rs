//! The `[[light]]` sections: directional and environment lights.

use super::check::Check;
use crate::error::Result;
use crate::material::PerChannel;
use crate::scene::Light;
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLight {
    #[serde(rename = "type")]
    kind: Option<String>,
    toward: Option<[f64; 3]>,
    irradiance: Option<PerChannel>,
    radiance: Option<PerChannel>,
}

pub(super) fn parse_light(ck: &Check, i: usize, l: RawLight) -> Result<Light> {
    let p = format!("light[{i}]");
    let kind = ck.need(&format!("{p}.type"), l.kind)?;
    match kind.as_str() {
        "directional" => {
            ck.unused(
                &p,
                "directional light",
                &[("radiance", l.radiance.is_some())],
                &["toward", "irradiance"],
            )?;
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
            ck.unused(
                &p,
                "environment light",
                &[
                    ("toward", l.toward.is_some()),
                    ("irradiance", l.irradiance.is_some()),
                ],
                &["radiance"],
            )?;
            Ok(Light::Environment {
                radiance: ck.rgb(
                    &format!("{p}.radiance"),
                    ck.need(&format!("{p}.radiance"), l.radiance)?,
                )?,
            })
        }
        other => Err(ck.err(
            &format!("{p}.type"),
            format!("\"{other}\""),
            "expected \"directional\" or \"environment\"",
        )),
    }
}
