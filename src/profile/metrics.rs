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

/// Fraction of the reference's tabulated R_d inside the radius the shape
/// error covers: where R_d lives, leaving out the noisy far tail.
pub const SHAPE_HOLD: f64 = 0.99;

/// The weights of the discrete L2 norm of r R_d(r) on the bins of `p`
/// whose left edge is below `r_lim`: bin width times r^2, one per bin.
pub fn shape_weights(p: &Profile, r_lim: f64) -> Vec<f64> {
    p.r_edges
        .windows(2)
        .zip(&p.r)
        .take_while(|(e, _)| e[0] < r_lim)
        .map(|(e, r)| (e[1] - e[0]) * r * r)
        .collect()
}

/// Relative L2 error of r R_d(r) over [0, r_lim] on the bins of
/// `reference` ([`shape_weights`]), and the same norm of the reference's
/// standard errors.
pub fn l2_errors(model: &[f64], reference: &Profile, c: usize, r_lim: f64) -> (f64, f64) {
    let (mut num, mut den, mut noise) = (0.0, 0.0, 0.0);
    for (i, w) in shape_weights(reference, r_lim).into_iter().enumerate() {
        let mc = reference.rd[c][i];
        num += w * (model[i] - mc).powi(2);
        den += w * mc.powi(2);
        if let Some(se) = &reference.rd_stderr {
            noise += w * se[c][i].powi(2);
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
    let r99 = radius_holding(reference, c, SHAPE_HOLD);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::RadialGrid;

    /// Bin width times r^2 for the bins whose left edge lies below the
    /// limit, and the L2 error of a model off by 10% everywhere is 10%.
    #[test]
    fn shape_weights_are_width_times_r_squared() {
        let grid = RadialGrid::uniform(0.5, 2.0).unwrap();
        let m = crate::material::preset("skin1").unwrap();
        let o = crate::profile::analytic::Options::default();
        let mut p = crate::profile::analytic::profile(
            &m,
            crate::profile::analytic::Model::Dipole,
            &grid,
            &o,
        )
        .unwrap();
        p.rd = vec![vec![1.0, 0.5, 0.25, 0.125]; 3];
        let w = shape_weights(&p, 1.2);
        assert_eq!(w.len(), 3, "bins starting at 0, 0.5 and 1.0");
        for (i, w) in w.iter().enumerate() {
            assert_eq!(*w, 0.5 * p.r[i] * p.r[i], "bin {i}");
        }
        let model: Vec<f64> = p.rd[0].iter().map(|v| 1.1 * v).collect();
        let (shape, _) = l2_errors(&model, &p, 0, 1.2);
        assert!((shape - 0.1).abs() < 1e-12, "{shape}");
    }
}
