//! Recorded measurements in the docs: every block
//! `<!-- BEGIN record:NAME/TABLE -->` in README.md or docs/*.md must equal
//! table TABLE of the committed record `docs/records/NAME.json`, rendered by
//! `Record::block`, so a timing in the docs always traces back to the run
//! that measured it (the record names the command, machine and date).
//!
//! `SSSKIT_BLESS=1 cargo test --release --test docs_records` rewrites the
//! blocks from the records (scripts/regen-docs does this); it never touches
//! a record, which only its benchmark writes.

use ssskit::report::present::record::Record;
use std::path::Path;

mod common;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn fresh_block(name: &str, file: &Path) -> String {
    let (record, table) = name
        .split_once('/')
        .unwrap_or_else(|| panic!("{}: block record:{name} has no /TABLE", file.display()));
    let path = ssskit::report::present::record::docs_path(record);
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
    let (checked, stale) = common::check_doc_blocks(&["record"], |_, name, f| fresh_block(name, f));
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
    // A missing folder is a failure: the docs show recorded blocks, so the
    // records they come from must be here.
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let all: String = common::doc_markdown_files()
        .iter()
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect();
    let mut tables = 0;
    for e in entries {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "json") {
            continue;
        }
        let r = Record::read(&p).unwrap();
        tables += r.tables.len();
        let stem = p.file_stem().unwrap().to_string_lossy().to_string();
        for t in r.tables.keys() {
            assert!(
                all.contains(&format!("<!-- BEGIN record:{stem}/{t} -->")),
                "{}: table '{t}' is shown in no markdown file",
                p.display()
            );
        }
    }
    // As many as `recorded_tables_match_their_records` finds in the docs.
    assert!(
        tables >= 6,
        "only {tables} recorded tables in {}",
        dir.display()
    );
}

/// GNU `date -u -f - +%F` converts every day in one call: the oracle for
/// the record dates' day count, leap years (2000 is one, 1900 and 2100 are
/// not) and dates before 1970.
fn gnu_dates(days: &[i64]) -> Vec<String> {
    use std::io::Write;
    let mut child = std::process::Command::new("date")
        .args(["-u", "-f", "-", "+%F"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("GNU date (coreutils) is the oracle of this test");
    let input: String = days.iter().map(|d| format!("@{}\n", d * 86_400)).collect();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()).unwrap());
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

#[test]
fn record_dates_match_gnu_date() {
    use ssskit::report::present::record::civil_date;
    // Every day from 1896 to 2104 (leap and non-leap centuries, the epoch),
    // and a stride through four 400-year eras either side.
    let mut days: Vec<i64> = (-27_000..49_000).collect();
    days.extend((-300_000..300_000).step_by(97));
    let want = gnu_dates(&days);
    assert_eq!(want.len(), days.len());
    for (d, w) in days.iter().zip(&want) {
        assert_eq!(&civil_date(*d), w, "day {d}");
    }
}

#[test]
fn a_new_record_is_dated_today() {
    // Two readings of `date` around the record's: the test passes across a
    // midnight, since the record's date then equals one of them.
    let date = || {
        let o = std::process::Command::new("date")
            .args(["-u", "+%F"])
            .output()
            .expect("date");
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    };
    let before = date();
    let r = Record::new("cmd", "machine");
    let after = date();
    assert!(
        r.date == before || r.date == after,
        "{} vs date {before} / {after}",
        r.date
    );
}
