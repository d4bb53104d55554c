//! `ssskit profiles compare`: every analytic model against a Monte Carlo
//! reference on the same grid, per material and channel; markdown table,
//! CSV and one PNG per material.

use super::errors::invalid;
use super::out::out;
use super::profile::FresnelArg;
use super::progress::Bar;
use ssskit::material::{preset_names, Channel, Material};
use ssskit::profile::analytic::{self, Model, Options};
use ssskit::profile::mc::{simulate, McConfig, PhotonBudget};
use ssskit::report::{compare, plot};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand)]
enum What {
    /// Analytic models against Monte Carlo: error of the total, relative L2
    /// error of r R_d(r) over the range holding 99% of R_d, time.
    Compare(CompareArgs),
}

#[derive(clap::Args)]
struct CompareArgs {
    /// Comma-separated presets or material files, or "all" (every preset).
    #[arg(long, default_value = "all")]
    materials: String,
    /// Photons per channel for the reference.
    #[arg(long, conflicts_with = "target_error")]
    reference_photons: Option<u64>,
    /// Trace until the reference's relative standard error is below this
    /// (default 0.01 when --reference-photons is not given).
    #[arg(long, allow_negative_numbers = true)]
    target_error: Option<f64>,
    /// Photon cap per channel with --target-error.
    #[arg(long, default_value_t = 10_000_000)]
    max_photons: u64,
    /// Fresnel moments for the models.
    #[arg(long, value_enum, default_value = "fit")]
    fresnel: FresnelArg,
    /// Seed of the reference simulation.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output folder for compare.md, compare.csv and compare_<material>.png.
    #[arg(long, default_value = ".")]
    out_dir: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Compare(a) => run_compare(a),
    }
}

fn run_compare(a: CompareArgs) -> anyhow::Result<()> {
    let names: Vec<String> = if a.materials.trim() == "all" {
        preset_names().iter().map(|s| s.to_string()).collect()
    } else {
        a.materials
            .split(',')
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect()
    };
    if names.is_empty() {
        anyhow::bail!(
            "--materials: invalid value '{}': no material named",
            a.materials
        );
    }
    let materials: Vec<Material> = names
        .iter()
        .map(|n| Material::load(n))
        .collect::<Result<_, _>>()?;
    for m in &materials {
        if !m.is_half_space() {
            anyhow::bail!(
                "--materials: '{}' is not one semi-infinite layer; analytic models need a half-space",
                m.name
            );
        }
    }
    let budget = match (a.reference_photons, a.target_error) {
        (Some(0), _) => return Err(invalid("--reference-photons", 0, "must be > 0")),
        (Some(n), _) => PhotonBudget::Fixed(n),
        (None, e) => {
            let rel = e.unwrap_or(0.01);
            if !(rel.is_finite() && rel > 0.0 && rel < 1.0) {
                return Err(invalid("--target-error", rel, "must be in (0, 1)"));
            }
            PhotonBudget::TargetError {
                rel,
                max_photons: a.max_photons,
            }
        }
    };
    std::fs::create_dir_all(&a.out_dir)
        .map_err(|e| anyhow::anyhow!("--out-dir {}: {e}", a.out_dir.display()))?;
    let options = Options {
        fresnel: a.fresnel.into(),
        channels: Channel::ALL.to_vec(),
    };
    let mut rows = Vec::new();
    for mat in &materials {
        let grid = analytic::default_grid(mat, &options.channels)?;
        let cfg = McConfig {
            budget: budget.clone(),
            seed: a.seed,
            threads: None,
            channels: options.channels.clone(),
            grid: Some(grid.clone()),
        };
        let reference = simulate(mat, &cfg, &Bar::new())?;
        let mut models = Vec::new();
        for model in Model::ALL {
            // A model that cannot run here (e.g. the Fresnel fits outside
            // their range) is reported and left out, not fatal for the table.
            match timed_profile(mat, model, &grid, &options) {
                Ok((p, secs)) => {
                    rows.extend(compare::compare(&p, &reference, secs)?);
                    models.push(p);
                }
                Err(e) => eprintln!("{}: {} left out: {e:#}", mat.name, model.name()),
            }
        }
        let png = a.out_dir.join(format!("compare_{}.png", mat.file_stem()));
        let title = format!(
            "{}: analytic models vs Monte Carlo ({} photons/channel)",
            mat.name,
            reference
                .source
                .photons
                .as_ref()
                .and_then(|v| v.iter().max())
                .map(|n| n.to_string())
                .unwrap_or_else(|| "?".into())
        );
        plot::render(
            &compare::comparison_panels(&reference, &models),
            3,
            &title,
            &png,
        )?;
        eprintln!("{}: done -> {}", mat.name, png.display());
    }
    let md = a.out_dir.join("compare.md");
    let csv = a.out_dir.join("compare.csv");
    ssskit::io::write_atomic(&md, compare::report(&rows).as_bytes())?;
    compare::csv_table(&rows).write_csv(&csv)?;
    out!("{}", compare::table(&rows).markdown())?;
    eprintln!("wrote {} and {}", md.display(), csv.display());
    Ok(())
}

/// A model's profile and its time per profile: repeated until 50 ms have
/// passed so that microsecond models are timed well.
fn timed_profile(
    mat: &Material,
    model: Model,
    grid: &ssskit::profile::RadialGrid,
    options: &Options,
) -> anyhow::Result<(ssskit::profile::Profile, f64)> {
    let start = std::time::Instant::now();
    let mut runs = 0u32;
    loop {
        let p = analytic::profile(mat, model, grid, options)?;
        runs += 1;
        let el = start.elapsed().as_secs_f64();
        if el > 0.05 || runs >= 1000 {
            return Ok((p, el / runs as f64));
        }
    }
}
