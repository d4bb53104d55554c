//! `ssskit transmission`: the light through slabs of a material lit from
//! behind, per thickness (total and radial spread), with the engines'
//! thin-object formulas fitted to it and scored at every thickness.

use super::args::{self, count, MaterialArg, McRunArgs, OutFile, PhotonsArg, ProfileFile};
use super::out::outln;
use super::progress::Bar;
use anyhow::Context;
use ssskit::engine::{self, transmission as et, Engine, Scene};
use ssskit::material::Material;
use ssskit::numerics::Bounded;
use ssskit::profile::mc::{self, McConfig, McOptions, PhotonBudget};
use ssskit::profile::transmission::{self as tr, TableOptions, ThicknessTable};
use ssskit::profile::Profile;
use ssskit::report::present::transmission_plots::FittedCurve;
use std::path::PathBuf;

#[derive(clap::Args)]
#[command(
    mut_arg("material", |a| args::required()(a)),
    mut_arg("photons", |a| a.conflicts_with("table_error").help(
        "Photons per channel of the Monte Carlo run: every slab's, a fixed count (e.g. 1e5) \
         [default: none: --table-error decides]"
    )),
    mut_arg("out", args::help(
        "Output file: the table (ssskit.transmission/1 JSON, with the engines' fits) \
         [default: not written]"
    )),
    mut_arg("profile", |a| a.help(
        "Reflectance profile file (ssskit.profile/1 JSON): the engines' diffusion side is \
         fitted to it [default: simulated, the last layer semi-infinite]"
    )),
)]
pub struct Args {
    #[command(flatten)]
    material: MaterialArg,
    /// Slab thicknesses in mm: a range LO..HI (geometric steps) or a list [default: a finite stack's own].
    ///
    /// The last layer of the material is cut so that the whole stack is
    /// this thick (the layers above keep theirs). Required for a stack
    /// whose last layer is semi-infinite; a finite stack without it gives
    /// the table of its own thickness.
    #[arg(long, value_name = "MM", allow_hyphen_values = true)]
    thickness: Option<String>,
    /// Thicknesses of a --thickness range, geometric steps.
    #[arg(long, value_name = "N", default_value_t = tr::DEFAULT_STEPS, value_parser = count::<usize>)]
    steps: usize,
    #[command(flatten)]
    photons: PhotonsArg,
    /// Monte Carlo target of every slab: relative error of T and of T_d's 1D factor (without --photons).
    ///
    /// Each slab's run stops when, in every channel, the relative standard
    /// errors of its total transmittance and of its transmittance profile's
    /// pre-integrated 1D factor (and of its reflectance) are below E, or at
    /// the absolute floor of `simulate` (2e-6 of the light), or at
    /// --slab-max-work.
    #[arg(long, value_name = "E", allow_hyphen_values = true, value_parser = args::real,
          default_value_t = tr::DEFAULT_TABLE_ERROR)]
    table_error: f64,
    /// Work cap of every slab, per channel, in events (interactions + boundary hits).
    #[arg(long, value_name = "N", default_value = args::count_text(tr::DEFAULT_TABLE_MAX_WORK), allow_hyphen_values = true, value_parser = count::<u64>)]
    slab_max_work: u64,
    #[command(flatten)]
    run: McRunArgs,
    #[command(flatten)]
    profile: ProfileFile,
    /// Index of refraction of the slab relative to the air [default: the material's].
    ///
    /// Replaces the material's, for a one-layer material: e.g. 1.0 for the
    /// index-matched object of a scene whose object sets `eta = 1.0`.
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = args::real)]
    eta: Option<f64>,
    /// Engines whose transmission is fitted and scored: unreal, unity-hdrp, godot, or none.
    #[arg(
        long,
        value_name = "ENGINE,...",
        value_delimiter = ',',
        default_value = "unreal,unity-hdrp,godot"
    )]
    engines: Vec<String>,
    /// Scene units per millimetre (0.001: a scene in metres) for every engine [default: each
    /// engine's own unit: unreal 0.1 (the cm), the others 0.001 (the metre)].
    #[arg(long, value_name = "UNITS", allow_negative_numbers = true, value_parser = args::real)]
    units_per_mm: Option<f64>,
    #[command(flatten)]
    out: OutFile,
    /// Also write a CSV: the table [default: not written].
    #[arg(long, value_name = "FILE.csv")]
    csv: Option<PathBuf>,
    /// Also plot to a PNG: T and its radial spread against thickness, log-log [default: not written].
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
}

/// The engines named by `--engines` (none for "none").
fn engines(names: &[String]) -> anyhow::Result<Vec<Engine>> {
    if names == ["none"] {
        return Ok(Vec::new());
    }
    names
        .iter()
        .map(|n| {
            let e: Engine = n.parse().context("--engines")?;
            if et::none_for(e).is_some() {
                anyhow::bail!("--engines: {n} has no thickness-based transmission to fit (unreal, unity-hdrp or godot)");
            }
            Ok(e)
        })
        .collect()
}

/// The thicknesses `--thickness` names for `material`.
fn thicknesses(a: &Args, material: &Material) -> anyhow::Result<Vec<f64>> {
    let t = match a.thickness.as_deref() {
        None => match material.layers.last().and_then(|l| l.thickness) {
            Some(_) => vec![material.layers.iter().filter_map(|l| l.thickness).sum()],
            None => {
                mc::require_finite(material, "a transmission table").context("--thickness")?;
                // Not reached: the stack's last layer is semi-infinite.
                Vec::new()
            }
        },
        Some(s) => match s.split_once("..") {
            Some((lo, hi)) => {
                let parse = |v: &str| {
                    v.trim()
                        .parse::<f64>()
                        .map_err(|_| anyhow::anyhow!("--thickness: '{v}' is not a number of mm"))
                };
                tr::thickness_range(parse(lo)?, parse(hi)?, a.steps).context("--thickness")?
            }
            None => s
                .split(',')
                .map(|v| {
                    v.trim()
                        .parse::<f64>()
                        .map_err(|_| anyhow::anyhow!("--thickness: '{v}' is not a number of mm"))
                })
                .collect::<anyhow::Result<Vec<f64>>>()?,
        },
    };
    tr::check_thicknesses(material, &t).context("--thickness")?;
    Ok(t)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut material = Material::load(a.material.material.as_deref().unwrap_or_default())?;
    if let Some(eta) = a.eta {
        if material.layers.len() != 1 {
            anyhow::bail!(
                "--eta: sets the index of a one-layer material; '{}' has {} layers",
                material.name,
                material.layers.len()
            );
        }
        material.layers[0].eta = eta * material.eta_above;
    }
    material
        .validate(&format!("material '{}'", material.name))
        .context("--eta")?;
    let thick = thicknesses(&a, &material)?;
    let engines = engines(&a.engines)?;
    let channels = a.run.channels.channels()?;
    if !engines.is_empty() && channels.len() != 3 {
        anyhow::bail!("--channels: the engines' settings are RGB: keep rgb, or --engines none");
    }
    for (flag, p) in [
        ("--out", &a.out.out),
        ("--csv", &a.csv),
        ("--plot", &a.plot),
    ] {
        if let Some(p) = p {
            let ext = match flag {
                "--out" => "json",
                "--csv" => "csv",
                _ => "png",
            };
            ssskit::io::check_extension(p, &[ext], flag)?;
        }
    }
    let reflectance = match &a.profile.profile {
        Some(p) => Some(Profile::read(p)?),
        None => None,
    };
    let budget = match a.photons.photons {
        Some(n) => PhotonBudget::Fixed(n),
        None => PhotonBudget::KernelFactor {
            rel: a.table_error,
            max_photons: mc::DEFAULT_MAX_PHOTONS,
        },
    };
    let opts = TableOptions {
        thicknesses: thick,
        budget: budget.clone(),
        mc: McOptions {
            max_work: a.slab_max_work,
            ..McOptions::default()
        },
        seed: a.run.seed.seed,
        threads: a.run.threads.threads,
        channels: channels.clone(),
    };
    let bar = Bar::new();
    let mut table = tr::thickness_table(&material, &opts, &bar)?;
    let fits = if engines.is_empty() {
        Vec::new()
    } else {
        let profile = match reflectance {
            Some(p) => p,
            None => half_space(&material, &opts, budget, &bar)?,
        };
        engines
            .iter()
            .map(|&e| {
                let scene = a
                    .units_per_mm
                    .map_or(Scene::native(e), |units_per_mm| Scene { units_per_mm });
                let reflect = engine::fit(e, &profile, scene)?;
                Ok(et::fit(e, &reflect, &table, scene)?)
            })
            .collect::<anyhow::Result<Vec<_>>>()?
            .into_iter()
            .flatten()
            .collect()
    };
    if !fits.is_empty() {
        table.engines = serde_json::to_value(&fits)?;
    }
    print_table(&table)?;
    for f in &fits {
        print_fit(f)?;
    }
    write_outputs(&a, &table, &fits)
}

/// The material's reflectance profile for the engines' diffusion side: its
/// last layer semi-infinite, the table's budget.
fn half_space(
    material: &Material,
    opts: &TableOptions,
    budget: PhotonBudget,
    bar: &Bar,
) -> anyhow::Result<Profile> {
    let mut m = material.clone();
    if let Some(l) = m.layers.last_mut() {
        l.thickness = None;
    }
    let cfg = McConfig {
        budget,
        seed: opts.seed,
        threads: opts.threads,
        channels: opts.channels.clone(),
        grid: None,
    };
    Ok(mc::simulate_with(&m, &cfg, &opts.mc, bar)?)
}

fn write_outputs(
    a: &Args,
    table: &ThicknessTable,
    fits: &[et::TransmissionFit],
) -> anyhow::Result<()> {
    if let Some(out) = &a.out.out {
        ssskit::io::write_json_atomic(out, table)?;
        eprintln!("wrote {}", out.display());
    }
    if let Some(csv) = &a.csv {
        ssskit::io::write_atomic(
            csv,
            ssskit::report::present::transmission_plots::csv(table).as_bytes(),
        )?;
        eprintln!("wrote {}", csv.display());
    }
    if let Some(png) = &a.plot {
        let curves: Vec<FittedCurve> = fits
            .iter()
            .map(|f| FittedCurve {
                engine: &f.engine,
                t: &f.engine_t,
            })
            .collect();
        ssskit::report::present::transmission_plots::render(table, &curves, png)?;
        eprintln!("wrote {}", png.display());
    }
    Ok(())
}

fn print_table(t: &ThicknessTable) -> anyhow::Result<()> {
    let names: Vec<&str> = t.channels.iter().map(|c| c.name()).collect();
    outln!(
        "{}: light through slabs lit from behind (normal beam), per channel {}",
        t.material.name,
        names.join(", ")
    )?;
    outln!(
        "{:>9}  {:<40} {:<40} {:<24} {:<24} stopped by",
        "mm",
        "T +- stderr",
        "scattered part of T +- stderr",
        "r50 mm",
        "r90 mm"
    )?;
    for r in &t.rows {
        let pm = |v: &[f64], e: &[f64]| -> String {
            (0..t.channels.len())
                .map(|c| format!("{:.4e}+-{:.1e}", v[c], e[c]))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        outln!(
            "{:>9.4}  {:<40} {:<40} {:<24} {:<24} {}",
            r.thickness_mm,
            pm(&r.transmittance, &r.transmittance_stderr),
            pm(&r.diffuse, &r.diffuse_stderr),
            list(&r.r50_mm),
            list(&r.r90_mm),
            r.stopped_by.join(", ")
        )?;
    }
    Ok(())
}

/// An engine's fitted settings and its error at every thickness.
pub(super) fn print_fit(f: &et::TransmissionFit) -> anyhow::Result<()> {
    outln!("{} transmission ({}):", f.engine, f.source)?;
    for (name, v) in &f.params {
        let unit = f.units.get(name).and_then(|u| u.as_str()).unwrap_or("");
        outln!("  {name} = {v}    [{unit}]")?;
    }
    outln!("  error (engine / table - 1, r, g, b; '-' where the table holds no light):")?;
    for (i, t) in f.thickness_mm.iter().enumerate() {
        let e: Vec<String> = f.rel_error[i]
            .iter()
            .map(|e| e.map_or("-".into(), |e| format!("{:+.1}%", Bounded(100.0 * e))))
            .collect();
        outln!("  {t:>9.4} mm: {}", e.join(", "))?;
    }
    let rms = f
        .rms_log_error
        .map(|x| format!("{:.3}", Bounded(x)))
        .join(", ");
    outln!("  RMS of ln(engine / table): {rms}")?;
    print_notes("  ", &f.requirements, &f.warnings)
}

/// A fit's requirements and warnings, one a line, indented by `indent`.
pub(super) fn print_notes(
    indent: &str,
    requirements: &[String],
    warnings: &[String],
) -> anyhow::Result<()> {
    for r in requirements {
        outln!("{indent}requires: {r}")?;
    }
    for w in warnings {
        outln!("{indent}warning: {w}")?;
    }
    Ok(())
}

/// `ssskit engine`'s transmission block: the fit, or why there is none.
pub(super) fn print_engine(
    e: Engine,
    asked: bool,
    fit: Option<&et::TransmissionFit>,
) -> anyhow::Result<()> {
    match (fit, et::none_for(e)) {
        (Some(f), _) => print_fit(f),
        (None, Some(why)) if asked => outln!("transmission: {why}"),
        (None, _) if !asked && et::none_for(e).is_none() => outln!(
            "transmission: not fitted (give --transmission TABLE.json from `ssskit transmission`)"
        ),
        _ => Ok(()),
    }
}

/// An engine fit as JSON, with its transmission fit under "transmission".
pub(super) fn with_transmission(
    fit: &engine::EngineFit,
    t: Option<&et::TransmissionFit>,
) -> anyhow::Result<serde_json::Value> {
    let mut v = serde_json::to_value(fit)?;
    if let (Some(t), Some(map)) = (t, v.as_object_mut()) {
        map.insert("transmission".into(), serde_json::to_value(t)?);
    }
    Ok(v)
}

/// `compare --scene --transmission`: the back-lit rows of `render` (of
/// `scene`, whose profile is `profile`) with the engines' transmission
/// fitted to the table at `table`, and their table.
pub(super) fn scene_block(
    scene: &ssskit::scene::Scene,
    render: &ssskit::scene::Render,
    profile: &Profile,
    table: &std::path::Path,
    ppd: f64,
) -> anyhow::Result<(
    ssskit::report::eval::scene::transmission::TransmissionComparison,
    ssskit::report::present::table::Table,
)> {
    let t = ThicknessTable::read(table)
        .with_context(|| format!("--transmission {}", table.display()))?;
    let mut fits = Vec::new();
    for e in [Engine::Unreal, Engine::UnityHdrp, Engine::Godot] {
        let s = Scene::native(e);
        let reflect = engine::fit(e, profile, s)?;
        fits.extend(et::fit(e, &reflect, &t, s)?);
    }
    let cmp = ssskit::report::eval::scene::transmission::compare_transmission(
        scene, render, &t, &fits, ppd,
    )
    .with_context(|| format!("--transmission {}", table.display()))?;
    let tab = ssskit::report::present::transmission_plots::scene_table(&cmp);
    Ok((cmp, tab))
}
