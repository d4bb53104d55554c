//! Every flag of every subcommand is defined in this folder: a flag that
//! several subcommands take once, in `args/`; the others in the file of
//! their subcommand, one file per subcommand; each file's `run` calls the
//! library and prints or writes. `walk.rs` checks the vocabulary.

mod advise;
mod apply;
mod args;
mod bench;
mod compare;
mod diff;
mod engine;
mod errors;
mod fit;
mod fit_disk;
mod generate;
mod kernels;
mod materials;
mod merge;
mod out;
mod outputs;
mod plot;
mod profile;
mod profile_source;
mod profiles;
mod progress;
mod scene;
mod scene_compare;
mod signal;
mod simulate;
mod study;
mod transmission;
#[cfg(test)]
mod walk;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Columns of the help: every line of `-h` (and of `--help`) fits in 80,
/// however wide the terminal (clap wraps to the terminal when narrower).
const HELP_WIDTH: usize = 79;

#[derive(Parser)]
#[command(
    name = "ssskit",
    version,
    about = "Subsurface-scattering kernels from optical coefficients",
    max_term_width = HELP_WIDTH
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
    ///
    /// The speed/accuracy trade of every knob for one material: Monte Carlo
    /// photons, profile model, taps, SVD rank and kernel model, against one
    /// reference profile. The photon sweep uses seed --seed + 1, independent
    /// of a reference made with --seed.
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
    ///
    /// Per channel: RMS and largest absolute difference, and both relative
    /// to the peak of A. --json prints {"rms": [3], "max_abs": [3],
    /// "rms_rel": [3], "max_rel": [3]}.
    Diff(diff::Args),
    /// Plots of profiles: R_d(r), linear and log.
    Plot(plot::Args),
    /// Engine parameters (Unreal, Unity HDRP, Blender, Godot, iryoku) fitted to a profile.
    Engine(engine::Args),
    /// GPU timing of the post-process (timestamp queries).
    Bench(bench::Args),
    /// Kernel models across materials, in kernel and image space (report, CSV, JSON, plots).
    Compare(compare::Args),
    /// Shell completions: bash, zsh, fish, powershell or elvish.
    ///
    /// Prints the completion script for SHELL, generated from the flag
    /// definitions; e.g. `source <(ssskit completions bash)`.
    Completions(generate::CompletionsArgs),
    /// Man pages, or the markdown command-line reference (docs/cli.md).
    Man(generate::ManArgs),
    /// Path-trace a scene (TOML) to an EXR: radiance, its standard error and the G-buffer.
    Scene(scene::Args),
    /// Light through slabs of a material lit from behind, per thickness; the engines' formulas.
    Transmission(transmission::Args),
}

/// Turns off Mesa's Vulkan device-select layer unless the user set it up:
/// the layer only reorders the adapters for the display's compositor
/// (ssskit picks its adapter itself: `ssskit::gpu`), and to find the
/// display it connects to Wayland, whose client library prints "error:
/// XDG_RUNTIME_DIR is invalid or not set in the environment" on every run
/// without a session (twice per `apply`). Set before any thread starts, so
/// nothing reads the environment meanwhile.
fn quiet_vulkan_loader() {
    const LAYER_OFF: &str = "NODEVICE_SELECT";
    let chosen = [LAYER_OFF, "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|v| std::env::var_os(v).is_some());
    if !chosen {
        std::env::set_var(LAYER_OFF, "1");
    }
}

/// Runs the CLI; returns the process exit code (0 ok, 2 error).
pub fn main() -> i32 {
    quiet_vulkan_loader();
    out::install_panic_hook();
    if let Err(e) = ssskit::io::remove_temps_on_signals() {
        eprintln!("warning: {e}: an interrupted write may leave a .ssskit-*.tmp file");
    }
    let argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let top = top_command();
    // Deprecated spellings: still accepted, noted, and named as typed in
    // every message.
    let deprecated = args::deprecated_spellings(&args::running_command(&top, &argv), &argv);
    errors::set_typed(
        deprecated
            .iter()
            .map(|d| (d.canonical.clone(), d.typed.clone()))
            .collect(),
    );
    let parsed = top
        .try_get_matches_from(&argv)
        .and_then(|m| Cli::from_arg_matches(&m).map(|cli| (cli, m)));
    let (cli, matches) = match parsed {
        Ok(parsed) => parsed,
        // Help, version and usage errors: clap prints them; a closed or
        // full standard output must not turn --help into a panic or a lie.
        Err(e) => {
            if let Some(message) = errors::parse_error(&e) {
                eprintln!("error: {message}");
                return 2;
            }
            let printed = if e.use_stderr() && !deprecated.is_empty() {
                eprint!("{}", errors::as_typed(&e.render().to_string()));
                Ok(())
            } else {
                e.print().map_err(out::map_err).and_then(|()| out::flush())
            };
            return match printed {
                Ok(()) => e.exit_code(),
                Err(err) => out::quiet_exit(&err).unwrap_or_else(|| {
                    eprintln!("error: {err:#}");
                    2
                }),
            };
        }
    };
    for d in &deprecated {
        eprintln!("{}", d.note);
    }
    // The subcommand that runs, whose flags the messages name.
    let mut path = Vec::new();
    let mut m = &matches;
    while let Some((name, sub)) = m.subcommand() {
        path.push(name.to_string());
        m = sub;
    }
    errors::set_running(path.clone());
    let scope = errors::running();
    // Before any work: the thread cap whatever the environment says, a
    // pool that cannot start, and output files that cannot be written.
    let ready = ssskit::limits::start_global_pool()
        .map_err(anyhow::Error::from)
        .and_then(|_| check_output_files(&path, m));
    if let Err(e) = ready {
        eprintln!("error: {}", scope.message(&e));
        return 2;
    }
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
        Command::Completions(a) => generate::completions(a),
        Command::Man(a) => generate::man(a),
        Command::Scene(a) => scene::run(a),
        Command::Transmission(a) => transmission::run(a),
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

/// Checks every output of the running subcommand `path` (arguments `m`)
/// before the work, by the rules of [`outputs`].
fn check_output_files(path: &[String], m: &clap::ArgMatches) -> anyhow::Result<()> {
    let path: Vec<&str> = path.iter().map(String::as_str).collect();
    match subcommand(&path) {
        Some(command) => outputs::check(&path, &command, m),
        None => Ok(()),
    }
}

/// The whole command line interface, built (help subcommands and all).
fn top_command() -> clap::Command {
    let mut c = args::negative_numbers_are_values(args::long_help_opens_with_help(Cli::command()));
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
    use super::args::flag_value;
    use super::*;
    use ssskit::engine::Engine;
    use ssskit::report::eval::evaluate::signal_name;
    use ssskit::report::eval::{
        advise::ADVISED_FAMILIES as ADVISE, compare::kernel::FAMILIES as COMPARE,
    };

    fn names<T: clap::ValueEnum>() -> Vec<String> {
        T::value_variants().iter().map(flag_value).collect()
    }

    /// The tables of output arguments name arguments that exist, and every
    /// path-valued `out`-like argument is in one of them.
    #[test]
    fn output_tables_name_real_arguments() {
        use outputs::{FILE_OUTPUTS, FOLDER_OUTPUTS};
        for (path, id) in FOLDER_OUTPUTS {
            let c = subcommand(path).unwrap_or_else(|| panic!("{path:?}"));
            assert!(c.get_arguments().any(|a| a.get_id() == id), "{path:?} {id}");
        }
        let mut files = 0;
        for c in leaf_subcommands() {
            files += c
                .get_arguments()
                .filter(|a| FILE_OUTPUTS.contains(&a.get_id().as_str()))
                .count();
        }
        assert!(files >= 15, "only {files} output arguments found");
    }

    /// Enumerated flags whose values the library also spells: the same names.
    #[test]
    fn flag_values_are_the_library_names() {
        // Every separable model of `fit --model` is a family of `compare`;
        // the disk model is not separable.
        let separable: Vec<String> = names::<args::ModelArg>()
            .into_iter()
            .filter(|m| m != "disk")
            .collect();
        assert_eq!(separable, COMPARE);
        // advise's default families are kernel models of `fit --model`.
        let models = names::<args::ModelArg>();
        assert!(ADVISE.iter().all(|f| models.iter().any(|m| m == f)));
        let engines: Vec<&str> = Engine::ALL.iter().map(|e| e.name()).collect();
        assert_eq!(names::<args::engine::EngineArg>(), engines);
        let signals: Vec<String> = <signal::Kind as clap::ValueEnum>::value_variants()
            .iter()
            .map(|&k| signal_name(k.into()).to_string())
            .collect();
        assert_eq!(names::<signal::Kind>(), signals);
        for &e in <args::engine::EngineArg as clap::ValueEnum>::value_variants() {
            assert_eq!(Engine::from(e).name(), flag_value(&e));
        }
        // --profile-model: Monte Carlo and every analytic model, each
        // spelled as the library names it.
        let analytic: Vec<String> = <args::ProfileModel as clap::ValueEnum>::value_variants()
            .iter()
            .filter_map(|&m| m.analytic().map(|a| (m, a)))
            .map(|(m, a)| {
                assert_eq!(flag_value(&m), a.name());
                a.name().to_string()
            })
            .collect();
        let all: Vec<String> = ssskit::profile::analytic::Model::ALL
            .iter()
            .map(|m| m.name().to_string())
            .collect();
        assert_eq!(analytic, all);
    }
}
