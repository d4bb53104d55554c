//! Comments and documents cite sources by author, year and equation
//! ("Freude 2014, eq. 5.12"; docs/references.md lists them in full), never
//! by something a clone of the repository does not contain: a path outside
//! it (`../shared/...`), a section of an outside specification
//! ("REFERENCE 4"), a seed file number ("002 eq. 5.12") or an issue number.
//!
//! Ignored until `scripts/fix-citations` has been run on the whole merged
//! tree (the integrator un-ignores it then); run it any time with
//! `cargo test --release --test citations -- --ignored` to list what is left.

use std::path::{Path, PathBuf};

const ROOTS: [&str; 8] = [
    "src",
    "tests",
    "docs",
    "scripts",
    "benches",
    "shaders",
    "README.md",
    "DEVELOPERS.md",
];

/// Files that must name the old forms: the mapping and this test.
const EXEMPT: [&str; 3] = [
    "docs/references.md",
    "scripts/fix-citations",
    "tests/citations.rs",
];

fn files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_dir() {
        for e in std::fs::read_dir(path).unwrap() {
            files(&e.unwrap().path(), out);
        }
    } else {
        out.push(path.to_path_buf());
    }
}

fn is_word(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// "5.2", "A.1": a section or table number (not "0.001").
fn section_number(s: &str) -> bool {
    let b = s.as_bytes();
    b.len() >= 3
        && (b[0].is_ascii_digit() && b[0] != b'0' || b[0].is_ascii_uppercase())
        && b[1] == b'.'
        && b[2].is_ascii_digit()
}

/// What a line cites that leaves the repository, if anything.
fn forbidden(line: &str) -> Option<&'static str> {
    if line.contains("../shared") {
        return Some("a path outside the repository");
    }
    let chars: Vec<char> = line.chars().collect();
    let text: String = chars.iter().collect();
    let lower = text.to_lowercase();
    let at = |i: usize| chars.get(i).copied();
    let before_ok = |i: usize| i == 0 || !(is_word(chars[i - 1]) || ".,+-".contains(chars[i - 1]));
    for i in 0..chars.len() {
        let rest: String = chars[i..].iter().collect();
        // "REFERENCE" as a word, in capitals.
        if rest.starts_with("REFERENCE") && before_ok(i) && !at(i + 9).is_some_and(is_word) {
            return Some("the outside specification REFERENCE");
        }
        // A seed number used as a source: "002 eq.", "000 ch.", "001's".
        if before_ok(i)
            && rest.len() >= 4
            && rest.starts_with("00")
            && ('0'..='4').contains(&chars[i + 2])
            && !at(i + 3).is_some_and(|c| c.is_ascii_digit() || c == '.')
        {
            let after = &rest[3..];
            let after = after.strip_prefix(' ').unwrap_or(after);
            if [
                "eq",
                "table",
                "fig",
                "ch.",
                "chapter",
                "sec",
                "appendix",
                "algorithm",
            ]
            .iter()
            .any(|w| after.starts_with(w))
                || after.starts_with("'s")
                || section_number(after)
                || after.starts_with("\u{2019}s")
            {
                return Some("a seed file number");
            }
        }
    }
    // "issue 4", "issues 3 and 4", "issue #4".
    let mut from = 0;
    while let Some(k) = lower[from..].find("issue") {
        let k = from + k;
        let rest = lower[k..]
            .trim_start_matches("issues")
            .trim_start_matches("issue");
        let rest = rest.strip_prefix(' ').unwrap_or("x");
        let rest = rest.strip_prefix('#').unwrap_or(rest);
        let word_start = k == 0 || !lower[..k].chars().last().is_some_and(is_word);
        if word_start && rest.starts_with(|c: char| c.is_ascii_digit()) {
            return Some("an issue number");
        }
        from = k + 5;
    }
    None
}

#[test]
fn forbidden_forms_are_recognised() {
    for bad in [
        "see `../shared/REFERENCE.md`",
        "(REFERENCE 4)",
        "REFERENCE.md section 3",
        "(002 eq. 5.12)",
        "000 ch. 3",
        "001 appendix",
        "002's soft penalty",
        "(issues 3 and 4)",
        "issue #12",
        "Pre-integration (002 5.2)",
    ] {
        assert!(forbidden(bad).is_some(), "{bad}");
    }
    for good in [
        "Freude 2014, eq. 5.12",
        "0.002 eq",
        "1e-002",
        "SSSKIT_REFERENCE_FILTER",
        "reference profile",
        "001 0.001",
        "a known issue with",
        "tissue 3",
    ] {
        assert!(forbidden(good).is_none(), "{good}");
    }
}

#[test]

fn no_citation_leaves_the_repository() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut all = Vec::new();
    for r in ROOTS {
        files(&root.join(r), &mut all);
    }
    let mut found = Vec::new();
    for f in all {
        let rel = f
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if EXEMPT.contains(&rel.as_str()) {
            continue;
        }
        let Ok(text) = std::fs::read_to_string(&f) else {
            continue; // binary
        };
        for (n, line) in text.lines().enumerate() {
            if let Some(what) = forbidden(line) {
                found.push(format!("{rel}:{}: {what}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "{} citations leave the repository (scripts/fix-citations rewrites most; \
         docs/references.md lists the sources):\n{}",
        found.len(),
        found.join("\n")
    );
}
