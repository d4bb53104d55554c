//! `ssskit engine --engine unreal --out-dir`: the editor Python script
//! that makes the Subsurface Profile asset, read with Python's `ast` and
//! run against a stand-in `unreal` module that records what it is asked.
//!
//! Oracles:
//! - `FSubsurfaceProfileStruct`'s UPROPERTYs, re-typed below with their
//!   kinds and ClampMin / ClampMax, from Epic's UnrealEngine
//!   Engine/Source/Runtime/Engine/Classes/Engine/SubsurfaceProfile.h
//!   (read in the 5.8.0 source, the unicorn2022/UE5.8.0 mirror; 5.0 has
//!   no `Implementation`);
//! - their Python names as Unreal's Python API reference lists the
//!   editor properties of `unreal.SubsurfaceProfileStruct` (5.7), which
//!   the test also derives from the C++ names by the rule of
//!   `PyGenUtil::PythonizePropertyName` (PythonScriptPlugin, PyGenUtil.cpp:
//!   a bool's "b" prefix dropped, CamelCase made snake_case);
//! - the calls and signatures of the same reference:
//!   `AssetToolsHelpers.get_asset_tools()`, `AssetTools.create_asset(
//!   asset_name, package_path, asset_class, factory, calling_context)`,
//!   `SubsurfaceProfileFactory(outer, name)`, `Object.get_editor_property(
//!   name)` (a struct comes back by value: a copy) and
//!   `set_editor_property(name, value, notify_mode)`, `LinearColor(r, g,
//!   b, a)`, `EditorAssetLibrary.does_asset_exist(asset_path)`,
//!   `load_asset(asset_path)`, `save_loaded_asset(asset_to_save,
//!   only_if_is_dirty)`, `SubsurfaceImplementationTechniqueHint.SIH_AFIS`
//!   and `SIH_SEPARABLE`, `log_warning(arg)`. The stand-in raises, as
//!   Unreal does, on a property the struct does not have.
//! - SubsurfaceProfile.cpp `UpgradeSubsurfaceProfileParameters`: a profile
//!   with `bEnableBurley` or `bEnableMeanFreePath` false has its values
//!   replaced on load, so the script must set both.

mod common;
use common::*;
use serde_json::Value;

const SKIN: &str = "profiles/reference/skin1.json";

/// A property's kind in the header.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Colour,
    Float,
    Bool,
    Enum,
}

/// FSubsurfaceProfileStruct's UPROPERTYs (5.8.0), in the header's order:
/// (C++ name, kind, ClampMin, ClampMax); NaN where there is no clamp.
const HEADER: [(&str, Kind, f64, f64); 21] = [
    ("SurfaceAlbedo", Kind::Colour, 0.01, 1.0),
    ("MeanFreePathColor", Kind::Colour, 0.001, 1.0),
    ("MeanFreePathDistance", Kind::Float, 0.1, 50.0),
    ("WorldUnitScale", Kind::Float, 0.1, 50.0),
    ("bEnableBurley", Kind::Bool, f64::NAN, f64::NAN),
    ("bEnableMeanFreePath", Kind::Bool, f64::NAN, f64::NAN),
    ("Tint", Kind::Colour, f64::NAN, f64::NAN),
    ("ScatterRadius", Kind::Float, 0.1, 1000.0),
    ("SubsurfaceColor", Kind::Colour, f64::NAN, f64::NAN),
    ("FalloffColor", Kind::Colour, f64::NAN, f64::NAN),
    ("BoundaryColorBleed", Kind::Colour, f64::NAN, f64::NAN),
    ("Implementation", Kind::Enum, f64::NAN, f64::NAN),
    ("ExtinctionScale", Kind::Float, 0.01, 100.0),
    ("NormalScale", Kind::Float, 0.01, 1.0),
    ("DistanceScale", Kind::Float, 0.1, 10.0),
    ("ScatteringDistribution", Kind::Float, 0.01, 1.0),
    ("IOR", Kind::Float, 1.0, 3.0),
    ("Roughness0", Kind::Float, 0.5, 2.0),
    ("Roughness1", Kind::Float, 0.5, 2.0),
    ("LobeMix", Kind::Float, 0.1, 0.9),
    ("TransmissionTintColor", Kind::Colour, 0.001, 1.0),
];

/// The editor properties of `unreal.SubsurfaceProfileStruct` as the
/// Python API reference (5.7) lists them.
const PYTHON_NAMES: [&str; 21] = [
    "surface_albedo",
    "mean_free_path_color",
    "mean_free_path_distance",
    "world_unit_scale",
    "enable_burley",
    "enable_mean_free_path",
    "tint",
    "scatter_radius",
    "subsurface_color",
    "falloff_color",
    "boundary_color_bleed",
    "implementation",
    "extinction_scale",
    "normal_scale",
    "distance_scale",
    "scattering_distribution",
    "ior",
    "roughness0",
    "roughness1",
    "lobe_mix",
    "transmission_tint_color",
];

/// PythonizePropertyName's rule for these names: a bool's "b" before a
/// capital dropped; an underscore before a capital that follows a small
/// letter (a run of capitals stays one word); all in small letters.
fn pythonize(name: &str) -> String {
    let c: Vec<char> = name.chars().collect();
    let start = usize::from(c.len() > 1 && c[0] == 'b' && c[1].is_uppercase());
    let mut out = String::new();
    for i in start..c.len() {
        if i > start && c[i].is_uppercase() && c[i - 1].is_lowercase() {
            out.push('_');
        }
        out.extend(c[i].to_lowercase());
    }
    out
}

#[test]
fn the_python_names_are_the_headers_pythonized() {
    let derived: Vec<String> = HEADER.iter().map(|h| pythonize(h.0)).collect();
    assert_eq!(derived, PYTHON_NAMES);
}

/// The stand-in `unreal` module, with the reference's signatures.
const FAKE_UNREAL: &str = r#"
import copy
LOG = []
PROPS = {}  # struct property -> kind, filled by the test
SAVED = []

class LinearColor:
    def __init__(self, r=0.0, g=0.0, b=0.0, a=0.0):
        self.r, self.g, self.b, self.a = float(r), float(g), float(b), float(a)

class _Enum:
    def __init__(self, name):
        self.name = name

class SubsurfaceImplementationTechniqueHint:
    SIH_AFIS = _Enum("SIH_AFIS")
    SIH_SEPARABLE = _Enum("SIH_SEPARABLE")

class SubsurfaceProfileStruct:
    def __init__(self):
        self._v = {}
    def get_editor_property(self, name):
        if name not in PROPS:
            raise Exception("Failed to find property '%s'" % name)
        return self._v.get(name)
    def set_editor_property(self, name, value, notify_mode=None):
        kind = PROPS.get(name)
        if kind is None:
            raise Exception("Failed to find property '%s'" % name)
        ok = {"colour": lambda v: isinstance(v, LinearColor),
              "float": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
              "bool": lambda v: isinstance(v, bool),
              "enum": lambda v: isinstance(v, _Enum)}[kind](value)
        if not ok:
            raise TypeError("%s takes a %s, not %r" % (name, kind, value))
        self._v[name] = value

class Object:
    def __init__(self, outer=None, name="None"):
        self._props = {}
    def get_editor_property(self, name):
        if name not in self._props:
            raise Exception("Failed to find property '%s'" % name)
        # A struct comes back by value.
        return copy.deepcopy(self._props[name])
    def set_editor_property(self, name, value, notify_mode=None):
        if name not in self._props:
            raise Exception("Failed to find property '%s'" % name)
        self._props[name] = copy.deepcopy(value)

class SubsurfaceProfile(Object):
    def __init__(self, outer=None, name="None"):
        Object.__init__(self, outer, name)
        self._props["settings"] = SubsurfaceProfileStruct()

class Factory(Object):
    pass

class SubsurfaceProfileFactory(Factory):
    pass

class AssetTools:
    def create_asset(self, asset_name, package_path, asset_class, factory, calling_context="None"):
        LOG.append(["create_asset", asset_name, package_path, asset_class.__name__,
                    type(factory).__name__])
        return asset_class()

class AssetToolsHelpers:
    @classmethod
    def get_asset_tools(cls):
        return AssetTools()

class EditorAssetLibrary:
    @classmethod
    def does_asset_exist(cls, asset_path):
        LOG.append(["does_asset_exist", asset_path])
        return False
    @classmethod
    def load_asset(cls, asset_path):
        raise AssertionError("nothing to load")
    @classmethod
    def save_loaded_asset(cls, asset_to_save, only_if_is_dirty=True):
        SAVED.append(asset_to_save)
        return True

def log_warning(arg):
    LOG.append(["log_warning", str(arg)])
"#;

/// Writes the fake module, parses the script (its SETTINGS, ENABLE,
/// IMPLEMENTATION, BASE_COLOR by `ast`), runs make_profile() and prints
/// what it did as JSON.
const RUN: &str = r#"
import ast, json, os, runpy, sys
script, fake_dir, props = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
tree = ast.parse(open(script).read())
out = {}
for node in tree.body:
    if isinstance(node, ast.Assign) and len(node.targets) == 1:
        name = getattr(node.targets[0], "id", None)
        if name in ("NAME", "PACKAGE_PATH", "SETTINGS", "ENABLE", "IMPLEMENTATION", "BASE_COLOR",
                    "WARNING"):
            out[name] = ast.literal_eval(node.value)
sys.path.insert(0, fake_dir)
import unreal
unreal.PROPS.update(props)
mod = runpy.run_path(script, run_name="ssskit_profile")
asset = mod["make_profile"]()
final = asset.get_editor_property("settings")._v
def plain(v):
    if isinstance(v, unreal.LinearColor):
        return [v.r, v.g, v.b, v.a]
    if isinstance(v, unreal._Enum):
        return v.name
    return v
out["final"] = {k: plain(v) for k, v in final.items()}
out["log"] = unreal.LOG
out["saved"] = [a is asset for a in unreal.SAVED]
print(json.dumps(out))
"#;

fn run_script(dir: &std::path::Path) -> Value {
    let fake = dir.join("fake");
    std::fs::create_dir_all(&fake).unwrap();
    std::fs::write(fake.join("unreal.py"), FAKE_UNREAL).unwrap();
    let kinds: serde_json::Map<String, Value> = HEADER
        .iter()
        .zip(PYTHON_NAMES)
        .map(|(h, py)| {
            let kind = match h.1 {
                Kind::Colour => "colour",
                Kind::Float => "float",
                Kind::Bool => "bool",
                Kind::Enum => "enum",
            };
            (py.to_string(), Value::from(kind))
        })
        .collect();
    let script = dir.join("files/skin1-unreal.py");
    let kinds = Value::Object(kinds).to_string();
    let o = common::output_ok(
        std::process::Command::new("python3").args(["-c", RUN, p(&script), p(&fake), &kinds]),
        "the script against the API",
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

fn numbers(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().map(|x| x.as_f64().unwrap()).collect(),
        x => vec![x.as_f64().unwrap()],
    }
}

/// The printed parameter each settings property holds.
const PRINTED: [(&str, &str); 5] = [
    ("surface_albedo", "SurfaceAlbedo"),
    ("mean_free_path_color", "MeanFreePathColor"),
    ("mean_free_path_distance", "MeanFreePathDistance"),
    ("world_unit_scale", "WorldUnitScale"),
    ("tint", "Tint"),
];

fn check(version: &str, implementation: Option<&str>) {
    let tmp = tempfile::tempdir().unwrap();
    let files = tmp.path().join("files");
    ok(&[
        "engine",
        "--profile",
        SKIN,
        "--engine",
        "unreal",
        "--engine-version",
        version,
        "--out-dir",
        p(&files),
    ]);
    let fit = read_json(&files.join("skin1-unreal.json"));
    let params = &fit["params"];
    let s = run_script(tmp.path());
    assert_eq!(s["NAME"], "skin1");
    assert_eq!(s["WARNING"], Value::Null);
    // Every property the script sets is one of the header's, under its
    // Python name, holding the printed value, inside the header's clamps.
    let settings = s["SETTINGS"].as_object().unwrap();
    assert_eq!(settings.len(), PRINTED.len(), "{settings:?}");
    for (py, printed) in PRINTED {
        let i = PYTHON_NAMES.iter().position(|n| *n == py).unwrap();
        let (_, kind, lo, hi) = HEADER[i];
        let got = numbers(&settings[py]);
        assert_eq!(got, numbers(&params[printed]), "{py}");
        assert_eq!(got.len(), if kind == Kind::Colour { 3 } else { 1 }, "{py}");
        for x in got {
            assert!(
                lo.is_nan() || (lo..=hi).contains(&x),
                "{py} = {x} outside [{lo}, {hi}]"
            );
        }
    }
    assert_eq!(numbers(&s["BASE_COLOR"]), numbers(&params["Base Color"]));
    // What the asset holds after make_profile: the values, Burley and mean
    // free paths on, the implementation where the version has one; made by
    // the factory where the reference says, and saved.
    let final_ = s["final"].as_object().unwrap();
    for (py, printed) in PRINTED {
        let mut want = numbers(&params[printed]);
        if want.len() == 3 {
            want.push(1.0);
        }
        let got = numbers(&final_[py]);
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(*g, *w, "{py}");
        }
    }
    assert_eq!(final_["enable_burley"], true);
    assert_eq!(final_["enable_mean_free_path"], true);
    assert_eq!(
        final_.get("implementation").and_then(Value::as_str),
        implementation
    );
    let create: Vec<&Value> = s["log"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|l| l[0] == "create_asset")
        .collect();
    assert_eq!(create.len(), 1);
    assert_eq!(
        create[0],
        &serde_json::json!([
            "create_asset",
            "skin1",
            "/Game/ssskit",
            "SubsurfaceProfile",
            "SubsurfaceProfileFactory"
        ])
    );
    assert_eq!(s["saved"], serde_json::json!([true]));
}

#[test]
fn the_script_makes_the_profile_with_the_printed_values() {
    check("5.4", Some("SIH_AFIS"));
    check("5.0", None);
}
