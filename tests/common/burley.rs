//! A Burley fit made by hand, to hand an engine's printer values a fit
//! never gives (a colour above 1): what the printer must still keep
//! inside the engine's ranges.

use ssskit::engine::burley::Burley;

/// Burley with `albedo` and mean free paths 1, 0.5 and 0.2 mm, not
/// truncated.
pub fn with_albedo(albedo: [f64; 3]) -> Burley {
    Burley {
        albedo,
        d_mm: [1.0, 0.5, 0.2],
        truncate_d: None,
    }
}
