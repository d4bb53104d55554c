//! The angular factor tables ([`AngularFactors`]): their nodes, the
//! lookup the shader header implements, their checks, where a profile
//! keeps them, and how they are built from an angle-resolved record
//! ([`from_angular`]). The simulation file beside it runs the Monte Carlo
//! that makes that record.

use crate::error::{Error, Result};
use crate::material::Channel;
use crate::profile::mc::Angular;
use crate::profile::Profile;
use serde::{Deserialize, Serialize};

/// Nodes of each table: cosines 0, 1/8, ..., 1.
pub const NODES: usize = 9;

/// Key of `extra` where a profile made by the main job keeps the tables of
/// its own factor run (a profile of `ssskit simulate --angle-bins
/// --incidence` keeps the whole record under `angular` instead).
pub const PROFILE_KEY: &str = "angular_factors";

/// The cosine of node `k`.
pub fn node_mu(k: usize) -> f64 {
    k as f64 / (NODES - 1) as f64
}

/// The table at `mu` (clamped to [0, 1]), linear between the nodes: what
/// the shader header's `sss_entry_factor` and `sss_exit_factor` compute.
pub fn lookup(table: &[[f64; 3]], mu: f64) -> [f64; 3] {
    let n = table.len();
    let x = if mu.is_nan() { 0.0 } else { mu.clamp(0.0, 1.0) } * (n - 1) as f64;
    let i = (x as usize).min(n - 2);
    let t = x - i as f64;
    std::array::from_fn(|c| table[i][c] + t * (table[i + 1][c] - table[i][c]))
}

/// The two tables with their standard errors, `[node][channel]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AngularFactors {
    /// The node cosines, k / (n - 1).
    pub mu: Vec<f64>,
    /// R_d(theta_in) / R_d(0) at N.L = mu.
    pub entry: Vec<[f64; 3]>,
    pub entry_stderr: Vec<[f64; 3]>,
    /// pi L(theta_out) / M at N.V = mu (normal incidence).
    pub exit: Vec<[f64; 3]>,
    pub exit_stderr: Vec<[f64; 3]>,
    /// Photons per channel of each run the tables came from.
    pub photons: u64,
}

/// Largest node count a file may carry.
pub const MAX_NODES: usize = 1024;

/// How far the entry factor at N.L = 1 may be from 1: tables are written
/// with every digit (the node is exactly 1), or typed with at least six.
pub const UNIT_ENTRY_TOLERANCE: f64 = 1e-6;

/// How far the exit table's Lambertian mean may be from 1: a table ssskit
/// writes meets it to rounding (each node averages the bins' pi L / M over
/// its interval, and the bins' shares of R_d sum to 1); the tolerance
/// admits tables typed to four significant digits and is a 0.1% change of
/// brightness, a twentieth of an 8-bit sRGB step at mid-grey.
pub const EXIT_MEAN_TOLERANCE: f64 = 1e-3;

/// How far E(mu) x total_rd may exceed 1: the entry factor's R_d(theta_in)
/// and R_d(0) come from a factor run of at least
/// [`MIN_PHOTONS`] photons and `total_rd` from the profile's own run, each
/// with a relative standard error of at most about 1% where R_d nears 1
/// (there nearly every photon comes back); 5% is far beyond their noise,
/// far below the factors of 10 and more a wrong table gives.
pub const ENTRY_ENERGY_SLACK: f64 = 0.05;

impl AngularFactors {
    /// The entry factor at N.L = `mu`.
    pub fn entry_at(&self, mu: f64) -> [f64; 3] {
        lookup(&self.entry, mu)
    }

    /// The exit factor at N.V = `mu`.
    pub fn exit_at(&self, mu: f64) -> [f64; 3] {
        lookup(&self.exit, mu)
    }

    /// Checks a table read from a file: node count, uniform cosines,
    /// finite positive factors, finite non-negative errors.
    pub fn validate(&self, what: &str) -> std::result::Result<(), String> {
        let n = self.mu.len();
        if !(2..=MAX_NODES).contains(&n) {
            return Err(format!(
                "{what}.mu: {n} nodes; between 2 and {MAX_NODES} expected"
            ));
        }
        for (k, &m) in self.mu.iter().enumerate() {
            let want = k as f64 / (n - 1) as f64;
            if !((m - want).abs() <= 1e-9) {
                return Err(format!(
                    "{what}.mu[{k}] = {m}: the nodes are k / (n - 1) = {want}"
                ));
            }
        }
        let tables = [
            ("entry", &self.entry, true),
            ("entry_stderr", &self.entry_stderr, false),
            ("exit", &self.exit, true),
            ("exit_stderr", &self.exit_stderr, false),
        ];
        for (name, t, factor) in tables {
            if t.len() != n {
                return Err(format!("{what}.{name}: {} rows for {n} nodes", t.len()));
            }
            for (k, row) in t.iter().enumerate() {
                for (c, &v) in row.iter().enumerate() {
                    let ok = v.is_finite() && if factor { v > 0.0 } else { v >= 0.0 };
                    if !ok {
                        return Err(format!(
                            "{what}.{name}[{k}][{c}] = {v}: must be finite and {}",
                            if factor { "> 0" } else { ">= 0" }
                        ));
                    }
                }
            }
        }
        for (c, ch) in ["r", "g", "b"].iter().enumerate() {
            // E(1) = R_d(0) / R_d(0).
            let e1 = self.entry[n - 1][c];
            if !((e1 - 1.0).abs() <= UNIT_ENTRY_TOLERANCE) {
                return Err(format!(
                    "{what}.entry[{}][{c}] = {e1}: the entry factor at N.L = 1 is 1 by \
                     definition (R_d(0) / R_d(0), channel {ch})",
                    n - 1
                ));
            }
            let mean = self.exit_lambertian_mean(c);
            if !((mean - 1.0).abs() <= EXIT_MEAN_TOLERANCE) {
                return Err(format!(
                    "{what}.exit: channel {ch} averages {mean:.6e} over the hemisphere with the \
                     Lambertian weight 2 N.V dN.V; pi L / M averages 1 by definition (M is the \
                     exitance L integrates to), so the exit factor would {} the light by that \
                     factor",
                    if mean > 1.0 { "multiply" } else { "divide" }
                ));
            }
        }
        Ok(())
    }

    /// The exit table of channel `c` averaged with the Lambertian weight
    /// 2 mu dmu: each node stands for the cosines within half a spacing of
    /// it (the intervals [`from_angular`] averages the bins over), so the
    /// weighted sum of the nodes is the integral of pi L / M over the
    /// hemisphere's projected solid angle, 1.
    pub fn exit_lambertian_mean(&self, c: usize) -> f64 {
        let n = self.mu.len();
        let h = 0.5 / (n - 1) as f64;
        (0..n)
            .map(|k| {
                let m = k as f64 / (n - 1) as f64;
                let (lo, hi) = ((m - h).max(0.0), (m + h).min(1.0));
                (hi * hi - lo * lo) * self.exit[k][c]
            })
            .sum()
    }

    /// Checks the entry table against the kernel's colour: R_d(theta_in) =
    /// E(mu) x R_d(0) is light that came back, at most the light that
    /// arrived (Fresnel transmittance keeps it below 1 at every angle), so
    /// E(mu) x `total_rd` may not exceed 1 beyond the Monte Carlo noise
    /// ([`ENTRY_ENERGY_SLACK`]).
    pub fn check_energy(&self, what: &str, total_rd: &[f64; 3]) -> std::result::Result<(), String> {
        for (k, row) in self.entry.iter().enumerate() {
            for c in 0..3 {
                let back = row[c] * total_rd[c];
                if !(back <= 1.0 + ENTRY_ENERGY_SLACK) {
                    return Err(format!(
                        "{what}.entry[{k}][{c}] = {}: with total_rd {} the light coming back at \
                         N.L = {} would be {back:.4e} of the light arriving (at most 1: the entry \
                         factor is R_d(theta_in) / R_d(0))",
                        row[c], total_rd[c], self.mu[k]
                    ));
                }
            }
        }
        Ok(())
    }

    /// The tables of a profile: those its angle-resolved record gives, or
    /// else those the main job stored under [`PROFILE_KEY`]; None when it
    /// has neither, or its record lacks one of the two (an exit table and
    /// at least one oblique incidence are needed).
    pub fn from_profile(p: &Profile) -> Result<Option<AngularFactors>> {
        if left_out(p) {
            return Ok(None);
        }
        let Some(a) = p.angular()? else {
            return stored(p);
        };
        let oblique = a.entry.as_ref().is_some_and(|e| e.incidence_deg.len() > 1);
        if a.exit.is_none() || !oblique || p.channels != Channel::ALL {
            return Ok(None);
        }
        let photons = a.entry.as_ref().map_or(0, |e| e.photons[0]);
        let f = from_angular(&a, photons)?;
        Ok(Some(f))
    }
}

/// The tables under [`PROFILE_KEY`] of `p`'s `extra`, validated.
fn stored(p: &Profile) -> Result<Option<AngularFactors>> {
    let v = &p.extra[PROFILE_KEY];
    if v.is_null() {
        return Ok(None);
    }
    let bad = |why: String| Error::Unsupported(format!("profile extra.{PROFILE_KEY}: {why}"));
    let f: AngularFactors = serde_json::from_value(v.clone()).map_err(|e| bad(e.to_string()))?;
    f.validate(&format!("extra.{PROFILE_KEY}")).map_err(bad)?;
    if let Ok(rgb) = <[f64; 3]>::try_from(p.total_rd.as_slice()) {
        f.check_energy(&format!("extra.{PROFILE_KEY}"), &rgb)
            .map_err(bad)?;
    }
    Ok(Some(f))
}

/// Stores `f` in `p` (under [`PROFILE_KEY`]), so that every kernel fitted
/// from `p` carries it.
pub fn attach(p: &mut Profile, f: &AngularFactors) {
    if !p.extra.is_object() {
        p.extra = serde_json::json!({});
    }
    p.extra[PROFILE_KEY] = serde_json::json!(f);
}

/// Key of `extra` marking a profile whose caller left the factors out:
/// no kernel fitted from it carries them and no later step (the scene
/// check of the advice) runs their Monte Carlo for it.
pub const LEFT_OUT_KEY: &str = "angular_factors_left_out";

/// Marks `p` as made without the entry and exit factors ([`LEFT_OUT_KEY`]):
/// tables it stored or recorded are no longer read as its factors.
pub fn leave_out(p: &mut Profile) {
    if !p.extra.is_object() {
        p.extra = serde_json::json!({});
    }
    p.extra[LEFT_OUT_KEY] = serde_json::Value::Bool(true);
}

/// Whether `p`'s caller left the factors out ([`leave_out`]).
pub fn left_out(p: &Profile) -> bool {
    p.extra[LEFT_OUT_KEY] == serde_json::Value::Bool(true)
}

/// One line saying what a profile without the tables lacks and how to get
/// them.
pub fn missing_note(p: &Profile) -> String {
    format!(
        "profile of {} ({}) has no angular tables: the kernels carry no entry and exit factors \
         (the main job makes them from a material by Monte Carlo; `ssskit simulate --angle-bins \
         90 --incidence 30,60,80` adds them to a profile)",
        p.material.name, p.source.kind
    )
}

/// Builds both tables from an angle-resolved record of the three channels.
pub fn from_angular(a: &Angular, photons: u64) -> Result<AngularFactors> {
    let bad = |why: String| Error::Unsupported(format!("angular factors: {why}"));
    let exit = a
        .exit
        .as_ref()
        .ok_or_else(|| bad("the run has no exit-angle bins".into()))?;
    let entry = a
        .entry
        .as_ref()
        .ok_or_else(|| bad("the run has no oblique incidence".into()))?;
    if exit.factor.len() != 3 || entry.factor.len() != 3 {
        return Err(bad("the tables need the three channels r, g, b".into()));
    }
    let mu: Vec<f64> = (0..NODES).map(node_mu).collect();
    let mut out = AngularFactors {
        mu: mu.clone(),
        entry: vec![[0.0; 3]; NODES],
        entry_stderr: vec![[0.0; 3]; NODES],
        exit: vec![[0.0; 3]; NODES],
        exit_stderr: vec![[0.0; 3]; NODES],
        photons,
    };
    for c in 0..3 {
        let runs: Vec<(f64, f64, f64)> = entry
            .incidence_deg
            .iter()
            .enumerate()
            .map(|(i, t)| {
                (
                    t.to_radians().cos(),
                    entry.factor[c][i],
                    entry.factor_stderr[c][i],
                )
            })
            .collect();
        for (k, &m) in mu.iter().enumerate() {
            let (v, s) = entry_node(&runs, m);
            out.entry[k][c] = v;
            out.entry_stderr[k][c] = s;
            let (v, s) = exit_node(
                &a.theta_edges_deg,
                &exit.factor[c],
                &exit.factor_stderr[c],
                m,
            );
            out.exit[k][c] = v;
            out.exit_stderr[k][c] = s;
        }
    }
    out.validate("angular factors").map_err(bad)?;
    Ok(out)
}

/// The entry factor at `mu` from `(mu, factor, stderr)` runs: linear in mu
/// between the two runs around it, the nearest run's value beyond them.
fn entry_node(runs: &[(f64, f64, f64)], mu: f64) -> (f64, f64) {
    let mut r = runs.to_vec();
    r.sort_by(|a, b| a.0.total_cmp(&b.0));
    let first = r[0];
    let last = r[r.len() - 1];
    if mu <= first.0 {
        return (first.1, first.2);
    }
    if mu >= last.0 {
        return (last.1, last.2);
    }
    let j = r.iter().position(|x| x.0 >= mu).unwrap_or(r.len() - 1);
    let (a, b) = (r[j - 1], r[j]);
    let t = (mu - a.0) / (b.0 - a.0);
    (
        a.1 + t * (b.1 - a.1),
        ((1.0 - t).powi(2) * a.2 * a.2 + t * t * b.2 * b.2).sqrt(),
    )
}

/// The exit factor averaged over the cosines mu +- half a node spacing
/// (clipped to [0, 1]) with the Lambertian weight 2 mu dmu: each angle bin
/// counts by the part of its Lambertian share inside the interval.
fn exit_node(edges_deg: &[f64], factor: &[f64], stderr: &[f64], mu: f64) -> (f64, f64) {
    let h = 0.5 / (NODES - 1) as f64;
    let (lo, hi) = ((mu - h).max(0.0), (mu + h).min(1.0));
    let (mut w_sum, mut v, mut var) = (0.0, 0.0, 0.0);
    for (b, (f, s)) in factor.iter().zip(stderr).enumerate() {
        // The bin's cosines, [cos(theta_hi), cos(theta_lo)].
        let m_lo = edges_deg[b + 1].to_radians().cos().max(0.0);
        let m_hi = edges_deg[b].to_radians().cos().min(1.0);
        let (a, z) = (m_lo.max(lo), m_hi.min(hi));
        if z <= a {
            continue;
        }
        let w = z * z - a * a;
        w_sum += w;
        v += w * f;
        var += w * w * s * s;
    }
    if w_sum > 0.0 {
        (v / w_sum, var.sqrt() / w_sum)
    } else {
        (f64::NAN, f64::NAN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::mc::angular::{lambert_shares, theta_edges_deg, EntryTable, ExitTable};

    fn record(exit: Vec<f64>, incidence: Vec<f64>, entry: Vec<f64>) -> Angular {
        let n = exit.len();
        let k = incidence.len();
        Angular {
            angle_bins: n,
            theta_edges_deg: theta_edges_deg(n),
            lambert_share: lambert_shares(n),
            exit: Some(ExitTable {
                fraction: vec![vec![0.0; n]; 3],
                fraction_stderr: vec![vec![0.0; n]; 3],
                factor: vec![exit.clone(); 3],
                factor_stderr: vec![vec![0.01; n]; 3],
                radiance: vec![],
                radiance_stderr: vec![],
                beyond_rmax: vec![vec![0.0; n]; 3],
            }),
            entry: Some(EntryTable {
                incidence_deg: incidence,
                photons: vec![1000; 3],
                specular: vec![vec![0.0; k]; 3],
                total_rd: vec![vec![0.5; k]; 3],
                total_rd_stderr: vec![vec![0.0; k]; 3],
                factor: vec![entry; 3],
                factor_stderr: vec![vec![0.0; k]; 3],
                energy_balance_minus_1: vec![vec![0.0; k]; 3],
                exit_factor: vec![],
                exit_factor_stderr: vec![],
            }),
            definitions: serde_json::Value::Null,
        }
    }

    #[test]
    fn a_lambertian_exit_and_a_linear_entry_come_back_exactly() {
        // Exit factor 1 in every bin; entry factor 2 - mu sampled at three
        // cosines: the nodes interpolate a linear function exactly.
        let inc: Vec<f64> = [1.0f64, 0.5, 0.1]
            .iter()
            .map(|m| m.acos().to_degrees())
            .collect();
        let entry = vec![1.0, 1.5, 1.9];
        let f = from_angular(&record(vec![1.0; 90], inc, entry), 1000).unwrap();
        for k in 0..NODES {
            let m = node_mu(k);
            for c in 0..3 {
                assert!((f.exit[k][c] - 1.0).abs() < 1e-12, "{k}: {:?}", f.exit[k]);
                let want = if m < 0.1 { 1.9 } else { 2.0 - m };
                assert!((f.entry[k][c] - want).abs() < 1e-9, "{k}: {:?}", f.entry[k]);
            }
        }
        // Node 1 of the exit table pools bins over mu in [1/16, 3/16]: the
        // errors of independent bins shrink by the pooled weights.
        assert!(f.exit_stderr[NODES - 1][0] < 0.01 && f.exit_stderr[NODES - 1][0] > 0.001);
    }

    #[test]
    fn the_exit_average_weighs_bins_by_their_lambertian_share_inside() {
        // Two bins, [0, 45] and [45, 90] degrees: cosines [c, 1] and [0, c].
        // Each bin holds half the Lambertian weight: factors 1.5 and 0.5
        // average 1, as pi L / M does.
        let f = from_angular(&record(vec![1.5, 0.5], vec![0.0, 60.0], vec![1.0, 1.2]), 1).unwrap();
        // Node mu = 0.75 averages [0.6875, 0.8125]: weights c^2 - 0.6875^2
        // (factor 0.5) and 0.8125^2 - c^2 (factor 1.5).
        let c2 = 0.5;
        let (w1, w3) = (c2 - 0.6875f64.powi(2), 0.8125f64.powi(2) - c2);
        let want = (0.5 * w1 + 1.5 * w3) / (w1 + w3);
        assert!(
            (f.exit[6][0] - want).abs() < 1e-12,
            "{} vs {want}",
            f.exit[6][0]
        );
        assert!((f.exit[0][1] - 0.5).abs() < 1e-12);
        assert!((f.exit[8][2] - 1.5).abs() < 1e-12);
        assert!((f.exit_lambertian_mean(0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn lookup_is_linear_between_nodes_and_clamped_outside() {
        let t: Vec<[f64; 3]> = (0..NODES).map(|k| [k as f64; 3]).collect();
        assert_eq!(lookup(&t, 0.5), [4.0; 3]);
        assert!((lookup(&t, 0.5 + 1.0 / 32.0)[1] - 4.25).abs() < 1e-12);
        assert_eq!(lookup(&t, -3.0), [0.0; 3]);
        assert_eq!(lookup(&t, 7.0), [8.0; 3]);
        assert_eq!(lookup(&t, f64::NAN), [0.0; 3]);
    }

    #[test]
    fn bad_tables_are_refused_naming_the_field() {
        let f = from_angular(&record(vec![1.0; 9], vec![0.0, 60.0], vec![1.0, 1.2]), 1).unwrap();
        let mut g = f.clone();
        g.exit[3][1] = f64::NAN;
        assert!(g.validate("k").unwrap_err().contains("k.exit[3][1]"));
        let mut g = f.clone();
        g.mu[2] = 0.3;
        assert!(g.validate("k").unwrap_err().contains("k.mu[2]"));
        let mut g = f.clone();
        g.entry.pop();
        assert!(g.validate("k").unwrap_err().contains("k.entry"));
        // Out of their physical range: E(1) is 1, the exit table averages
        // 1, and E x total_rd is light that came back, at most 1.
        let mut g = f.clone();
        g.entry[NODES - 1][2] = 5.0;
        let e = g.validate("k").unwrap_err();
        assert!(
            e.contains("k.entry[8][2] = 5") && e.contains("1 by definition"),
            "{e}"
        );
        let mut g = f.clone();
        g.exit.iter_mut().for_each(|r| r[1] = 1e-300);
        let e = g.validate("k").unwrap_err();
        assert!(e.contains("k.exit: channel g averages"), "{e}");
        let mut g = f.clone();
        g.entry[0][0] = 1e30;
        g.validate("k").unwrap();
        let e = g.check_energy("k", &[0.4; 3]).unwrap_err();
        assert!(
            e.contains("k.entry[0][0] = 1000000000000000000000000000000"),
            "{e}"
        );
        f.check_energy("k", &[0.8; 3]).unwrap();
    }
}
