//! `ssskit study`: the speed/accuracy trade of every knob for one material.

use super::args::{self, count, ProfileModel, ProfileSourceArgs, ReportArgs};
use super::errors::invalid;
use super::out::out;
use super::profile_source::command_line;
use ssskit::report::eval::study::{self, Settings};
use ssskit::report::present::study_report;

#[derive(clap::Args)]
#[command(
    mut_args(args::profile_source(ProfileModel::Mc)),
    mut_args(args::report())
)]
#[command(mut_arg("sweep_photons", |a| a
    .alias("photons")
    .default_value(args::counts_text(&Settings::default().photons))))]
pub struct Args {
    #[command(flatten)]
    profile: ProfileSourceArgs,
    #[command(flatten)]
    report: ReportArgs,
    /// Photon counts per channel of the Monte Carlo sweep, comma-separated.
    ///
    /// The sweep draws its photons with seed --seed + 1, independent of a
    /// reference made with --seed (a shared seed would make each sweep
    /// profile a prefix of the reference's photons and hide its error).
    #[arg(long, value_name = "N,...", value_delimiter = ',', required = false, value_parser = count::<u64>)]
    sweep_photons: Vec<u64>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mm_per_pixel =
        super::errors::positive("--mm-per-pixel", a.report.mm_per_pixel.or_default())?;
    let photons = &a.sweep_photons;
    let cap = ssskit::profile::mc::DEFAULT_MAX_PHOTONS;
    if let Some(&n) = photons.iter().find(|&&n| n == 0 || n > cap) {
        return Err(invalid(
            "--sweep-photons",
            n,
            &format!("each count must be between 1 and {cap:e}"),
        ));
    }
    let out_dir = a.report.out_dir.path()?;
    // The folder is written aside and swapped in whole at the end.
    let staged = ssskit::io::StagedDir::new(out_dir)?;
    let t0 = std::time::Instant::now();
    let (reference, source) = a.profile.load()?;
    let sweep_seed = a.profile.seed.seed.wrapping_add(1);
    if reference.source.seed == Some(sweep_seed) {
        return Err(invalid(
            "--seed",
            a.profile.seed.seed,
            &format!(
                "the sweep (seed + 1 = {sweep_seed}) would trace the photons of the reference \
                 profile, which has that seed; give another --seed"
            ),
        ));
    }
    eprintln!("{}: reference profile {source}", reference.material.name);
    let settings = Settings {
        mm_per_pixel,
        size: a.report.signal_size.signal_size,
        photons: photons.clone(),
        seed: sweep_seed,
        ..Settings::default()
    };
    let s = study::run(&reference, &settings, &super::progress::Bar::new())?;
    let files = study_report::write(
        &s,
        staged.path(),
        &command_line(out_dir),
        !a.report.no_plots.no_plots,
    )?;
    staged.commit()?;
    out!("{}", study_report::table(&s).markdown())?;
    eprintln!(
        "{} entries in {:.1} s -> {}/{}",
        s.entries.len(),
        t0.elapsed().as_secs_f64(),
        out_dir.display(),
        files.join(", ")
    );
    Ok(())
}
