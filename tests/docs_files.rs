//! Recipes the docs print are the files the tests run: every block
//! `<!-- BEGIN file:PATH -->` in README.md or docs/*.md must be the file
//! PATH of the repository in a fenced code block, and every block
//! `<!-- BEGIN output:PATH -->` the standard output of the script PATH run
//! with no arguments in a clean environment (its defaults), in a fenced
//! `yaml` block. `SSSKIT_BLESS=1 cargo test --release --test docs_files`
//! rewrites the blocks from the files.

use std::path::Path;
use std::process::Command;

mod common;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The language of a file's fence, from its first line or its ending.
fn fence(path: &str, text: &str) -> &'static str {
    if text.starts_with("#!/bin/sh") || text.starts_with("#!/usr/bin/env bash") {
        "sh"
    } else if path.ends_with(".py") {
        "python"
    } else if path.ends_with(".yaml") {
        "yaml"
    } else {
        ""
    }
}

fn fresh(kind: &str, path: &str) -> String {
    let full = Path::new(ROOT).join(path);
    let (lang, body) = match kind {
        "file" => {
            let text = std::fs::read_to_string(&full).unwrap_or_else(|e| panic!("{path}: {e}"));
            (fence(path, &text), text)
        }
        _ => {
            let out = common::output_ok(
                Command::new(&full).env_clear().env("PATH", "/usr/bin:/bin"),
                path,
            );
            ("yaml", String::from_utf8(out.stdout).unwrap())
        }
    };
    format!("```{lang}\n{body}```\n")
}

#[test]
fn printed_recipes_are_the_files_the_tests_run() {
    let (checked, stale) =
        common::check_doc_blocks(&["file", "output"], |kind, name, _| fresh(kind, name));
    assert!(
        checked >= 3,
        "the Slurm, shard and Kubernetes recipes are printed in the docs"
    );
    assert!(
        stale.is_empty(),
        "blocks differ from their files (SSSKIT_BLESS=1 cargo test --release --test docs_files):\n{}",
        stale.join("\n")
    );
}
