//! Small inputs the CLI tests write into their temporary folder before
//! the command under test.

use std::path::Path;

/// Writes p.json into `dir`: skin1's dipole profile (analytic, instant).
pub fn dipole_profile(dir: &Path) {
    super::ok_in(dir, &super::profile_args("skin1", "dipole", "p.json", &[]));
}
