//! The angular factors around the blur (see [`crate::kernel::angular`]):
//! the irradiance weighted by the entry factor at each pixel's N.L before
//! the pass, the blurred result by the exit factor at its N.V after it.

use super::{Image, Scale};
use crate::error::{Error, Result};
use crate::kernel::angular::AngularFactors;

/// `img` with each pixel's colour multiplied by `factor(cosines[i])`.
fn weighted(img: &Image, cosines: &[f64], factor: impl Fn(f64) -> [f64; 3]) -> Result<Image> {
    if cosines.len() != img.len() {
        return Err(Error::Unsupported(format!(
            "angular factors: {} cosines for a {}x{} image",
            cosines.len(),
            img.width,
            img.height
        )));
    }
    let mut out = img.clone();
    for (i, &mu) in cosines.iter().enumerate() {
        let f = factor(mu);
        for c in 0..3 {
            out.rgb[c][i] *= f[c];
        }
    }
    Ok(out)
}

/// The irradiance buffer weighted by the entry factor at N.L (`n_dot_l`
/// per pixel; values <= 0 receive no light, their irradiance is 0 anyway).
pub fn entry_weighted(irradiance: &Image, n_dot_l: &[f64], f: &AngularFactors) -> Result<Image> {
    weighted(irradiance, n_dot_l, |mu| f.entry_at(mu))
}

/// The blurred exitance weighted by the exit factor at N.V (`n_dot_v` per
/// pixel).
pub fn exit_weighted(blurred: &Image, n_dot_v: &[f64], f: &AngularFactors) -> Result<Image> {
    weighted(blurred, n_dot_v, |mu| f.exit_at(mu))
}

/// N.V per pixel from view-space unit normals (x right, y up, z toward the
/// camera; `[x, y, z][pixel]`) on `scale`'s camera: the view direction of
/// pixel (px, py) is that of the scene camera's ray through its centre
/// (square pixels, `fov_y` vertical: s_x = (2 (px + 1/2) / w - 1) tan(fov_y
/// / 2) w / h, s_y = (1 - 2 (py + 1/2) / h) tan(fov_y / 2), V = (-s_x,
/// -s_y, 1) / |.|), and (0, 0, 1) for an orthographic view. A zero normal
/// (nothing seen) gives 0.
pub fn n_dot_v(normals: &[Vec<f64>; 3], width: usize, height: usize, scale: &Scale) -> Vec<f64> {
    let t = match *scale {
        Scale::Perspective { fov_y_deg, .. } => Some((0.5 * fov_y_deg).to_radians().tan()),
        Scale::MmPerPixel(_) => None,
    };
    let (w, h) = (width as f64, height as f64);
    (0..width * height)
        .map(|i| {
            let n = [normals[0][i], normals[1][i], normals[2][i]];
            let Some(t) = t else { return n[2] };
            let sx = (2.0 * ((i % width) as f64 + 0.5) / w - 1.0) * t * w / h;
            let sy = (1.0 - 2.0 * ((i / width) as f64 + 0.5) / h) * t;
            (-sx * n[0] - sy * n[1] + n[2]) / (sx * sx + sy * sy + 1.0).sqrt()
        })
        .collect()
}

/// N.L per pixel of view-space normals with the unit direction `toward`
/// the light (view space too).
pub fn n_dot_l(normals: &[Vec<f64>; 3], toward: [f64; 3]) -> Vec<f64> {
    (0..normals[0].len())
        .map(|i| (0..3).map(|c| normals[c][i] * toward[c]).sum())
        .collect()
}

/// Checks view-space normals read from a file: `width` x `height`, finite,
/// each of length 1 (within [`NORMAL_LENGTH_TOLERANCE`]) or 0 (nothing
/// seen there).
pub fn check_normals(
    what: &str,
    normals: &[Vec<f64>; 3],
    width: usize,
    height: usize,
) -> Result<()> {
    if normals.iter().any(|v| v.len() != width * height) {
        return Err(Error::format(
            what,
            format!("{} normals for a {width}x{height} image", normals[0].len()),
        ));
    }
    for i in 0..width * height {
        let n = [normals[0][i], normals[1][i], normals[2][i]];
        let len = n.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(len == 0.0 || (len - 1.0).abs() <= NORMAL_LENGTH_TOLERANCE) {
            return Err(Error::format(
                what,
                format!(
                    "the normal at pixel ({}, {}) is {n:?}, of length {len}: unit normals (or 0 \
                     where nothing is seen) expected",
                    i % width,
                    i / width
                ),
            ));
        }
    }
    Ok(())
}

/// How far from 1 a normal's length may be: a normal stored in f32 (or
/// f16, relative step 1e-3) and renormalised by nobody.
pub const NORMAL_LENGTH_TOLERANCE: f64 = 2e-3;

/// What the factors around a pass need per pixel: N.L (None: the input is
/// already weighted by the entry factor, as an engine's lighting pass
/// writes it) and N.V.
pub struct AngularView<'a> {
    pub factors: &'a AngularFactors,
    pub n_dot_l: Option<Vec<f64>>,
    pub n_dot_v: Vec<f64>,
}
