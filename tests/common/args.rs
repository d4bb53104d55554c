//! Command lines as a user types them: flags written on one line instead
//! of one array element a line.

/// The words of a command line as typed (split at white space): a
/// literal command on one line, for arguments without spaces
/// (`"--models svd --ranks 1"`).
pub fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// The arguments of `ssskit advise --profile profile --mm-per-pixel mm`,
/// then `extra`.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn advise_profile<'a>(profile: &'a str, mm: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&["advise", "--profile", profile, "--mm-per-pixel", mm][..], extra].concat()
}

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
