//! MCML's ASCII output (.mco, MCML 1.2 manual, section 6): the input
//! parameters, the totals (RAT), Rd_r and, for a finite stack, Tt_r; when
//! the run tallied exit angles, Rd_a and Rd_ra (and Tt_a, Tt_ra), so that a
//! run diffs line by line with an MCML run of the same .mci file, in
//! MCML's order (mcmlio.c `WriteResult`: Rd_r, Rd_a, Tt_r, Tt_a, then
//! Rd_ra, Tt_ra). Units are MCML's: cm, cm^-1, cm^-2 and sr^-1. A_l, A_z
//! and A_rz are not tallied here and not written.
//!
//! Where it follows MCML rather than the profile JSON: weight that leaves
//! beyond the grid is added to the last Rd_r (Tt_r) bin (MCML's convention,
//! its RecordR and RecordT clamp the radius index), and to the last row of
//! Rd_ra (Tt_ra); the JSON keeps it apart (`rd_beyond_rmax`,
//! `transmittance_profile.beyond_rmax`) so that kernels see no spike there.
//! The arrays are scaled as MCML's ScaleRdTt does (mcmlio.c, MCML 1.2.2):
//! Rd_r and Tt_r by the annulus 2 pi (i + 1/2) dr^2, Rd_a and Tt_a by
//! 2 pi da sin(a) (its approximation of the solid angle), Rd_ra and Tt_ra
//! by the annulus times 4 pi sin(a) sin(da/2) cos(a), a at the bin centre.
//! Tt_a bins the transmitted direction below the stack (RecordT:
//! acos(uz) of the refracted packet).

use crate::error::{Error, Result};
use crate::numerics::annulus_area;
use crate::profile::Profile;
use std::fmt::Write as _;
use std::path::Path;

/// C's `%G` (precision 6): the shorter of fixed and exponent notation,
/// trailing zeros removed.
fn c_g(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if !x.is_finite() {
        return format!("{x}").to_uppercase();
    }
    let exp = x.abs().log10().floor() as i32;
    // Exponent after rounding to 6 significant digits.
    let e = format!("{:.5e}", x);
    let exp_r: i32 = e
        .split('e')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(exp);
    let trim = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if (-4..6).contains(&exp_r) {
        let decimals = (5 - exp_r).max(0) as usize;
        trim(format!("{:.*}", decimals, x))
    } else {
        let (mant, _) = e.split_once('e').unwrap_or((&e, "0"));
        format!(
            "{}E{}{:02}",
            trim(mant.to_string()),
            if exp_r < 0 { '-' } else { '+' },
            exp_r.abs()
        )
    }
}

/// C's `%12.4E`.
fn c_e(x: f64) -> String {
    let e = format!("{:.4e}", x);
    let (mant, exp) = e.split_once('e').unwrap_or((&e, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    format!(
        "{:>12}",
        format!("{mant}E{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
    )
}

/// The bin width of `p`'s radial grid, refused unless uniform (MCML's
/// dr, nr).
fn uniform_dr(p: &Profile) -> Result<f64> {
    let dr = p.r_edges[1] - p.r_edges[0];
    if p.r_edges
        .iter()
        .enumerate()
        .any(|(i, e)| (e - i as f64 * dr).abs() > 1e-9 * dr.max(*e))
    {
        return Err(Error::Unsupported(
            "an .mco file needs a uniform radial grid (MCML's dr, nr); this run has geometric bins"
                .into(),
        ));
    }
    Ok(dr)
}

/// The .mco text of a one-channel profile on a uniform grid.
pub fn mco_text(p: &Profile, output_name: &str) -> Result<String> {
    if p.channels.len() != 1 {
        return Err(Error::Unsupported(format!(
            "an .mco file holds one wavelength (MCML is monochrome); this run has {} channels: \
             simulate one channel",
            p.channels.len()
        )));
    }
    let dr = uniform_dr(p)?;
    let cm = |mm: f64| mm / 10.0;
    let angular = p.angular()?;
    let exit = angular
        .as_ref()
        .and_then(|a| a.exit.as_ref().map(|x| (a, x)));
    let na = exit.map_or(1, |(a, _)| a.angle_bins);
    let mut s = String::new();
    let _ = writeln!(s, "A1 \t# Version number of the file format.\n");
    let tt = p.transmittance_profile()?;
    let tt_angles = tt.as_ref().and_then(|t| t.angular.as_ref());
    let mut ones = vec!["Rd_r"];
    let mut twos = vec![];
    if exit.is_some() {
        ones.push("Rd_a");
        twos.push("Rd_ra");
    }
    if tt.is_some() {
        ones.push("Tt_r");
    }
    if tt_angles.is_some() && exit.is_some() {
        ones.push("Tt_a");
        twos.push("Tt_ra");
    }
    write_categories(&mut s, &ones, &twos);
    write_in_parm(&mut s, p, output_name, dr, na);
    write_rat(&mut s, p);
    let _ = writeln!(s, "Rd_r #Rd[0], [1],..Rd[nr-1]. [1/cm2]");
    let beyond = p.rd_beyond_rmax()?.map_or(0.0, |b| b[0]);
    write_radial(&mut s, p, &p.rd[0], beyond);
    if let Some((a, x)) = exit {
        write_rd_a(&mut s, a, x);
    }
    if let Some(t) = &tt {
        let _ = writeln!(s, "Tt_r #Tt[0], [1],..Tt[nr-1]. [1/cm2]");
        write_radial(&mut s, p, &t.td[0], t.beyond_rmax[0]);
    }
    let tt_a = tt_angles.filter(|_| exit.is_some());
    if let Some(ta) = tt_a {
        write_tt_a(&mut s, ta);
    }
    if let Some((a, x)) = exit {
        write_rd_ra(&mut s, p, a, x, cm(dr));
    }
    if let Some(ta) = tt_a {
        write_tt_ra(&mut s, ta, cm(dr));
    }
    Ok(s)
}

/// The header's list of the data categories written.
fn write_categories(s: &mut String, ones: &[&str], twos: &[&str]) {
    let mut all = vec!["InParm", "RAT"];
    all.extend(ones);
    all.extend(twos);
    let only = match all.split_last() {
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
        None => String::new(),
    };
    let mut cats = format!("InParm, RAT, \n# {}, ", ones.join(", "));
    if !twos.is_empty() {
        cats.push_str(&format!("\n# {}", twos.join(", ")));
    }
    if ones.len() == 1 {
        cats = "InParm, RAT, Rd_r".into();
    }
    let _ = writeln!(s, "####\n# Data categories include: \n# {cats} \n####\n");
    let _ = writeln!(
        s,
        "# Written by ssskit: only {only}; weight beyond the grid is in the last radial bin.\n"
    );
}

/// MCML's InParm block: the run's photons, grid and layers, in cm.
fn write_in_parm(s: &mut String, p: &Profile, output_name: &str, dr: f64, na: usize) {
    let n = p.r.len();
    let photons = p
        .source
        .photons
        .as_ref()
        .and_then(|v| v.first())
        .copied()
        .unwrap_or(0);
    let c = p.channels[0].index();
    let m = &p.material;
    let cm = |mm: f64| mm / 10.0;
    let _ = writeln!(s, "InParm \t\t\t# Input parameters. cm is used.");
    let _ = writeln!(s, "{output_name} \tA\t\t# output file name, ASCII.");
    let _ = writeln!(s, "{photons} \t\t\t# No. of photons");
    let _ = writeln!(s, "{}\t{}\t\t# dz, dr [cm]", c_g(cm(dr)), c_g(cm(dr)));
    let _ = writeln!(s, "{}\t{}\t{}\t# No. of dz, dr, da.\n", 1, n, na);
    let _ = writeln!(s, "{}\t\t\t\t\t# Number of layers", m.layers.len());
    let _ = writeln!(s, "#n\tmua\tmus\tg\td\t# One line for each layer");
    let _ = writeln!(s, "{}\t\t\t\t\t# n for medium above", c_g(m.eta_above));
    for (i, l) in m.layers.iter().enumerate() {
        // A semi-infinite layer is written the way MCML users do: 1E8 cm.
        let d = l.thickness.map_or(1e8, cm);
        let _ = writeln!(
            s,
            "{}\t{}\t{}\t{}\t{}\t# layer {}",
            c_g(l.eta),
            c_g(l.sigma_a[c] * 10.0),
            c_g(l.sigma_s[c] * 10.0),
            c_g(l.g[c]),
            c_g(d),
            i + 1
        );
    }
    let _ = writeln!(s, "{}\t\t\t\t\t# n for medium below\n", c_g(m.eta_below));
}

/// MCML's RAT block: specular, diffuse, absorbed, transmitted.
fn write_rat(s: &mut String, p: &Profile) {
    let get = |v: &Option<Vec<f64>>| v.as_ref().and_then(|v| v.first()).copied().unwrap_or(0.0);
    let _ = writeln!(s, "RAT #Reflectance, absorption, transmission. ");
    let _ = writeln!(s, "{:<14} \t#Specular reflectance [-]", c_g(p.specular[0]));
    let _ = writeln!(s, "{:<14} \t#Diffuse reflectance [-]", c_g(p.total_rd[0]));
    let _ = writeln!(s, "{:<14} \t#Absorbed fraction [-]", c_g(get(&p.absorbed)));
    let _ = writeln!(
        s,
        "{:<14} \t#Transmittance [-]\n",
        c_g(get(&p.transmittance))
    );
}

/// A radial array in 1/cm^2, one value a line, the light beyond the grid
/// in the last bin (MCML's WriteRd_r and WriteTt_r).
fn write_radial(s: &mut String, p: &Profile, v: &[f64], beyond: f64) {
    let n = p.r.len();
    let last_area = annulus_area(p.r_edges[n - 1], p.r_edges[n]);
    for (i, v) in v.iter().enumerate() {
        let mm2 = if i + 1 == n {
            v + beyond / last_area
        } else {
            *v
        };
        let _ = writeln!(s, "{}", c_e(mm2 * 100.0));
    }
    s.push('\n');
}

/// MCML's solid angle of exit bin `ia` of `na` (ScaleRdTt): 2 pi da sin(a)
/// at the bin centre, and the bin centre.
fn solid_angle(ia: usize, na: usize) -> (f64, f64) {
    use std::f64::consts::PI;
    let da = PI / (2.0 * na as f64);
    let a = (ia as f64 + 0.5) * da;
    (2.0 * PI * da * a.sin(), a)
}

/// MCML's scale of a radius x angle cell (ScaleRdTt): the annulus
/// 2 pi (i + 1/2) dr^2 times 4 pi sin(a) sin(da/2) cos(a).
fn cell_scale(ir: usize, ia: usize, na: usize, dr_cm: f64) -> f64 {
    use std::f64::consts::PI;
    let da = PI / (2.0 * na as f64);
    let t = (ia as f64 + 0.5) * da;
    2.0 * PI * (ir as f64 + 0.5) * dr_cm * dr_cm * 4.0 * PI * t.sin() * (da / 2.0).sin() * t.cos()
}

/// Five `%12.4E ` values a line, counted over the whole array (MCML's
/// WriteRd_ra and WriteTt_ra); `cell(ir, ia)` is the part of the incident
/// light in the cell.
fn write_cells(
    s: &mut String,
    nr: usize,
    na: usize,
    dr_cm: f64,
    cell: impl Fn(usize, usize) -> f64,
) {
    for ir in 0..nr {
        for ia in 0..na {
            let _ = write!(s, "{} ", c_e(cell(ir, ia) / cell_scale(ir, ia, na, dr_cm)));
            if (ir * na + ia + 1).is_multiple_of(5) {
                s.push('\n');
            }
        }
    }
    s.push('\n');
}

/// Tt_a, one value a line (MCML's WriteTt_a).
fn write_tt_a(s: &mut String, t: &crate::profile::mc::TransmittedAngles) {
    let na = t.angle_bins;
    let _ = writeln!(s, "Tt_a #Tt[0], [1],..Tt[na-1]. [sr-1]");
    for ia in 0..na {
        let _ = writeln!(s, "{}", c_e(t.fraction[0][ia] / solid_angle(ia, na).0));
    }
    s.push('\n');
}

/// Tt_ra (MCML's WriteTt_ra), the row beyond r_max added to the last.
fn write_tt_ra(s: &mut String, t: &crate::profile::mc::TransmittedAngles, dr_cm: f64) {
    let cells = &t.cell[0];
    let nr = cells.len() - 1;
    let _ = writeln!(
        s,
        "# Tt[r][angle]. [1/(cm2sr)].\n# Tt[0][0], [0][1],..[0][na-1]\n\
         # Tt[1][0], [1][1],..[1][na-1]\n# ...\n# Tt[nr-1][0], [nr-1][1],..[nr-1][na-1]\nTt_ra"
    );
    write_cells(s, nr, t.angle_bins, dr_cm, |ir, ia| {
        cells[ir][ia] + if ir + 1 == nr { cells[nr][ia] } else { 0.0 }
    });
}

/// Rd_a, one value a line (MCML's WriteRd_a).
fn write_rd_a(
    s: &mut String,
    a: &crate::profile::mc::Angular,
    x: &crate::profile::mc::angular::ExitTable,
) {
    let na = a.angle_bins;
    let _ = writeln!(s, "Rd_a #Rd[0], [1],..Rd[na-1]. [sr-1]");
    for ia in 0..na {
        let _ = writeln!(s, "{}", c_e(x.fraction[0][ia] / solid_angle(ia, na).0));
    }
    s.push('\n');
}

/// Rd_ra (MCML's WriteRd_ra), the light beyond r_max in the last row.
fn write_rd_ra(
    s: &mut String,
    p: &Profile,
    a: &crate::profile::mc::Angular,
    x: &crate::profile::mc::angular::ExitTable,
    dr_cm: f64,
) {
    let nr = p.r.len();
    let _ = writeln!(
        s,
        "# Rd[r][angle]. [1/(cm2sr)].\n# Rd[0][0], [0][1],..[0][na-1]\n\
         # Rd[1][0], [1][1],..[1][na-1]\n# ...\n# Rd[nr-1][0], [nr-1][1],..[nr-1][na-1]\nRd_ra"
    );
    let area_mm2 = |ir: usize| annulus_area(p.r_edges[ir], p.r_edges[ir + 1]);
    write_cells(s, nr, a.angle_bins, dr_cm, |ir, ia| {
        // The part of the incident light in the cell: pi L x area x share.
        let w = x.radiance[0][ir][ia] * area_mm2(ir) * a.lambert_share[ia];
        w + if ir + 1 == nr {
            x.beyond_rmax[0][ia]
        } else {
            0.0
        }
    });
}

/// Writes `mco_text` atomically.
pub fn write_mco(p: &Profile, path: &Path) -> Result<()> {
    let name = path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out.mco".into());
    let text = mco_text(p, &name)?;
    crate::io::write_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c_formats() {
        assert_eq!(c_g(0.0270339123), "0.0270339");
        assert_eq!(c_g(100.0), "100");
        assert_eq!(c_g(1e8), "1E+08");
        assert_eq!(c_g(0.002), "0.002");
        assert_eq!(c_g(2e-5), "2E-05");
        assert_eq!(c_g(1.37), "1.37");
        assert_eq!(c_g(999999.7), "1E+06");
        assert_eq!(c_e(14.355), "  1.4355E+01");
        assert_eq!(c_e(0.0), "  0.0000E+00");
        assert_eq!(c_e(1.2345e-7), "  1.2345E-07");
    }
}
