//! What an engine fit keeps first, colour or shape, and how close the
//! colour is kept: plain data every engine's fit reads (a leaf, so the
//! engines need not import the dispatch in `request`).

use crate::error::Result;
use serde::Serialize;

/// What a fit keeps first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Priority {
    /// Each channel's total (the colour a user sees) equals the
    /// profile's, within [`COLOUR_TOL`]; the shape is fitted for it.
    #[default]
    Colour,
    /// Least squares on r R_d(r) with the colour free: the best shape,
    /// the total moved by up to several percent.
    Shape,
}

impl Priority {
    pub fn other(self) -> Priority {
        match self {
            Priority::Colour => Priority::Shape,
            Priority::Shape => Priority::Colour,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Priority::Colour => "colour",
            Priority::Shape => "shape",
        }
    }
}

impl std::str::FromStr for Priority {
    type Err = crate::error::Error;
    fn from_str(s: &str) -> Result<Priority> {
        match s {
            "colour" | "color" => Ok(Priority::Colour),
            "shape" => Ok(Priority::Shape),
            _ => Err(crate::error::Error::invalid(
                "engine",
                "priority",
                s,
                "expected colour or shape",
            )),
        }
    }
}

/// How far a channel's rendered total may stand from the profile's when
/// the colour is kept: 1%, about a third of the smallest step an 8-bit
/// sRGB colour takes at mid grey (1/255 of 0.5 in sRGB is 1.7% in
/// linear), so the kept colour is the one a user sees. The fits themselves
/// hold the total to the 4 printed digits (5e-4); a UI clamp or a colour
/// the engine cannot reach moves it further, with a warning.
pub const COLOUR_TOL: f64 = 0.01;
