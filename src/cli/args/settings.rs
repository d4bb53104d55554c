//! Per-subcommand settings of a shared flag, for
//! `#[command(mut_arg("id", ...))]`: this subcommand's default, help,
//! requirement or old spelling; and the rule that a long help opens with
//! the one-line help.

use super::values::flag_value;
use clap::ValueEnum;

/// `mut_arg(ID, default(v))`: this subcommand's default, shown in its help.
pub fn default<T: std::fmt::Display>(v: T) -> impl FnOnce(clap::Arg) -> clap::Arg {
    let s = v.to_string();
    move |a| a.default_value(s)
}

/// [`default`] of an enumerated flag.
pub fn default_enum<T: ValueEnum>(v: T) -> impl FnOnce(clap::Arg) -> clap::Arg {
    default(flag_value(&v))
}

/// `mut_arg(ID, help(...))`: this subcommand's one-line help; it keeps the
/// shared flag's concept (the words before the first ':').
pub fn help(text: &'static str) -> impl FnOnce(clap::Arg) -> clap::Arg {
    move |a| a.help(text)
}

/// `mut_arg(ID, required())`.
pub fn required() -> impl FnOnce(clap::Arg) -> clap::Arg {
    |a| a.required(true)
}

/// `mut_arg(ID, alias("--old"))`: a deprecated spelling, hidden, still
/// accepted, with a note when used.
pub fn alias(old: &'static str) -> impl FnOnce(clap::Arg) -> clap::Arg {
    move |a| a.alias(old.trim_start_matches("--"))
}

/// The long help (`--help`) of every argument of `cmd` and its
/// subcommands opens with its one-line help (`-h`): where a subcommand
/// refines the one-line help of a shared flag, the long help follows.
pub fn long_help_opens_with_help(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        let (Some(short), Some(long)) = (a.get_help(), a.get_long_help()) else {
            return a;
        };
        let (short, long) = (short.to_string(), long.to_string());
        let rest = long.split_once("\n\n").map_or("", |(_, rest)| rest);
        let first = long.split_once("\n\n").map_or(long.as_str(), |(f, _)| f);
        if first.trim_end_matches('.') == short {
            return a;
        }
        let text = if rest.is_empty() {
            short
        } else {
            format!("{short}\n\n{rest}")
        };
        a.long_help(text)
    })
    .mut_subcommands(long_help_opens_with_help)
}

/// Every flag that takes a value takes a negative number as its value
/// (`--samples -1`), to be refused by its parser with the flag named,
/// rather than read as an unknown flag `-1`.
pub fn negative_numbers_are_values(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        if a.get_num_args().is_some_and(|n| n.takes_values()) || a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(negative_numbers_are_values)
}
