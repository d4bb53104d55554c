//! Deprecated spellings: which of the flags the user typed are hidden
//! aliases or hidden flags, for the one-line note each prints.

use std::ffi::OsString;

/// A deprecated spelling the user typed: the flag as typed (`--size`), the
/// flag it stands for (`--signal-size`), and the note to print.
pub struct Deprecated {
    pub typed: String,
    pub canonical: String,
    pub note: String,
}

/// The subcommand `argv` runs (walking the subcommand names from the top;
/// the top-level command has no flag that takes a value, so no value can
/// be mistaken for a name).
pub fn running_command(top: &clap::Command, argv: &[OsString]) -> clap::Command {
    let mut c = top.clone();
    for a in argv.iter().skip(1) {
        let Some(a) = a.to_str() else { break };
        if a.starts_with('-') {
            continue;
        }
        match c.find_subcommand(a) {
            Some(sub) => c = sub.clone(),
            None => break,
        }
    }
    c
}

/// The deprecated spellings among the flags of `argv` for the subcommand
/// `cmd`: hidden aliases of a flag, and hidden flags (whose help says what
/// replaces them).
pub fn deprecated_spellings(cmd: &clap::Command, argv: &[OsString]) -> Vec<Deprecated> {
    let mut out: Vec<Deprecated> = Vec::new();
    for a in argv.iter().skip(1) {
        let Some(a) = a.to_str() else { continue };
        if a == "--" {
            break;
        }
        let Some(name) = a.strip_prefix("--") else {
            continue;
        };
        let name = name.split_once('=').map_or(name, |(n, _)| n);
        let typed = format!("--{name}");
        if out.iter().any(|d| d.typed == typed) {
            continue;
        }
        for arg in cmd.get_arguments() {
            let Some(long) = arg.get_long() else { continue };
            let hidden_alias = arg.get_all_aliases().unwrap_or_default().contains(&name)
                && !arg
                    .get_visible_aliases()
                    .unwrap_or_default()
                    .contains(&name);
            if hidden_alias {
                out.push(Deprecated {
                    note: format!("note: {typed} is deprecated: use --{long}"),
                    typed: typed.clone(),
                    canonical: format!("--{long}"),
                });
            } else if long == name && arg.is_hide_set() {
                let why = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
                out.push(Deprecated {
                    note: format!("note: {typed} is {}", lower_first(&why)),
                    typed: typed.clone(),
                    canonical: typed.clone(),
                });
            }
        }
    }
    out
}

fn lower_first(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_lowercase().chain(c).collect(),
        None => String::new(),
    }
}
