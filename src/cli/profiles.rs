//! `ssskit profiles compare`: every analytic model against a Monte Carlo
//! reference on the same grid, per material and channel; markdown table,
//! CSV and one PNG per material.

use super::args::{
    self, FresnelArg, MaterialsArg, MaxPhotonsArg, McErrorArg, OutDir, PhotonsArg, SeedArg,
};
use super::errors::invalid;
use super::out::{out, outln};
use super::progress::Bar;
use ssskit::material::{Channel, Material};
use ssskit::profile::analytic::{self, Model};
use ssskit::profile::mc::{self, PhotonBudget};
use ssskit::profile::source::{make_profile_on, ProfileSource};
use ssskit::report::eval::compare::profile as compare;
use ssskit::report::eval::radial::comparison_figure;
use ssskit::report::present::{plot, profile_tables};

pub type Args = args::Group<What>;

#[derive(clap::Subcommand)]
pub enum What {
    /// Analytic models against a Monte Carlo reference: errors and time.
    ///
    /// Per material and channel: the error of the total, the relative L2
    /// error of r R_d(r) over the range holding 99% of R_d, and the time
    /// of each analytic model, against a Monte Carlo reference on the same
    /// grid.
    Compare(CompareArgs),
}

#[derive(clap::Args)]
#[command(
    mut_arg("photons", |a| a.conflicts_with("mc_error").alias("reference-photons").help(
        "Photons per channel of the Monte Carlo run: a fixed count (e.g. 1e6) \
         [default: none: --mc-error decides]"
    )),
    mut_arg("mc_error", |a| args::default(compare::REFERENCE_MC_ERROR)(a).alias("target-error")),
    mut_arg("max_photons", args::default(args::count_text(compare::REFERENCE_MAX_PHOTONS))),
    mut_arg("out_dir", |a| a.help(
        "Output folder (created): compare.md, compare.csv, compare_<material>.png"
    )),
)]
pub struct CompareArgs {
    #[command(flatten)]
    materials: MaterialsArg,
    #[command(flatten)]
    photons: PhotonsArg,
    #[command(flatten)]
    mc_error: McErrorArg,
    #[command(flatten)]
    max_photons: MaxPhotonsArg,
    #[command(flatten)]
    fresnel: FresnelArg,
    #[command(flatten)]
    seed: SeedArg,
    #[command(flatten)]
    out_dir: OutDir,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Compare(a) => run_compare(a),
    }
}

fn run_compare(a: CompareArgs) -> anyhow::Result<()> {
    let names: Vec<String> = match a.materials.named()? {
        Some(v) => v.to_vec(),
        None => MaterialsArg::half_space_presets(),
    };
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
    let budget = reference_budget(&a)?;
    let out_dir = a.out_dir.path()?;
    std::fs::create_dir_all(out_dir)
        .map_err(|e| anyhow::anyhow!("--out-dir {}: {e}", out_dir.display()))?;
    let fresnel = a.fresnel.fresnel.into();
    // The reference runs to its own budget under the tracer's default work
    // cap (a reference is not held to the pipeline's minute).
    let reference_source = ProfileSource::MonteCarlo {
        budget,
        seed: a.seed.seed,
        max_work: mc::DEFAULT_MAX_WORK,
    };
    let mut rows = Vec::new();
    let mut warnings = Vec::new();
    for mat in &materials {
        let grid = analytic::default_grid(mat, &Channel::ALL)?;
        let (reference, _) = make_profile_on(mat, &reference_source, Some(&grid), &Bar::new())?;
        for w in reference.warnings()? {
            warnings.push(format!("Monte Carlo reference of {}: {w}", mat.name));
        }
        let mut models = Vec::new();
        for model in Model::ALL {
            // A model that cannot run here (e.g. the Fresnel fits outside
            // their range) is reported and left out, not fatal for the table.
            let source = ProfileSource::Analytic { model, fresnel };
            match timed_profile(mat, &source, &grid) {
                Ok((p, secs)) => {
                    rows.extend(compare::compare(&p, &reference, secs)?);
                    models.push(p);
                }
                Err(e) => eprintln!("{}: {} left out: {e:#}", mat.name, model.name()),
            }
        }
        let png = out_dir.join(format!("compare_{}.png", mat.file_stem()));
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
            &profile_tables::comparison_panels(&comparison_figure(&reference, &models)),
            3,
            &title,
            &png,
        )?;
        eprintln!("{}: done -> {}", mat.name, png.display());
    }
    let md = out_dir.join("compare.md");
    let csv = out_dir.join("compare.csv");
    // A reference too noisy to judge the models by says so in the report
    // and on standard output, not only on standard error.
    let mut report = profile_tables::report(&rows);
    if !warnings.is_empty() {
        report.push_str("\n## Warnings\n\n");
        for w in &warnings {
            report.push_str(&format!("- {w}\n"));
        }
    }
    ssskit::io::write_atomic(&md, report.as_bytes())?;
    profile_tables::csv_table(&rows).write_csv(&csv)?;
    out!("{}", profile_tables::table(&rows).markdown())?;
    for w in &warnings {
        outln!("warning: {w}")?;
    }
    eprintln!("wrote {} and {}", md.display(), csv.display());
    Ok(())
}

/// The Monte Carlo reference's budget: --photons, or --mc-error (the
/// comparison's own default) under --max-photons.
fn reference_budget(a: &CompareArgs) -> anyhow::Result<PhotonBudget> {
    Ok(match (a.photons.photons, a.mc_error.mc_error) {
        (Some(0), _) => return Err(invalid("--photons", 0, "must be > 0")),
        (Some(n), _) => PhotonBudget::Fixed(n),
        (None, e) => {
            let rel = e.unwrap_or(compare::REFERENCE_MC_ERROR);
            if !(rel.is_finite() && rel > 0.0 && rel < 1.0) {
                return Err(invalid("--mc-error", rel, "must be in (0, 1)"));
            }
            PhotonBudget::TargetError {
                rel,
                max_photons: a.max_photons.max_photons,
            }
        }
    })
}

/// A model's profile and its time per profile: repeated until 50 ms have
/// passed so that microsecond models are timed well.
fn timed_profile(
    mat: &Material,
    source: &ProfileSource,
    grid: &ssskit::profile::RadialGrid,
) -> anyhow::Result<(ssskit::profile::Profile, f64)> {
    let start = std::time::Instant::now();
    let mut runs = 0u32;
    loop {
        let (p, _) = make_profile_on(mat, source, Some(grid), &ssskit::progress::NoProgress)?;
        runs += 1;
        let el = start.elapsed().as_secs_f64();
        if el > 0.05 || runs >= 1000 {
            return Ok((p, el / runs as f64));
        }
    }
}
