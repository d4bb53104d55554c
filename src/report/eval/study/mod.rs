//! The study job (`ssskit study`): every knob a user turns, measured in
//! one run against one reference profile. Results type: [`Study`].

pub mod run;

pub use run::{run, Entry, Settings, Study};
