//! The radial ranges the profile figures span, measured once here so that
//! `present::plot` and `present::profile_tables` only read them: the
//! radius holding a fraction of a channel's tabulated R_d
//! ([`radius_holding`]).

use crate::material::Channel;
use crate::profile::{radius_holding, Profile};

/// Fraction of R_d the "near the origin" panels of a profile figure hold,
/// so that the peak and its shoulder fill the panel.
pub const NEAR_HOLD: f64 = 0.6;

/// The fractions of the reference's R_d the rows of a profile comparison
/// figure hold (top row near the origin, bottom row the tail), with their
/// words in the titles.
pub const COMPARISON_HOLDS: [(f64, &str); 2] = [(0.9, "90%"), (0.999, "99.9%")];

/// Profiles to draw one row per channel (Freude 2014, figure 6.1 layout),
/// with the ranges of their panels.
pub struct ProfileFigure<'a> {
    /// (label, profile), one colour each.
    pub profiles: &'a [(String, Profile)],
    /// Every channel a profile has, sorted, each with the radius holding
    /// [`NEAR_HOLD`] of R_d (the largest over the profiles, at most
    /// `r_full`), mm.
    pub near: Vec<(Channel, f64)>,
    /// The largest tabulated radius over the profiles, mm.
    pub r_full: f64,
}

/// The ranges of the figure of `profiles`.
pub fn profile_figure(profiles: &[(String, Profile)]) -> ProfileFigure<'_> {
    let mut chans: Vec<Channel> = Vec::new();
    for (_, p) in profiles {
        for c in &p.channels {
            if !chans.contains(c) {
                chans.push(*c);
            }
        }
    }
    chans.sort();
    let r_full = profiles
        .iter()
        .map(|(_, p)| *p.r_edges.last().unwrap_or(&1.0))
        .fold(0.0, f64::max);
    let near = chans
        .into_iter()
        .map(|ch| {
            let r_near = profiles
                .iter()
                .filter_map(|(_, p)| p.channel_index(ch).map(|i| radius_holding(p, i, NEAR_HOLD)))
                .fold(0.0, f64::max)
                .min(r_full);
            (ch, r_near)
        })
        .collect();
    ProfileFigure {
        profiles,
        near,
        r_full,
    }
}

/// Analytic profiles against a Monte Carlo reference, with the ranges of
/// the panels.
pub struct ComparisonFigure<'a> {
    pub reference: &'a Profile,
    pub models: &'a [Profile],
    /// Per row of [`COMPARISON_HOLDS`]: its words, and per channel of the
    /// reference the radius holding that fraction of its R_d, mm.
    pub rows: Vec<(&'static str, Vec<f64>)>,
}

/// The ranges of the figure of `models` against `reference`.
pub fn comparison_figure<'a>(
    reference: &'a Profile,
    models: &'a [Profile],
) -> ComparisonFigure<'a> {
    let rows = COMPARISON_HOLDS
        .iter()
        .map(|&(fraction, what)| {
            let radii = (0..reference.channels.len())
                .map(|c| radius_holding(reference, c, fraction))
                .collect();
            (what, radii)
        })
        .collect();
    ComparisonFigure {
        reference,
        models,
        rows,
    }
}
