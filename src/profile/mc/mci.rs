//! MCML input files (.mci, MCML 1.2 manual, section 5): so that cases set up
//! for MCML can be rerun here. Lengths are in cm and coefficients in cm^-1
//! there; everything is converted to mm. `#` starts a comment. Layout:
//!
//! ```text
//! 1.0                 # file version
//! 1                   # number of runs
//! out.mco A           # per run: output file, A(SCII)/B(inary) (kept as a note)
//! 100000              # photons
//! 20E-4 20E-4         # dz dr (cm)
//! 1 500 1             # nz nr na
//! 1                   # layers
//! 1.0                 # n above
//! 1.37 1 100 0.9 1E8  # n mua mus g d, one line per layer
//! 1.0                 # n below
//! ```
//!
//! A last layer at least `SEMI_INFINITE_CM` thick (MCML users write 1E8) is
//! read as semi-infinite. MCML's depth grid (dz, nz) is read and ignored;
//! its angle grid `na` is kept (`angle_bins`): above 1 it asks for the
//! exit-angle tallies (Rd_a, Rd_ra). Clear layers (mua = mus =
//! 0, e.g. glass slides) are not supported and are reported as such.

use crate::error::{Error, Result};
use crate::material::{Layer, Material};
use crate::profile::RadialGrid;
use std::path::Path;

/// Most radial bins a run may ask for (as for any radial grid).
const MAX_BINS: usize = crate::limits::MAX_RADIAL_BINS;

/// Thickness (cm) from which the last layer counts as semi-infinite.
pub const SEMI_INFINITE_CM: f64 = 1e6;

/// One run of an .mci file, converted to mm.
#[derive(Clone, Debug)]
pub struct McmlRun {
    pub material: Material,
    pub photons: u64,
    pub grid: RadialGrid,
    /// MCML's `na`: exit-angle bins over [0, 90] degrees.
    pub angle_bins: usize,
    /// The .mco name MCML would have written (informative).
    pub output_name: String,
    /// The file it came from.
    pub source: String,
}

/// Reads every run of an .mci file.
pub fn read_mci(path: &Path) -> Result<Vec<McmlRun>> {
    let text = crate::io::read_text_capped(path, crate::limits::MAX_MCI_BYTES, "MCML .mci file")?;
    parse_mci(&text, &path.display().to_string())
}

/// Lines with their tokens and 1-based line numbers, comments removed.
struct Lines<'a> {
    lines: Vec<(usize, Vec<&'a str>)>,
    pos: usize,
    context: &'a str,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str, context: &'a str) -> Lines<'a> {
        let lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("")))
            .map(|(i, l)| (i, l.split_whitespace().collect::<Vec<_>>()))
            .filter(|(_, t)| !t.is_empty())
            .collect();
        Lines {
            lines,
            pos: 0,
            context,
        }
    }

    /// The next line, which must hold at least `n` tokens named `what`.
    fn next(&mut self, n: usize, what: &str) -> Result<(usize, Vec<&'a str>)> {
        let Some((no, toks)) = self.lines.get(self.pos).cloned() else {
            return Err(Error::format(
                self.context,
                format!("unexpected end of file: expected {what}"),
            ));
        };
        self.pos += 1;
        if toks.len() < n {
            return Err(Error::format(
                self.context,
                format!(
                    "line {no}: expected {what} ({n} values), found '{}'",
                    toks.join(" ")
                ),
            ));
        }
        Ok((no, toks))
    }

    /// Refuses a header count `n` that needs more than the lines left
    /// (`per` lines per item) before anything is allocated for it.
    fn check_count(&self, line: usize, n: usize, per: usize, what: &str, why: &str) -> Result<()> {
        let left = self.lines.len() - self.pos;
        if n.saturating_mul(per) > left {
            return Err(Error::format(
                self.context,
                format!(
                    "unexpected end of file: line {line}: {what} is {n}, but only {left} \
                     lines follow ({why}): the count or the file is wrong"
                ),
            ));
        }
        Ok(())
    }

    fn num<T: std::str::FromStr>(&self, line: usize, tok: &str, what: &str) -> Result<T> {
        tok.parse::<T>().map_err(|_| {
            Error::format(
                self.context,
                format!("line {line}: {what} '{tok}' is not a valid number"),
            )
        })
    }
}

/// Parses the text of an .mci file; `context` names it in errors.
pub fn parse_mci(text: &str, context: &str) -> Result<Vec<McmlRun>> {
    let mut l = Lines::new(text, context);
    let (no, t) = l.next(1, "file version")?;
    let _version: f64 = l.num(no, t[0], "file version")?;
    let (no, t) = l.next(1, "number of runs")?;
    let n_runs: usize = l.num(no, t[0], "number of runs")?;
    if n_runs == 0 {
        return Err(Error::format(
            context,
            format!("line {no}: number of runs is 0"),
        ));
    }
    // Counts in the header size allocations: each must fit in what is left
    // of the file (a run takes at least 8 lines, a layer one).
    l.check_count(
        no,
        n_runs,
        8,
        "number of runs",
        "each run takes at least 8 lines",
    )?;
    (0..n_runs).map(|k| parse_run(&mut l, context, k)).collect()
}

/// Run `k` (from 0) of an .mci file.
fn parse_run(l: &mut Lines, context: &str, k: usize) -> Result<McmlRun> {
    let run_ctx = format!("{context} run {}", k + 1);
    let (_, t) = l.next(1, "output file name")?;
    let output_name = t[0].to_string();
    let (no, t) = l.next(1, "number of photons")?;
    let photons: u64 = l.num(no, t[0], "number of photons")?;
    if photons == 0 {
        return Err(Error::invalid(&run_ctx, "photons", 0, "must be >= 1"));
    }
    let (no, t) = l.next(2, "dz dr (cm)")?;
    let _dz: f64 = l.num(no, t[0], "dz")?;
    let dr_cm: f64 = l.num(no, t[1], "dr")?;
    let dr_line = no;
    let (no, t) = l.next(3, "nz nr na")?;
    let nr: usize = l.num(no, t[1], "nr")?;
    let angle_bins: usize = l.num(no, t[2], "na")?;
    if angle_bins == 0 {
        return Err(Error::invalid(&run_ctx, "na", 0, "must be >= 1"));
    }
    if nr > MAX_BINS {
        return Err(Error::format(
            context,
            format!("line {no}: nr = {nr}: more than {MAX_BINS} radial bins"),
        ));
    }
    let (no, t) = l.next(1, "number of layers")?;
    let n_layers: usize = l.num(no, t[0], "number of layers")?;
    if n_layers == 0 {
        return Err(Error::invalid(
            &run_ctx,
            "number of layers",
            0,
            "must be >= 1",
        ));
    }
    l.check_count(no, n_layers, 1, "number of layers", "one line per layer")?;
    let (no, t) = l.next(1, "n of the medium above")?;
    let n_above: f64 = l.num(no, t[0], "n above")?;
    let layers = parse_layers(l, &run_ctx, n_layers)?;
    let (no, t) = l.next(1, "n of the medium below")?;
    let n_below: f64 = l.num(no, t[0], "n below")?;
    let material = Material {
        name: Path::new(&output_name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| format!("mci-run-{}", k + 1)),
        eta_above: n_above,
        eta_below: n_below,
        layers,
    };
    material.validate(&run_ctx)?;
    if !(dr_cm.is_finite() && dr_cm > 0.0) || nr == 0 {
        return Err(Error::invalid(
            &run_ctx,
            "dr, nr",
            format!("{dr_cm}, {nr}"),
            "radial grid needs dr > 0 and nr >= 1",
        ));
    }
    let grid = RadialGrid::uniform(dr_cm * 10.0, nr as f64 * dr_cm * 10.0)
        .map_err(|e| Error::format(context, format!("run {}, line {dr_line}: {e}", k + 1)))?;
    Ok(McmlRun {
        material,
        photons,
        grid,
        angle_bins,
        output_name,
        source: context.to_string(),
    })
}

/// The `n_layers` layer lines of a run: n mua mus g d, in cm.
fn parse_layers(l: &mut Lines, run_ctx: &str, n_layers: usize) -> Result<Vec<Layer>> {
    let mut layers = Vec::with_capacity(n_layers);
    for i in 0..n_layers {
        let (no, t) = l.next(5, "layer: n mua mus g d")?;
        let n: f64 = l.num(no, t[0], "n")?;
        let mua: f64 = l.num(no, t[1], "mua")?;
        let mus: f64 = l.num(no, t[2], "mus")?;
        let g: f64 = l.num(no, t[3], "g")?;
        let d: f64 = l.num(no, t[4], "d")?;
        if mua == 0.0 && mus == 0.0 {
            return Err(Error::invalid(
                run_ctx,
                format!("layer[{i}] mua, mus"),
                0,
                "clear layers (no absorption or scattering) are not supported",
            ));
        }
        let semi = i + 1 == n_layers && d >= SEMI_INFINITE_CM;
        layers.push(Layer {
            sigma_a: [mua / 10.0; 3],
            sigma_s: [mus / 10.0; 3],
            g: [g; 3],
            eta: n,
            thickness: (!semi).then_some(d * 10.0),
        });
    }
    Ok(layers)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "1.0 # version\n2 # runs\n\n# run 1\nskin.mco A\n10000\n20E-4 20E-4\n1 500 1\n2\n1.0\n1.37 1 100 0.9 0.1\n1.37 2 10 0.0 1E8\n1.0\n\nsecond.mco A\n500\n0.01 0.01\n10 50 1\n1\n1.0\n1.0 10 90 0.75 0.02\n1.0\n";

    #[test]
    fn parses_runs_and_converts_cm_to_mm() {
        let runs = parse_mci(SAMPLE, "s.mci").unwrap();
        assert_eq!(runs.len(), 2);
        let a = &runs[0];
        assert_eq!(a.photons, 10000);
        assert_eq!(a.material.layers.len(), 2);
        assert!((a.material.layers[0].sigma_s[0] - 10.0).abs() < 1e-12);
        assert_eq!(a.material.layers[0].thickness, Some(1.0));
        assert_eq!(a.material.layers[1].thickness, None);
        assert_eq!(a.grid.len(), 500);
        assert!((a.grid.edges[1] - 0.02).abs() < 1e-12);
        assert_eq!(runs[1].material.name, "second");
        assert!((runs[1].material.layers[0].thickness.unwrap() - 0.2).abs() < 1e-12);
    }

    #[test]
    fn errors_name_line_and_field() {
        let bad = SAMPLE.replace("10000\n", "lots\n");
        let e = parse_mci(&bad, "s.mci").unwrap_err().to_string();
        assert!(
            e.contains("s.mci") && e.contains("line 6") && e.contains("lots"),
            "{e}"
        );
        let e = parse_mci("1.0\n1\nx.mco A\n10\n", "t.mci")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unexpected end of file"), "{e}");
        let bad = SAMPLE.replace("0.9 0.1", "1.5 0.1");
        let e = parse_mci(&bad, "s.mci").unwrap_err().to_string();
        assert!(e.contains("run 1") && e.contains("g"), "{e}");
        // A grid beyond f64 (found by the fuzz harness) names file and line.
        let bad = SAMPLE.replace("20E-4 20E-4", "20E-4 1e308");
        let e = parse_mci(&bad, "s.mci").unwrap_err().to_string();
        assert!(
            e.contains("s.mci") && e.contains("line 7") && e.contains("dr"),
            "{e}"
        );
    }
}
