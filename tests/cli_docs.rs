//! What the command line generates from its one definition of every flag,
//! and how it treats old spellings, through the real binary:
//! - docs/cli.md is what `ssskit man --format markdown` prints
//!   (`SSSKIT_BLESS=1` rewrites it);
//! - the bash completion script loads in bash and completes a subcommand,
//!   a flag and a flag's value, and offers no deprecated spelling;
//! - the other shells' scripts and the man pages are generated;
//! - an old spelling still works, prints a one-line deprecation note, and
//!   messages name the flag as typed.

use std::path::Path;
use std::process::Command;

mod common;
use common::{assert_fails, assert_ok, p, run, run_in};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

#[test]
fn docs_cli_md_is_what_the_binary_prints() {
    let fresh = common::ok(&["man", "--format", "markdown"]);
    let path = Path::new(ROOT).join("docs/cli.md");
    if common::bless() {
        std::fs::write(&path, &fresh).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == fresh,
        "docs/cli.md is stale: run scripts/regen-docs (or SSSKIT_BLESS=1 cargo test --release \
         --test cli_docs) and commit it"
    );
    // It holds every subcommand's help, flags with their value names.
    for needle in [
        "## ssskit simulate",
        "## ssskit profiles compare",
        "--mc-error <E>",
        "--signal-size <PX>",
    ] {
        assert!(fresh.contains(needle), "docs/cli.md lacks {needle}");
    }
}

/// The words bash completes for `words` (the last one is being typed),
/// with the completion script of the binary loaded.
fn bash_complete(script: &Path, words: &[&str]) -> Vec<String> {
    let quoted: Vec<String> = words.iter().map(|w| format!("'{w}'")).collect();
    let program = format!(
        "source '{}'\n\
         COMP_WORDS=({})\n\
         COMP_CWORD=$(( ${{#COMP_WORDS[@]}} - 1 ))\n\
         COMP_LINE=\"${{COMP_WORDS[*]}}\"\n\
         COMP_POINT=${{#COMP_LINE}}\n\
         _ssskit ssskit \"${{COMP_WORDS[COMP_CWORD]}}\" \"${{COMP_WORDS[COMP_CWORD-1]}}\"\n\
         printf '%s\\n' \"${{COMPREPLY[@]}}\"\n",
        script.display(),
        quoted.join(" ")
    );
    let o = common::output_ok(Command::new("bash").arg("-c").arg(&program), "bash");
    String::from_utf8_lossy(&o.stdout)
        .split_whitespace()
        .map(String::from)
        .collect()
}

#[test]
fn bash_completion_loads_and_completes() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("ssskit.bash");
    std::fs::write(&script, common::ok(&["completions", "bash"])).unwrap();
    // A subcommand, from its first letters.
    assert_eq!(bash_complete(&script, &["ssskit", "sim"]), ["simulate"]);
    let pro = bash_complete(&script, &["ssskit", "pro"]);
    assert!(pro.contains(&"profile".into()) && pro.contains(&"profiles".into()));
    // A subcommand of a subcommand.
    assert_eq!(
        bash_complete(&script, &["ssskit", "profiles", "com"]),
        ["compare"]
    );
    // A flag, from its first letters; no deprecated spelling offered.
    assert_eq!(
        bash_complete(&script, &["ssskit", "simulate", "--mc-e"]),
        ["--mc-error"]
    );
    let flags = bash_complete(&script, &["ssskit", "kernels", "--"]);
    assert!(flags.contains(&"--signal-size".into()) && flags.contains(&"--out-dir".into()));
    for old in ["--size", "--out", "--mc-photons", "--target-error"] {
        assert!(!flags.contains(&old.into()), "{old} offered: {flags:?}");
    }
    // The values of an enumerated flag.
    assert_eq!(
        bash_complete(&script, &["ssskit", "simulate", "--backend", ""]),
        ["cpu", "gpu", "auto"]
    );
}

#[test]
fn every_shell_and_the_man_pages_are_generated() {
    for (shell, needle) in [
        ("zsh", "#compdef ssskit"),
        ("fish", "complete -c ssskit"),
        ("powershell", "Register-ArgumentCompleter"),
        ("elvish", "edit:completion:arg-completer[ssskit]"),
    ] {
        let s = common::ok(&["completions", shell]);
        assert!(s.contains(needle), "{shell}: no '{needle}'");
        assert!(s.contains("signal-size"), "{shell}: no signal-size");
    }
    let roff = common::ok(&["man"]);
    assert!(roff.starts_with(".ie \\n(.g .ds Aq") || roff.contains(".TH ssskit"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("man");
    common::ok(&["man", "--out-dir", p(&out)]);
    for page in ["ssskit.1", "ssskit-simulate.1", "ssskit-profiles-compare.1"] {
        let text = std::fs::read_to_string(out.join(page)).unwrap();
        assert!(text.contains(".TH"), "{page}: not a man page");
    }
    let simulate = std::fs::read_to_string(out.join("ssskit-simulate.1")).unwrap();
    assert!(simulate.contains("mc\\-error") && !simulate.contains("target\\-error"));
    common::ok(&["man", "--format", "markdown", "--out-dir", p(&out)]);
    assert_eq!(
        std::fs::read_to_string(out.join("cli.md")).unwrap(),
        common::ok(&["man", "--format", "markdown"])
    );
}

/// An old spelling works and says it is old, in one line.
#[test]
fn old_spellings_work_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["signal", "edge", "--size", "24x16", "--out", "e.png"];
    let (_, err) = assert_ok(&run_in(dir.path(), &args), &args);
    let notes: Vec<&str> = err.lines().filter(|l| l.starts_with("note:")).collect();
    assert_eq!(notes, ["note: --size is deprecated: use --image-size"]);
    let img = image_size(&dir.path().join("e.png"));
    assert_eq!(img, (24, 16));
    // The new spelling: no note, the same image.
    let args = ["signal", "edge", "--image-size", "24x16", "--out", "f.png"];
    let (_, err) = assert_ok(&run_in(dir.path(), &args), &args);
    assert!(!err.contains("note:"), "{err}");
    assert_eq!(
        std::fs::read(dir.path().join("e.png")).unwrap(),
        std::fs::read(dir.path().join("f.png")).unwrap()
    );
    // A hidden flag that was replaced: noted too.
    let kernel = Path::new(ROOT).join("kernels/skin1-svd1.json");
    let args = ["bench", "filter", "--kernel", p(&kernel), "--width", "0"];
    let e = assert_fails(&run(&args), &args, &[]);
    assert!(
        e.contains("note: --width is deprecated: use --image-size WxH"),
        "{e}"
    );
}

/// Messages name the flag as the user typed it: clap's parse errors and
/// the library's parameter errors alike.
#[test]
fn messages_name_the_flag_as_typed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // clap: a value out of range, old and new spelling.
    for flag in ["--size", "--signal-size"] {
        let args = [
            "kernels",
            "--material",
            "skin1",
            flag,
            "5",
            "--out-dir",
            p(&out),
        ];
        assert_fails(
            &run(&args),
            &args,
            &[&format!("{flag}: invalid value 5: must be between 8 and")],
        );
    }
    // The library: the kernel grid's size, as fit's old --size.
    let profile = Path::new(ROOT).join("profiles/reference/skin1.json");
    let kernel = dir.path().join("k.json");
    for flag in ["--size", "--grid-size"] {
        let args = common::fit_args(p(&profile), "svd", p(&kernel), &[flag, "20"]);
        let e = assert_fails(&run(&args), &args, &[&format!("{flag}: invalid value 20")]);
        assert_eq!(e.contains("note:"), flag == "--size", "{e}");
    }
    // A CLI check, as apply's old --sss-width.
    let args = common::apply_args(
        "k.json",
        "in.exr",
        "o.exr",
        "0.1",
        &["--sss-width", "0.001"],
    );
    assert_fails(&run(&args), &args, &["--sss-width", "--mm-per-pixel"]);
}

fn image_size(path: &Path) -> (u32, u32) {
    let d = std::fs::read(path).unwrap();
    // PNG IHDR: width and height, big-endian, at bytes 16..24.
    (
        u32::from_be_bytes(d[16..20].try_into().unwrap()),
        u32::from_be_bytes(d[20..24].try_into().unwrap()),
    )
}

/// The study's photon sweep never traces the photons of its reference: a
/// seed whose sweep stream (seed + 1) is the reference's is refused, before
/// any work.
#[test]
fn the_study_sweep_never_reuses_the_reference_photons() {
    let dir = tempfile::tempdir().unwrap();
    let profile = Path::new(ROOT).join("profiles/reference/skin1.json");
    let seed: u64 = common::read_json(&profile)["source"]["seed"]
        .as_u64()
        .unwrap();
    let clash = (seed - 1).to_string();
    let out = dir.path().join("study");
    #[rustfmt::skip] // one line a part: the command reads as typed
    let args = ["study", "--profile", p(&profile), "--seed", &clash, "--sweep-photons", "1000", "--signal-size", "8", "--no-plots", "--out-dir", p(&out)];
    assert_fails(
        &run(&args),
        &args,
        &[&format!("--seed: invalid value {clash}"), "reference"],
    );
    assert!(!out.exists());
}
