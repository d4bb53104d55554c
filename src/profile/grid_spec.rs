//! The radial grid a user asks for: bin width, largest radius and bin kind,
//! each optional, completed from the material's rule and validated in one
//! place for every command that tabulates a profile.

use super::grid::log_bin_count;
use super::RadialGrid;
use crate::error::{finite_positive, Error, Result};
use crate::material::{Channel, Material};

/// What to override of the material's automatic grid
/// (`RadialGrid::for_material`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridSpec {
    /// Width of the first bin, mm (all bins when uniform).
    pub dr: Option<f64>,
    /// Largest radius, mm.
    pub r_max: Option<f64>,
    /// Geometric bins growing from `dr` at the centre out to `r_max`.
    pub log_bins: bool,
}

impl GridSpec {
    /// The grid; a missing value comes from the material rule. Invalid
    /// values fail with the parameter named ("radial grid", "dr" or
    /// "rmax"), an invalid material (whose rule would be meaningless) with
    /// its own error.
    pub fn grid(&self, material: &Material, channels: &[Channel]) -> Result<RadialGrid> {
        material.validate_named()?;
        for (field, value) in [("dr", self.dr), ("rmax", self.r_max)] {
            if let Some(v) = value {
                finite_positive("radial grid", field, v, " (mm)")?;
            }
        }
        let auto = RadialGrid::for_material(material, channels);
        let dr = self.dr.unwrap_or(auto.edges[1]);
        let r_max = self.r_max.unwrap_or(auto.r_max());
        if self.r_max.is_none() && dr.is_finite() && dr > r_max {
            // Blame the value the user gave, not a radius they never set.
            return Err(Error::invalid(
                "radial grid",
                "dr",
                dr,
                format!(
                    "wider than the default radius {r_max:.4} mm (from the material): give a \
                     smaller dr or a larger rmax"
                ),
            ));
        }
        let max = crate::limits::MAX_RADIAL_BINS;
        if !self.log_bins && self.dr.is_none() && r_max / dr > max as f64 {
            // Too many bins of the default width: the radius given is to blame.
            return Err(Error::invalid(
                "radial grid",
                "rmax",
                r_max,
                format!(
                    "gives {:.3e} bins of the default width {dr:.4e} mm, more than {max}: give \
                     a smaller rmax or a wider dr",
                    r_max / dr
                ),
            ));
        }
        if self.log_bins {
            RadialGrid::logarithmic(dr, r_max, log_bin_count(dr, r_max))
        } else {
            RadialGrid::uniform(dr, r_max)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::preset;

    #[test]
    fn defaults_come_from_the_material_and_bad_values_name_the_parameter() {
        let m = preset("skin1").unwrap();
        let ch = Channel::ALL;
        assert_eq!(
            GridSpec::default().grid(&m, &ch).unwrap(),
            RadialGrid::for_material(&m, &ch)
        );
        let g = GridSpec {
            dr: Some(0.5),
            r_max: Some(2.0),
            log_bins: false,
        };
        assert_eq!(g.grid(&m, &ch).unwrap().len(), 4);
        for (spec, field) in [
            (
                GridSpec {
                    dr: Some(-1.0),
                    ..g
                },
                "dr",
            ),
            (
                GridSpec {
                    dr: Some(f64::NAN),
                    log_bins: true,
                    ..g
                },
                "dr",
            ),
            (
                GridSpec {
                    r_max: Some(0.1),
                    ..g
                },
                "rmax",
            ),
            (
                GridSpec {
                    r_max: Some(f64::INFINITY),
                    log_bins: true,
                    ..g
                },
                "rmax",
            ),
        ] {
            match spec.grid(&m, &ch) {
                Err(Error::Invalid {
                    context, field: f, ..
                }) => {
                    assert_eq!(
                        (context.as_str(), f.as_str()),
                        ("radial grid", field),
                        "{spec:?}"
                    )
                }
                other => panic!("{spec:?}: {other:?}"),
            }
        }
    }
}
