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

/// `pass` of `image` with the angular factors of `around` (when given)
/// around it, then `specular` added: the exit factor weighs the subsurface
/// light only. The image is handed on by value, so an in-place pass holds
/// no second copy of it. `ssskit apply` and the Python binding both call it.
pub fn around_pass<E: From<Error>>(
    around: Option<&AngularView>,
    image: Image,
    specular: Option<Image>,
    pass: impl FnOnce(Image) -> std::result::Result<Image, E>,
) -> std::result::Result<Image, E> {
    let mut out = match around {
        None => pass(image)?,
        Some(a) => {
            let lit = match &a.n_dot_l {
                Some(nl) => entry_weighted(&image, nl, a.factors)?,
                None => image,
            };
            exit_weighted(&pass(lit)?, &a.n_dot_v, a.factors)?
        }
    };
    if let Some(s) = specular {
        if (s.width, s.height) != (out.width, out.height) {
            return Err(Error::Unsupported(format!(
                "specular is {}x{} but the image is {}x{}",
                s.width, s.height, out.width, out.height
            ))
            .into());
        }
        for c in 0..3 {
            for (o, v) in out.rgb[c].iter_mut().zip(&s.rgb[c]) {
                *o += v;
            }
        }
    }
    Ok(out)
}

/// What a caller of the pass was given for a kernel's entry and exit
/// factors, in its own spelling (`--normals` on the command line, `normals`
/// in Python), so that `ssskit apply` and the binding follow one rule.
pub struct FactorArgs<'a> {
    /// The first factor-only argument given (the normals, then the light).
    pub first_given: Option<&'a str>,
    /// Normals are at hand (given, or in the input file).
    pub has_normals: bool,
    /// The caller asked to leave the factors out.
    pub leave_out: bool,
    /// How this caller gives the normals, for the error that asks for them.
    pub normals_hint: &'a str,
}

/// Whether the factors go around the pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FactorPlan {
    /// No factors: the kernel has none, or the caller left them out.
    Without,
    /// The kernel has factors but no normals are at hand and nothing else
    /// was asked of them: the pass runs without them, and the caller warns.
    WithoutNormals,
    /// Around the pass, with the normals and a light.
    With,
}

/// The one rule: a factor-only argument on a kernel without factors is an
/// error, as is a light without normals; leaving them out wins; a kernel
/// with factors and nothing to apply them with runs without them (warned).
pub fn factor_plan(kernel_has_factors: bool, a: &FactorArgs) -> Result<FactorPlan> {
    if !kernel_has_factors {
        return match a.first_given {
            Some(arg) => Err(Error::Unsupported(format!(
                "{arg}: the kernel carries no angular entry and exit factors"
            ))),
            None => Ok(FactorPlan::Without),
        };
    }
    if a.leave_out {
        return Ok(FactorPlan::Without);
    }
    if !a.has_normals {
        return match a.first_given {
            Some(arg) => Err(Error::Unsupported(format!(
                "{arg}: the exit factor needs the normals: give {}",
                a.normals_hint
            ))),
            None => Ok(FactorPlan::WithoutNormals),
        };
    }
    Ok(FactorPlan::With)
}

/// Where the light of the entry factor comes from.
pub enum Light {
    /// One light, the view-space direction toward it (any length above 0).
    Toward([f64; 3]),
    /// N.L per pixel, finite (a G-buffer's channel).
    Cosines(Vec<f64>),
    /// The input is already weighted by the entry factor (an engine's
    /// lighting pass): only the exit factor is applied.
    EntryWeighted,
}

/// The unit vector along `v`, scaled by its largest component first so
/// that a long vector (1e200, 0, 0) has a length (its square overflowed).
pub fn unit_direction(v: [f64; 3]) -> Result<[f64; 3]> {
    let bad = |why: &str| {
        Error::invalid(
            "angular factors",
            "light direction",
            format!("{v:?}"),
            format!("{why} (the view-space direction toward the light)"),
        )
    };
    if v.iter().any(|x| !x.is_finite()) {
        return Err(bad("three finite numbers expected"));
    }
    let big = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if big == 0.0 {
        return Err(bad("all three are 0: no direction"));
    }
    let s = v.map(|x| x / big);
    let len = s.iter().map(|x| x * x).sum::<f64>().sqrt();
    Ok(s.map(|x| x / len))
}

/// How far beyond [-1, 1] a stored cosine may be: a G-buffer's N.L in f16
/// (relative step 1e-3) or computed from normals of that precision; as
/// [`NORMAL_LENGTH_TOLERANCE`]. Within it a cosine is rounding and is
/// clamped; beyond it, it is no cosine (a channel of another meaning, a
/// scaled or unnormalised product) and is refused rather than clamped,
/// which would turn every such pixel into a light at the normal or behind.
pub const COSINE_TOLERANCE: f64 = NORMAL_LENGTH_TOLERANCE;

/// Checks a plane of cosines read from a file (`what`: N.L): one per pixel
/// of a `width` x `height` image, finite, within [-1, 1] up to
/// [`COSINE_TOLERANCE`].
pub fn check_cosines(what: &str, nl: &[f64], width: usize, height: usize) -> Result<()> {
    if nl.len() != width * height {
        return Err(Error::Unsupported(format!(
            "{what} has {} values for a {width}x{height} image",
            nl.len()
        )));
    }
    let at = |i: usize| {
        format!(
            "{what} at pixel ({}, {}) is {}",
            i % width,
            i / width,
            nl[i]
        )
    };
    if let Some(i) = nl.iter().position(|x| !x.is_finite()) {
        return Err(Error::Unsupported(format!("{}: must be finite", at(i))));
    }
    if let Some(i) = nl.iter().position(|x| x.abs() > 1.0 + COSINE_TOLERANCE) {
        return Err(Error::Unsupported(format!(
            "{}: a cosine lies in [-1, 1] (a normal and a light direction both of length 1); \
             is this the N.L channel?",
            at(i)
        )));
    }
    Ok(())
}

/// The cosines `factors` take around a pass over a `width` x `height`
/// image: N.V from the view-space `normals` (checked) on `scale`'s camera,
/// N.L from `light`.
pub fn angular_view<'a>(
    factors: &'a AngularFactors,
    normals: &[Vec<f64>; 3],
    light: Light,
    (width, height): (usize, usize),
    scale: &Scale,
) -> Result<AngularView<'a>> {
    check_normals("normals", normals, width, height)?;
    let n_dot_l = match light {
        Light::EntryWeighted => None,
        Light::Toward(v) => Some(n_dot_l(normals, unit_direction(v)?)),
        Light::Cosines(nl) => {
            check_cosines("N.L", &nl, width, height)?;
            Some(nl)
        }
    };
    Ok(AngularView {
        factors,
        n_dot_l,
        n_dot_v: n_dot_v(normals, width, height, scale),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(first_given: Option<&str>, has_normals: bool, leave_out: bool) -> FactorArgs<'_> {
        FactorArgs {
            first_given,
            has_normals,
            leave_out,
            normals_hint: "the normals",
        }
    }

    #[test]
    fn the_factor_rule_in_each_case() {
        let plan = |has, a: FactorArgs| factor_plan(has, &a).map_err(|e| e.to_string());
        assert_eq!(
            plan(false, args(None, true, false)),
            Ok(FactorPlan::Without)
        );
        let e = plan(false, args(Some("--normals"), true, false)).unwrap_err();
        assert!(e.starts_with("--normals: the kernel carries no"), "{e}");
        // Leaving the factors out wins over every other argument.
        assert_eq!(
            plan(true, args(Some("--light-toward"), false, true)),
            Ok(FactorPlan::Without)
        );
        assert_eq!(
            plan(true, args(None, false, false)),
            Ok(FactorPlan::WithoutNormals)
        );
        let e = plan(true, args(Some("n_dot_l"), false, false)).unwrap_err();
        assert_eq!(
            e,
            "n_dot_l: the exit factor needs the normals: give the normals"
        );
        assert_eq!(plan(true, args(None, true, false)), Ok(FactorPlan::With));
    }
}
