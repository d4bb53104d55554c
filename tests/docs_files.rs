//! Recipes the docs print are the files the tests run: every block
//! `<!-- BEGIN file:PATH -->` in README.md or docs/*.md must be the file
//! PATH of the repository in a fenced code block, and every block
//! `<!-- BEGIN output:PATH -->` the standard output of the script PATH run
//! with no arguments in a clean environment (its defaults), in a fenced
//! `yaml` block. `SSSKIT_BLESS=1 cargo test --release --test docs_files`
//! rewrites the blocks from the files.

use ssskit::report::present::kernel_report::blocks_of;
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
            let out = Command::new(&full)
                .env_clear()
                .env("PATH", "/usr/bin:/bin")
                .output()
                .unwrap_or_else(|e| panic!("{path}: {e}"));
            assert!(
                out.status.success(),
                "{path} failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            ("yaml", String::from_utf8(out.stdout).unwrap())
        }
    };
    format!("```{lang}\n{body}```\n")
}

#[test]
fn printed_recipes_are_the_files_the_tests_run() {
    let bless = common::bless();
    let mut stale = Vec::new();
    let mut checked = 0;
    for f in common::doc_markdown_files() {
        let mut text = std::fs::read_to_string(&f).unwrap();
        let mut changed = false;
        for kind in ["file", "output"] {
            for (name, body) in blocks_of(&text.clone(), kind) {
                let want = fresh(kind, &name);
                checked += 1;
                if want == body {
                    continue;
                }
                if bless {
                    common::replace_block(&mut text, kind, &name, &want);
                    changed = true;
                } else {
                    stale.push(format!("{}: {kind}:{name}", f.display()));
                }
            }
        }
        if changed {
            std::fs::write(&f, text).unwrap();
        }
    }
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
