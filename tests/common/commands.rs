//! Argument lists of commands the tests type again and again, written once
//! so that a call reads on one line.

/// The arguments of `ssskit engine --profile profile --engine engine`,
/// then `extra` (`--out`, versions, units).
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn engine_args<'a>(profile: &'a str, engine: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&["engine", "--profile", profile, "--engine", engine][..], extra].concat()
}

/// The arguments of `ssskit simulate --material skin1 --channels r`, then
/// `extra`: one channel, the quickest Monte Carlo run.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn skin1_red_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    [&["simulate", "--material", "skin1", "--channels", "r"][..], extra].concat()
}

/// The words of a command line as typed (split at spaces): a literal
/// command on one line, for arguments without spaces.
pub fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}
