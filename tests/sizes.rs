//! Units a reader can hold in mind (DEVELOPERS.md, "Size"): no source file
//! of the library, the binary or the Python binding (`python/src`) over
//! [`MAX_FILE_LINES`] lines, no function over [`MAX_FN_LINES`] from its
//! `fn` line to its closing brace. The scanner is checked on strings,
//! characters, comments and nested bodies.

mod common;

use std::path::Path;

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const MAX_FILE_LINES: usize = 650;
const MAX_FN_LINES: usize = 120;

/// The braces of `line` outside string and character literals and `//`
/// comments, as +1 / -1, with the string state carried across lines.
fn braces(line: &str, in_string: &mut bool) -> Vec<i32> {
    let c: Vec<char> = line.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        if *in_string {
            match c[i] {
                '\\' => i += 1,
                '"' => *in_string = false,
                _ => {}
            }
        } else {
            match c[i] {
                '"' => *in_string = true,
                '/' if c.get(i + 1) == Some(&'/') => break,
                // '{', '}', '\'' and '\\' as character literals.
                '\'' if c.get(i + 2) == Some(&'\'') => i += 2,
                '\'' if c.get(i + 1) == Some(&'\\') && c.get(i + 3) == Some(&'\'') => i += 3,
                '{' => out.push(1),
                '}' => out.push(-1),
                _ => {}
            }
        }
        i += 1;
    }
    out
}

/// Whether `line` starts a function item (`fn name`, with any qualifiers).
fn starts_fn(line: &str) -> Option<String> {
    let words: Vec<&str> = line.split_whitespace().collect();
    let mut k = 0;
    while k < words.len() {
        let w = words[k];
        let qualifier = w.starts_with("pub")
            || matches!(
                w,
                "const" | "async" | "unsafe" | "extern" | "\"C\"" | "default"
            );
        if w == "fn" {
            return words
                .get(k + 1)
                .map(|n| n.split(['(', '<']).next().unwrap_or("").to_string());
        }
        if !qualifier {
            return None;
        }
        k += 1;
    }
    None
}

/// `(name, first line, length)` of every function in `text` with a body.
fn functions(text: &str) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        if l.trim_start().starts_with("//") {
            continue;
        }
        let Some(name) = starts_fn(l) else { continue };
        let (mut depth, mut opened, mut in_string) = (0, false, false);
        for (j, m) in lines.iter().enumerate().skip(i) {
            for b in braces(m, &mut in_string) {
                depth += b;
                opened |= b > 0;
            }
            if opened && depth == 0 {
                out.push((name.clone(), i + 1, j - i + 1));
                break;
            }
            if !opened && m.trim_end().ends_with(';') {
                break;
            }
        }
    }
    out
}

#[test]
fn the_scanner_counts_bodies_not_braces_in_text() {
    let text = "pub(crate) fn a(x: u8) -> u8 {\n    let s = \"}}{\";\n    let c = '{';\n    \
                // }\n    if x > 0 { 1 } else {\n        2\n    }\n}\nfn decl();\nasync fn b() {}\n\
                const fn c<T>() {\n    let e = '\\'';\n}\n";
    let f = functions(text);
    assert_eq!(
        f,
        [
            ("a".to_string(), 1, 8),
            ("b".to_string(), 10, 1),
            ("c".to_string(), 11, 3)
        ]
    );
    // A string spanning lines hides its braces.
    let text = "fn d() {\n    let s = \"{\n}}\";\n}\n";
    assert_eq!(functions(text), [("d".to_string(), 1, 4)]);
}

#[test]
fn no_source_file_or_function_is_longer_than_the_limits() {
    let binding = common::rust_sources(&Path::new(REPO).join("python/src"));
    // lib.rs, the conversions and every group of functions: a dozen files.
    const BINDING_FILES_AT_LEAST: usize = 10;
    assert!(binding.len() >= BINDING_FILES_AT_LEAST, "{binding:?}");
    let mut files = common::rust_sources(&Path::new(REPO).join("src"));
    files.extend(binding);
    assert!(files.len() > 50, "{} files", files.len());
    let mut over = Vec::new();
    let mut counted = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let rel = f.strip_prefix(REPO).unwrap().display().to_string();
        let n = text.lines().count();
        if n > MAX_FILE_LINES {
            over.push(format!("{rel}: {n} lines (at most {MAX_FILE_LINES})"));
        }
        for (name, line, len) in functions(&text) {
            counted += 1;
            if len > MAX_FN_LINES {
                over.push(format!(
                    "{rel}:{line}: fn {name} is {len} lines (at most {MAX_FN_LINES})"
                ));
            }
        }
    }
    assert!(counted > 1000, "only {counted} functions found");
    assert!(over.is_empty(), "split by job:\n{}", over.join("\n"));
}
