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

/// The sibling files each file of a folder names: `super::NAME` (alone or
/// in a `super::{...}` group) where NAME is a sibling file, or an item the
/// folder's module file re-exports from one (`pub use NAME::{...}`). The
/// folder's module file (`mod.rs`, or `D.rs` beside `D/`) only declares
/// and re-exports, so it is no node; code after `#[cfg(test)]` is left
/// out, since a test module's `super::` is the file itself.
fn sibling_edges(
    siblings: &BTreeMap<String, String>,
    module_file: &str,
) -> BTreeMap<String, Vec<String>> {
    sibling_edges_by(siblings, module_file, "super::")
}

/// [`sibling_edges`] with the paths that name a sibling starting with
/// `prefix`: `super::` in a folder of the library, `crate::` in a crate
/// whose files all sit beside its root (the Python binding).
fn sibling_edges_by(
    siblings: &BTreeMap<String, String>,
    module_file: &str,
    prefix: &str,
) -> BTreeMap<String, Vec<String>> {
    let reexports = reexported_items(module_file);
    let resolve = |name: &str| -> Option<String> {
        if siblings.contains_key(name) {
            Some(name.to_string())
        } else {
            reexports.get(name).cloned()
        }
    };
    let mut edges = BTreeMap::new();
    for (file, code) in siblings {
        let code = code.split("#[cfg(test)]").next().unwrap_or("");
        let mut to: Vec<String> = Vec::new();
        for line in code.lines() {
            let line = line.split("//").next().unwrap_or("");
            let mut rest = line;
            while let Some(k) = rest.find(prefix) {
                rest = &rest[k + prefix.len()..];
                for name in first_names(rest) {
                    if let Some(t) = resolve(&name).filter(|t| t != file) {
                        to.push(t);
                    }
                }
            }
        }
        to.sort();
        to.dedup();
        edges.insert(file.clone(), to);
    }
    edges
}

/// The first name of a path, or of each entry of a `{...}` group that
/// opens it (one level; grouped entries are read up to the closing brace
/// on the same line).
fn first_names(rest: &str) -> Vec<String> {
    let ident = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    if let Some(group) = rest.strip_prefix('{') {
        let inner = group.split('}').next().unwrap_or("");
        inner
            .split(',')
            .map(ident)
            .filter(|n| !n.is_empty())
            .collect()
    } else {
        vec![ident(rest)]
            .into_iter()
            .filter(|n| !n.is_empty())
            .collect()
    }
}

/// Item -> sibling file, from the module file's `pub use NAME::...` lines
/// (one line or a `{...}` group over several).
fn reexported_items(module_file: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut rest = module_file;
    while let Some(k) = rest.find("pub use ") {
        rest = &rest[k + "pub use ".len()..];
        let stmt = rest.split(';').next().unwrap_or("");
        let Some((from, items)) = stmt.split_once("::") else {
            continue;
        };
        let items = items.trim().trim_start_matches('{').trim_end_matches('}');
        for item in items.split(',') {
            let item = item.trim();
            let name = item.rsplit(" as ").next().unwrap_or(item);
            let name = name.rsplit("::").next().unwrap_or(name).trim();
            if !name.is_empty() && name != "self" && name != "*" {
                out.insert(name.to_string(), from.trim().to_string());
            }
        }
    }
    out
}

/// The cycles of `edges` (strongly connected sets of two or more files),
/// each sorted, by Tarjan's algorithm (Tarjan 1972).
fn cycles(edges: &BTreeMap<String, Vec<String>>) -> Vec<Vec<String>> {
    struct State<'a> {
        edges: &'a BTreeMap<String, Vec<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        for w in s.edges.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.stack.contains(&w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut set = Vec::new();
            while let Some(w) = s.stack.pop() {
                set.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if set.len() > 1 {
                set.sort();
                s.out.push(set);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// Every folder of `src/` with its module file's text and its sibling
/// files (stem -> text).
fn folders() -> Vec<(String, String, BTreeMap<String, String>)> {
    let src = Path::new(REPO).join("src");
    let mut by_dir: BTreeMap<std::path::PathBuf, BTreeMap<String, String>> = BTreeMap::new();
    for p in common::rust_sources(&src) {
        let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
        let dir = p.parent().unwrap().to_path_buf();
        if stem != "mod" && dir != src {
            let text = std::fs::read_to_string(&p).unwrap();
            by_dir.entry(dir).or_default().insert(stem, text);
        }
    }
    by_dir
        .into_iter()
        .map(|(dir, siblings)| {
            let module_file = [dir.join("mod.rs"), dir.with_extension("rs")]
                .iter()
                .find_map(|p| std::fs::read_to_string(p).ok())
                .unwrap_or_default();
            let rel = dir
                .strip_prefix(REPO)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            (rel, module_file, siblings)
        })
        .collect()
}

#[test]
fn no_files_import_each_other_in_a_circle_inside_a_folder() {
    let folders = folders();
    // src/cli, src/kernel, src/scene, src/report/eval, ... : every folder.
    const FOLDERS_AT_LEAST: usize = 15;
    assert!(
        folders.len() >= FOLDERS_AT_LEAST,
        "only {} folders",
        folders.len()
    );
    let mut bad = Vec::new();
    let mut edge_count = 0;
    for (dir, module_file, siblings) in &folders {
        let edges = sibling_edges(siblings, module_file);
        edge_count += edges.values().map(Vec::len).sum::<usize>();
        for c in cycles(&edges) {
            bad.push(format!("{dir}: {}", c.join(" <-> ")));
        }
    }
    // The scanner sees the folders' imports at all: today about 150 edges.
    const EDGES_AT_LEAST: usize = 100;
    assert!(
        edge_count >= EDGES_AT_LEAST,
        "only {edge_count} edges between sibling files"
    );
    assert!(
        bad.is_empty(),
        "files of one folder that import each other in a circle (move what both \
         need into a leaf file):\n{}",
        bad.join("\n")
    );
}

/// The Python binding (`python/src`) under the same rule as a folder of the
/// library: its files import each other (`crate::FILE`) in one direction
/// only, with `lib.rs` as the module file that only declares them.
#[test]
fn the_binding_files_import_each_other_one_way() {
    let dir = Path::new(REPO).join("python/src");
    let mut siblings = BTreeMap::new();
    let mut module_file = String::new();
    for p in common::rust_sources(&dir) {
        let text = std::fs::read_to_string(&p).unwrap();
        let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
        if stem == "lib" {
            module_file = text;
        } else {
            siblings.insert(stem, text);
        }
    }
    // lib.rs declares the modules and builds the Python module: it holds
    // the one `#[pymodule]` function and no other.
    let fns = module_file
        .lines()
        .filter(|l| l.trim_start().starts_with("fn ") || l.contains(" fn "))
        .count();
    assert_eq!(fns, 1, "python/src/lib.rs only declares and registers");
    let edges = sibling_edges_by(&siblings, &module_file, "crate::");
    let edge_count: usize = edges.values().map(Vec::len).sum();
    // The binding's files lean on the argument and call helpers: today
    // about 35 edges.
    const BINDING_EDGES_AT_LEAST: usize = 20;
    assert!(
        edge_count >= BINDING_EDGES_AT_LEAST,
        "only {edge_count} edges between the binding's files"
    );
    let bad = cycles(&edges);
    assert!(
        bad.is_empty(),
        "python/src: files that import each other in a circle (move what both need into \
         call.rs or args.rs):\n{bad:?}"
    );
}

/// The cycle scanner: a direct pair, a pair through the module file's
/// re-export and a three-file ring are found; a test module's `super::`,
/// a comment and a one-way edge are not.
#[test]
fn the_cycle_scanner_finds_circles_between_siblings() {
    let files = |pairs: &[(&str, &str)]| -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(n, c)| (n.to_string(), c.to_string()))
            .collect()
    };
    let module_file = "mod a;\nmod b;\npub use b::{Budget, other as Other};\n";
    let siblings = files(&[
        ("a", "use super::b::thing;\n"),
        ("b", "use super::{a, Budget};\n"),
        (
            "c",
            "use super::a;\n// super::d\n#[cfg(test)]\nmod tests { use super::d; }\n",
        ),
        ("d", "use super::c::x;\n"),
        ("e", "use super::Budget;\n"),
    ]);
    let edges = sibling_edges(&siblings, module_file);
    assert_eq!(edges["e"], ["b"], "a re-exported item resolves to its file");
    assert_eq!(cycles(&edges), [vec!["a".to_string(), "b".to_string()]]);
    let ring = files(&[
        ("x", "use super::y::f;\n"),
        ("y", "use super::{z::g, Budget};\n"),
        ("z", "let v = super::x::h();\n"),
    ]);
    let found = cycles(&sibling_edges(&ring, module_file));
    assert_eq!(found, [vec!["x", "y", "z"]]);
}

/// Every full path that `code` names from `crate::` (comments stripped
/// by the caller): `use crate::a::{b, c::{d, e}}` is `crate::a::b`,
/// `crate::a::c::d` and `crate::a::c::e`; `crate::x::f(..)` is
/// `crate::x::f`; `self` stays the last segment (a module named whole).
fn full_paths(code: &str) -> Vec<String> {
    fn ident(s: &[u8], i: &mut usize) -> String {
        let start = *i;
        while *i < s.len() && (s[*i].is_ascii_alphanumeric() || s[*i] == b'_') {
            *i += 1;
        }
        String::from_utf8_lossy(&s[start..*i]).into_owned()
    }
    fn skip_ws(s: &[u8], i: &mut usize) {
        while *i < s.len() && s[*i].is_ascii_whitespace() {
            *i += 1;
        }
    }
    /// The paths of one entry starting at `i` under `prefix`.
    fn entry(s: &[u8], i: &mut usize, prefix: &str, out: &mut Vec<String>) {
        let mut path = prefix.to_string();
        loop {
            skip_ws(s, i);
            if s.get(*i) == Some(&b'{') {
                *i += 1;
                loop {
                    skip_ws(s, i);
                    match s.get(*i) {
                        Some(b'}') => {
                            *i += 1;
                            return;
                        }
                        Some(b',') => *i += 1,
                        None => return,
                        _ => entry(s, i, &path, out),
                    }
                }
            }
            let name = ident(s, i);
            if name.is_empty() {
                out.push(path);
                return;
            }
            path = format!("{path}::{name}");
            if s[*i..].starts_with(b"::") {
                *i += 2;
                continue;
            }
            skip_ws(s, i);
            if s[*i..].starts_with(b"as ") {
                *i += 3;
                skip_ws(s, i);
                ident(s, i);
            }
            out.push(path);
            return;
        }
    }
    let s = code.as_bytes();
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find("crate::") {
        let at = from + k;
        from = at + "crate::".len();
        let before = code[..at].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        let mut i = from;
        entry(s, &mut i, "crate", &mut out);
    }
    out
}

/// Modules src/report/present may use whole: itself, and the output side
/// (errors, atomic writes, size caps before an image is allocated).
const PRESENT_MAY_USE: [&str; 4] = [
    "crate::report::present",
    "crate::error",
    "crate::io",
    "crate::limits",
];

/// What src/report/present may name from the layers below (never from
/// `crate::engine`: engine results reach it as eval's plain data): plain
/// data, and the colour maps that turn a number into a pixel (showing,
/// not measuring).
const PRESENT_PLAIN_DATA: [&str; 18] = [
    "crate::filter::Image",
    "crate::filter::Which",
    "crate::kernel::Factors",
    "crate::kernel::Kernel2D",
    "crate::kernel::KernelFile",
    "crate::kernel::disk::DiskKernelFile",
    "crate::kernel::angular::AngularFactors",
    "crate::material::Channel",
    "crate::numerics::Bounded",
    "crate::profile::Profile",
    "crate::profile::fresnel::FresnelMode",
    "crate::profile::transmission::ThicknessTable",
    "crate::profile::transmission::ThicknessRow",
    // Colour maps.
    "crate::filter::diff::false_colour",
    "crate::filter::diff::heat",
    "crate::filter::diff::ramp_top",
    "crate::filter::image::linear_to_srgb",
    // Its error type, as the caller sees it.
    "crate::filter::diff::DiffError",
];

/// Where a path named in src/report/present breaks the rule: from
/// `report::eval` a type or a constant only (a name that starts upper
/// case: a results type, a table's constant), never a function or a
/// module named whole; from the layers below only [`PRESENT_PLAIN_DATA`].
fn present_breaks(path: &str) -> bool {
    let inside = |m: &str| path == m || path.starts_with(&format!("{m}::"));
    if PRESENT_MAY_USE.iter().any(|m| inside(m)) || PRESENT_PLAIN_DATA.iter().any(|m| inside(m)) {
        return false;
    }
    if path.starts_with("crate::report::eval::") {
        let last = path.rsplit("::").next().unwrap_or("");
        return !last.starts_with(|c: char| c.is_ascii_uppercase());
    }
    true
}

/// Presentation computes nothing (DEVELOPERS.md, "Inside report"): the
/// files of src/report/present name, outside themselves, only eval's
/// results types and constants and the plain data and colour maps of
/// [`PRESENT_PLAIN_DATA`].
#[test]
fn presentation_computes_nothing() {
    let dir = Path::new(REPO).join("src/report/present");
    let mut found = Vec::new();
    let mut seen = 0;
    for p in common::rust_sources(&dir) {
        let text = std::fs::read_to_string(&p).unwrap();
        let code: String = text
            .split("#[cfg(test)]")
            .next()
            .unwrap_or("")
            .lines()
            .map(|l| l.split("//").next().unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\n");
        let file = p.file_name().unwrap().to_string_lossy().into_owned();
        for path in full_paths(&code) {
            seen += 1;
            if present_breaks(&path) {
                found.push(format!("{file}: {path}"));
            }
        }
    }
    // The scanner reads the folder's paths at all: today about 150.
    const PATHS_AT_LEAST: usize = 100;
    assert!(seen >= PATHS_AT_LEAST, "only {seen} crate:: paths read");
    found.sort();
    found.dedup();
    assert!(
        found.is_empty(),
        "src/report/present names something that computes: compute it in report::eval \
         and hand present the result as plain data:\n  {}",
        found.join("\n  ")
    );
}

#[test]
fn the_path_scanner_expands_groups_and_reads_the_rule() {
    let code = "use crate::report::eval::advise::{self, decide::{tie, Cost}, Advice};\n\
                let x = crate::filter::diff::false_colour(a, b);\n\
                use crate::engine::method::SubsurfaceMethod as M;\n";
    let paths = full_paths(code);
    assert_eq!(
        paths,
        [
            "crate::report::eval::advise::self",
            "crate::report::eval::advise::decide::tie",
            "crate::report::eval::advise::decide::Cost",
            "crate::report::eval::advise::Advice",
            "crate::filter::diff::false_colour",
            "crate::engine::method::SubsurfaceMethod",
        ]
    );
    let breaks: Vec<bool> = paths.iter().map(|p| present_breaks(p)).collect();
    assert_eq!(breaks, [true, true, false, false, false, true]);
}
