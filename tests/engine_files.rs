//! `ssskit engine --out-dir`: the files an engine imports, read the way
//! each engine reads them, with the names and types its own source gives,
//! holding the values the CLI printed; and the folder written by the safe
//! output writer (never over a device, a pipe, an input or someone else's
//! files; replaced as a whole).
//!
//! Oracles:
//! - Blender: blender/blender source/blender/nodes/shader/nodes/
//!   node_shader_bsdf_principled.cc, `node_declare` (v5.0.x): the
//!   Principled BSDF's input sockets and their kinds; the
//!   `subsurface_method` enum items as Blender 5.0.1 (PyPI bpy) lists them
//!   (`ShaderNodeBsdfPrincipled.bl_rna.properties["subsurface_method"]`).
//!   The script itself runs in bpy 5.0.1 in scripts/engine-cycles, which
//!   builds its material with it and reads every socket back.
//! - Unity HDRP: Unity-Technologies/Graphics, com.unity.render-pipelines.
//!   high-definition, Samples~/MaterialSamples/Settings/Diffusion
//!   Profiles/Wool Thick.asset (saved by the editor; commit 7ec51fcf) for
//!   the document, Runtime/Material/DiffusionProfile/
//!   DiffusionProfileSettings.cs (`DiffusionProfile`, `UpdateKernel`) for
//!   the fields and what they mean. python/tests/test_engine_files.py reads
//!   the same file with a Unity YAML reader from PyPI (unityparser).
//! - Godot 4: godotengine/godot core/variant/variant_parser.cpp
//!   (`VariantParser::get_token`, `parse_value`, `parse_tag`,
//!   `parse_tag_assign_eof`: the grammar re-implemented below),
//!   scene/resources/resource_format_text.cpp (`ResourceLoaderText`: the
//!   `gd_resource` header tag with `type` and `format`, then `[resource]`
//!   and its properties), scene/resources/material.cpp
//!   (`BaseMaterial3D::_bind_methods`: property names and types;
//!   `_update_shader`: `uniform vec4 albedo : source_color`, an sRGB
//!   colour), servers/rendering/rendering_server.cpp (the GLOBAL_DEF lines
//!   of the subsurface scattering project settings).

mod common;
use common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};

const SKIN: &str = "profiles/reference/skin1.json";

/// The engine's files for `engine` written into a new folder; the folder.
fn write(engine: &str, extra: &[&str]) -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("files");
    let mut args = vec!["engine", "--profile", SKIN, "--engine", engine];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out-dir", p(&out)]);
    ok(&args);
    (tmp, out)
}

fn fit(dir: &Path, engine: &str) -> Value {
    read_json(&dir.join(format!("skin1-{engine}.json")))
}

fn numbers(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().map(|x| x.as_f64().unwrap()).collect(),
        x => vec![x.as_f64().unwrap()],
    }
}

/// IEC 61966-2-1's sRGB encoding of a linear value (the curve Unity's
/// Color.gamma / Color.linear and Godot's source_color undo).
fn srgb(l: f64) -> f64 {
    if l <= 0.0031308 {
        12.92 * l
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

fn linear(s: f64) -> f64 {
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// A value written as a 32-bit float (the shortest text that reads back):
/// equal to float32's resolution, 2^-24 relative, with margin.
const FLOAT32_REL: f64 = 2e-7;

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

// ---- Blender ------------------------------------------------------------

/// Socket kinds of `node_declare` (node_shader_bsdf_principled.cc).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Color,
    Vector,
    Float,
}

/// The Principled BSDF's inputs, in `node_declare`'s order (v5.0.x), with
/// the kind each is declared with (`decl::Color`, `decl::Vector`,
/// `decl::Float`); Normal, Tangent and Coat Normal hide their value.
const PRINCIPLED_INPUTS: [(&str, Kind); 28] = [
    ("Base Color", Kind::Color),
    ("Metallic", Kind::Float),
    ("Roughness", Kind::Float),
    ("IOR", Kind::Float),
    ("Alpha", Kind::Float),
    ("Weight", Kind::Float),
    ("Diffuse Roughness", Kind::Float),
    ("Subsurface Weight", Kind::Float),
    ("Subsurface Radius", Kind::Vector),
    ("Subsurface Scale", Kind::Float),
    ("Subsurface IOR", Kind::Float),
    ("Subsurface Anisotropy", Kind::Float),
    ("Specular IOR Level", Kind::Float),
    ("Specular Tint", Kind::Color),
    ("Anisotropic", Kind::Float),
    ("Anisotropic Rotation", Kind::Float),
    ("Transmission Weight", Kind::Float),
    ("Coat Weight", Kind::Float),
    ("Coat Roughness", Kind::Float),
    ("Coat IOR", Kind::Float),
    ("Coat Tint", Kind::Color),
    ("Sheen Weight", Kind::Float),
    ("Sheen Roughness", Kind::Float),
    ("Sheen Tint", Kind::Color),
    ("Emission Color", Kind::Color),
    ("Emission Strength", Kind::Float),
    ("Thin Film Thickness", Kind::Float),
    ("Thin Film IOR", Kind::Float),
];

/// `subsurface_method`'s enum items in Blender 5.0.1: (identifier, UI name).
const METHOD_ITEMS: [(&str, &str); 3] = [
    ("BURLEY", "Christensen-Burley"),
    ("RANDOM_WALK", "Random Walk"),
    ("RANDOM_WALK_SKIN", "Random Walk (Skin)"),
];

/// Python (no bpy) parses the script and prints its NAME, METHOD and
/// VALUES, and whether make_material sets `bsdf.inputs[...].default_value`
/// and `bsdf.subsurface_method`.
const READ_SCRIPT: &str = r#"
import ast, json, sys
tree = ast.parse(open(sys.argv[1]).read())
out = {}
for node in tree.body:
    if isinstance(node, ast.Assign) and len(node.targets) == 1:
        name = getattr(node.targets[0], "id", None)
        if name in ("NAME", "METHOD", "VALUES"):
            out[name] = ast.literal_eval(node.value)
sets_inputs = sets_method = False
for node in ast.walk(tree):
    if isinstance(node, ast.Assign):
        for t in node.targets:
            if isinstance(t, ast.Attribute) and t.attr == "subsurface_method":
                sets_method = True
            if isinstance(t, ast.Attribute) and t.attr == "default_value":
                sets_inputs = True
out["sets_inputs"] = sets_inputs
out["sets_method"] = sets_method
out["reads_inputs"] = "bsdf.inputs[key]" in open(sys.argv[1]).read()
print(json.dumps(out))
"#;

fn read_script(path: &Path) -> Value {
    let o = std::process::Command::new("python3")
        .args(["-c", READ_SCRIPT, p(path)])
        .output()
        .expect("python3 runs");
    assert!(
        o.status.success(),
        "the script does not parse: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

fn check_blender(extra: &[&str]) {
    let (_tmp, dir) = write("blender", extra);
    let fit = fit(&dir, "blender");
    let params = fit["params"].as_object().unwrap();
    let s = read_script(&dir.join("skin1-blender.py"));
    assert_eq!(s["NAME"], "skin1");
    assert!(s["sets_inputs"].as_bool().unwrap() && s["reads_inputs"].as_bool().unwrap());
    assert!(s["sets_method"].as_bool().unwrap());
    // The method is the fit's, under the enum identifier of its UI name.
    let ui = params["Subsurface Method"].as_str().unwrap();
    let item = METHOD_ITEMS
        .iter()
        .find(|m| m.1 == ui)
        .expect("a Blender method");
    assert_eq!(s["METHOD"], item.0);
    let values = s["VALUES"].as_object().unwrap();
    // Every printed socket value is in the script, under its socket name,
    // with its kind; nothing else is.
    let printed: Vec<&String> = params
        .keys()
        .filter(|k| !k.ends_with(" hex") && *k != "Subsurface Method")
        .collect();
    assert_eq!(values.len(), printed.len(), "{values:?}");
    for key in printed {
        let (_, kind) = PRINCIPLED_INPUTS
            .iter()
            .find(|s| s.0 == key)
            .unwrap_or_else(|| panic!("{key} is not a Principled BSDF input"));
        let got = numbers(&values[key]);
        let mut want = numbers(&params[key]);
        match kind {
            Kind::Color => want.push(1.0),
            Kind::Vector => assert_eq!(want.len(), 3),
            Kind::Float => assert_eq!(want.len(), 1),
        }
        assert_eq!(got, want, "{key}");
    }
}

#[test]
fn blender_script_sets_the_printed_sockets_and_method() {
    check_blender(&[]);
    check_blender(&["--engine-version", "eevee"]);
}

// ---- Unity HDRP ---------------------------------------------------------

/// Wool Thick.asset's document, line by line: the exact text where it is
/// the same for every profile, else the key and the form of its value
/// (`{}`: a flow mapping with these keys; `#`: a number; `$`: text).
const UNITY_DOCUMENT: [&str; 28] = [
    "%YAML 1.1",
    "%TAG !u! tag:unity3d.com,2011:",
    "--- !u!114 &11400000",
    "MonoBehaviour:",
    "  m_ObjectHideFlags: 0",
    "  m_CorrespondingSourceObject: {fileID: 0}",
    "  m_PrefabInstance: {fileID: 0}",
    "  m_PrefabAsset: {fileID: 0}",
    "  m_GameObject: {fileID: 0}",
    "  m_Enabled: 1",
    "  m_EditorHideFlags: 0",
    "  m_Script: {fileID: 11500000, guid: b2686e09ec7aef44bad2843e4416f057, type: 3}",
    "  m_Name: $",
    "  m_EditorClassIdentifier: ",
    "  profile:",
    "    scatteringDistance: {r g b a}",
    "    scatteringDistanceMultiplier: #",
    "    transmissionTint: {r g b a}",
    "    texturingMode: #",
    "    smoothnessMultipliers: {x y}",
    "    lobeMix: #",
    "    diffuseShadingPower: #",
    "    transmissionMode: #",
    "    thicknessRemap: {x y}",
    "    worldScale: #",
    "    ior: #",
    "    hash: #",
    "  m_Version: 2",
];

/// A flow mapping `{k: v, ...}` as (key, number) pairs.
fn flow(v: &str) -> Vec<(String, f64)> {
    let inner = v.strip_prefix('{').and_then(|v| v.strip_suffix('}'));
    inner
        .unwrap_or_else(|| panic!("{v} is not a flow mapping"))
        .split(", ")
        .map(|kv| {
            let (k, v) = kv.split_once(": ").unwrap();
            (k.to_string(), v.parse().unwrap())
        })
        .collect()
}

/// The asset's profile fields, checked line by line against the oracle.
fn read_asset(text: &str) -> std::collections::BTreeMap<String, Vec<(String, f64)>> {
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), UNITY_DOCUMENT.len(), "{text}");
    let mut fields = std::collections::BTreeMap::new();
    for (got, want) in lines.iter().zip(UNITY_DOCUMENT) {
        let Some((key, form)) = want.rsplit_once(": ") else {
            assert_eq!(*got, want);
            continue;
        };
        if !matches!(form, "#" | "$") && !form.starts_with("{r") && !form.starts_with("{x") {
            assert_eq!(*got, want);
            continue;
        }
        let value = got
            .strip_prefix(&format!("{key}: "))
            .unwrap_or_else(|| panic!("'{got}' is not '{key}: ...'"));
        let name = key.trim().to_string();
        match form {
            "$" => assert!(!value.is_empty() && !value.contains(['\'', '"', ':'])),
            "#" => {
                fields.insert(name, vec![(String::new(), value.parse::<f64>().unwrap())]);
            }
            _ => {
                let pairs = flow(value);
                let keys: Vec<&str> = pairs.iter().map(|p| p.0.as_str()).collect();
                let want_keys: Vec<&str> = form[1..form.len() - 1].split(' ').collect();
                assert_eq!(keys, want_keys, "{name}");
                fields.insert(name, pairs);
            }
        }
    }
    fields
}

#[test]
fn unity_asset_is_a_diffusion_profile_with_the_printed_values() {
    let (_tmp, dir) = write("unity-hdrp", &[]);
    let fit = fit(&dir, "unity-hdrp");
    let text = std::fs::read_to_string(dir.join("skin1.asset")).unwrap();
    assert!(text.contains("  m_Name: skin1\n"));
    let f = read_asset(&text);
    let params = &fit["params"];
    let one = |k: &str| f[k][0].1;
    let multiplier = one("scatteringDistanceMultiplier");
    assert!(close(
        multiplier,
        params["Multiplier"].as_f64().unwrap(),
        FLOAT32_REL
    ));
    assert!(close(
        one("worldScale"),
        params["World Scale"].as_f64().unwrap(),
        FLOAT32_REL
    ));
    // TexturingMode.PostScatter = 1 (DiffusionProfileSettings.cs).
    assert_eq!(one("texturingMode"), 1.0);
    assert_eq!(one("hash"), 0.0, "0: the editor makes the hash on import");
    let shown = numbers(&params["Scattering Color"]);
    let stored = &f["scatteringDistance"];
    for c in 0..3 {
        // The picker shows sRGB and stores Color.linear.
        assert!(close(stored[c].1, linear(shown[c]), FLOAT32_REL), "{c}");
        // UpdateKernel: 1 / S = Multiplier x scatteringDistance, mm at
        // World Scale 1 in a scene in metres: the d ssskit scored.
        let d = multiplier * stored[c].1 / one("worldScale");
        let scored = fit["rendered"]["d_mm"][c].as_f64().unwrap();
        assert!(close(d, scored, 1e-6), "channel {c}: {d} vs {scored}");
    }
    assert_eq!(stored[3].1, 1.0);
}

// ---- Godot --------------------------------------------------------------

/// A value of Godot's text format (`VariantParser::parse_value`).
#[derive(Clone, Debug, PartialEq)]
enum GdValue {
    Bool(bool),
    Int(i64),
    Real(f64),
    Str(String),
    /// A constructor such as `Color(r, g, b, a)`: its name and arguments.
    Call(String, Vec<GdValue>),
}

/// `VariantParser::get_token`'s tokens.
#[derive(Clone, Debug, PartialEq)]
enum Token {
    Open(char),
    Close(char),
    Comma,
    Equal,
    Ident(String),
    Number(String),
    Str(String),
}

/// get_token: punctuation, identifiers ([A-Za-z_][A-Za-z0-9_]*), numbers
/// (sign, digits, '.', exponent), strings in double quotes with
/// backslash escapes, ';' starting a comment to the end of the line.
fn tokens(text: &str) -> Vec<(usize, Token)> {
    let c: Vec<char> = text.chars().collect();
    let (mut i, mut line, mut out) = (0, 1, Vec::new());
    while i < c.len() {
        let ch = c[i];
        match ch {
            '\n' => line += 1,
            ' ' | '\t' | '\r' => {}
            ';' => {
                while i < c.len() && c[i] != '\n' {
                    i += 1;
                }
                continue;
            }
            '[' | '(' | '{' => out.push((line, Token::Open(ch))),
            ']' | ')' | '}' => out.push((line, Token::Close(ch))),
            ',' => out.push((line, Token::Comma)),
            '=' => out.push((line, Token::Equal)),
            '"' => {
                let mut s = String::new();
                i += 1;
                while c[i] != '"' {
                    if c[i] == '\\' {
                        i += 1;
                    }
                    s.push(c[i]);
                    i += 1;
                }
                out.push((line, Token::Str(s)));
            }
            _ if ch == '-' || ch.is_ascii_digit() => {
                let start = i;
                while i + 1 < c.len()
                    && (c[i + 1].is_ascii_alphanumeric() || "+-.".contains(c[i + 1]))
                {
                    i += 1;
                }
                out.push((line, Token::Number(c[start..=i].iter().collect())));
            }
            _ if ch.is_alphabetic() || ch == '_' => {
                // Keys of a tag assignment may hold '/' (project.godot's
                // "environment/subsurface_scattering/...":
                // parse_tag_assign_eof reads the key up to '=').
                let start = i;
                while i + 1 < c.len() && (c[i + 1].is_alphanumeric() || "_/".contains(c[i + 1])) {
                    i += 1;
                }
                out.push((line, Token::Ident(c[start..=i].iter().collect())));
            }
            _ => panic!("line {line}: unexpected '{ch}'"),
        }
        i += 1;
    }
    out
}

/// parse_value over the tokens from `at`; the value and the next index.
fn value(t: &[(usize, Token)], at: usize) -> (GdValue, usize) {
    match &t[at].1 {
        Token::Number(n) if n.contains(['.', 'e']) => (GdValue::Real(n.parse().unwrap()), at + 1),
        Token::Number(n) => (GdValue::Int(n.parse().unwrap()), at + 1),
        Token::Str(s) => (GdValue::Str(s.clone()), at + 1),
        Token::Ident(b) if b == "true" || b == "false" => (GdValue::Bool(b == "true"), at + 1),
        Token::Ident(name) => {
            assert_eq!(t[at + 1].1, Token::Open('('), "{name} is not a constructor");
            let (mut args, mut i) = (Vec::new(), at + 2);
            while t[i].1 != Token::Close(')') {
                let (v, next) = value(t, i);
                args.push(v);
                i = next;
                if t[i].1 == Token::Comma {
                    i += 1;
                }
            }
            (GdValue::Call(name.clone(), args), i + 1)
        }
        other => panic!("line {}: no value starts with {other:?}", t[at].0),
    }
}

/// A file of tags and assignments (parse_tag / parse_tag_assign_eof):
/// each tag's name, its `key=value` fields, and the `key = value` lines
/// after it.
type Section = (String, Vec<(String, GdValue)>, Vec<(String, GdValue)>);

fn sections(text: &str) -> Vec<Section> {
    let t = tokens(text);
    let (mut out, mut i) = (Vec::<Section>::new(), 0);
    while i < t.len() {
        if t[i].1 == Token::Open('[') {
            let Token::Ident(name) = &t[i + 1].1 else {
                panic!("a tag needs a name")
            };
            let (mut fields, mut j) = (Vec::new(), i + 2);
            while t[j].1 != Token::Close(']') {
                let Token::Ident(k) = &t[j].1 else {
                    panic!("a tag field needs a name")
                };
                assert_eq!(t[j + 1].1, Token::Equal);
                let (v, next) = value(&t, j + 2);
                fields.push((k.clone(), v));
                j = next;
            }
            out.push((name.clone(), fields, Vec::new()));
            i = j + 1;
        } else {
            let Token::Ident(k) = &t[i].1 else {
                panic!("line {}: expected a key", t[i].0)
            };
            assert_eq!(t[i + 1].1, Token::Equal, "line {}", t[i].0);
            let (v, next) = value(&t, i + 2);
            out.last_mut()
                .expect("an assignment before any tag")
                .2
                .push((k.clone(), v));
            i = next;
        }
    }
    out
}

/// BaseMaterial3D's properties the `.tres` may set (material.cpp
/// `BaseMaterial3D::_bind_methods`: ADD_PROPERTY with Variant::COLOR,
/// BOOL, FLOAT), and Resource's `resource_name` (STRING).
const MATERIAL_PROPERTIES: [(&str, &str); 5] = [
    ("resource_name", "String"),
    ("albedo_color", "Color"),
    ("subsurf_scatter_enabled", "bool"),
    ("subsurf_scatter_strength", "float"),
    ("subsurf_scatter_skin_mode", "bool"),
];

fn kind(v: &GdValue) -> &'static str {
    match v {
        GdValue::Bool(_) => "bool",
        GdValue::Int(_) | GdValue::Real(_) => "float",
        GdValue::Str(_) => "String",
        GdValue::Call(name, args) if name == "Color" && args.len() == 4 => "Color",
        GdValue::Call(..) => "constructor",
    }
}

fn real(v: &GdValue) -> f64 {
    match v {
        GdValue::Int(i) => *i as f64,
        GdValue::Real(x) => *x,
        other => panic!("{other:?} is not a number"),
    }
}

/// rendering_server.cpp GLOBAL_DEF: the quality's enum hint, in order.
const QUALITY_HINT: [&str; 4] = [
    "Disabled (Fastest)",
    "Low (Fast)",
    "Medium (Average)",
    "High (Slow)",
];
const SSS: &str = "environment/subsurface_scattering/";

fn godot_material(dir: &Path, fit: &Value) {
    let s = sections(&std::fs::read_to_string(dir.join("skin1.tres")).unwrap());
    assert_eq!(s.len(), 2, "a header tag and [resource]");
    let (head, fields, props) = &s[0];
    assert_eq!(head, "gd_resource");
    assert!(props.is_empty());
    assert_eq!(
        fields[0],
        ("type".into(), GdValue::Str("StandardMaterial3D".into()))
    );
    // resource_format_text.h: FORMAT_VERSION_COMPAT = 3, the format the
    // saver writes for a resource without the newer variant types of
    // FORMAT_VERSION 4; the loader takes both.
    assert_eq!(fields[1], ("format".into(), GdValue::Int(3)));
    assert_eq!(s[1].0, "resource");
    let props = &s[1].2;
    let get = |k: &str| {
        &props
            .iter()
            .find(|p| p.0 == k)
            .unwrap_or_else(|| panic!("{k}"))
            .1
    };
    for (k, v) in props {
        let want = MATERIAL_PROPERTIES.iter().find(|p| p.0 == k);
        assert_eq!(want.map(|p| p.1), Some(kind(v)), "{k}: {v:?}");
    }
    assert_eq!(get("subsurf_scatter_enabled"), &GdValue::Bool(true));
    assert_eq!(get("subsurf_scatter_skin_mode"), &GdValue::Bool(false));
    let strength = fit["params"]["subsurf_scatter_strength"].as_f64().unwrap();
    assert_eq!(real(get("subsurf_scatter_strength")), strength);
    let GdValue::Call(_, rgba) = get("albedo_color") else {
        unreachable!()
    };
    let albedo = numbers(&fit["params"]["albedo"]);
    for c in 0..3 {
        // source_color: the file holds the sRGB encoding of the albedo.
        assert!(
            close(real(&rgba[c]), srgb(albedo[c]), FLOAT32_REL),
            "channel {c}"
        );
    }
    assert_eq!(real(&rgba[3]), 1.0);
}

fn godot_project(dir: &Path, fit: &Value) {
    let s = sections(&std::fs::read_to_string(dir.join("skin1-project.godot")).unwrap());
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].0, "rendering");
    let props = &s[0].2;
    assert_eq!(props.len(), 2);
    let label = fit["params"]["subsurface_scattering_quality"]
        .as_str()
        .unwrap();
    let want = QUALITY_HINT.iter().position(|q| *q == label).unwrap() as i64;
    assert_eq!(
        props[0],
        (
            format!("{SSS}subsurface_scattering_quality"),
            GdValue::Int(want)
        )
    );
    let depth = fit["params"]["subsurface_scattering_depth_scale"]
        .as_f64()
        .unwrap();
    assert_eq!(
        props[1].0,
        format!("{SSS}subsurface_scattering_depth_scale")
    );
    assert_eq!(real(&props[1].1), depth);
}

#[test]
fn godot_files_are_a_material_and_project_settings_by_godots_grammar() {
    let (_tmp, dir) = write("godot", &[]);
    let fit = fit(&dir, "godot");
    godot_material(&dir, &fit);
    godot_project(&dir, &fit);
}

#[test]
fn godot_parser_reads_what_godot_writes() {
    // The grammar's own cases: a comment, a constructor, a string with an
    // escaped quote, an exponent, a slash key.
    let s = sections(
        "; c\n[gd_resource type=\"X\" format=3]\n\n[resource]\na = Color(1, 0.5, 2e-3, 1)\n\
         b = \"q\\\"\"\nc/d = -1.5\n",
    );
    assert_eq!(s.len(), 2);
    assert_eq!(
        s[1].2[0].1,
        GdValue::Call(
            "Color".into(),
            vec![
                GdValue::Int(1),
                GdValue::Real(0.5),
                GdValue::Real(2e-3),
                GdValue::Int(1)
            ]
        )
    );
    assert_eq!(s[1].2[1].1, GdValue::Str("q\"".into()));
    assert_eq!(s[1].2[2], ("c/d".into(), GdValue::Real(-1.5)));
}

// ---- The writer ---------------------------------------------------------

#[test]
fn engines_without_a_file_are_refused_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("files");
    for e in ["unreal", "iryoku"] {
        fails_with(
            &[
                "engine",
                "--profile",
                SKIN,
                "--engine",
                e,
                "--out-dir",
                p(&out),
            ],
            &["--engine", e, "no file to import"],
        );
    }
    fails_with(
        &[
            "engine",
            "--profile",
            SKIN,
            "--engine",
            "blender",
            "--engine-version",
            "2.93",
            "--out-dir",
            p(&out),
        ],
        &["--engine-version", "2.93"],
    );
    assert!(!out.exists(), "a refused run made the folder");
}

#[cfg(unix)]
#[test]
fn the_folder_is_never_a_device_a_pipe_an_input_or_theirs() {
    let tmp = tempfile::tempdir().unwrap();
    let args = |out: &Path, profile: &Path| -> Vec<String> {
        [
            "engine",
            "--profile",
            p(profile),
            "--engine",
            "godot",
            "--out-dir",
            p(out),
        ]
        .map(String::from)
        .to_vec()
    };
    let run_fails = |a: Vec<String>, needles: &[&str]| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        fails_with(&a, needles)
    };
    let skin = Path::new(SKIN);
    // A named pipe, and a character device.
    let fifo = tmp.path().join("pipe");
    assert!(std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    run_fails(args(&fifo, skin), &["not a folder"]);
    run_fails(args(Path::new("/dev/null"), skin), &["not a folder"]);
    // An earlier output folder that now holds a pipe: the swap would remove it.
    let (_keep, dir) = write("godot", &[]);
    let inner = dir.join("pipe");
    assert!(std::process::Command::new("mkfifo")
        .arg(&inner)
        .status()
        .unwrap()
        .success());
    run_fails(args(&dir, skin), &["named pipe"]);
    std::fs::remove_file(&inner).unwrap();
    // The input inside the folder that replaces it.
    let input = dir.join("skin1.json");
    std::fs::copy(skin, &input).unwrap();
    run_fails(args(&dir, &input), &["--profile", "inside", "--out-dir"]);
    assert!(input.exists(), "the input was removed");
    // A folder of someone else's files.
    let theirs = tmp.path().join("theirs");
    std::fs::create_dir(&theirs).unwrap();
    std::fs::write(theirs.join("notes.txt"), "keep").unwrap();
    run_fails(args(&theirs, skin), &["notes.txt"]);
    assert_eq!(
        std::fs::read_to_string(theirs.join("notes.txt")).unwrap(),
        "keep"
    );
}

#[test]
fn a_second_run_replaces_the_folder_as_a_whole() {
    let (tmp, dir) = write("godot", &[]);
    std::fs::remove_file(dir.join("skin1.tres")).unwrap();
    std::fs::write(dir.join("stale.txt"), "from a run by hand").unwrap();
    ok(&[
        "engine",
        "--profile",
        SKIN,
        "--engine",
        "unity-hdrp",
        "--out-dir",
        p(&dir),
    ]);
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [".ssskit-output", "skin1-unity-hdrp.json", "skin1.asset"]
    );
    let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().collect();
    assert_eq!(left.len(), 1, "temporaries left beside the folder");
}
