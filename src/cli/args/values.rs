//! The value parsers of the shared flags, and the text of a default that
//! they read back as the same value.
//!
//! A parser's message is the reason only: the one format of a bad value
//! (`errors::parse_error`) names the flag and the value.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::ValueEnum;
use ssskit::material::Channel;
use ssskit::report::eval::evaluate;

/// A count: an integer, or a whole number in exponent notation (1e6).
pub fn count<T: TryFrom<u64>>(s: &str) -> Result<T, String> {
    let t = s.trim();
    let n = match t.parse::<u64>() {
        Ok(n) => n,
        Err(_) => {
            let v: f64 = t
                .parse()
                .map_err(|_| "expected a whole number, e.g. 1000000 or 1e6".to_string())?;
            if !(v >= 0.0 && v.fract() == 0.0) {
                return Err("expected a whole number >= 0, e.g. 1000000 or 1e6".into());
            }
            // 2^64 is exactly representable; every f64 below it converts exactly.
            if v >= 18_446_744_073_709_551_616.0 {
                return Err(format!("beyond the largest count, {}", u64::MAX));
            }
            v as u64
        }
    };
    T::try_from(n).map_err(|_| format!("too large (at most {})", max_of::<T>()))
}

/// The largest `T` a count converts to.
fn max_of<T: TryFrom<u64>>() -> u64 {
    // The largest n with T::try_from(n) ok: bisection over u64.
    let (mut lo, mut hi) = (0u64, u64::MAX);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if T::try_from(mid).is_ok() {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    lo
}

/// "WIDTHxHEIGHT", each a [`count`].
pub fn image_size(s: &str) -> Result<(usize, usize), String> {
    let bad = || "expected WIDTHxHEIGHT, e.g. 512x256".to_string();
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    Ok((count(w).map_err(|_| bad())?, count(h).map_err(|_| bad())?))
}

/// A real number: finite, as every real-valued flag takes (Rust reads
/// "NaN", "inf" and "1e400" as `f64`s; none of them is a quantity, and a
/// NaN passes every `<` check the library makes after it).
pub fn real(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| "expected a number, e.g. 0.5 or 1e-3".to_string())?;
    if !v.is_finite() {
        return Err("must be a finite number".into());
    }
    Ok(v)
}

/// "R,G,B": three numbers, one per channel.
pub fn rgb(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(real)
        .collect::<Result<_, _>>()
        .map_err(|e| format!("not three numbers R,G,B ({e})"))?;
    match v.as_slice() {
        [r, g, b] => Ok([*r, *g, *b]),
        _ => Err(format!("{} values, expected three (R,G,B)", v.len())),
    }
}

/// "R,G,B" of a default, as [`rgb`] reads it back.
pub fn rgb_text(v: [f64; 3]) -> String {
    format!("{},{},{}", v[0], v[1], v[2])
}

/// A tap count: odd, 1 to 255 (`ssskit::kernel::taps::check_count`).
pub fn taps(s: &str) -> Result<usize, String> {
    let n = count::<usize>(s)?;
    ssskit::kernel::taps::check_count(n).map_err(|e| reason(&e))?;
    Ok(n)
}

/// Side of a square test signal, in [`evaluate::SIGNAL_SIZE_RANGE`].
pub fn signal_size(s: &str) -> Result<usize, String> {
    let n = count::<usize>(s)?;
    let r = evaluate::SIGNAL_SIZE_RANGE;
    if !r.contains(&n) {
        return Err(format!("must be between {} and {}", r.start(), r.end()));
    }
    Ok(n)
}

/// One item of a rank list, "N" or "N-M", as the library reads it
/// (`compare::kernel::parse_ranks`); kept as text for that reader.
pub fn rank_item(s: &str) -> Result<String, String> {
    ssskit::report::eval::compare::kernel::parse_ranks(s).map_err(|e| reason(&e))?;
    Ok(s.trim().to_string())
}

/// One item of a channel list: "r", "g", "b" or letters of them ("rgb"),
/// as the library reads them (`Channel::parse_list`).
pub fn channel_item(s: &str) -> Result<String, String> {
    Channel::parse_list(s).map_err(|e| reason(&e))?;
    Ok(s.trim().to_string())
}

/// A name in a list: not empty.
pub fn name_item(s: &str) -> Result<String, String> {
    match s.trim() {
        "" => Err("an empty name (two commas in a row?)".into()),
        t => Ok(t.to_string()),
    }
}

/// The reason of a library error, for a parser's message (clap names the
/// flag and the value).
fn reason(e: &ssskit::Error) -> String {
    match e {
        ssskit::Error::Invalid { reason, .. } => reason.clone(),
        e => e.to_string(),
    }
}

/// A list item of an enumerated flag: a value of `T` (Some) or the one
/// extra word `other` (None). The values' own help is dropped: it names
/// the flags of the subcommand that owns `T`.
pub fn value_or<T>(other: PossibleValue) -> impl TypedValueParser<Value = Option<T>>
where
    T: ValueEnum + Clone + Send + Sync + 'static,
{
    let values = T::value_variants()
        .iter()
        .filter_map(ValueEnum::to_possible_value)
        .map(|v| v.help(None::<&'static str>));
    PossibleValuesParser::new(std::iter::once(other).chain(values))
        .map(|s| T::from_str(&s, false).ok())
}

/// How a value of an enumerated flag is spelled on the command line.
pub fn flag_value<T: ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

/// A count as a person writes it: 1e6, 1.5e9, 20260101, 17.
pub fn count_text(n: u64) -> String {
    let zeros = (0..19)
        .take_while(|&k| n != 0 && n.is_multiple_of(10u64.pow(k + 1)))
        .count() as u32;
    if n < 10_000 || zeros < 3 {
        return n.to_string();
    }
    let m = (n / 10u64.pow(zeros)).to_string();
    let exp = zeros as usize + m.len() - 1;
    match m.split_at(1) {
        (d, "") => format!("{d}e{exp}"),
        (d, frac) => format!("{d}.{frac}e{exp}"),
    }
}

/// Counts as a person writes them, comma-separated.
pub fn counts_text(v: &[u64]) -> String {
    v.iter()
        .map(|&n| count_text(n))
        .collect::<Vec<_>>()
        .join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_take_exponent_notation() {
        assert_eq!(count::<u64>("1000000"), Ok(1_000_000));
        assert_eq!(count::<u64>("1e6"), Ok(1_000_000));
        assert_eq!(count::<u64>(" 2.5e3 "), Ok(2500));
        assert_eq!(count::<usize>("17"), Ok(17));
        assert_eq!(count::<u32>("1e9"), Ok(1_000_000_000));
        assert_eq!(
            count::<u32>("1e10").unwrap_err(),
            "too large (at most 4294967295)"
        );
        assert!(count::<u64>("1.5").unwrap_err().contains("whole number"));
        assert!(count::<u64>("-1").unwrap_err().contains(">= 0"));
        assert!(count::<u64>("abc").unwrap_err().contains("whole number"));
        assert!(count::<u64>("1e20").unwrap_err().contains("largest count"));
        assert_eq!(count::<u64>("18446744073709551615"), Ok(u64::MAX));
        assert_eq!(image_size("1e3x20"), Ok((1000, 20)));
        assert!(image_size("40by20").is_err());
    }

    #[test]
    fn counts_are_written_as_they_are_read() {
        for (n, text) in [
            (17, "17"),
            (1000, "1000"),
            (10_000, "1e4"),
            (300_000, "3e5"),
            (2_000_000, "2e6"),
            (1_500_000_000, "1.5e9"),
            (20_260_101, "20260101"),
            (20_260_000, "2.026e7"),
            (u64::MAX, "18446744073709551615"),
        ] {
            assert_eq!(count_text(n), text);
            assert_eq!(count::<u64>(text), Ok(n));
        }
    }

    #[test]
    fn list_items_are_read_by_the_library() {
        assert!(taps("17").is_ok() && taps("1e1").is_err() && taps("257").is_err());
        assert!(rank_item("1-3").is_ok() && rank_item("3-1").is_err());
        assert!(channel_item("rg").is_ok() && channel_item("x").is_err());
        assert!(name_item(" ").is_err());
        assert_eq!(rgb("1, 2,3"), Ok([1.0, 2.0, 3.0]));
        assert_eq!(rgb(&rgb_text([0.48, 0.41, 0.28])), Ok([0.48, 0.41, 0.28]));
        let r = evaluate::SIGNAL_SIZE_RANGE;
        assert!(signal_size(&r.start().to_string()).is_ok());
        assert!(signal_size(&(r.start() - 1).to_string()).is_err());
        assert!(signal_size(&r.end().to_string()).is_ok());
        assert!(signal_size(&(r.end() + 1).to_string()).is_err());
    }
}
