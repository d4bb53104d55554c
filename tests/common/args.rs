//! Command lines as a user types them: flags written on one line instead
//! of one array element a line.

/// The words of `line` split at single spaces: flags and values without
/// spaces or paths in them (`"--models svd --ranks 1"`).
pub fn words(line: &str) -> Vec<&str> {
    line.split(' ').collect()
}

/// The arguments of `ssskit advise --profile profile --mm-per-pixel mm`,
/// then `extra`.
#[rustfmt::skip] // one line a part: the command reads as typed
pub fn advise_profile<'a>(profile: &'a str, mm: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    [&["advise", "--profile", profile, "--mm-per-pixel", mm][..], extra].concat()
}
