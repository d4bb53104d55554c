//! The error of a model profile against a reference profile on the same
//! grid, per channel: the relative error of the total reflectance and the
//! relative L2 error of r R_d(r) over the radius holding 99% of the
//! reference (where R_d lives). One definition, used by `profiles
//! compare` (the report) and by `ssskit engine` (the engine fits).

use super::{radius_holding, Profile};
use crate::error::{Error, Result};

/// (model - reference) / reference with the 0/0 and x/0 cases made
/// explicit: +inf when the reference is 0 and the model is not.
pub fn relative(model: f64, reference: f64) -> f64 {
    if reference > 0.0 {
        (model - reference) / reference
    } else if model > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// Relative L2 error of r R_d(r) over [0, r_lim] on the bins of
/// `reference` (bin-width weights, bins whose left edge is below r_lim),
/// and the same norm of the reference's standard errors.
pub fn l2_errors(model: &[f64], reference: &Profile, c: usize, r_lim: f64) -> (f64, f64) {
    let (mut num, mut den, mut noise) = (0.0, 0.0, 0.0);
    for (i, e) in reference.r_edges.windows(2).enumerate() {
        if e[0] >= r_lim {
            break;
        }
        let (w, r) = (e[1] - e[0], reference.r[i]);
        let mc = reference.rd[c][i];
        num += w * (r * (model[i] - mc)).powi(2);
        den += w * (r * mc).powi(2);
        if let Some(se) = &reference.rd_stderr {
            noise += w * (r * se[c][i]).powi(2);
        }
    }
    if den > 0.0 {
        ((num / den).sqrt(), (noise / den).sqrt())
    } else if num > 0.0 {
        (f64::INFINITY, 0.0)
    } else {
        (0.0, 0.0)
    }
}

/// The error of one model channel against reference channel `c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelError {
    /// (model total - reference total) / reference total.
    pub total: f64,
    /// Relative L2 error of r R_d(r) over [0, r99] (the shape error).
    pub shape: f64,
    /// The same norm of the reference's standard errors.
    pub noise: f64,
    /// Radius holding 99% of the reference's tabulated R_d, mm.
    pub r99: f64,
}

/// The error of `model_rd` (bin averages on the reference's grid) with
/// total `model_total` against channel `c` of `reference`.
pub fn channel_error(
    model_rd: &[f64],
    model_total: f64,
    reference: &Profile,
    c: usize,
) -> ChannelError {
    let r99 = radius_holding(reference, c, 0.99);
    let (shape, noise) = l2_errors(model_rd, reference, c, r99);
    ChannelError {
        total: relative(model_total, reference.total_rd[c]),
        shape,
        noise,
        r99,
    }
}

/// Refuses two profiles on different radial grids.
pub fn same_grid(model: &Profile, reference: &Profile) -> Result<()> {
    if model.r_edges != reference.r_edges {
        return Err(Error::Unsupported(
            "model and reference profiles have different radial grids".into(),
        ));
    }
    Ok(())
}
