//! The layers DEVELOPERS.md states: every `crate::` path in the library's
//! source (comments aside) names a module of a lower layer, or a neighbour
//! in layer 0. The table is read from DEVELOPERS.md, and every module that
//! `src/lib.rs` declares must be in it.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

const REPO: &str = env!("CARGO_MANIFEST_DIR");

/// Module -> layer, from the `layers` block of DEVELOPERS.md.
fn layers() -> BTreeMap<String, u32> {
    let text = std::fs::read_to_string(Path::new(REPO).join("DEVELOPERS.md")).unwrap();
    let begin = text
        .find("<!-- BEGIN layers -->")
        .expect("DEVELOPERS.md: no layers block");
    let end = text
        .find("<!-- END layers -->")
        .expect("DEVELOPERS.md: layers block unclosed");
    let mut out = BTreeMap::new();
    for line in text[begin..end].lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let Some(layer) = cells.get(1).and_then(|c| c.parse::<u32>().ok()) else {
            continue;
        };
        for m in cells[2].split(',').map(str::trim).filter(|m| !m.is_empty()) {
            assert!(out.insert(m.to_string(), layer).is_none(), "{m} twice");
        }
    }
    out
}

/// The modules each `crate::NAME` of `code` names, with their line numbers;
/// `//` comments (doc comments included) are skipped.
fn crate_paths(code: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in code.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(k) = rest.find("crate::") {
            let before = rest[..k].chars().last();
            rest = &rest[k + "crate::".len()..];
            // `ssskit_crate::` or `$crate::` are other paths.
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
                continue;
            }
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            out.push((i + 1, name));
        }
    }
    out
}

/// The edges of `files` that point up or across (file:line, from, to).
fn violations(files: &[(String, String, String)], layer: &BTreeMap<String, u32>) -> Vec<String> {
    let mut bad = Vec::new();
    for (file, module, code) in files {
        let Some(&from) = layer.get(module) else {
            continue;
        };
        for (line, to) in crate_paths(code) {
            let Some(&target) = layer.get(&to) else {
                continue;
            };
            let across = target == from && to != *module && from != 0;
            if target > from || across {
                bad.push(format!(
                    "{file}:{line}: {module} (layer {from}) uses crate::{to} (layer {target})"
                ));
            }
        }
    }
    bad
}

#[test]
fn no_module_imports_a_higher_layer() {
    let layer = layers();
    let lib = std::fs::read_to_string(Path::new(REPO).join("src/lib.rs")).unwrap();
    let declared: Vec<String> = lib
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';').to_string())
        .collect();
    assert!(declared.len() >= 10, "src/lib.rs declares {declared:?}");
    for m in &declared {
        assert!(
            layer.contains_key(m),
            "module {m} is in no layer of DEVELOPERS.md"
        );
    }
    let paths = common::rust_sources(&Path::new(REPO).join("src"));
    let mut files = Vec::new();
    for p in paths {
        let rel = p.strip_prefix(REPO).unwrap().to_string_lossy().into_owned();
        let module = rel
            .trim_start_matches("src/")
            .split('/')
            .next()
            .unwrap()
            .trim_end_matches(".rs")
            .to_string();
        files.push((rel, module, std::fs::read_to_string(&p).unwrap()));
    }
    let scanned = files.iter().filter(|f| layer.contains_key(&f.1)).count();
    assert!(scanned >= 80, "only {scanned} library files scanned");
    let bad = violations(&files, &layer);
    assert!(
        bad.is_empty(),
        "upward or sideways edges:\n{}",
        bad.join("\n")
    );
}

/// The scanner itself: an upward `use`, a sideways one in layer 3 and a
/// path in an expression are found; comments, layer-0 neighbours and
/// `$crate::` are not.
#[test]
fn the_scanner_finds_upward_and_sideways_paths() {
    let layer: BTreeMap<String, u32> = [
        ("io", 0),
        ("limits", 0),
        ("profile", 2),
        ("kernel", 3),
        ("scene", 3),
        ("report", 6),
    ]
    .into_iter()
    .map(|(m, l)| (m.to_string(), l))
    .collect();
    let file =
        |module: &str, code: &str| ("f.rs".to_string(), module.to_string(), code.to_string());
    let files = vec![
        file(
            "profile",
            "use crate::kernel::Kernel2D;\n// crate::report::x in a comment\n",
        ),
        file(
            "scene",
            "let k = crate::kernel::fit(p);\nuse crate::profile::Profile;\n",
        ),
        file(
            "io",
            "use crate::limits::MAX;\nmacro_rules! m { () => { $crate::report::x } }\n",
        ),
        file(
            "kernel",
            "/// see `crate::report::table`\nuse crate::kernel::taps;\n",
        ),
    ];
    let bad = violations(&files, &layer);
    assert_eq!(bad.len(), 2, "{bad:?}");
    assert!(bad[0].contains("f.rs:1: profile (layer 2) uses crate::kernel (layer 3)"));
    assert!(bad[1].contains("f.rs:1: scene (layer 3) uses crate::kernel (layer 3)"));
}
