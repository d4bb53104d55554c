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
    let (width, height) = camera_size(ck, c.size)?;
    crate::limits::check_image_size(&format!("{} camera", ck.context), width, height)?;
    let kind = ck.need("camera.type", c.kind)?;
    let projection = projection(ck, &kind, c.fov_y, c.mm_per_pixel, width.max(height))?;
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

/// `camera.size`: [width, height], whole pixels within the image limit.
fn camera_size(ck: &Check, size: Option<Vec<f64>>) -> Result<(usize, usize)> {
    let size = ck.need("camera.size", size)?;
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
    Ok((side(0)?, side(1)?))
}

/// The projection of a camera of `kind`: a perspective one takes `fov_y`
/// (degrees), an orthographic one `mm_per_pixel` (its view, `side`
/// pixels, within the space scenes may use), neither the other's.
fn projection(
    ck: &Check,
    kind: &str,
    fov_y: Option<f64>,
    mm_per_pixel: Option<f64>,
    side: usize,
) -> Result<Projection> {
    let refuse =
        |field: &str, why: &str| -> Result<Projection> { Err(ck.err(field, "given", why)) };
    Ok(match kind {
        "perspective" => {
            if mm_per_pixel.is_some() {
                return refuse(
                    "camera.mm_per_pixel",
                    "a perspective camera takes fov_y, not mm_per_pixel",
                );
            }
            let f = ck.need("camera.fov_y", fov_y)?;
            if !(f > 0.0 && f < 180.0) {
                return Err(ck.err("camera.fov_y", f, "must be in (0, 180) degrees"));
            }
            Projection::Perspective { fov_y_deg: f }
        }
        "orthographic" => {
            if fov_y.is_some() {
                return refuse(
                    "camera.fov_y",
                    "an orthographic camera takes mm_per_pixel, not fov_y",
                );
            }
            let m = ck.positive(
                "camera.mm_per_pixel",
                ck.need("camera.mm_per_pixel", mm_per_pixel)?,
            )?;
            if m * side as f64 > 4.0 * MAX_COORDINATE_MM {
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
    })
}
