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
use common::args::engine_args;
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
    let o = common::output_ok(
        std::process::Command::new("python3").args(["-c", READ_SCRIPT, p(path)]),
        "python3 parsing the script",
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
            "$" => assert!(matches!(yaml11_scalar(value), Yaml::Str(_)), "{value}"),
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
    assert!(text.contains("  m_Name: 'skin1'\n"));
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
        assert!(
            close(stored[c].1, srgb::decode(shown[c]), FLOAT32_REL),
            "{c}"
        );
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
    // source_color: the inspector shows, and the file holds, the sRGB
    // colour; ssskit printed it so.
    let shown = numbers(&fit["params"]["albedo_color"]);
    let total = numbers(&read_json(Path::new(SKIN))["total_rd"]);
    let mut hex = String::from("#");
    for c in 0..3 {
        assert!(close(real(&rgba[c]), shown[c], FLOAT32_REL), "channel {c}");
        // Decoded as Godot decodes a source_color, the printed colour is
        // the profile's total (the colour kept), to its 4 digits.
        assert!(
            close(srgb::decode(shown[c]), total[c], srgb::TYPED_REL),
            "channel {c}: {} decodes to {}, the profile reflects {}",
            shown[c],
            srgb::decode(shown[c]),
            total[c]
        );
        hex += &format!("{:02X}", (srgb::encode(total[c]) * 255.0).round() as u8);
    }
    assert_eq!(fit["params"]["albedo_color hex"], hex.as_str());
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
    let out_dir = ["--out-dir", p(&out)];
    fails_with(
        &engine_args(SKIN, "iryoku", &out_dir),
        &["--engine", "iryoku", "no file to import"],
    );
    let blender = engine_args(SKIN, "blender", &["--engine-version", "2.93"]);
    fails_with(
        &[&blender[..], &out_dir].concat(),
        &["--engine-version", "2.93"],
    );
    assert!(!out.exists(), "a refused run made the folder");
}

/// Makes a named pipe at `path` (mkfifo(1)).
#[cfg(unix)]
fn mkfifo(path: &Path) {
    let status = std::process::Command::new("mkfifo").arg(path).status();
    assert!(status.unwrap().success(), "mkfifo {}", path.display());
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
    mkfifo(&fifo);
    run_fails(args(&fifo, skin), &["not a folder"]);
    run_fails(args(Path::new("/dev/null"), skin), &["not a folder"]);
    // An earlier output folder that now holds a pipe: the swap would remove it.
    let (_keep, dir) = write("godot", &[]);
    let inner = dir.join("pipe");
    mkfifo(&inner);
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

// ---- Names no engine's reader mistakes -----------------------------------

/// A scalar as a YAML 1.1 reader resolves it (the YAML 1.1
/// specification: the single-quoted style, where a doubled quote is the
/// only escape and a line break folds; a plain scalar's implicit types
/// from the tag repository: bool, null, int, float, merge and value; a
/// plain scalar cannot start with an indicator).
#[derive(Clone, Debug, PartialEq)]
enum Yaml {
    Str(String),
    /// Another type, or no scalar at all.
    Other(&'static str),
}

fn yaml11_scalar(text: &str) -> Yaml {
    if let Some(body) = text.strip_prefix('\'') {
        let Some(inner) = body.strip_suffix('\'') else {
            return Yaml::Other("an unterminated quote");
        };
        // A lone quote inside ends the scalar early: not one scalar.
        if inner.replace("''", "").contains('\'') {
            return Yaml::Other("two scalars");
        }
        if inner.contains(['\n', '\r']) {
            return Yaml::Other("a folded line");
        }
        return Yaml::Str(inner.replace("''", "'"));
    }
    if text.starts_with('"') {
        return Yaml::Other("a double-quoted scalar (escapes not read here)");
    }
    let first = text.chars().next();
    let next_blank = text.chars().nth(1).is_none_or(char::is_whitespace);
    match first {
        None => return Yaml::Other("null (empty)"),
        Some('-' | '?' | ':') if next_blank => return Yaml::Other("an indicator"),
        Some(
            ',' | '[' | ']' | '{' | '}' | '#' | '&' | '*' | '!' | '|' | '>' | '\'' | '"' | '%'
            | '@' | '`',
        ) => return Yaml::Other("an indicator"),
        _ => {}
    }
    let bools = [
        "y", "Y", "yes", "Yes", "YES", "n", "N", "no", "No", "NO", "true", "True", "TRUE", "false",
        "False", "FALSE", "on", "On", "ON", "off", "Off", "OFF",
    ];
    if bools.contains(&text) {
        return Yaml::Other("bool");
    }
    if ["~", "null", "Null", "NULL"].contains(&text) {
        return Yaml::Other("null");
    }
    if text == "<<" {
        return Yaml::Other("merge");
    }
    if text == "=" {
        return Yaml::Other("value");
    }
    if yaml11_int(text) {
        return Yaml::Other("int");
    }
    if yaml11_float(text) {
        return Yaml::Other("float");
    }
    Yaml::Str(text.to_string())
}

/// Every char of `s` (not empty) passes `ok`.
fn all_of(s: &str, ok: impl Fn(char) -> bool) -> bool {
    !s.is_empty() && s.chars().all(ok)
}

/// The tag repository's int: [-+]?0b[0-1_]+ | [-+]?0[0-7_]+ |
/// [-+]?(0|[1-9][0-9_]*) | [-+]?0x[0-9a-fA-F_]+ |
/// [-+]?[1-9][0-9_]*(:[0-5]?[0-9])+.
fn yaml11_int(t: &str) -> bool {
    let u = t.strip_prefix(['-', '+']).unwrap_or(t);
    if let Some(r) = u.strip_prefix("0b") {
        return all_of(r, |c| matches!(c, '0' | '1' | '_'));
    }
    if let Some(r) = u.strip_prefix("0x") {
        return all_of(r, |c| c.is_ascii_hexdigit() || c == '_');
    }
    if u == "0" {
        return true;
    }
    if let Some(r) = u.strip_prefix('0') {
        return all_of(r, |c| matches!(c, '0'..='7' | '_'));
    }
    let mut parts = u.split(':');
    let head = parts.next().unwrap_or("");
    head.starts_with(|c: char| matches!(c, '1'..='9'))
        && all_of(head, |c| c.is_ascii_digit() || c == '_')
        && parts.all(sexagesimal)
}

/// [0-5]?[0-9]: one place of a base-60 number.
fn sexagesimal(p: &str) -> bool {
    let b = p.as_bytes();
    match b.len() {
        1 => b[0].is_ascii_digit(),
        2 => (b'0'..=b'5').contains(&b[0]) && b[1].is_ascii_digit(),
        _ => false,
    }
}

/// The tag repository's float: [-+]?([0-9][0-9_]*)?\.[0-9.]*([eE][-+][0-9]+)?
/// | [-+]?[0-9][0-9_]*(:[0-5]?[0-9])+\.[0-9_]* | [-+]?\.(inf|Inf|INF) |
/// \.(nan|NaN|NAN).
fn yaml11_float(t: &str) -> bool {
    if [".nan", ".NaN", ".NAN"].contains(&t) {
        return true;
    }
    let u = t.strip_prefix(['-', '+']).unwrap_or(t);
    if [".inf", ".Inf", ".INF"].contains(&u) {
        return true;
    }
    let Some((whole, frac)) = u.split_once('.') else {
        return false;
    };
    if whole.contains(':') {
        let mut parts = whole.split(':');
        let head = parts.next().unwrap_or("");
        return head.starts_with(|c: char| c.is_ascii_digit())
            && all_of(head, |c| c.is_ascii_digit() || c == '_')
            && parts.all(sexagesimal)
            && frac.chars().all(|c| c.is_ascii_digit() || c == '_');
    }
    let whole_ok = whole.is_empty()
        || (whole.starts_with(|c: char| c.is_ascii_digit())
            && all_of(whole, |c| c.is_ascii_digit() || c == '_'));
    let (digits, exp) = match frac.find(['e', 'E']) {
        Some(i) => (&frac[..i], Some(&frac[i + 1..])),
        None => (frac, None),
    };
    let exp_ok = exp.is_none_or(|e| {
        e.strip_prefix(['-', '+'])
            .is_some_and(|d| all_of(d, |c| c.is_ascii_digit()))
    });
    whole_ok && digits.chars().all(|c| c.is_ascii_digit() || c == '.') && exp_ok
}

/// Names that a plain YAML scalar would read as something else, names
/// with a quote, a backslash or a non-ASCII letter, and names a Python or
/// Godot string literal must escape.
const HOSTILE: [&str; 24] = [
    "-",
    "true",
    "null",
    "1e3",
    "0x10",
    ".inf",
    "-.inf",
    "yes",
    "NO",
    "on",
    "Null",
    "~",
    "1_000",
    "0b101",
    "+12",
    "1:20",
    "<<",
    "=",
    "it's",
    "a\"b",
    "back\\slash",
    "ÿé",
    "-5",
    "1.5e+3",
];

#[test]
fn the_yaml_reader_resolves_plain_scalars_as_yaml_1_1_does() {
    for (text, want) in [
        ("true", Yaml::Other("bool")),
        ("-", Yaml::Other("an indicator")),
        ("1e3", Yaml::Str("1e3".into())),
        ("1.5e+3", Yaml::Other("float")),
        ("017", Yaml::Other("int")),
        ("0x10", Yaml::Other("int")),
        (".inf", Yaml::Other("float")),
        ("~", Yaml::Other("null")),
        ("1:20", Yaml::Other("int")),
        ("skin1", Yaml::Str("skin1".into())),
        ("'true'", Yaml::Str("true".into())),
        ("'it''s'", Yaml::Str("it's".into())),
        ("'a'b'", Yaml::Other("two scalars")),
    ] {
        assert_eq!(yaml11_scalar(text), want, "{text}");
    }
}

/// A stand-in fit of each engine, to write files under any name.
fn fits() -> Vec<(&'static str, ssskit::engine::EngineFit)> {
    use ssskit::engine::method::SubsurfaceMethod;
    use ssskit::engine::{fit, fit_method, Engine, Scene};
    let profile = ssskit::profile::Profile::read(Path::new(SKIN)).unwrap();
    let native = |e| Scene::native(e);
    vec![
        (
            "unity-hdrp",
            fit(Engine::UnityHdrp, &profile, native(Engine::UnityHdrp)).unwrap(),
        ),
        (
            "godot",
            fit(Engine::Godot, &profile, native(Engine::Godot)).unwrap(),
        ),
        (
            "unreal",
            fit(Engine::Unreal, &profile, native(Engine::Unreal)).unwrap(),
        ),
        (
            "blender",
            fit_method(
                Engine::Blender,
                &profile,
                native(Engine::Blender),
                None,
                SubsurfaceMethod::ChristensenBurley,
            )
            .unwrap(),
        ),
    ]
}

/// What Python prints running `code` with `input` on its stdin.
fn python_stdin(code: &str, input: &str) -> String {
    let mut child = std::process::Command::new("python3")
        .args(["-c", code])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("python3 runs");
    use std::io::Write as _;
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success());
    String::from_utf8(o.stdout).unwrap()
}

/// The name a Python script's NAME holds, by Python's own `ast`.
fn python_names(scripts: &[String]) -> Vec<String> {
    let code = "import ast, json, sys\nout = []\nfor text in json.load(sys.stdin):\n    \
                for node in ast.parse(text).body:\n        \
                if isinstance(node, ast.Assign) and getattr(node.targets[0], 'id', '') == 'NAME':\n            \
                out.append(ast.literal_eval(node.value))\nprint(json.dumps(out))\n";
    let out = python_stdin(code, &serde_json::to_string(scripts).unwrap());
    serde_json::from_str(&out).unwrap()
}

/// The characters an Unreal object's name may not hold: the asset is
/// named with each made '_' (Epic's UnrealEngine Core/Public/UObject/
/// NameTypes.h, INVALID_OBJECTNAME_CHARACTERS).
const INVALID_OBJECTNAME: &str = "\"' ,/.:|&!~\n\r\t@#(){}[]=;^%$`";

/// Every name reads back as itself in each engine's reader: the file stem
/// the CLI writes (`io::file_stem` of the material's name), and the raw
/// names with quotes and backslashes the library's writers take.
#[test]
fn every_name_reads_back_as_itself_in_each_engines_reader() {
    use ssskit::engine::files::files;
    let fits = fits();
    let engine_of = |name: &str| {
        name.parse::<ssskit::engine::Engine>()
            .unwrap_or_else(|_| panic!("{name}"))
    };
    let mut scripts = Vec::new();
    let mut want = Vec::new();
    for raw in HOSTILE {
        for name in [ssskit::io::file_stem(raw), raw.to_string()] {
            for (engine, fit) in &fits {
                let written = files(engine_of(engine), fit, &name).unwrap();
                let text = &written[0].text;
                match *engine {
                    "unity-hdrp" => {
                        let line = text.lines().find(|l| l.starts_with("  m_Name: ")).unwrap();
                        let value = &line["  m_Name: ".len()..];
                        assert_eq!(yaml11_scalar(value), Yaml::Str(name.clone()), "{line}");
                    }
                    "godot" => {
                        let s = sections(text);
                        let got = &s[1].2.iter().find(|p| p.0 == "resource_name").unwrap().1;
                        assert_eq!(got, &GdValue::Str(name.clone()));
                    }
                    "unreal" => {
                        scripts.push(text.clone());
                        let asset: String = name
                            .chars()
                            .map(|c| {
                                if INVALID_OBJECTNAME.contains(c) {
                                    '_'
                                } else {
                                    c
                                }
                            })
                            .collect();
                        want.push(asset);
                    }
                    _ => {
                        scripts.push(text.clone());
                        want.push(name.clone());
                    }
                }
            }
        }
    }
    assert_eq!(python_names(&scripts), want);
}

/// A line break in a name: refused where the format cannot hold it as
/// itself (a YAML single-quoted scalar folds it, a Godot line ends),
/// escaped in a Python string.
#[test]
fn a_line_break_is_refused_where_a_format_would_change_it() {
    use ssskit::engine::files::files;
    for (engine, fit) in fits() {
        let e: ssskit::engine::Engine = engine.parse().unwrap();
        let got = files(e, &fit, "two\nlines");
        match engine {
            "unity-hdrp" | "godot" => {
                let err = got.unwrap_err().to_string();
                assert!(err.contains("U+000A"), "{engine}: {err}");
            }
            _ => {
                let text = &got.unwrap()[0].text;
                assert_eq!(python_names(std::slice::from_ref(text)).len(), 1);
            }
        }
    }
}

/// A fitted value beyond the 32-bit floats the engines store is refused,
/// the field named, never written as infinity.
#[test]
fn a_value_beyond_32_bit_floats_is_refused_with_its_field() {
    for (engine, field) in [
        ("unity-hdrp", "Multiplier"),
        ("godot", "subsurf_scatter_strength"),
    ] {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join(engine);
        let out_dir = ["--out-dir", p(&out)];
        let args = engine_args(SKIN, engine, &["--units-per-mm", "1e40"]);
        fails_with(&[&args[..], &out_dir].concat(), &[field, "32-bit"]);
        assert!(!out.exists());
    }
}

/// The Blender script sets every layer the fit needs at 0 (closure.h
/// `principled`: each takes its share of the subsurface weight), Specular
/// IOR Level among them, whose default `node_declare` makes 0.5.
#[test]
fn blender_script_zeroes_every_layer_above_the_subsurface() {
    for extra in [&[][..], &["--subsurface-method", "christensen-burley"][..]] {
        let (_tmp, dir) = write("blender", extra);
        let s = read_script(&dir.join("skin1-blender.py"));
        for layer in [
            "Metallic",
            "Specular IOR Level",
            "Transmission Weight",
            "Coat Weight",
            "Sheen Weight",
        ] {
            assert_eq!(s["VALUES"][layer], 0.0, "{layer} in {extra:?}");
        }
    }
}

/// A fit that cannot match its profile is still written (the best the
/// engine can do), with the verdict at the top of every file that takes a
/// comment, in the scripts' WARNING (which they print when run), and on
/// stderr: never silently.
#[test]
fn a_fit_that_cannot_match_says_so_in_its_files() {
    use ssskit::engine::files::files;
    for (engine, mut fit) in fits() {
        fit.error.shape = [0.6, 0.2, 0.2];
        let verdict = fit.cannot_match().expect("over CANNOT_MATCH_SHAPE");
        let e: ssskit::engine::Engine = engine.parse().unwrap();
        let written = files(e, &fit, "skin1").unwrap();
        let text = &written[0].text;
        let first = text.lines().next().unwrap();
        match engine {
            // The editor's own YAML layout: the warning goes to stderr.
            "unity-hdrp" => assert!(first.starts_with("%YAML"), "{first}"),
            "godot" => {
                assert!(first.starts_with("; WARNING from ssskit: godot cannot match"));
                // Still Godot's grammar: the comment is skipped.
                assert_eq!(sections(text)[0].0, "gd_resource");
            }
            _ => {
                assert!(first.starts_with("# WARNING from ssskit"), "{first}");
                let warning = python_warnings(text);
                assert!(warning.contains(&verdict), "{warning}");
            }
        }
    }
    // Godot cannot match skin1: the CLI says so on stderr as it writes.
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("g");
    let o = run(&[
        "engine",
        "--profile",
        SKIN,
        "--engine",
        "godot",
        "--out-dir",
        p(&out),
    ]);
    assert!(o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("cannot match this profile") && err.contains("the files are written"),
        "{err}"
    );
}

/// The WARNING a Python script holds, by Python's own `ast`.
fn python_warnings(script: &str) -> String {
    let code = "import ast, sys\nfor node in ast.parse(sys.stdin.read()).body:\n    \
                if isinstance(node, ast.Assign) and getattr(node.targets[0], 'id', '') == 'WARNING':\n        \
                print(ast.literal_eval(node.value))\n";
    python_stdin(code, script)
}
