//! Recorded measurements in the docs: every block
//! `<!-- BEGIN record:NAME/TABLE -->` in README.md or docs/*.md must equal
//! table TABLE of the committed record `docs/records/NAME.json`, rendered by
//! `Record::block`, so a timing in the docs always traces back to the run
//! that measured it (the record names the command, machine and date).
//!
//! `SSSKIT_BLESS=1 cargo test --release --test docs_records` rewrites the
//! blocks from the records (scripts/regen-docs does this); it never touches
//! a record, which only its benchmark writes.

use ssskit::report::kernel_report::blocks_of;
use ssskit::report::record::Record;
use std::path::Path;

mod common;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn fresh_block(name: &str, file: &Path) -> String {
    let (record, table) = name
        .split_once('/')
        .unwrap_or_else(|| panic!("{}: block record:{name} has no /TABLE", file.display()));
    let path = ssskit::report::record::docs_path(record);
    let r = Record::read(&path)
        .unwrap_or_else(|e| panic!("{}: block record:{name}: {e}", file.display()));
    r.block(table).unwrap_or_else(|| {
        panic!(
            "{}: block record:{name}: {} has no table '{table}'",
            file.display(),
            path.display()
        )
    })
}

#[test]
fn recorded_tables_match_their_records() {
    let bless = std::env::var_os("SSSKIT_BLESS").is_some_and(|v| v == "1");
    let mut stale = Vec::new();
    let mut checked = 0;
    for f in common::doc_markdown_files() {
        let mut text = std::fs::read_to_string(&f).unwrap();
        let mut changed = false;
        for (name, body) in blocks_of(&text.clone(), "record") {
            let fresh = fresh_block(&name, &f);
            checked += 1;
            if fresh != body {
                if bless {
                    let begin = format!("<!-- BEGIN record:{name} -->\n");
                    let end = format!("<!-- END record:{name} -->");
                    let i = text.find(&begin).unwrap() + begin.len();
                    let j = i + text[i..].find(&end).unwrap();
                    text.replace_range(i..j, &fresh);
                    changed = true;
                } else {
                    stale.push(format!(
                        "{}: record:{name}\n--- committed\n{body}--- recorded\n{fresh}",
                        f.display()
                    ));
                }
            }
        }
        if changed {
            ssskit::io::write_atomic(&f, text.as_bytes()).unwrap();
        }
    }
    eprintln!("{checked} recorded blocks checked");
    // profiles/{speed,presets}, filter-cpu/{opencv,threads},
    // kernels/{fit,commands} at least.
    assert!(checked >= 6, "only {checked} recorded blocks found");
    assert!(
        stale.is_empty(),
        "tables differ from their records (run scripts/regen-docs):\n{}",
        stale.join("\n")
    );
}

/// Every committed record parses, and every table it holds is shown
/// somewhere (a record nobody shows is a table that went missing).
#[test]
fn every_record_is_shown() {
    let dir = Path::new(ROOT).join("docs/records");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return;
    };
    let all: String = common::doc_markdown_files()
        .iter()
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect();
    for e in entries {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "json") {
            continue;
        }
        let r = Record::read(&p).unwrap();
        let stem = p.file_stem().unwrap().to_string_lossy().to_string();
        for t in r.tables.keys() {
            assert!(
                all.contains(&format!("<!-- BEGIN record:{stem}/{t} -->")),
                "{}: table '{t}' is shown in no markdown file",
                p.display()
            );
        }
    }
}
