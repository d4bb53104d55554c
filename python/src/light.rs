//! A kernel's angular entry and exit factors around `apply`'s pass: the
//! normals and the light (`--normals` with `--light-toward`, `--n-dot-l`
//! or `--entry-weighted`), by the library's rule.

use crate::call::{to_py, warn_all};
use crate::image::{image_of, plane_of, Sanitize};
use crate::options::LightOptions;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use ssskit::filter::angular::{
    angular_view, factor_plan, AngularView, FactorArgs, FactorPlan, Light,
};
use ssskit::filter::{Image, Scale};
use ssskit::kernel::angular::AngularFactors;

/// The argument that only the factors use, if one was given.
fn any_given(l: &LightOptions) -> Option<&'static str> {
    if l.normals.is_some() {
        Some("normals")
    } else if l.n_dot_l.is_some() {
        Some("n_dot_l")
    } else if l.toward.is_some() {
        Some("light_toward")
    } else if l.entry_weighted {
        Some("entry_weighted")
    } else {
        None
    }
}

/// The cosines the kernel's factors take, by the library's `factor_plan`
/// (the rule `ssskit apply` follows): none without factors or with
/// factors=False; a warning and none without normals; the light from
/// exactly one of light_toward, n_dot_l and entry_weighted.
pub(crate) fn light_view<'f>(
    py: Python<'_>,
    l: &LightOptions,
    f: Option<&'f AngularFactors>,
    image: &Image,
    scale: &Scale,
) -> PyResult<Option<AngularView<'f>>> {
    let (w, h) = (image.width, image.height);
    let plan = factor_plan(
        f.is_some(),
        &FactorArgs {
            first_given: any_given(l),
            has_normals: l.normals.is_some(),
            leave_out: l.leave_out,
            normals_hint: "normals=(H, W, 3) array",
        },
    )
    .map_err(to_py)?;
    if plan == FactorPlan::WithoutNormals {
        warn_all(
            py,
            [
                "the kernel carries angular entry and exit factors, but no normals are given: \
              applied without them (factors=False says so)"
                    .to_string(),
            ],
        )?;
    }
    let (FactorPlan::With, Some(f), Some(normals)) = (plan, f, l.normals.as_ref()) else {
        return Ok(None);
    };
    let (n, _) = image_of(normals.bind(py), "normals")?;
    let given = [l.toward.is_some(), l.n_dot_l.is_some(), l.entry_weighted];
    if given.iter().filter(|g| **g).count() > 1 {
        return Err(PyValueError::new_err(
            "give one of light_toward, n_dot_l and entry_weighted",
        ));
    }
    let light = match (l.toward, l.n_dot_l.as_ref(), l.entry_weighted) {
        (Some(v), _, _) => Light::Toward(v),
        (_, Some(p), _) => Light::Cosines(plane_of(p.bind(py), "n_dot_l", Sanitize::Refuse)?.data),
        (_, _, true) => Light::EntryWeighted,
        _ => {
            return Err(PyValueError::new_err(
                "the kernel's entry factor needs the light: give light_toward=(x, y, z), \
                 n_dot_l=(H, W) array or entry_weighted=True (or factors=False to leave the \
                 factors out)",
            ))
        }
    };
    let view = angular_view(f, &n.rgb, light, (w, h), scale).map_err(to_py)?;
    Ok(Some(view))
}
