//! The vocabulary of the command line, checked by walking clap's
//! `Command` through every subcommand:
//! - every visible argument that takes a value has a help line and a value
//!   name chosen for it (not the field name clap puts by default, except a
//!   one-letter symbol such as `--k <K>`; enumerated values show their
//!   possible values instead);
//! - one flag name, one value name and one concept across subcommands: the
//!   concept is the help up to its first ':' (all of it when there is
//!   none), so a subcommand may add detail after the colon, not change
//!   the meaning; a list's value name is its item's with ",..." added;
//! - the default of every optional flag is in its help;
//! - every line of `-h` is under 80 columns and no line of `--help` is
//!   over 100, drawn as the binary draws it here (clap wraps to the
//!   terminal, at most `HELP_WIDTH` columns; without a terminal to the
//!   COLUMNS variable or 100 columns, so the maximum is what keeps the
//!   lines short);
//! - old spellings are hidden aliases or hidden flags that say what
//!   replaces them.

use std::collections::BTreeMap;

/// Every command with its path (`ssskit profiles compare`), the top first;
/// clap's `help` subcommands left out.
fn commands() -> Vec<(String, clap::Command)> {
    fn walk(path: &str, c: &clap::Command, out: &mut Vec<(String, clap::Command)>) {
        let path = format!("{path} {}", c.get_name()).trim().to_string();
        out.push((path.clone(), c.clone()));
        for s in c.get_subcommands().filter(|s| s.get_name() != "help") {
            walk(&path, s, out);
        }
    }
    let mut out = Vec::new();
    walk("", &super::top_command(), &mut out);
    out
}

/// The visible arguments of a command, clap's own --help/--version left out.
fn visible(c: &clap::Command) -> impl Iterator<Item = &clap::Arg> {
    c.get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter(|a| !matches!(a.get_id().as_str(), "help" | "version"))
}

fn takes_value(a: &clap::Arg) -> bool {
    a.get_num_args().is_none_or(|n| n.takes_values())
}

/// The help line (`-h`) of an argument, as one string.
fn short_help(a: &clap::Arg) -> String {
    a.get_help().map(|h| h.to_string()).unwrap_or_default()
}

/// The concept of a help line: the words before the first ':'.
fn concept(help: &str) -> &str {
    help.split_once(':').map_or(help, |(c, _)| c).trim()
}

/// The value name of an argument, one item of a list.
fn value_name(a: &clap::Arg) -> Option<String> {
    let names = a.get_value_names()?;
    Some(
        names
            .iter()
            .map(|n| n.as_str().trim_end_matches(",...").to_string())
            .collect::<Vec<_>>()
            .join(" "),
    )
}

fn name(a: &clap::Arg) -> String {
    match a.get_long() {
        Some(l) => format!("--{l}"),
        None => format!("<{}>", a.get_id()),
    }
}

/// The name clap puts when none is given: the field name in capitals.
fn default_value_name(a: &clap::Arg) -> String {
    a.get_id().as_str().to_ascii_uppercase().replace('-', "_")
}

/// The problems with the value names and help of `commands`' arguments.
fn value_name_problems(commands: &[(String, clap::Command)]) -> Vec<String> {
    let mut bad = Vec::new();
    for (path, c) in commands {
        for a in visible(c).filter(|a| takes_value(a)) {
            let n = name(a);
            if short_help(a).trim().is_empty() {
                bad.push(format!("{path} {n}: no help"));
            }
            match value_name(a) {
                None => bad.push(format!("{path} {n}: no value name")),
                Some(v) => {
                    let enumerated = !a.get_possible_values().is_empty();
                    if v.len() > 1 && v == default_value_name(a) && !enumerated {
                        bad.push(format!(
                            "{path} {n}: value name {v} is the field's name; name the \
                             kind of value (N, MM, FILE...)"
                        ));
                    }
                }
            }
        }
    }
    bad
}

/// The problems with one flag name across `commands`: value names and
/// concepts that differ.
fn consistency_problems(commands: &[(String, clap::Command)]) -> Vec<String> {
    // flag -> (value name, concept) -> commands
    let mut seen: BTreeMap<String, BTreeMap<(String, String), Vec<String>>> = BTreeMap::new();
    for (path, c) in commands {
        for a in visible(c).filter(|a| a.get_long().is_some()) {
            let help = short_help(a);
            let key = (
                value_name(a).filter(|_| takes_value(a)).unwrap_or_default(),
                concept(&help).to_string(),
            );
            seen.entry(name(a))
                .or_default()
                .entry(key)
                .or_default()
                .push(path.clone());
        }
    }
    seen.into_iter()
        .filter(|(_, uses)| uses.len() > 1)
        .map(|(flag, uses)| {
            let uses: Vec<String> = uses
                .into_iter()
                .map(|((v, c), paths)| format!("<{v}> '{c}' in {}", paths.join(", ")))
                .collect();
            format!("{flag}: {}", uses.join("; "))
        })
        .collect()
}

/// Flags whose absence is not a default but the choice of another input
/// (`--material` or `--profile`, `--kernel` or `--reference`...): their
/// help need not show a default.
const ALTERNATIVES: &[&str] = &[
    "--material",
    "--profile",
    "--kernel",
    "--reference",
    "--mci",
    "--profiles",
    "--model",
    "--fov-y",
    "--view-depth",
    "--image-height",
];

/// The optional flags whose default is not in their help.
fn default_problems(commands: &[(String, clap::Command)]) -> Vec<String> {
    let mut bad = Vec::new();
    for (path, c) in commands {
        for a in visible(c).filter(|a| a.get_long().is_some() && takes_value(a)) {
            let n = name(a);
            let shown = !a.get_default_values().is_empty() && !a.is_hide_default_value_set();
            let said = short_help(a).contains("[default: ");
            if !(a.is_required_set() || shown || said || ALTERNATIVES.contains(&n.as_str())) {
                bad.push(format!("{path} {n}: its default is not in its help"));
            }
        }
    }
    bad
}

/// Lines of the help of `c` longer than the limits: -h under 80 columns,
/// --help at most 100.
fn width_problems(path: &str, c: &clap::Command) -> Vec<String> {
    let mut bad = Vec::new();
    let drawn = c.clone();
    for (flag, text, limit) in [
        ("-h", drawn.clone().render_help().to_string(), 79),
        ("--help", drawn.clone().render_long_help().to_string(), 100),
    ] {
        for line in text.lines() {
            let cols = line.chars().count();
            if cols > limit {
                bad.push(format!("{path} {flag}: {cols} columns: {line}"));
            }
        }
    }
    bad
}

/// The hidden arguments that are not a deprecated spelling.
fn hidden_problems(commands: &[(String, clap::Command)]) -> Vec<String> {
    let mut bad = Vec::new();
    for (path, c) in commands {
        for a in c.get_arguments().filter(|a| a.is_hide_set()) {
            if !short_help(a).starts_with("Deprecated: use --") {
                bad.push(format!("{path} {}: hidden but not deprecated", name(a)));
            }
        }
        for a in c.get_arguments() {
            let visible_aliases = a.get_visible_aliases().unwrap_or_default();
            if !visible_aliases.is_empty() {
                bad.push(format!(
                    "{path} {}: visible aliases {visible_aliases:?}: one name per concept",
                    name(a)
                ));
            }
        }
    }
    bad
}

fn assert_none(what: &str, problems: Vec<String>) {
    assert!(problems.is_empty(), "{what}:\n{}", problems.join("\n"));
}

#[test]
fn every_valued_flag_has_help_and_a_value_name() {
    assert_none("value names and help", value_name_problems(&commands()));
}

#[test]
fn one_flag_name_means_one_thing() {
    assert_none(
        "one flag, several meanings",
        consistency_problems(&commands()),
    );
}

#[test]
fn every_default_is_in_the_help() {
    assert_none("defaults", default_problems(&commands()));
}

#[test]
fn help_fits_a_terminal() {
    let cmds = commands();
    let bad: Vec<String> = cmds
        .iter()
        .flat_map(|(p, c)| width_problems(p, c))
        .collect();
    assert_none("help wider than a terminal", bad);
}

#[test]
fn old_spellings_are_hidden_and_deprecated() {
    assert_none("hidden flags", hidden_problems(&commands()));
}

/// The checks find what they are for: a command built with each fault.
#[test]
fn the_checks_catch_each_fault() {
    use clap::{Arg, Command};
    let cmd = |args: Vec<Arg>| vec![("t".to_string(), Command::new("t").args(args))];
    let valued = |id: &'static str| Arg::new(id).long(id).value_name("N").help("A count");
    // No help; the field's name as value name (a derive default).
    assert_eq!(
        value_name_problems(&cmd(vec![Arg::new("n").long("n").value_name("N")])).len(),
        1
    );
    assert_eq!(
        value_name_problems(&cmd(vec![valued("seed").value_name("SEED")])).len(),
        1
    );
    assert!(value_name_problems(&cmd(vec![valued("k").value_name("K")])).is_empty());
    // Two commands, one flag: another value name, another concept.
    let two = |a: Arg, b: Arg| {
        vec![
            ("a".to_string(), Command::new("a").arg(a)),
            ("b".to_string(), Command::new("b").arg(b)),
        ]
    };
    assert_eq!(
        consistency_problems(&two(valued("size"), valued("size").value_name("WxH"))).len(),
        1
    );
    assert_eq!(
        consistency_problems(&two(valued("size"), valued("size").help("Another count"))).len(),
        1
    );
    assert!(consistency_problems(&two(
        valued("size").help("A count: of taps"),
        valued("size").help("A count: of cells")
    ))
    .is_empty());
    // A default neither set nor said.
    assert_eq!(default_problems(&cmd(vec![valued("n")])).len(), 1);
    assert!(default_problems(&cmd(vec![valued("n").default_value("1")])).is_empty());
    assert!(default_problems(&cmd(vec![valued("n").help("A count [default: all]")])).is_empty());
    // A help line too wide for a terminal, even where clap can wrap.
    let wide = Command::new("t").term_width(super::HELP_WIDTH).arg(
        valued("x")
            .value_name("AN_UNBREAKABLE_VALUE_NAME_LONGER_THAN_ANY_TERMINAL_LINE_CAN_HOLD_AT_ALL"),
    );
    assert!(!width_problems("t", &wide).is_empty());
    let long = Command::new("t").arg(valued("x").help("word ".repeat(30)));
    assert!(!width_problems("t", &long.clone().term_width(200)).is_empty());
    assert!(width_problems("t", &long.term_width(super::HELP_WIDTH)).is_empty());
    // Hidden without saying what replaces it; a visible alias.
    assert_eq!(hidden_problems(&cmd(vec![valued("w").hide(true)])).len(), 1);
    assert_eq!(
        hidden_problems(&cmd(vec![valued("w").visible_alias("width")])).len(),
        1
    );
    assert!(hidden_problems(&cmd(vec![valued("w").alias("width")])).is_empty());
}

/// The deprecation notes: an alias typed names the flag it stands for; a
/// hidden flag says what replaces it; nothing else is noted.
#[test]
fn deprecated_spellings_are_noted() {
    let argv = |a: &[&str]| -> Vec<std::ffi::OsString> { a.iter().map(Into::into).collect() };
    let top = super::top_command();
    let run = |a: &[&str]| {
        let v = argv(a);
        let c = super::args::running_command(&top, &v);
        super::args::deprecated_spellings(&c, &v)
    };
    let d = run(&[
        "ssskit",
        "kernels",
        "--size=64",
        "--out",
        "x",
        "--material",
        "skin1",
    ]);
    let notes: Vec<&str> = d.iter().map(|d| d.note.as_str()).collect();
    assert_eq!(
        notes,
        [
            "note: --size is deprecated: use --signal-size",
            "note: --out is deprecated: use --out-dir"
        ]
    );
    assert_eq!(
        (d[0].canonical.as_str(), d[0].typed.as_str()),
        ("--signal-size", "--size")
    );
    let d = run(&["ssskit", "bench", "filter", "--width", "640"]);
    assert_eq!(d.len(), 1);
    assert_eq!(
        d[0].note,
        "note: --width is deprecated: use --image-size WxH"
    );
    assert!(run(&["ssskit", "kernels", "--signal-size", "64", "--out-dir", "x"]).is_empty());
    assert!(run(&["ssskit", "fit", "--", "--size"]).is_empty());
}

/// Every old spelling, per subcommand, and the flag it stands for: each
/// is accepted for that flag and noted once.
const OLD_SPELLINGS: &[(&str, &str, &str)] = &[
    ("advise", "--depth", "--view-depth"),
    ("advise", "--fov", "--fov-y"),
    ("advise", "--height", "--image-height"),
    ("advise", "--mc-photons", "--max-photons"),
    ("advise", "--scene-units-per-mm", "--units-per-mm"),
    ("advise", "--size", "--signal-size"),
    ("advise", "--target-error", "--image-error"),
    ("apply", "--sss-width", "--units-per-mm"),
    ("compare", "--out", "--out-dir"),
    ("compare", "--size", "--signal-size"),
    ("engine", "--mc-photons", "--max-photons"),
    ("fit", "--falloff", "--jimenez-falloff"),
    ("fit", "--size", "--grid-size"),
    ("fit", "--strength", "--jimenez-strength"),
    ("fit", "--width", "--jimenez-width"),
    ("kernels", "--mc-photons", "--max-photons"),
    ("kernels", "--out", "--out-dir"),
    ("kernels", "--size", "--signal-size"),
    ("kernels", "--target-error", "--image-error"),
    ("profile", "--model", "--profile-model"),
    ("profiles compare", "--reference-photons", "--photons"),
    ("profiles compare", "--target-error", "--mc-error"),
    ("signal", "--size", "--image-size"),
    ("simulate", "--target-error", "--mc-error"),
    ("study", "--mc-photons", "--max-photons"),
    ("study", "--out", "--out-dir"),
    ("study", "--photons", "--sweep-photons"),
    ("study", "--size", "--signal-size"),
];

/// A value `a` accepts, for a command line that uses it: one of its
/// possible values, its default, or one of the kind its value name says.
fn some_value(a: &clap::Arg) -> String {
    if let Some(v) = a.get_possible_values().first() {
        return v.get_name().to_string();
    }
    if let Some(v) = a.get_default_values().first() {
        return v.to_string_lossy().into();
    }
    match value_name(a).as_deref() {
        Some("WxH") => "8x8",
        Some("R,G,B") => "1,1,1",
        Some("PX") => "64",
        Some("FILE") | Some("DIR") => "x",
        _ => "9",
    }
    .to_string()
}

#[test]
fn every_old_spelling_is_accepted_and_noted() {
    let top = super::top_command();
    let mut found = Vec::new();
    for (path, c) in commands() {
        let sub = path.trim_start_matches("ssskit").trim().to_string();
        for a in c.get_arguments() {
            for alias in a.get_all_aliases().unwrap_or_default() {
                let (old, flag) = (format!("--{alias}"), name(a));
                found.push((sub.clone(), old.clone(), flag.clone()));
                let value = some_value(a);
                let mut argv: Vec<String> = vec!["ssskit".into()];
                argv.extend(sub.split_whitespace().map(String::from));
                argv.extend([old.clone(), value.clone()]);
                let argv: Vec<std::ffi::OsString> = argv.into_iter().map(Into::into).collect();
                let notes = super::args::deprecated_spellings(
                    &super::args::running_command(&top, &argv),
                    &argv,
                );
                assert_eq!(notes.len(), 1, "{sub} {old}");
                assert_eq!(
                    notes[0].note,
                    format!("note: {old} is deprecated: use {flag}")
                );
                // clap takes it for the flag (other required flags aside).
                let m = c
                    .clone()
                    .ignore_errors(true)
                    .try_get_matches_from([
                        std::ffi::OsString::from("t"),
                        old.clone().into(),
                        value.clone().into(),
                    ])
                    .unwrap();
                assert_eq!(
                    m.value_source(a.get_id().as_str()),
                    Some(clap::parser::ValueSource::CommandLine),
                    "{sub} {old} {value}"
                );
            }
        }
    }
    found.sort();
    let expected: Vec<(String, String, String)> = OLD_SPELLINGS
        .iter()
        .map(|(c, o, f)| (c.to_string(), o.to_string(), f.to_string()))
        .collect();
    assert_eq!(found, expected);
}

/// One default seed: every `--seed` defaults to the library's one.
#[test]
fn one_default_seed() {
    let seed = ssskit::profile::mc::DEFAULT_SEED.to_string();
    let mut seen = 0;
    for (path, c) in commands() {
        for a in c.get_arguments().filter(|a| a.get_long() == Some("seed")) {
            let d: Vec<String> = a
                .get_default_values()
                .iter()
                .map(|v| v.to_string_lossy().into())
                .collect();
            assert_eq!(d, std::slice::from_ref(&seed), "{path} --seed");
            seen += 1;
        }
    }
    // kernels, advise, study, simulate, profiles compare, compare, scene,
    // engine (its --material), transmission.
    assert_eq!(seen, 9);
}

/// Values that parse as an `f64` (Rust's `FromStr` reads all of them) but
/// are no quantity: each real-valued flag must refuse them while parsing,
/// before any work.
const NOT_FINITE: [&str; 5] = ["NaN", "nan", "inf", "-inf", "1e400"];

/// Every flag that takes real numbers (`f64`, or `[f64; 3]` for R,G,B),
/// hidden ones included, with its command.
fn real_flags(commands: &[(String, clap::Command)]) -> Vec<(String, clap::Command, clap::Arg)> {
    use std::any::TypeId;
    let mut out = Vec::new();
    for (path, c) in commands {
        for a in c.get_arguments() {
            let t = a.get_value_parser().type_id();
            if t == TypeId::of::<f64>() || t == TypeId::of::<[f64; 3]>() {
                out.push((path.clone(), c.clone(), a.clone()));
            }
        }
    }
    out
}

/// The flags of `commands` whose parser accepts a value of [`NOT_FINITE`].
fn non_finite_problems(commands: &[(String, clap::Command)]) -> Vec<String> {
    let mut bad = Vec::new();
    for (path, c, a) in real_flags(commands) {
        let rgb = a.get_value_parser().type_id() == std::any::TypeId::of::<[f64; 3]>();
        for v in NOT_FINITE {
            let text = if rgb {
                format!("1,{v},1")
            } else {
                v.to_string()
            };
            let token = match a.get_long() {
                Some(l) => format!("--{l}={text}"),
                None => text.clone(),
            };
            // A parse error is the one wanted; a missing or conflicting
            // flag reported instead means the value itself was accepted.
            let kind = c
                .clone()
                .try_get_matches_from([c.get_name().to_string(), token])
                .err()
                .map(|e| e.kind());
            if kind != Some(clap::error::ErrorKind::ValueValidation) {
                bad.push(format!("{path} {}: accepts {text}", name(&a)));
            }
        }
    }
    bad
}

/// Real-valued flags the walk must find at least (so that a change to how
/// it recognises them cannot make the check below vacuous): the count when
/// the check was written (46), less a margin for flags later removed.
const MIN_REAL_FLAGS: usize = 40;

#[test]
fn real_flags_refuse_values_that_are_not_finite() {
    let cmds = commands();
    let n = real_flags(&cmds).len();
    assert!(n >= MIN_REAL_FLAGS, "only {n} real-valued flags found");
    assert_none("non-finite values accepted", non_finite_problems(&cmds));
}
