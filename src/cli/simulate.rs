//! `ssskit simulate`: Monte Carlo reflectance profile of a material (or of
//! the first run, or a chosen run, of an MCML .mci file).

use super::out::outln;
use super::progress::Bar;
use anyhow::Context;
use ssskit::material::{Channel, Material};
use ssskit::profile::mc::{self, mci, BoundaryMode, McConfig, McOptions, PhotonBudget};
use ssskit::profile::{Profile, RadialGrid};
use std::path::{Path, PathBuf};

/// Default budget: 1% relative error of total R_d and of the profile, at most
/// 10^7 photons per channel (skin1 takes a few seconds on 2 cores).
const DEFAULT_TARGET_ERROR: f64 = 0.01;
const DEFAULT_MAX_PHOTONS: u64 = 10_000_000;

/// Boxed so that the subcommand enum stays small.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    flags: Box<Flags>,
}

#[derive(clap::Args)]
struct Flags {
    /// Material preset name or TOML file.
    #[arg(long, required_unless_present = "mci", conflicts_with = "mci")]
    material: Option<String>,
    /// MCML input file (.mci, lengths in cm): layers, photon count and grid
    /// are taken from it; flags given here override photons and grid.
    #[arg(long, value_name = "FILE.mci")]
    mci: Option<PathBuf>,
    /// Which run of the .mci file to simulate (1-based).
    #[arg(long, default_value_t = 1, requires = "mci")]
    mci_run: usize,
    /// Photons per channel.
    #[arg(long, conflicts_with = "target_error", allow_hyphen_values = true)]
    photons: Option<u64>,
    /// Trace until the relative standard error of total R_d and of the
    /// profile inside the 99% radius is below E in every channel
    /// (default 0.01 when neither --photons nor an .mci count is given).
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    target_error: Option<f64>,
    /// Cap on photons per channel for --target-error.
    #[arg(long, default_value_t = DEFAULT_MAX_PHOTONS, allow_hyphen_values = true)]
    max_photons: u64,
    /// RNG seed: the same seed gives bit-identical output.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (results are identical for any count).
    #[arg(long, allow_hyphen_values = true)]
    threads: Option<usize>,
    /// Channels to simulate: rgb, r, g, b, rg, ...
    #[arg(long, default_value = "rgb")]
    channels: String,
    /// Radial bin width in mm (default: min MFP / 20).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    dr: Option<f64>,
    /// Outer radius of the tally in mm (default: from the material).
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    rmax: Option<f64>,
    /// Geometric bins: width dr at the centre growing out to rmax.
    #[arg(long)]
    log_bins: bool,
    /// Boundary treatment: classic (MCML's all-or-none random choice; the
    /// more efficient, see docs/mc.md) or split (score (1-R) w, keep R w).
    #[arg(long, default_value = "classic", value_parser = ["classic", "split"])]
    boundary: String,
    /// Events per packet after which it is abandoned (energy reported as
    /// truncated).
    #[arg(long, default_value_t = mc::DEFAULT_MAX_EVENTS)]
    max_events: u64,
    /// Work cap per channel for --target-error runs, in events
    /// (interactions + boundary hits); ~1.5e9 is about half a minute on 2 cores
    /// [default: 1500000000]. A fixed --photons count is not capped: refused with it.
    #[arg(long)]
    max_work: Option<u64>,
    /// Weight below which Russian roulette plays, survival 1/10 (unbiased for
    /// any value in (0, 1); MCML uses 1e-4, the default 0.01 is ~1.5x more
    /// efficient, see docs/mc.md).
    #[arg(long, default_value_t = mc::DEFAULT_ROULETTE_THRESHOLD, allow_hyphen_values = true)]
    roulette: f64,
    /// Output profile JSON (default: <material>.json).
    #[arg(long, value_name = "FILE.json")]
    out: Option<PathBuf>,
    /// Also write the profile as CSV.
    #[arg(long, value_name = "FILE.csv")]
    csv: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let args = *args.flags;
    let (material, mci_run) = match (&args.material, &args.mci) {
        (_, Some(path)) => {
            let runs = mci::read_mci(path)?;
            let run = runs
                .get(args.mci_run.wrapping_sub(1))
                .cloned()
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "--mci-run {}: {} holds {} run(s)",
                        args.mci_run,
                        path.display(),
                        runs.len()
                    )
                })?;
            (run.material.clone(), Some(run))
        }
        (Some(spec), None) => (Material::load(spec)?, None),
        (None, None) => anyhow::bail!("give --material or --mci"),
    };
    let channels = match &mci_run {
        // MCML is monochrome: the .mci coefficients fill every channel.
        Some(_) if args.channels == "rgb" => vec![Channel::R],
        _ => Channel::parse_list(&args.channels)?,
    };
    let budget = match (args.photons, args.target_error, &mci_run) {
        (Some(n), _, _) => PhotonBudget::Fixed(n),
        (None, Some(e), _) => PhotonBudget::TargetError {
            rel: e,
            max_photons: args.max_photons,
        },
        (None, None, Some(r)) => PhotonBudget::Fixed(r.photons),
        (None, None, None) => PhotonBudget::TargetError {
            rel: DEFAULT_TARGET_ERROR,
            max_photons: args.max_photons,
        },
    };
    if let (PhotonBudget::Fixed(n), Some(w)) = (&budget, args.max_work) {
        anyhow::bail!(
            "--max-work {w} caps runs with a target error, but this run traces a fixed {n} \
             photons per channel (--photons or the .mci count): lower the photon count, or give \
             --target-error with --max-work"
        );
    }
    let grid = match (&mci_run, args.dr, args.rmax, args.log_bins) {
        (Some(r), None, None, false) => Some(r.grid.clone()),
        (_, None, None, false) => None,
        (_, dr, rmax, log) => Some(explicit_grid(&material, &channels, dr, rmax, log)?),
    };
    let boundary = match args.boundary.as_str() {
        "classic" => BoundaryMode::Classic,
        _ => BoundaryMode::Split,
    };
    let cfg = McConfig {
        budget,
        seed: args.seed,
        threads: args.threads,
        channels,
        grid,
    };
    let opts = McOptions {
        boundary,
        max_events: args.max_events,
        single_scatter: false,
        max_work: args.max_work.unwrap_or(mc::DEFAULT_MAX_WORK),
        roulette_threshold: args.roulette,
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.json", material.name)));
    // Fail before the simulation, not after it, on an unwritable destination.
    ssskit::io::check_extension(&out, &["json"], "profile")?;
    if let Some(csv) = &args.csv {
        ssskit::io::check_extension(csv, &["csv"], "table")?;
    }
    for (flag, path) in [("--out", Some(&out)), ("--csv", args.csv.as_ref())] {
        if let Some(dir) = path.and_then(|p| p.parent()) {
            if !dir.as_os_str().is_empty() && !dir.is_dir() {
                anyhow::bail!("{flag}: directory '{}' does not exist", dir.display());
            }
        }
    }
    let bar = Bar::new();
    let mut profile = mc::simulate_with(&material, &cfg, &opts, &bar)?;
    if let Some(r) = &mci_run {
        profile.source.params["mci"] =
            serde_json::json!({"file": r.source, "run": args.mci_run, "mco_name": r.output_name});
    }
    // JSON and CSV are renamed together: concurrent runs never mix them.
    let mut outputs = ssskit::io::AtomicGroup::new();
    profile
        .write_into(&mut outputs, &out)
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(csv) = &args.csv {
        write_csv(&profile, csv, &mut outputs)?;
    }
    outputs.commit()?;
    print_summary(&profile, &out)?;
    Ok(())
}

/// The grid from --dr/--rmax/--log-bins; a missing value comes from the
/// material rule.
fn explicit_grid(
    m: &Material,
    channels: &[Channel],
    dr: Option<f64>,
    rmax: Option<f64>,
    log_bins: bool,
) -> anyhow::Result<RadialGrid> {
    let auto = RadialGrid::for_material(m, channels);
    let dr = dr.unwrap_or(auto.edges[1]);
    let rmax = rmax.unwrap_or(auto.r_max());
    for (flag, v) in [("--dr", dr), ("--rmax", rmax)] {
        if !(v.is_finite() && v > 0.0) {
            anyhow::bail!("{flag}: invalid value {v}: must be finite and > 0 (mm)");
        }
    }
    Ok(if log_bins {
        let n = (25.0 * (rmax / dr).ln()).ceil().clamp(50.0, 2000.0) as usize;
        RadialGrid::logarithmic(dr, rmax, n)?
    } else {
        RadialGrid::uniform(dr, rmax)?
    })
}

/// CSV: one row per bin, r and R_d with standard error per channel.
fn write_csv(
    p: &Profile,
    path: &Path,
    outputs: &mut ssskit::io::AtomicGroup,
) -> anyhow::Result<()> {
    use std::io::Write;
    outputs
        .add_with(path, |w| {
            write!(w, "r_inner_mm,r_outer_mm,r_mm")?;
            for c in &p.channels {
                write!(w, ",rd_{0},rd_{0}_stderr", c.name())?;
            }
            writeln!(w)?;
            for i in 0..p.r.len() {
                write!(w, "{},{},{}", p.r_edges[i], p.r_edges[i + 1], p.r[i])?;
                for c in 0..p.channels.len() {
                    let e = p.rd_stderr.as_ref().map_or(0.0, |e| e[c][i]);
                    write!(w, ",{:e},{:e}", p.rd[c][i], e)?;
                }
                writeln!(w)?;
            }
            Ok(())
        })
        .with_context(|| format!("writing {}", path.display()))
}

fn print_summary(p: &Profile, out: &Path) -> anyhow::Result<()> {
    let photons = p.source.photons.clone().unwrap_or_default();
    outln!(
        "{}: {} bins to r = {:.3} mm, {:.2} s",
        p.material.name,
        p.r.len(),
        p.r_edges.last().copied().unwrap_or(0.0),
        p.elapsed_s
    )?;
    outln!(
        "{:>2} {:>10} {:>20} {:>10} {:>10} {:>9} {:>10}",
        "ch",
        "photons",
        "total R_d +- stderr",
        "T",
        "absorbed",
        "specular",
        "balance-1"
    )?;
    for (i, c) in p.channels.iter().enumerate() {
        let bal = p.extra["energy_balance"][c.name()]["sum_minus_1"]
            .as_f64()
            .unwrap_or(f64::NAN);
        outln!(
            "{:>2} {:>10} {:>11.6} +- {:<7.1e} {:>10.6} {:>10.6} {:>9.6} {:>10.1e}",
            c.name(),
            photons.get(i).copied().unwrap_or(0),
            p.total_rd[i],
            p.total_rd_stderr.as_ref().map_or(0.0, |e| e[i]),
            p.transmittance.as_ref().map_or(0.0, |t| t[i]),
            p.absorbed.as_ref().map_or(0.0, |a| a[i]),
            p.specular[i],
            bal
        )?;
    }
    if let Some(ws) = p.extra["warnings"].as_array() {
        for w in ws.iter().filter_map(|w| w.as_str()) {
            eprintln!("warning: {w}");
        }
    }
    outln!("wrote {}", out.display())
}
