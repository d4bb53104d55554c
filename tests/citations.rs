//! Comments and documents cite sources by author, year and equation
//! ("Freude 2014, eq. 5.12"; docs/references.md lists them in full), never
//! by something a clone of the repository does not contain: a path outside
//! it (`../shared/...`, `seeds/...`), a section of an outside specification
//! ("REFERENCE 4"), a seed file number in any wording ("002 eq. 5.12",
//! "the renderer of 002") or an issue number ("issue 13", "#13", "(#9)").
//!
//! And the other way round: every source cited by author and year ("Jensen
//! et al. 2001", "Christensen and Burley 2015", "Wang, Jacques & Zheng
//! 1995") has a full entry in docs/references.md (authors, italic title,
//! venue and year), and every entry there is cited somewhere.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Everything in the repository that is text a reader may meet (the
/// presets' comments and the committed profiles' and kernels' recorded
/// rules included).
const ROOTS: [&str; 13] = [
    "src",
    "python",
    "tests",
    "docs",
    "scripts",
    "benches",
    "shaders",
    ".ci",
    "profiles",
    "kernels",
    "README.md",
    "DEVELOPERS.md",
    "Cargo.toml",
];

/// This test names the forbidden forms to recognise them.
const CHECKER: &str = "tests/citations.rs";

/// The list of sources.
const REFERENCES: &str = "docs/references.md";

fn files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_dir() {
        for e in std::fs::read_dir(path).unwrap() {
            files(&e.unwrap().path(), out);
        }
    } else if path.exists() {
        out.push(path.to_path_buf());
    }
}

/// (path relative to the repository, text) of every text file in `ROOTS`.
fn tree() -> Vec<(String, String)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut all = Vec::new();
    for r in ROOTS {
        files(&root.join(r), &mut all);
    }
    let mut out: Vec<(String, String)> = all
        .into_iter()
        .filter_map(|f| {
            let rel = f
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            // Binary files (fonts, images) are not text.
            std::fs::read_to_string(&f).ok().map(|t| (rel, t))
        })
        .collect();
    out.sort();
    assert!(
        out.iter().any(|(f, _)| f == "src/lib.rs") && out.len() > 100,
        "the walk found {} files",
        out.len()
    );
    out
}

fn is_word(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// What a line cites that leaves the repository, if anything.
fn forbidden(line: &str) -> Option<&'static str> {
    if line.contains("../shared") || line.contains("shared/seeds") {
        return Some("a path outside the repository");
    }
    let lower = line.to_lowercase();
    let mut prev: Option<char> = None;
    for (i, c) in line.char_indices() {
        let rest = &line[i..];
        let next = |n: usize| rest.chars().nth(n);
        let before_ok = !prev.is_some_and(|p| is_word(p) || ".,+-".contains(p));
        prev = Some(c);
        // "REFERENCE" as a word, in capitals.
        if rest.starts_with("REFERENCE") && before_ok && !next(9).is_some_and(is_word) {
            return Some("the outside specification REFERENCE");
        }
        // The seed folder: "seeds/002_freude.txt".
        if rest.starts_with("seeds/") && next(6).is_some_and(|c| c.is_ascii_digit()) {
            return Some("a path outside the repository");
        }
        // A seed number used as a source, in any wording: "002 eq.", "000
        // ch.", "001's", "000 §3", "the renderer of 002", "(002)": a
        // standalone 000..004 that is not a digit group of a number
        // ("52 000", "0.002", "1e-002").
        if before_ok
            && rest.starts_with("00")
            && next(2).is_some_and(|c| ('0'..='4').contains(&c))
            && !next(3).is_some_and(|c| {
                is_word(c) || c == '.' && next(4).is_some_and(|d| d.is_ascii_digit())
            })
            && !line[..i]
                .strip_suffix(' ')
                .is_some_and(|b| b.ends_with(|d: char| d.is_ascii_digit()))
        {
            return Some("a seed file number");
        }
        // "#13", "(#9)": an issue or pull request number. Not "#[test]",
        // not a colour ("#1f77b4"), not a shell comment ("# 1").
        if c == '#'
            && (i == 0 || line[..i].ends_with(|p: char| p.is_whitespace() || "([".contains(p)))
        {
            let digits = rest[1..].chars().take_while(|c| c.is_ascii_digit()).count();
            if (1..=4).contains(&digits) && !next(1 + digits).is_some_and(is_word) {
                return Some("an issue number");
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
        "/work/shared/seeds/002_freude.txt",
        "as seeds/002_freude.txt derives",
        "(REFERENCE 4)",
        "REFERENCE.md section 3",
        "(002 eq. 5.12)",
        "000 ch. 3",
        "001 appendix",
        "002's soft penalty",
        "000 \u{a7}3.2",
        "(issues 3 and 4)",
        "issue #12",
        "issue 13",
        "fixed in #13",
        "the grid rule (#9)",
        "#42: the flag names",
        "Pre-integration (002 5.2)",
        "since the SSSS renderer of 002 normalises",
        "see 001",
        "(000)",
        "[004]",
        "002: the thesis",
        "as 003 says.",
    ] {
        assert!(forbidden(bad).is_some(), "{bad}");
    }
    for good in [
        "Freude 2014, eq. 5.12",
        "0.002 eq",
        "1e-002",
        "SSSKIT_REFERENCE_FILTER",
        "reference profile",
        "0.001 0.002",
        "a known issue with",
        "tissue 3",
        "#[test]",
        "colour #1f77b4",
        "1.0 # version",
        "different seeds give",
        "the seeds/shards of a run",
        "52 000×",
        "200 000 uniform bins",
        "1 000 000",
        "x002",
        "ab_002",
        "v1.002",
    ] {
        assert!(forbidden(good).is_none(), "{good}");
    }
}

#[test]
fn no_citation_leaves_the_repository() {
    let mut found = Vec::new();
    for (rel, text) in tree() {
        if rel == CHECKER {
            continue;
        }
        for (n, line) in text.lines().enumerate() {
            if let Some(what) = forbidden(line) {
                found.push(format!("{rel}:{}: {what}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "{} citations leave the repository (cite by author, year and equation; \
         docs/references.md lists the sources):\n{}",
        found.len(),
        found.join("\n")
    );
}

/// Capitalised words before a year that are not authors.
const NOT_AUTHORS: [&str; 14] = [
    "January",
    "February",
    "March",
    "April",
    "May",
    "June",
    "July",
    "August",
    "September",
    "October",
    "November",
    "December",
    "Recorded",
    "Rust",
];

/// A surname as cited: "Freude", "d'Eon", "Akenine-Möller", "Moré"; not an
/// acronym ("SIGGRAPH", "EGSR") or a word in `NOT_AUTHORS`.
fn surname(w: &str) -> Option<&str> {
    let w = w.trim_start_matches(['(', '[', '"', '`', '*']);
    let w = w.trim_end_matches(',');
    let body = w.strip_prefix("d'").unwrap_or(w);
    let mut chars = body.chars();
    let first = chars.next()?;
    let ok = first.is_uppercase()
        && body
            .chars()
            .all(|c| c.is_alphabetic() || c == '-' || c == '\'')
        && body.chars().skip(1).any(|c| c.is_lowercase())
        && !NOT_AUTHORS.contains(&w);
    ok.then_some(w)
}

/// The author-year citations in `text`, in the short form of
/// docs/references.md (one author "Freude", two "Christensen and Burley",
/// three or more "Jensen et al.", surnames only) with their year:
/// "Wang, Jacques & Zheng 1995" -> ("Wang et al.", "1995"), "van de Hulst
/// 1980" -> ("Hulst", "1980").
fn citations(text: &str) -> Vec<(String, String)> {
    citations_at(text)
        .into_iter()
        .map(|(a, y, _)| (a, y))
        .collect()
}

/// `citations` with the byte offset of each year.
fn citations_at(text: &str) -> Vec<(String, String, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    for i in 1..b.len().saturating_sub(3) {
        let year = &b[i..i + 4];
        let is_year = (year.starts_with(b"19") || year.starts_with(b"20"))
            && year.iter().all(u8::is_ascii_digit);
        // A year stands alone: no digit, letter or '-' after it (a date
        // "2026-11-30", "20260101"), a space before it.
        let after = b.get(i + 4).copied();
        if !is_year
            || b[i - 1] != b' '
            || after.is_some_and(|c| c.is_ascii_alphanumeric() || c == b'-')
        {
            continue;
        }
        let prefix = &text[..i - 1];
        let words: Vec<&str> = prefix.split_whitespace().rev().take(12).collect();
        if prefix.ends_with(char::is_whitespace) || words.is_empty() {
            continue;
        }
        let authors = if words[0] == "al." && words.get(1) == Some(&"et") {
            words
                .get(2)
                .and_then(|w| surname(w))
                .map(|a| format!("{a} et al."))
        } else if let Some(last) = surname(words[0]) {
            // Walk back over "A and B", "A & B", "A, B & C": the names
            // from the last to the first.
            let mut names = vec![last];
            let mut k = 1;
            loop {
                match words.get(k) {
                    Some(&"and") | Some(&"&") => match words.get(k + 1).and_then(|w| surname(w)) {
                        Some(s) => {
                            names.push(s);
                            k += 2;
                        }
                        None => break,
                    },
                    Some(w) if w.ends_with(',') && names.len() > 1 && surname(w).is_some() => {
                        names.push(surname(w).unwrap());
                        k += 1;
                    }
                    _ => break,
                }
            }
            Some(match names.len() {
                1 => last.to_string(),
                2 => format!("{} and {last}", names[1]),
                _ => format!("{} et al.", names[names.len() - 1]),
            })
        } else {
            None
        };
        if let Some(a) = authors {
            out.push((a, String::from_utf8_lossy(year).into_owned(), i));
        }
    }
    out
}

#[test]
fn author_year_citations_are_recognised() {
    let cite = |s: &str| {
        citations(s)
            .into_iter()
            .map(|(a, y)| format!("{a} {y}"))
            .collect::<Vec<_>>()
    };
    assert_eq!(cite("(Jensen et al. 2001, eq. 5)"), ["Jensen et al. 2001"]);
    assert_eq!(cite("Dal Corso 2014, eq. 3.8"), ["Corso 2014"]);
    assert_eq!(
        cite("fit (Christensen and Burley 2015) and d'Eon and Irving 2011"),
        ["Christensen and Burley 2015", "d'Eon and Irving 2011"]
    );
    assert_eq!(
        cite("MCML (Wang, Jacques & Zheng 1995),"),
        ["Wang et al. 1995"]
    );
    assert_eq!(
        cite("Philox (Salmon, Moraes, Dror & Shaw 2011)"),
        ["Salmon et al. 2011"]
    );
    assert_eq!(cite("tables of van de Hulst 1980."), ["Hulst 1980"]);
    assert_eq!(cite("Moré and Thuente 1994"), ["Moré and Thuente 1994"]);
    assert_eq!(cite("Freude 2014's table"), ["Freude 2014"]);
    for none in [
        "Recorded 2026-11-30 on",
        "SIGGRAPH 2011",
        "seed 20260101",
        "in 2014, the",
        "shaders, 2014",
        "x1 2014",
    ] {
        assert!(cite(none).is_empty(), "{none}: {:?}", cite(none));
    }
}

/// The file's text as one line, comment markers and line breaks folded to
/// spaces, so that a citation wrapped over two lines reads as one; with the
/// offset at which each line starts.
fn unwrapped(text: &str) -> (String, Vec<usize>) {
    let (mut out, mut starts) = (String::new(), Vec::new());
    for line in text.lines() {
        starts.push(out.len());
        let t = line.trim_start();
        let t = ["//!", "///", "//", "#", "*"]
            .iter()
            .find_map(|m| t.strip_prefix(m))
            .unwrap_or(t);
        out.push_str(t.trim());
        out.push(' ');
    }
    (out, starts)
}

/// One entry of docs/references.md: its bold key ("Jensen et al. 2001.")
/// and the text that follows on its list item.
struct Entry {
    line: usize,
    key: String,
    body: String,
}

fn entries(md: &str) -> Vec<Entry> {
    let mut out: Vec<Entry> = Vec::new();
    let mut open = false;
    for (n, line) in md.lines().enumerate() {
        if let Some(rest) = line.strip_prefix("- **") {
            let (key, body) = rest.split_once("**").expect("a closed bold key");
            out.push(Entry {
                line: n + 1,
                key: key.to_string(),
                body: body.to_string(),
            });
            open = true;
        } else if open && line.starts_with("  ") {
            let e = out.last_mut().unwrap();
            e.body.push(' ');
            e.body.push_str(line.trim());
        } else {
            open = false;
        }
    }
    out
}

/// (first author, year) of each source docs/references.md lists, with the
/// line of its entry; checks each entry is a full citation.
fn listed_sources() -> BTreeMap<(String, String), usize> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(REFERENCES);
    let md = std::fs::read_to_string(path).unwrap();
    let mut listed = BTreeMap::new();
    let mut incomplete = Vec::new();
    let list = entries(&md);
    assert!(list.len() > 20, "{} entries in {REFERENCES}", list.len());
    for e in &list {
        let keys: Vec<(String, String)> = e
            .key
            .trim_end_matches('.')
            .split(';')
            .flat_map(|k| citations(&format!(" {}", k.trim())))
            .collect();
        if keys.is_empty() && !e.key.starts_with("pbrt") {
            incomplete.push(format!(
                "line {}: key '{}' has no author and year",
                e.line, e.key
            ));
        }
        // Authors, then the title in italics, then venue and year.
        let title = e.body.split('*').nth(1).unwrap_or("");
        let after_title = e.body.splitn(3, '*').nth(2).unwrap_or("");
        let authors = e.body.split('*').next().unwrap_or("");
        if authors.trim().len() < 3 || title.trim().len() < 5 {
            incomplete.push(format!(
                "line {}: '{}' lacks its authors or its *title*",
                e.line, e.key
            ));
        }
        for (a, y) in keys {
            if !after_title.contains(&y) {
                incomplete.push(format!(
                    "line {}: '{}' names no venue with the year {y} after its title",
                    e.line, e.key
                ));
            }
            listed.insert((a, y), e.line);
        }
    }
    assert!(
        incomplete.is_empty(),
        "{REFERENCES}: entries that are not full citations:\n{}",
        incomplete.join("\n")
    );
    listed
}

#[test]
fn every_cited_source_is_listed_in_full_and_every_listed_one_is_cited() {
    let listed = listed_sources();
    let mut missing: BTreeMap<(String, String), Vec<String>> = BTreeMap::new();
    let mut cited = BTreeSet::new();
    for (rel, text) in tree() {
        if rel == REFERENCES || rel == CHECKER {
            continue;
        }
        let (one_line, starts) = unwrapped(&text);
        for (a, y, at) in citations_at(&one_line) {
            let key = (a, y);
            if !listed.contains_key(&key) {
                let line = starts.partition_point(|&s| s <= at);
                missing
                    .entry(key.clone())
                    .or_default()
                    .push(format!("{rel}:{line}"));
            }
            cited.insert(key);
        }
    }
    let missing: Vec<String> = missing
        .into_iter()
        .map(|((a, y), at)| format!("{a} {y} (cited at {})", at.join(", ")))
        .collect();
    assert!(
        missing.is_empty(),
        "sources cited by author and year but not listed in {REFERENCES}:\n{}",
        missing.join("\n")
    );
    let uncited: Vec<String> = listed
        .iter()
        .filter(|(k, _)| !cited.contains(*k))
        .map(|((a, y), line)| format!("{a} {y} ({REFERENCES}:{line})"))
        .collect();
    assert!(
        uncited.is_empty(),
        "sources listed in {REFERENCES} that nothing cites by author and year:\n{}",
        uncited.join("\n")
    );
}
