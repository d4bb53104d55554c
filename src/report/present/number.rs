//! Number formatting of the reports: significant digits, percentages,
//! durations. One definition per format, shared by every table.
use crate::numerics::Bounded;

/// Three significant digits, plain or in exponent form.
pub fn sig(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        format!("{v}")
    } else if v.abs() >= 0.01 && v.abs() < 1000.0 {
        let d = (2 - v.abs().log10().floor() as i32).max(0) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.2e}")
    }
}

/// A percentage with one decimal, signed ("+1.2%") or not ("1.2%");
/// "inf" when not finite.
fn percent(x: f64, signed: bool) -> String {
    match (x.is_finite(), signed) {
        (false, _) => "inf".into(),
        (true, true) => format!("{:+.1}%", Bounded(100.0 * x)),
        (true, false) => format!("{:.1}%", Bounded(100.0 * x)),
    }
}

/// A signed percentage, "+1.2%"; "inf" when not finite.
pub fn pct(x: f64) -> String {
    percent(x, true)
}

/// Four decimals, or three significant digits in exponent form below 1e-3.
pub fn num(x: f64) -> String {
    if x == 0.0 || x >= 1e-3 {
        format!("{x:.4}")
    } else {
        format!("{x:.2e}")
    }
}

/// A percentage, "1.2%"; "inf" when not finite.
pub fn pct_abs(x: f64) -> String {
    percent(x, false)
}

/// Seconds as "372 µs", "1.5 ms", "2.07 s".
pub fn time(s: f64) -> String {
    if s < 1e-3 {
        format!("{:.0} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

/// A relative error for the summaries: "0.45%", "1.1%", "41%", "204%",
/// and "90×" from 10 (1000%) up.
pub fn short(x: f64) -> String {
    if !x.is_finite() {
        return "inf".into();
    }
    let p = 100.0 * x;
    if x >= 10.0 {
        format!("{x:.0}×")
    } else if p >= 10.0 {
        format!("{p:.0}%")
    } else if p >= 1.0 {
        format!("{p:.1}%")
    } else {
        format!("{p:.2}%")
    }
}

/// [`sig`] of a value that may be missing ("-").
pub fn sig_or_dash(v: Option<f64>) -> String {
    v.map_or("-".into(), sig)
}

/// A percentage with two decimals and no sign or "%" (the unit is in the
/// column's name), "-" when not finite: the scene tables' cells.
pub fn pct_cell(v: f64) -> String {
    if v.is_finite() {
        format!("{:.2}", 100.0 * v)
    } else {
        "-".into()
    }
}

/// [`pct_cell`] per channel, "r / g / b".
pub fn pct_cell_rgb(v: [f64; 3]) -> String {
    format!(
        "{} / {} / {}",
        pct_cell(v[0]),
        pct_cell(v[1]),
        pct_cell(v[2])
    )
}
