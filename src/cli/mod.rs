//! Every flag of every subcommand is defined in this folder, one file per
//! subcommand; each file's `run` calls the library and prints or writes.

mod advise;
mod apply;
mod bench;
mod compare;
mod diff;
mod engine;
mod errors;
mod fit;
mod kernels;
mod materials;
mod merge;
mod out;
mod plot;
mod profile;
mod profile_source;
mod profiles;
mod progress;
mod scene;
mod signal;
mod simulate;
mod study;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

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
    /// Combine the shards of one Monte Carlo run (simulate --shard K/N).
    Merge(merge::Args),
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
    /// Engine parameters (Unreal, Unity HDRP, Blender, Godot, iryoku)
    /// fitted to a profile.
    Engine(engine::Args),
    /// GPU timing of the post-process (timestamp queries).
    Bench(bench::Args),
    /// Kernel models across materials, in kernel and image space (report, CSV, JSON, plots).
    Compare(compare::Args),
    /// Path-trace a scene (TOML) to an EXR: radiance, its standard error and the G-buffer.
    Scene(scene::Args),
}

/// How a value of an enumerated flag is spelled on the command line.
fn flag_value<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

/// Runs the CLI; returns the process exit code (0 ok, 2 error).
pub fn main() -> i32 {
    out::install_panic_hook();
    if let Err(e) = ssskit::io::remove_temps_on_signals() {
        eprintln!("warning: {e}: an interrupted write may leave a .ssskit-*.tmp file");
    }
    let parsed = Cli::command()
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m).map(|cli| (cli, m)));
    let (cli, matches) = match parsed {
        Ok(parsed) => parsed,
        // Help, version and usage errors: clap prints them; a closed or
        // full standard output must not turn --help into a panic or a lie.
        Err(e) => {
            let printed = e.print().map_err(out::map_err).and_then(|()| out::flush());
            return match printed {
                Ok(()) => e.exit_code(),
                Err(err) => out::quiet_exit(&err).unwrap_or_else(|| {
                    eprintln!("error: {err:#}");
                    2
                }),
            };
        }
    };
    // The subcommand that runs, whose flags the messages name.
    let mut path = Vec::new();
    let mut m = &matches;
    while let Some((name, sub)) = m.subcommand() {
        path.push(name.to_string());
        m = sub;
    }
    errors::set_running(path);
    let scope = errors::running();
    let result = match cli.command {
        Command::Kernels(a) => kernels::run(a),
        Command::Advise(a) => advise::run(a),
        Command::Study(a) => study::run(a),
        Command::Materials(a) => materials::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Profile(a) => profile::run(a),
        Command::Profiles(a) => profiles::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Apply(a) => apply::run(a),
        Command::Signal(a) => signal::run(a),
        Command::Diff(a) => diff::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Engine(a) => engine::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Scene(a) => scene::run(a),
    };
    match result.and_then(|()| out::flush()) {
        Ok(()) => 0,
        Err(e) => match out::quiet_exit(&e) {
            Some(code) => code,
            None => {
                eprintln!("error: {}", scope.message(&e));
                2
            }
        },
    }
}

/// The whole command line interface, built (help subcommands and all).
fn top_command() -> clap::Command {
    let mut c = Cli::command();
    c.build();
    c
}

/// The subcommand at `path` (`["profiles", "compare"]`), with its flags.
fn subcommand(path: &[&str]) -> Option<clap::Command> {
    let mut c = top_command();
    for name in path {
        c = c.find_subcommand(name)?.clone();
    }
    Some(c)
}

/// Every subcommand that runs something (no subcommands of its own).
#[cfg(test)]
fn leaf_subcommands() -> Vec<clap::Command> {
    fn walk(c: &clap::Command, out: &mut Vec<clap::Command>) {
        if c.has_subcommands() {
            c.get_subcommands().for_each(|s| walk(s, out));
        } else {
            out.push(c.clone());
        }
    }
    let mut out = Vec::new();
    walk(&top_command(), &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use ssskit::engine::Engine;
    use ssskit::report::evaluate::signal_name;
    use ssskit::report::{advise::FAMILIES as ADVISE, kernel_compare::FAMILIES as COMPARE};

    fn names<T: clap::ValueEnum>() -> Vec<String> {
        T::value_variants().iter().map(flag_value).collect()
    }

    /// Enumerated flags whose values the library also spells: the same names.
    #[test]
    fn flag_values_are_the_library_names() {
        assert_eq!(names::<advise::Family>(), ADVISE);
        assert_eq!(names::<fit::ModelArg>(), COMPARE);
        let engines: Vec<&str> = Engine::ALL.iter().map(|e| e.name()).collect();
        assert_eq!(names::<engine::EngineArg>(), engines);
        let signals: Vec<String> = <signal::Kind as clap::ValueEnum>::value_variants()
            .iter()
            .map(|&k| signal_name(k.into()).to_string())
            .collect();
        assert_eq!(names::<signal::Kind>(), signals);
        for &e in <engine::EngineArg as clap::ValueEnum>::value_variants() {
            assert_eq!(Engine::from(e).name(), flag_value(&e));
        }
    }
}
