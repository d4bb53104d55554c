//! Angle-resolved Monte Carlo: where the escaping light goes (exit angle,
//! MCML's Rd_a and Rd_ra; Wang et al. 1995) and how much comes back when
//! the beam arrives obliquely (entry angle), from one run.
//!
//! - **Exit.** Every escape through the top is binned by its polar angle in
//!   the ambient medium after refraction (MCML's `na` bins uniform in angle
//!   over [0, 90] degrees), over the whole plane and per radial bin. The
//!   *exit factor* of a bin is pi L / M: the radiance averaged over the bin
//!   (weighted by cos theta) relative to a Lambertian surface of the same
//!   exitance M, i.e. the bin's share of R_d divided by the share a
//!   Lambertian exit puts there, sin^2(theta_hi) - sin^2(theta_lo). The
//!   *radiance profile* pi L(r, theta) (mm^-2) is R_d(r) for a Lambertian
//!   exit; along the normal it is what a camera looking straight down sees.
//! - **Entry.** For each incidence angle theta_in a run of as many photons as
//!   the normal run's (same seed, its own streams) launches the pencil beam
//!   refracted by Snell's law after the unpolarised Fresnel reflection at
//!   that angle (MCML's launch at any angle). The *entry factor* is
//!   R_d(theta_in) / R_d(0), both per incident photon, R_d(0) the normal run.
//!
//! Standard errors: per-photon second moments (bins, totals), the delta
//! method for ratios of correlated sums (the exit factor, from the per-photon
//! product of a bin's weight with the photon's R_d) and independent streams
//! for the entry factor.

use super::exact::ExactTally;
use super::tally::{AngleLayout, ChunkTally, Moments};
use super::CONTEXT;
use crate::error::{Error, Result};
use crate::profile::{Profile, RadialGrid};
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

mod ahead;
mod incidence;
pub use ahead::{ahead_share, AheadShare, MAX_AHEAD_PHOTONS};
pub(super) use incidence::trace_incidences;

/// Most exit-angle bins (0.1 degree).
pub const MAX_ANGLE_BINS: usize = 900;
/// Most radius x angle cells of the radiance table (memory of the exact
/// sums and of the JSON).
pub const MAX_ANGLE_CELLS: usize = 1 << 18;
/// Most oblique incidence angles (each costs a run as long as the normal one).
pub const MAX_INCIDENCES: usize = 16;
/// Largest incidence angle in degrees: at grazing incidence the Fresnel
/// reflectance tends to 1 and R_d(theta_in) to 0 (and its relative error
/// to infinity).
pub const MAX_INCIDENCE_DEG: f64 = 89.0;

/// What to resolve by angle.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AngularOptions {
    /// Exit-angle bins over [0, 90] degrees (MCML's `na`); 0: no exit tally.
    pub angle_bins: usize,
    /// Oblique incidence angles in degrees, besides the normal (entry factor).
    pub incidence_deg: Vec<f64>,
}

impl AngularOptions {
    /// The incidence angles of the entry table: the normal first, then the
    /// given ones in order.
    pub fn incidences(&self) -> Vec<f64> {
        std::iter::once(0.0)
            .chain(self.incidence_deg.iter().copied().filter(|&t| t != 0.0))
            .collect()
    }

    /// The exit-angle layout of the normal run on `radial_bins` bins (plus
    /// the row beyond r_max), None without exit bins.
    pub(super) fn layout(&self, radial_bins: usize) -> Option<AngleLayout> {
        (self.angle_bins > 0).then_some(AngleLayout {
            angle_bins: self.angle_bins,
            radial: radial_bins + 1,
        })
    }

    /// Checks the options against a grid of `radial_bins` bins.
    pub fn validate(&self, radial_bins: usize) -> Result<()> {
        if self.angle_bins == 0 && self.incidence_deg.is_empty() {
            return Err(Error::invalid(
                CONTEXT,
                "angle_bins",
                0,
                "angle-resolved tallies need exit-angle bins, incidence angles or both",
            ));
        }
        if self.angle_bins > MAX_ANGLE_BINS {
            return Err(Error::invalid(
                CONTEXT,
                "angle_bins",
                self.angle_bins,
                format!("at most {MAX_ANGLE_BINS} (0.1 degree)"),
            ));
        }
        let cells = (radial_bins + 1).saturating_mul(self.angle_bins);
        if cells > MAX_ANGLE_CELLS {
            return Err(Error::invalid(
                CONTEXT,
                "angle_bins",
                self.angle_bins,
                format!(
                    "{} radial bins x {} angle bins = {cells} cells of the radiance table, at \
                     most {MAX_ANGLE_CELLS}: fewer angle bins or a coarser radial grid",
                    radial_bins + 1,
                    self.angle_bins
                ),
            ));
        }
        if self.incidence_deg.len() > MAX_INCIDENCES {
            return Err(Error::invalid(
                CONTEXT,
                "incidence_deg",
                format!("{} angles", self.incidence_deg.len()),
                format!("at most {MAX_INCIDENCES} (each costs a run as long as the normal one)"),
            ));
        }
        for (i, &t) in self.incidence_deg.iter().enumerate() {
            if !(t.is_finite() && (0.0..=MAX_INCIDENCE_DEG).contains(&t)) {
                return Err(Error::invalid(
                    CONTEXT,
                    "incidence_deg",
                    t,
                    format!("each angle must be in [0, {MAX_INCIDENCE_DEG}] degrees"),
                ));
            }
            if self.incidence_deg[..i].contains(&t) {
                return Err(Error::invalid(CONTEXT, "incidence_deg", t, "given twice"));
            }
        }
        Ok(())
    }
}

/// The exit-angle bin edges in degrees (MCML: da = 90 / na degrees).
pub fn theta_edges_deg(angle_bins: usize) -> Vec<f64> {
    (0..=angle_bins)
        .map(|j| 90.0 * j as f64 / angle_bins as f64)
        .collect()
}

/// The share of a Lambertian exit in each bin: sin^2(hi) - sin^2(lo), the
/// bin's projected solid angle over pi.
pub fn lambert_shares(angle_bins: usize) -> Vec<f64> {
    let s2 = |j: usize| (FRAC_PI_2 * j as f64 / angle_bins as f64).sin().powi(2);
    (0..angle_bins).map(|j| s2(j + 1) - s2(j)).collect()
}

/// The exit table of one run, normal incidence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExitTable {
    /// Part of the incident light leaving through each angle bin, whole
    /// plane: `[channel][angle bin]`.
    pub fraction: Vec<Vec<f64>>,
    pub fraction_stderr: Vec<Vec<f64>>,
    /// pi L / M per angle bin (1 for a Lambertian exit).
    pub factor: Vec<Vec<f64>>,
    pub factor_stderr: Vec<Vec<f64>>,
    /// pi L(r, theta) in mm^-2, averaged over each radial bin's annulus and
    /// each angle bin (cos-weighted): `[channel][radial bin][angle bin]`;
    /// sum over angle bins of radiance x Lambertian share = R_d(r).
    pub radiance: Vec<Vec<Vec<f64>>>,
    pub radiance_stderr: Vec<Vec<Vec<f64>>>,
    /// Part of the incident light leaving beyond r_max per angle bin.
    pub beyond_rmax: Vec<Vec<f64>>,
}

/// The entry table: one run per incidence angle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EntryTable {
    /// Incidence angles in degrees, the normal first.
    pub incidence_deg: Vec<f64>,
    /// Photons per channel of every incidence (the normal run's count).
    pub photons: Vec<u64>,
    /// `[channel][incidence]`: Fresnel reflection at entry, reported apart.
    pub specular: Vec<Vec<f64>>,
    /// R_d per incident photon and its standard error.
    pub total_rd: Vec<Vec<f64>>,
    pub total_rd_stderr: Vec<Vec<f64>>,
    /// R_d(theta_in) / R_d(0) (independent runs: relative errors add in
    /// quadrature; exactly 1 and 0 for the normal).
    pub factor: Vec<Vec<f64>>,
    pub factor_stderr: Vec<Vec<f64>>,
    /// specular + R_d + T + absorbed + roulette and truncation residual - 1.
    pub energy_balance_minus_1: Vec<Vec<f64>>,
    /// pi L / M per exit-angle bin for each incidence: `[channel][incidence]
    /// [angle bin]` (empty without exit bins).
    pub exit_factor: Vec<Vec<Vec<f64>>>,
    pub exit_factor_stderr: Vec<Vec<Vec<f64>>>,
}

/// Everything angle-resolved a run recorded (`extra.angular` of a profile).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Angular {
    pub angle_bins: usize,
    /// Exit-angle bin edges in degrees, in the ambient medium.
    pub theta_edges_deg: Vec<f64>,
    /// Lambertian share of each bin, sin^2(hi) - sin^2(lo).
    pub lambert_share: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exit: Option<ExitTable>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entry: Option<EntryTable>,
    /// What each table means, for a reader of the JSON.
    #[serde(default)]
    pub definitions: serde_json::Value,
}

/// The standard error of the ratio sum(x) / sum(y) of per-photon values
/// from their sums (delta method): sqrt(N/(N-1) sum (x - R y)^2) / sum(y).
fn ratio_stderr(sx: f64, sxx: f64, sxy: f64, sy: f64, syy: f64, n: u64) -> f64 {
    if n < 2 || !(sy > 0.0) {
        return 0.0;
    }
    let r = sx / sy;
    let nf = n as f64;
    let ss = (sxx - 2.0 * r * sxy + r * r * syy).max(0.0);
    (nf / (nf - 1.0) * ss).sqrt() / sy
}

/// Per angle bin of one tally: (fraction, its stderr, exit factor, its stderr).
fn exit_columns(t: &ChunkTally, shares: &[f64]) -> [Vec<f64>; 4] {
    let n = t.photons;
    let e = &t.exit;
    let mut out: [Vec<f64>; 4] = Default::default();
    for (i, share) in shares.iter().enumerate() {
        let m = Moments {
            sum: e.a.sum[i],
            sum_sq: e.a.sum_sq[i],
        };
        let (sx, sy) = (e.a.sum[i], t.rd.sum);
        let r = if sy > 0.0 { sx / sy } else { 0.0 };
        let se = ratio_stderr(sx, e.a.sum_sq[i], e.a_cross[i], sy, t.rd.sum_sq, n);
        out[0].push(m.mean(n));
        out[1].push(m.stderr(n));
        out[2].push(r / share);
        out[3].push(se / share);
    }
    out
}

/// The angle-resolved results of a run: the normal runs' tallies `main`
/// (per channel) and the oblique ones (`trace_incidences`).
pub(super) fn results(
    grid: &RadialGrid,
    opts: &AngularOptions,
    main: &[ExactTally],
    oblique: &[Vec<ExactTally>],
) -> Angular {
    let na = opts.angle_bins;
    let shares = lambert_shares(na);
    let ts: Vec<ChunkTally> = main.iter().map(ExactTally::to_f64).collect();
    let exit = (na > 0).then(|| exit_table(grid, &ts, &shares));
    let entry = (opts.incidences().len() > 1).then(|| entry_table(opts, &ts, oblique, &shares));
    Angular {
        angle_bins: na,
        theta_edges_deg: if na > 0 { theta_edges_deg(na) } else { vec![] },
        lambert_share: shares,
        exit,
        entry,
        definitions: serde_json::json!({
            "theta": "polar angle of the escaping direction in the ambient medium, after \
                      refraction; bins uniform in angle over [0, 90] degrees (MCML's na)",
            "exit.fraction": "part of the incident light leaving through the angle bin, whole \
                              plane (MCML's Rd_a times the bin's solid angle)",
            "exit.factor": "pi L / M: the bin's share of R_d over sin^2(hi) - sin^2(lo), the \
                            share of a Lambertian exit; 1 for a Lambertian surface",
            "exit.radiance": "pi L(r, theta) in mm^-2 per radial and angle bin; equals R_d(r) \
                              for a Lambertian exit",
            "entry.factor": "R_d(theta_in) / R_d(0), both per incident photon (the Fresnel \
                             reflection at entry reported apart as entry.specular)",
            "stderr": "from per-photon second moments; ratios by the delta method (exit) or \
                       as independent runs (entry)",
        }),
    }
}

/// The exit table of the normal runs `ts` (per channel), on `shares.len()`
/// angle bins.
fn exit_table(grid: &RadialGrid, ts: &[ChunkTally], shares: &[f64]) -> ExitTable {
    let mut x = ExitTable {
        fraction: vec![],
        fraction_stderr: vec![],
        factor: vec![],
        factor_stderr: vec![],
        radiance: vec![],
        radiance_stderr: vec![],
        beyond_rmax: vec![],
    };
    let areas = grid.areas();
    let (na, nb) = (shares.len(), grid.len());
    for t in ts {
        let [f, fe, k, ke] = exit_columns(t, shares);
        x.fraction.push(f);
        x.fraction_stderr.push(fe);
        x.factor.push(k);
        x.factor_stderr.push(ke);
        let n = t.photons;
        let cell = |ir: usize, ia: usize| Moments {
            sum: t.exit.ra.sum[ir * na + ia],
            sum_sq: t.exit.ra.sum_sq[ir * na + ia],
        };
        // pi L = pi W / (N area pi share): the projected solid angle of
        // a bin is pi x its Lambertian share.
        let (v, e): (Vec<Vec<f64>>, Vec<Vec<f64>>) = (0..nb)
            .map(|ir| {
                (0..na)
                    .map(|ia| {
                        let m = cell(ir, ia);
                        let d = areas[ir] * shares[ia];
                        (m.mean(n) / d, m.stderr(n) / d)
                    })
                    .unzip()
            })
            .unzip();
        x.radiance.push(v);
        x.radiance_stderr.push(e);
        x.beyond_rmax
            .push((0..na).map(|ia| cell(nb, ia).mean(n)).collect());
    }
    x
}

/// The entry table: per channel, the normal run `ts[c]` and the oblique
/// ones `oblique[c]` (its first, the normal, unused).
fn entry_table(
    opts: &AngularOptions,
    ts: &[ChunkTally],
    oblique: &[Vec<ExactTally>],
    shares: &[f64],
) -> EntryTable {
    let mut e = EntryTable {
        incidence_deg: opts.incidences(),
        photons: ts.iter().map(|t| t.photons).collect(),
        specular: vec![],
        total_rd: vec![],
        total_rd_stderr: vec![],
        factor: vec![],
        factor_stderr: vec![],
        energy_balance_minus_1: vec![],
        exit_factor: vec![],
        exit_factor_stderr: vec![],
    };
    for (c, t0) in ts.iter().enumerate() {
        let runs: Vec<ChunkTally> = std::iter::once(t0.clone())
            .chain(oblique[c].iter().skip(1).map(ExactTally::to_f64))
            .collect();
        let ([s, r, rs, f, fe, b], xf, xe) = entry_rows(&runs, shares);
        e.specular.push(s);
        e.total_rd.push(r);
        e.total_rd_stderr.push(rs);
        e.factor.push(f);
        e.factor_stderr.push(fe);
        e.energy_balance_minus_1.push(b);
        e.exit_factor.push(xf);
        e.exit_factor_stderr.push(xe);
    }
    e
}

/// One channel's entry rows over its incidence runs (the normal first):
/// specular, R_d, its stderr, the entry factor, its stderr and the energy
/// balance - 1 per incidence, and the exit factors with their stderrs
/// (empty without exit bins).
#[allow(clippy::type_complexity)]
fn entry_rows(
    runs: &[ChunkTally],
    shares: &[f64],
) -> ([Vec<f64>; 6], Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let t0 = &runs[0];
    let rd0 = t0.rd.mean(t0.photons);
    let rel0 = if rd0 > 0.0 {
        t0.rd.stderr(t0.photons) / rd0
    } else {
        0.0
    };
    let mut row = [vec![], vec![], vec![], vec![], vec![], vec![]];
    let (mut xf, mut xe) = (vec![], vec![]);
    for (k, t) in runs.iter().enumerate() {
        let n = t.photons;
        let nf = n.max(1) as f64;
        let rd = t.rd.mean(n);
        let se = t.rd.stderr(n);
        let (f, fe) = if k == 0 {
            (1.0, 0.0)
        } else if rd0 > 0.0 {
            let rel = if rd > 0.0 { se / rd } else { 0.0 };
            (rd / rd0, rd / rd0 * rel.hypot(rel0))
        } else {
            (0.0, 0.0)
        };
        let balance = (t.specular + t.rd.sum + t.transmittance.sum + t.absorbed.sum - 1.0 * nf
            + t.residual())
            / nf;
        row[0].push(t.specular / nf);
        row[1].push(rd);
        row[2].push(se);
        row[3].push(f);
        row[4].push(fe);
        row[5].push(balance);
        if !shares.is_empty() {
            let [_, _, k, ke] = exit_columns(t, shares);
            xf.push(k);
            xe.push(ke);
        }
    }
    (row, xf, xe)
}

/// The profile seen from `theta_deg` (0: along the normal): R_d replaced by
/// pi L(r, theta) of the exit-angle bin holding `theta_deg` (the bin nearer
/// the normal on an edge), `total_rd` by the whole-plane pi L of that bin,
/// so that a kernel fitted from it blurs what a camera in that direction
/// sees. Needs a profile with the exit table (`extra.angular`).
pub fn view_profile(p: &Profile, theta_deg: f64) -> Result<Profile> {
    let a = p.angular()?.ok_or_else(|| {
        Error::Unsupported(format!(
            "profile of '{}' has no angle-resolved tallies (simulate with exit-angle bins)",
            p.material.name
        ))
    })?;
    let x = a.exit.as_ref().ok_or_else(|| {
        Error::Unsupported(format!(
            "profile of '{}' has no exit-angle bins (only entry factors)",
            p.material.name
        ))
    })?;
    if !(theta_deg.is_finite() && (0.0..=90.0).contains(&theta_deg)) {
        return Err(Error::invalid(
            CONTEXT,
            "view_deg",
            theta_deg,
            "must be in [0, 90] degrees from the normal",
        ));
    }
    let na = a.angle_bins;
    let b = ((theta_deg / 90.0 * na as f64) as usize).min(na - 1);
    let share = a.lambert_share[b];
    let mut v = p.clone();
    v.rd = x
        .radiance
        .iter()
        .map(|t| t.iter().map(|r| r[b]).collect())
        .collect();
    v.rd_stderr = Some(
        x.radiance_stderr
            .iter()
            .map(|t| t.iter().map(|r| r[b]).collect())
            .collect(),
    );
    v.total_rd = x.fraction.iter().map(|f| f[b] / share).collect();
    v.total_rd_stderr = Some(x.fraction_stderr.iter().map(|f| f[b] / share).collect());
    v.transmittance = None;
    v.transmittance_stderr = None;
    v.absorbed = None;
    let (lo, hi) = (a.theta_edges_deg[b], a.theta_edges_deg[b + 1]);
    let view = serde_json::json!({
        "theta_deg": theta_deg,
        "bin_deg": [lo, hi],
        "definition": "rd is pi L(r, theta), the radiance seen from the view angle relative \
                       to a Lambertian exit (cos-weighted average over the bin), total_rd its \
                       whole-plane value: R_d x the exit factor",
    });
    v.source.params["view"] = view.clone();
    let beyond: Vec<f64> = x.beyond_rmax.iter().map(|f| f[b] / share).collect();
    v.extra = serde_json::json!({
        "view": view,
        "rd_beyond_rmax": beyond,
        "warnings": p.warnings()?,
    });
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ratio's standard error from the five sums equals the delta
    /// method written out per photon: sqrt(N/(N-1) sum (x_i - R y_i)^2) /
    /// sum y, R = sum x / sum y.
    #[test]
    fn ratio_stderr_is_the_delta_method() {
        let ys: Vec<f64> = (0..50).map(|i| ((i * 37) % 11) as f64 * 0.1).collect();
        let xs: Vec<f64> = ys
            .iter()
            .enumerate()
            .map(|(i, y)| if i % 3 == 0 { *y } else { 0.3 * y })
            .collect();
        let (sx, sy): (f64, f64) = (xs.iter().sum(), ys.iter().sum());
        let r = sx / sy;
        let direct = (50.0 / 49.0
            * xs.iter()
                .zip(&ys)
                .map(|(x, y)| (x - r * y).powi(2))
                .sum::<f64>())
        .sqrt()
            / sy;
        let sxx = xs.iter().map(|x| x * x).sum();
        let syy = ys.iter().map(|y| y * y).sum();
        let sxy = xs.iter().zip(&ys).map(|(x, y)| x * y).sum();
        let got = ratio_stderr(sx, sxx, sxy, sy, syy, 50);
        assert!((got - direct).abs() < 1e-14, "{got} vs {direct}");
    }

    #[test]
    fn bins_and_shares() {
        let l = AngleLayout {
            angle_bins: 9,
            radial: 0,
        };
        assert_eq!(l.angle_bin(1.0), 0);
        assert_eq!(l.angle_bin(0.0), 8);
        assert_eq!(l.angle_bin(25f64.to_radians().cos()), 2);
        assert_eq!(l.angle_bin(9.999f64.to_radians().cos()), 0);
        assert_eq!(l.angle_bin(10.001f64.to_radians().cos()), 1);
        let s = lambert_shares(2);
        assert!((s[0] - 0.5).abs() < 1e-15 && (s[1] - 0.5).abs() < 1e-15);
        assert_eq!(theta_edges_deg(3), [0.0, 30.0, 60.0, 90.0]);
    }
}
