//! `--max-passes`, `--max-samples`, `--max-taps`: what a recommended
//! kernel may cost, shared by `advise` and `kernels`.

use super::values::count;

/// A cost limit: a count, or none (no limit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limit(pub Option<usize>);

impl std::fmt::Display for Limit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(n) => write!(f, "{n}"),
            None => write!(f, "none"),
        }
    }
}

/// A [`Limit`]: `none` lifts it, else a count of at least 1 (0 would
/// allow no kernel at all; it once meant no limit, which nothing said).
pub fn limit(s: &str) -> Result<Limit, String> {
    if s.trim().eq_ignore_ascii_case("none") {
        return Ok(Limit(None));
    }
    let n: usize = count(s).map_err(|e| format!("{e}, or none for no limit"))?;
    if n == 0 {
        return Err("0 allows no kernel: give a count of at least 1, or none for no limit".into());
    }
    Ok(Limit(Some(n)))
}

/// `--max-passes`, `--max-samples`, `--max-taps`: what a recommended kernel
/// may cost (`ssskit::report::eval::advise::Budget`).
#[derive(clap::Args)]
pub struct BudgetArgs {
    /// Budget: one-dimensional passes at most (rank r runs 2r); none: any.
    ///
    /// A separable kernel of r terms runs a horizontal and a vertical pass
    /// per term, 2r one-dimensional passes. The default, 2, is one rank-1
    /// pair, what every engine in `ssskit engine` runs; 1 allows only a
    /// disk kernel (one pass). none lifts the limit; the search then tries
    /// ranks 1 to 3.
    #[arg(long, value_name = "N", value_parser = limit,
          default_value_t = Limit(Some(ssskit::report::eval::advise::DEFAULT_MAX_PASSES)))]
    pub max_passes: Limit,
    /// Budget: samples per pixel at most, over all passes; none: any.
    #[arg(long, value_name = "N", value_parser = limit, default_value_t = Limit(None))]
    pub max_samples: Limit,
    /// Budget: taps per pass at most (full factors: pixels spanned); none: any.
    #[arg(long, value_name = "N", value_parser = limit, default_value_t = Limit(None))]
    pub max_taps: Limit,
}

impl BudgetArgs {
    pub fn budget(&self) -> ssskit::report::eval::advise::Budget {
        ssskit::report::eval::advise::Budget {
            max_passes: self.max_passes.0,
            max_samples: self.max_samples.0,
            max_taps: self.max_taps.0,
        }
    }
}
