//! Every flag of every subcommand is defined in this folder, one file per
//! subcommand; each file's `run` calls the library and prints or writes.

mod advise;
mod apply;
mod compare;
mod diff;
mod fit;
mod kernels;
mod materials;
mod plot;
mod profile;
mod profile_source;
mod profiles;
mod progress;
mod signal;
mod simulate;
mod study;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "ssskit",
    version,
    about = "Subsurface-scattering kernels from optical coefficients"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job: profile, every kernel model, shader arrays, report, what to ship.
    Kernels(kernels::Args),
    /// The cheapest kernel configuration meeting a target error at a pixel scale.
    Advise(advise::Args),
    /// Speed/accuracy study: photons, profile model, taps, rank, kernel model.
    Study(study::Args),
    /// List material presets with derived quantities per channel.
    Materials(materials::Args),
    /// Monte Carlo simulation of the diffuse reflectance profile R_d(r).
    Simulate(simulate::Args),
    /// Analytic reflectance profile (dipole, photon beam diffusion, ...).
    Profile(profile::Args),
    /// Work on several profiles: compare analytic models with Monte Carlo.
    Profiles(profiles::Args),
    /// Fit a separable kernel to a profile.
    Fit(fit::Args),
    /// Apply a kernel to an image (CPU reference or wgpu).
    Apply(apply::Args),
    /// Write a test image (edge, shapes, dirac, checker).
    Signal(signal::Args),
    /// Image-space difference of two images.
    Diff(diff::Args),
    /// Plots of profiles and kernels.
    Plot(plot::Args),
    /// Kernel models across materials, in kernel and image space (report, CSV, JSON, plots).
    Compare(compare::Args),
}

/// Runs the CLI; returns the process exit code (0 ok, 2 error).
pub fn main() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Kernels(a) => kernels::run(a),
        Command::Advise(a) => advise::run(a),
        Command::Study(a) => study::run(a),
        Command::Materials(a) => materials::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Profile(a) => profile::run(a),
        Command::Profiles(a) => profiles::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Apply(a) => apply::run(a),
        Command::Signal(a) => signal::run(a),
        Command::Diff(a) => diff::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Compare(a) => compare::run(a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e:#}");
            2
        }
    }
}
