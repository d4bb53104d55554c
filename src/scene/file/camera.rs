//! The `[camera]` section: projection, placement, image size and what the
//! camera measures.

use super::check::Check;
use super::MAX_COORDINATE_MM;
use crate::error::Result;
use crate::scene::camera::{Camera, Measure, Projection};
use crate::scene::{Unit, V3};
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    #[serde(rename = "type")]
    kind: Option<String>,
    position: Option<[f64; 3]>,
    look_at: Option<[f64; 3]>,
    up: Option<[f64; 3]>,
    fov_y: Option<f64>,
    mm_per_pixel: Option<f64>,
    size: Option<Vec<f64>>,
    measure: Option<String>,
}

pub(super) fn parse_camera(ck: &Check, c: RawCamera, unit: Unit) -> Result<Camera> {
    let position = ck.point(
        "camera.position",
        ck.need("camera.position", c.position)?,
        unit,
    )?;
    let look_at = ck.point(
        "camera.look_at",
        ck.need("camera.look_at", c.look_at)?,
        unit,
    )?;
    let up_raw = c.up.unwrap_or([0.0, 1.0, 0.0]);
    for (i, x) in up_raw.iter().enumerate() {
        ck.finite(&format!("camera.up[{i}]"), *x)?;
    }
    let Some((forward, right, up)) = Camera::frame(position, look_at, V3::from(up_raw)) else {
        return Err(ck.err(
            "camera.up",
            format!("{up_raw:?}"),
            "the camera needs position != look_at and an up vector not along the view",
        ));
    };
    let size = ck.need("camera.size", c.size)?;
    if size.len() != 2 {
        return Err(ck.err(
            "camera.size",
            format!("{size:?}"),
            "expected [width, height] in pixels",
        ));
    }
    let side = |i: usize| -> Result<usize> {
        let v = size[i];
        if !(v >= 1.0 && v <= crate::limits::MAX_IMAGE_SIDE as f64 && v.fract() == 0.0) {
            return Err(ck.err(
                &format!("camera.size[{i}]"),
                v,
                format!(
                    "must be a whole number of pixels in 1..={}",
                    crate::limits::MAX_IMAGE_SIDE
                ),
            ));
        }
        Ok(v as usize)
    };
    let (width, height) = (side(0)?, side(1)?);
    crate::limits::check_image_size(&format!("{} camera", ck.context), width, height)?;
    let kind = ck.need("camera.type", c.kind)?;
    let projection = match kind.as_str() {
        "perspective" => {
            if c.mm_per_pixel.is_some() {
                return Err(ck.err(
                    "camera.mm_per_pixel",
                    "given",
                    "a perspective camera takes fov_y, not mm_per_pixel",
                ));
            }
            let f = ck.need("camera.fov_y", c.fov_y)?;
            if !(f > 0.0 && f < 180.0) {
                return Err(ck.err("camera.fov_y", f, "must be in (0, 180) degrees"));
            }
            Projection::Perspective { fov_y_deg: f }
        }
        "orthographic" => {
            if c.fov_y.is_some() {
                return Err(ck.err(
                    "camera.fov_y",
                    "given",
                    "an orthographic camera takes mm_per_pixel, not fov_y",
                ));
            }
            let m = ck.positive(
                "camera.mm_per_pixel",
                ck.need("camera.mm_per_pixel", c.mm_per_pixel)?,
            )?;
            if m * width.max(height) as f64 > 4.0 * MAX_COORDINATE_MM {
                return Err(ck.err(
                    "camera.mm_per_pixel",
                    m,
                    "the view is wider than the space scenes may use",
                ));
            }
            Projection::Orthographic { mm_per_pixel: m }
        }
        other => {
            return Err(ck.err(
                "camera.type",
                format!("\"{other}\""),
                "expected \"perspective\" or \"orthographic\"",
            ))
        }
    };
    let measure = match c.measure.as_deref() {
        None | Some("radiance") => Measure::Radiance,
        Some("exitance") => Measure::Exitance,
        Some(m) => {
            return Err(ck.err(
                "camera.measure",
                format!("\"{m}\""),
                "expected \"radiance\" or \"exitance\"",
            ))
        }
    };
    Ok(Camera {
        projection,
        position,
        forward,
        right,
        up,
        width,
        height,
        measure,
    })
}
