//! `ssskit simulate`: Monte Carlo reflectance profile of a material (or of
//! the first run, or a chosen run, of an MCML .mci file).

use super::args::{
    self, count, Backend, BackendArg, CsvArg, GridArgs, MaterialArg, MaxPhotonsArg, McErrorArg,
    McRunArgs, OutFile, PhotonsArg,
};
use super::out::outln;
use super::progress::Bar;
use anyhow::Context;
use ssskit::material::{Channel, Material};
use ssskit::profile::mc::gpu::McGpu;
use ssskit::profile::mc::{
    self, mci, mci::McmlRun, AngularOptions, BoundaryMode, EnergyBalance, McConfig, McOptions,
    PhotonBudget, Shard,
};
use ssskit::profile::{GridSpec, Profile};
use std::io::Write as _;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum BoundaryArg {
    /// MCML's all-or-none random choice (the more efficient, see docs/mc.md).
    Classic,
    /// Score (1-R) w, keep R w.
    Split,
}

impl From<BoundaryArg> for BoundaryMode {
    fn from(b: BoundaryArg) -> BoundaryMode {
        match b {
            BoundaryArg::Classic => BoundaryMode::Classic,
            BoundaryArg::Split => BoundaryMode::Split,
        }
    }
}

impl From<BoundaryMode> for BoundaryArg {
    fn from(b: BoundaryMode) -> BoundaryArg {
        match b {
            BoundaryMode::Classic => BoundaryArg::Classic,
            BoundaryMode::Split => BoundaryArg::Split,
        }
    }
}

/// Boxed so that the subcommand enum stays small.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    flags: Box<Flags>,
}

#[derive(clap::Args)]
#[command(
    mut_arg("material", |a| a.required_unless_present("mci").conflicts_with("mci")),
    mut_arg("photons", |a| a.conflicts_with_all(["mc_error", "kernel_error"]).help(
        "Photons per channel of the Monte Carlo run: a fixed count (e.g. 1e6) \
         [default: none: an error target decides]"
    )),
    mut_arg("mc_error", |a| a.conflicts_with("kernel_error").alias("target-error").help(
        "Monte Carlo target: relative standard error of total R_d and profile \
         [default: none: --kernel-error decides]"
    )),
    mut_arg("max_photons", args::default(args::count_text(mc::DEFAULT_MAX_PHOTONS))),
    mut_arg("kernel_error", |a| a.help(format!(
        "Monte Carlo target on the kernel: relative error of its 1D factor \
         [default: E = {} when no other budget is given]",
        mc::DEFAULT_KERNEL_ERROR
    ))),
    mut_arg("backend", args::default_enum(Backend::Cpu)),
    mut_arg("out", args::help(
        "Output file: the profile, .json [default: <material>.json, or \
         <material>.shard-K-of-N.json with --shard]"
    )),
)]
struct Flags {
    #[command(flatten)]
    material: MaterialArg,
    /// MCML input file (.mci, lengths in cm) instead of --material.
    ///
    /// Layers, photon count and grid are taken from it; flags given here
    /// override photons and grid.
    #[arg(long, value_name = "FILE.mci")]
    mci: Option<PathBuf>,
    /// Which run of the .mci file to simulate (1-based).
    #[arg(long, value_name = "N", default_value_t = 1, requires = "mci", value_parser = count::<usize>)]
    mci_run: usize,
    #[command(flatten)]
    photons: PhotonsArg,
    /// Monte Carlo target on the kernel: relative error of its 1D factor.
    ///
    /// Trace until the relative L2 standard error of the pre-integrated 1D
    /// kernel factor on the default kernel grid and the relative standard
    /// error of total R_d are below E in every channel (rule
    /// "kernel-factor", the default when no other budget is given). Its
    /// default grid has geometric bins. A channel also stops at the
    /// absolute floor (--abs-floor).
    #[arg(long, value_name = "E", allow_hyphen_values = true, value_parser = args::real)]
    kernel_error: Option<f64>,
    /// Absolute floor of the kernel-factor rule, a fraction of the incident light.
    ///
    /// A channel also stops once the standard error of its total R_d and
    /// R_d x the kernel factor's relative error are below A, after at least
    /// 3/A photons (media that barely scatter back, e.g. wine, beer; 2e-6
    /// is 150x below the smallest 8-bit sRGB value); never before the
    /// relative target where R_d >= A/E. 0 = off.
    #[arg(long, value_name = "A", default_value = format!("{:e}", mc::DEFAULT_ABS_FLOOR), allow_hyphen_values = true, value_parser = args::real)]
    abs_floor: f64,
    #[command(flatten)]
    mc_error: McErrorArg,
    #[command(flatten)]
    max_photons: MaxPhotonsArg,
    #[command(flatten)]
    run: McRunArgs,
    #[command(flatten)]
    grid: GridArgs,
    /// Geometric bins: width --dr at the centre, growing out to --rmax.
    #[arg(long)]
    log_bins: bool,
    /// Boundary treatment where a packet meets the ambient medium.
    #[arg(long, value_enum, value_name = "MODE", default_value_t = BoundaryArg::from(McOptions::default().boundary))]
    boundary: BoundaryArg,
    /// Events per packet from which the event-count roulette plays.
    ///
    /// Survival 1/sqrt(2) at each doubling of the count, weight boosted on
    /// survival: unbiased; ends the unbounded walks of albedo 1, see
    /// docs/mc.md.
    #[arg(long, value_name = "N", default_value_t = mc::DEFAULT_EVENT_ROULETTE, value_parser = count::<u64>)]
    event_roulette: u64,
    /// Hard cap on events per packet [default: none].
    ///
    /// A packet stopped there is abandoned and its energy reported as
    /// truncated (biased).
    #[arg(long, value_name = "N", value_parser = count::<u64>)]
    max_events: Option<u64>,
    /// Work cap per channel, in events (interactions + boundary hits).
    ///
    /// Applies to every rule; a --photons count is refused up front when
    /// its first photons project more.
    #[arg(long, value_name = "N", default_value = args::count_text(mc::DEFAULT_MAX_WORK), allow_hyphen_values = true, value_parser = count::<u64>)]
    max_work: u64,
    /// Weight below which Russian roulette plays, survival 1/10.
    ///
    /// Unbiased for any value in (0, 1); MCML uses 1e-4, the default is
    /// more efficient: the Speed table of docs/mc.md.
    #[arg(long, value_name = "WEIGHT", default_value_t = mc::DEFAULT_ROULETTE_THRESHOLD, allow_hyphen_values = true, value_parser = args::real)]
    roulette: f64,
    #[command(flatten)]
    backend: BackendArg,
    /// Trace part K of N disjoint parts of the run [default: all of it].
    ///
    /// Same seed, same --photons for every part: writes a partial profile
    /// with exact sums that `ssskit merge` combines into the single run,
    /// bit for bit.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<Shard>,
    #[command(flatten)]
    out: OutFile,
    #[command(flatten)]
    csv: CsvArg,
    /// Also write MCML's .mco format [default: not written].
    ///
    /// InParm, RAT, Rd_r in cm units, and Rd_a, Rd_ra with --angle-bins;
    /// one channel, uniform grid; weight beyond the grid in the last radial
    /// bin as MCML.
    #[arg(long, value_name = "FILE.mco")]
    mco: Option<PathBuf>,
    /// Exit-angle bins over [0, 90] degrees [default: the .mci file's na when above 1, else none].
    ///
    /// MCML's na: R_d by exit angle (the exit factor pi L / M) and by
    /// radius and angle (the radiance profile pi L(r, theta)), with
    /// standard errors, in extra.angular of the profile.
    #[arg(long, value_name = "NA")]
    angle_bins: Option<usize>,
    /// Oblique incidence angles in degrees, comma-separated, e.g. 30,60,80 [default: none].
    ///
    /// One more run per angle with the normal run's photon count, for the
    /// entry factor R_d(theta_in) / R_d(0) (extra.angular.entry).
    #[arg(long, value_name = "DEG,...", value_delimiter = ',', allow_hyphen_values = true, value_parser = args::real)]
    incidence: Vec<f64>,
    /// Also write the profile seen from --view-angle [default: not written].
    ///
    /// pi L(r, theta) of the exit-angle bin holding that angle in place of
    /// R_d(r), ready to fit a kernel from (needs exit-angle bins).
    #[arg(long, value_name = "FILE.json")]
    view_profile: Option<PathBuf>,
    /// View angle from the normal in degrees, for --view-profile.
    #[arg(long, value_name = "DEG", default_value_t = 0.0, allow_hyphen_values = true, requires = "view_profile", value_parser = args::real)]
    view_angle: f64,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let args = *args.flags;
    let (material, mci_run) = input(&args)?;
    let (cfg, opts) = settings(&args, &material, mci_run.as_ref())?;
    let out = out_path(&args, &material);
    // Fail before the simulation, not after it, on an unwritable destination.
    check_outputs(&args, &cfg, &out)?;
    let bar = Bar::new();
    let finite = material
        .layers
        .last()
        .is_some_and(|l| l.thickness.is_some());
    let mut profile = match open_gpu(args.backend.backend, &opts, finite)? {
        Some(g) => g.simulate(&material, &cfg, &opts, g.default_dispatch(), &bar)?,
        None => mc::simulate_with(&material, &cfg, &opts, &bar)?,
    };
    if let Some(r) = &mci_run {
        profile.source.params["mci"] =
            serde_json::json!({"file": r.source, "run": args.mci_run, "mco_name": r.output_name});
    }
    write_outputs(&args, &profile, &out)?;
    print_summary(&profile, &out)?;
    Ok(())
}

/// The material to trace: from --material, or the chosen run of the .mci
/// file (returned too: its photons, grid and angle bins are defaults).
fn input(args: &Flags) -> anyhow::Result<(Material, Option<McmlRun>)> {
    Ok(match (&args.material.material, &args.mci) {
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
    })
}

/// The run's configuration and tracer options from the flags, the .mci
/// run filling what they leave.
fn settings(
    args: &Flags,
    material: &Material,
    mci_run: Option<&McmlRun>,
) -> anyhow::Result<(McConfig, McOptions)> {
    let channels = match mci_run {
        // MCML is monochrome: the .mci coefficients fill every channel.
        Some(_) if args.run.channels.is_default() => vec![Channel::R],
        _ => args.run.channels.channels()?,
    };
    let budget = photon_budget(args, mci_run)?;
    let spec = GridSpec {
        dr: args.grid.dr,
        r_max: args.grid.rmax,
        log_bins: args.log_bins,
    };
    // No grid flag: the .mci file's grid, else the tracer's own rule. A
    // value given completes from the material's rule, as in `profile`.
    let grid = match mci_run {
        _ if spec != GridSpec::default() => Some(spec.grid(material, &channels)?),
        Some(r) => Some(r.grid.clone()),
        None => None,
    };
    let angular = angular_options(args, mci_run)?;
    let cfg = McConfig {
        budget,
        seed: args.run.seed.seed,
        threads: args.run.threads.threads,
        channels,
        grid,
    };
    let opts = McOptions {
        boundary: BoundaryMode::from(args.boundary),
        event_roulette: args.event_roulette,
        max_events: args.max_events.unwrap_or(mc::DEFAULT_MAX_EVENTS),
        single_scatter: false,
        max_work: args.max_work,
        roulette_threshold: args.roulette,
        shard: args.shard,
        abs_floor: args.abs_floor,
        angular,
    };
    Ok((cfg, opts))
}

/// When the run stops: --photons, else an error target, else the .mci
/// file's photon count, else the kernel-factor rule. A shard needs a fixed
/// count.
fn photon_budget(args: &Flags, mci_run: Option<&McmlRun>) -> anyhow::Result<PhotonBudget> {
    let max_photons = args.max_photons.max_photons;
    let budget = match (
        args.photons.photons,
        args.mc_error.mc_error,
        args.kernel_error,
        mci_run,
    ) {
        (Some(n), _, _, _) => PhotonBudget::Fixed(n),
        (None, Some(e), _, _) => PhotonBudget::TargetError {
            rel: e,
            max_photons,
        },
        (None, None, Some(e), _) => PhotonBudget::KernelFactor {
            rel: e,
            max_photons,
        },
        (None, None, None, Some(r)) => PhotonBudget::Fixed(r.photons),
        (None, None, None, None) => ssskit::profile::source::default_budget(max_photons),
    };
    if args.shard.is_some() && !matches!(budget, PhotonBudget::Fixed(_)) {
        anyhow::bail!(
            "--shard needs --photons N (or an .mci photon count): every shard traces its part \
             of one fixed total; the target-error rules decide when to stop from all photons \
             and cannot be split"
        );
    }
    Ok(budget)
}

/// The angle-resolved tallies (exit-angle bins, oblique incidences), None
/// when neither is asked for; --view-profile needs the exit-angle bins.
fn angular_options(
    args: &Flags,
    mci_run: Option<&McmlRun>,
) -> anyhow::Result<Option<AngularOptions>> {
    let angle_bins = args
        .angle_bins
        .or(mci_run.map(|r| r.angle_bins).filter(|&n| n > 1))
        .unwrap_or(0);
    let angular = (angle_bins > 0 || !args.incidence.is_empty()).then(|| AngularOptions {
        angle_bins,
        incidence_deg: args.incidence.clone(),
    });
    if args.view_profile.is_some() {
        if angle_bins == 0 {
            anyhow::bail!(
                "--view-profile needs exit-angle bins: give --angle-bins NA (e.g. 9 for 10 degrees)"
            );
        }
        if !(args.view_angle.is_finite() && (0.0..=90.0).contains(&args.view_angle)) {
            anyhow::bail!(
                "--view-angle: invalid value {}: must be in [0, 90] degrees from the normal",
                args.view_angle
            );
        }
    }
    Ok(angular)
}

/// --out, else a name from the material's name, a label: made a plain file
/// name in the working folder.
fn out_path(args: &Flags, material: &Material) -> PathBuf {
    args.out.out.clone().unwrap_or_else(|| {
        let stem = material.file_stem();
        PathBuf::from(match args.shard {
            Some(s) => format!("{stem}.shard-{}-of-{}.json", s.k, s.n),
            None => format!("{stem}.json"),
        })
    })
}

/// Every output's format and destination, checked before the simulation.
fn check_outputs(args: &Flags, cfg: &McConfig, out: &Path) -> anyhow::Result<()> {
    if args.mco.is_some() && cfg.channels.len() != 1 {
        anyhow::bail!(
            "--mco: an .mco file holds one wavelength (MCML is monochrome); give --channels r, g or b"
        );
    }
    ssskit::io::check_extension(out, &["json"], "profile")?;
    if let Some(csv) = &args.csv.csv {
        ssskit::io::check_extension(csv, &["csv"], "table")?;
    }
    if let Some(mco) = &args.mco {
        ssskit::io::check_extension(mco, &["mco"], "MCML output")?;
    }
    if let Some(v) = &args.view_profile {
        ssskit::io::check_extension(v, &["json"], "profile")?;
    }
    for (flag, path) in [
        ("--out", Some(out)),
        ("--csv", args.csv.csv.as_deref()),
        ("--mco", args.mco.as_deref()),
        ("--view-profile", args.view_profile.as_deref()),
    ] {
        if let Some(p) = path {
            ssskit::io::check_output_file(p, flag)?;
        }
    }
    Ok(())
}

/// The profile and the outputs asked with it, renamed together:
/// concurrent runs never mix them.
fn write_outputs(args: &Flags, profile: &Profile, out: &Path) -> anyhow::Result<()> {
    let mut outputs = ssskit::io::AtomicGroup::new();
    profile
        .write_into(&mut outputs, out)
        .with_context(|| format!("writing {}", out.display()))?;
    if let Some(csv) = &args.csv.csv {
        write_csv(profile, csv, &mut outputs)?;
    }
    if let Some(mco) = &args.mco {
        let name = mco
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let text = mc::mco::mco_text(profile, &name).context("--mco")?;
        outputs
            .add_with(mco, |w| w.write_all(text.as_bytes()))
            .with_context(|| format!("writing {}", mco.display()))?;
    }
    if let Some(v) = &args.view_profile {
        mc::angular::view_profile(profile, args.view_angle)
            .context("--view-profile")?
            .write_into(&mut outputs, v)
            .with_context(|| format!("writing {}", v.display()))?;
    }
    outputs.commit()?;
    Ok(())
}

/// The GPU tracer when the backend asks for it (printing the adapter), None
/// for the CPU; `auto` falls back to the CPU, saying why.
fn open_gpu(backend: Backend, opts: &McOptions, finite: bool) -> anyhow::Result<Option<McGpu>> {
    let open = || McGpu::new().context("--backend gpu");
    match backend {
        Backend::Cpu => Ok(None),
        Backend::Gpu => {
            let g = open()?;
            let kind = if g.is_software() {
                " (software rasteriser: correct but slower than the CPU)"
            } else {
                ""
            };
            eprintln!("backend: gpu, adapter {}{kind}", g.describe());
            if finite {
                eprintln!(
                    "warning: the GPU tracer tallies total T only, no T_d(r): the profile has no \
                     transmittance profile (--backend cpu has it)"
                );
            }
            Ok(Some(g))
        }
        Backend::Auto => {
            if opts.boundary != BoundaryMode::Classic {
                eprintln!("backend: cpu (auto: the GPU tracer has classic boundaries only)");
                return Ok(None);
            }
            if opts.angular.is_some() {
                eprintln!("backend: cpu (auto: the GPU tracer has no angle-resolved tallies)");
                return Ok(None);
            }
            if finite {
                eprintln!("backend: cpu (auto: the GPU tracer tallies no transmittance profile)");
                return Ok(None);
            }
            match open() {
                Ok(g) if !g.is_software() => {
                    eprintln!("backend: gpu (auto), adapter {}", g.describe());
                    Ok(Some(g))
                }
                Ok(g) => {
                    eprintln!(
                        "backend: cpu (auto: the only adapter, {}, is a software rasteriser, \
                         slower than the CPU; --backend gpu forces it)",
                        g.describe()
                    );
                    Ok(None)
                }
                Err(e) => {
                    eprintln!("backend: cpu (auto: {e:#})");
                    Ok(None)
                }
            }
        }
    }
}

/// "K/N" with 1 <= K <= N.
fn parse_shard(s: &str) -> Result<Shard, String> {
    let bad = || "expected K/N with 1 <= K <= N, e.g. 3/8".to_string();
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n) = (
        k.trim().parse::<u64>().map_err(|_| bad())?,
        n.trim().parse::<u64>().map_err(|_| bad())?,
    );
    if k == 0 || k > n {
        return Err(bad());
    }
    Ok(Shard { k, n })
}

/// CSV: one row per bin, r and R_d with standard error per channel.
pub(super) fn write_csv(
    p: &Profile,
    path: &Path,
    outputs: &mut ssskit::io::AtomicGroup,
) -> anyhow::Result<()> {
    use std::io::Write;
    outputs
        .add_with(path, |w| {
            let tp = p.transmittance_profile().ok().flatten();
            write!(w, "r_inner_mm,r_outer_mm,r_mm")?;
            for c in &p.channels {
                write!(w, ",rd_{0},rd_{0}_stderr", c.name())?;
            }
            if tp.is_some() {
                for c in &p.channels {
                    write!(w, ",td_{0},td_{0}_stderr", c.name())?;
                }
            }
            writeln!(w)?;
            for i in 0..p.r.len() {
                write!(w, "{},{},{}", p.r_edges[i], p.r_edges[i + 1], p.r[i])?;
                for c in 0..p.channels.len() {
                    let e = p.rd_stderr.as_ref().map_or(0.0, |e| e[c][i]);
                    write!(w, ",{:e},{:e}", p.rd[c][i], e)?;
                }
                if let Some(t) = &tp {
                    for c in 0..p.channels.len() {
                        write!(w, ",{:e},{:e}", t.td[c][i], t.td_stderr[c][i])?;
                    }
                }
                writeln!(w)?;
            }
            Ok(())
        })
        .with_context(|| format!("writing {}", path.display()))
}

pub(super) fn print_summary(p: &Profile, out: &Path) -> anyhow::Result<()> {
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
        let bal = EnergyBalance::of(p, *c)?.map_or(f64::NAN, |b| b.sum_minus_1);
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
    if let Some(a) = p.angular()? {
        print_angular(p, &a)?;
    }
    for w in p.warnings()? {
        super::errors::warn(&w);
    }
    outln!("wrote {}", out.display())
}

/// The exit factor along the normal and the entry factors, per channel.
fn print_angular(p: &Profile, a: &mc::Angular) -> anyhow::Result<()> {
    if let Some(x) = &a.exit {
        let hi = a.theta_edges_deg.get(1).copied().unwrap_or(0.0);
        outln!("exit factor pi L / M, exit angle 0-{hi:.3} degrees:")?;
        for (i, c) in p.channels.iter().enumerate() {
            outln!(
                "{:>2} {:>9.4} +- {:.1e}",
                c.name(),
                x.factor[i][0],
                x.factor_stderr[i][0]
            )?;
        }
    }
    if let Some(e) = &a.entry {
        outln!("entry factor R_d(theta_in) / R_d(0):")?;
        let head: Vec<String> = e.incidence_deg.iter().map(|t| format!("{t:>16}")).collect();
        outln!("ch {}", head.join(" "))?;
        for (i, c) in p.channels.iter().enumerate() {
            let row: Vec<String> = e.factor[i]
                .iter()
                .zip(&e.factor_stderr[i])
                .map(|(f, s)| format!("{f:>7.4} +- {s:<6.1e}"))
                .collect();
            outln!("{:>2} {}", c.name(), row.join(" "))?;
        }
    }
    Ok(())
}
