//! A real kernel comparison that runs in about a second: skin1's committed
//! profile, SVD rank 1, pre-integration and the manual fit, on 32-pixel
//! edge and shapes signals (the contact sheets' and the plots' tests).

use ssskit::filter::signals::Signal;
use ssskit::filter::Which;
use ssskit::profile::Profile;
use ssskit::report::eval::compare;
use ssskit::report::eval::compare::kernel::{Comparison, Config, MaterialInput};
use ssskit::report::eval::evaluate::{ImageCase, Options};
use std::path::PathBuf;

/// Side of the test signals: small enough to fit in a second, and narrow
/// tiles make every label of a sheet wrap, the hardest case for its layout.
pub const SIZE: usize = 32;
/// Scale of the signals: skin1's kernel (radius holding 99% about 3 mm)
/// spans a good part of a 32-pixel tile.
pub const MM_PER_PIXEL: f64 = 0.25;
/// Tap count of the tables drawn.
pub const TAPS: usize = 9;
/// The index of the shapes case in [`comparison`].
pub const SHAPES: usize = 1;

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// skin1's committed Monte Carlo profile.
pub fn profile() -> Profile {
    Profile::read(&root().join("profiles/reference/skin1.json")).unwrap()
}

pub fn comparison() -> Comparison {
    let cases = [Signal::Edge, Signal::Shapes]
        .map(|s| ImageCase::signal(s, SIZE, MM_PER_PIXEL).unwrap())
        .to_vec();
    let cfg = Config {
        families: ["svd", "preintegrate", "manual"].map(String::from).to_vec(),
        ranks: vec![1],
        cases,
        taps: vec![TAPS],
        options: Options::default(),
        keep: Some(Which::Taps(TAPS)),
        extent_mm: None,
    };
    let input = MaterialInput {
        name: "skin1".into(),
        profile: profile(),
    };
    compare::kernel::run(&[input], &cfg, &ssskit::progress::NoProgress).unwrap()
}
