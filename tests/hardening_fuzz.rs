//! A fuzz harness over every file reader: material TOML, profile JSON,
//! kernel JSON, Monte Carlo shard JSON, MCML .mci, EXR and PNG, scene TOML
//! and the OBJ meshes it names. Each case
//! mutates a valid file (bytes flipped, inserted, deleted or truncated;
//! JSON values replaced by hostile ones; numbers replaced by extreme
//! ones) and reads it the way ssskit does: the reader returns an error or
//! a value that passes its own checks, and never panics. The case count is
//! fixed (`CASES` per reader, from a fixed seed) so that CI time stays in
//! seconds; `PROPTEST_CASES=N PROPTEST_RNG_SEED=S` runs a longer campaign.

use proptest::prelude::*;
use serde_json::{json, Value};
use ssskit::filter::image::{read_image, write_exr, write_image, PngDepth};
use ssskit::filter::Image;
use ssskit::kernel::emit::{emit, Lang};
use ssskit::kernel::KernelFile;
use ssskit::material::{parse_material_toml, preset, Channel};
use ssskit::profile::mc::{self, McConfig, McOptions, PhotonBudget, Shard};
use ssskit::profile::{analytic, Profile, RadialGrid};
use std::path::Path;
use std::sync::OnceLock;

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const CASES: u32 = 128;

/// `CASES` cases from a fixed seed (the same cases in every CI run);
/// PROPTEST_CASES and PROPTEST_RNG_SEED (read by proptest) change both.
fn config() -> ProptestConfig {
    let env = |k: &str| std::env::var_os(k).is_some();
    let base = ProptestConfig::default();
    ProptestConfig {
        cases: if env("PROPTEST_CASES") {
            base.cases
        } else {
            CASES
        },
        rng_seed: if env("PROPTEST_RNG_SEED") {
            base.rng_seed
        } else {
            proptest::test_runner::RngSeed::Fixed(20260101)
        },
        failure_persistence: None,
        ..base
    }
}

/// One edit of a byte string.
#[derive(Clone, Debug)]
enum ByteEdit {
    Set(usize, u8),
    Insert(usize, Vec<u8>),
    Delete(usize, usize),
    Truncate(usize),
}

fn byte_edits() -> impl Strategy<Value = Vec<ByteEdit>> {
    let edit = prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| ByteEdit::Set(i, b)),
        (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, v)| ByteEdit::Insert(i, v)),
        (any::<usize>(), 1usize..64).prop_map(|(i, n)| ByteEdit::Delete(i, n)),
        any::<usize>().prop_map(ByteEdit::Truncate),
    ];
    prop::collection::vec(edit, 1..6)
}

fn apply_edits(mut b: Vec<u8>, edits: &[ByteEdit]) -> Vec<u8> {
    for e in edits {
        let n = b.len().max(1);
        match e {
            ByteEdit::Set(i, v) => {
                if !b.is_empty() {
                    b[i % n] = *v;
                }
            }
            ByteEdit::Insert(i, v) => {
                let at = i % (b.len() + 1);
                b.splice(at..at, v.iter().copied());
            }
            ByteEdit::Delete(i, k) => {
                let at = i % n;
                let end = (at + k).min(b.len());
                if at < end {
                    b.drain(at..end);
                }
            }
            ByteEdit::Truncate(i) => b.truncate(i % n),
        }
    }
    b
}

/// Values a hostile file puts where a number or a list was.
fn hostile_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(json!(null)),
        Just(json!(-1)),
        Just(json!(0)),
        Just(json!(1e308)),
        Just(json!(-1e308)),
        Just(json!(1e-308)),
        Just(json!(5e-324)),
        Just(json!(u64::MAX)),
        Just(json!(i64::MIN)),
        Just(json!("x")),
        Just(json!("ffffffffffffffffffffffffffffffff:ffffffffffffffff")),
        Just(json!([])),
        Just(json!({})),
        Just(json!([1e308, 1e308, 1e308])),
        (-1e6f64..1e6).prop_map(|x| json!(x)),
        (0u32..40).prop_map(|n| json!(vec![1.0; n as usize])),
    ]
}

/// Every path (object keys and array indices) of a JSON value, up to
/// `limit` of them, breadth first.
fn paths(v: &Value, limit: usize) -> Vec<Vec<PathStep>> {
    let mut out = vec![vec![]];
    let mut i = 0;
    while i < out.len() && out.len() < limit {
        let p = out[i].clone();
        let node = get(v, &p);
        match node {
            Some(Value::Object(m)) => {
                for k in m.keys() {
                    let mut q = p.clone();
                    q.push(PathStep::Key(k.clone()));
                    out.push(q);
                }
            }
            Some(Value::Array(a)) => {
                // First, last and a middle element: arrays are long.
                let mut idx = vec![0, a.len() / 2, a.len().saturating_sub(1)];
                idx.dedup();
                for j in idx.into_iter().filter(|&j| j < a.len()) {
                    let mut q = p.clone();
                    q.push(PathStep::Index(j));
                    out.push(q);
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

#[derive(Clone, Debug)]
enum PathStep {
    Key(String),
    Index(usize),
}

fn get<'a>(v: &'a Value, p: &[PathStep]) -> Option<&'a Value> {
    p.iter().try_fold(v, |v, s| match s {
        PathStep::Key(k) => v.get(k),
        PathStep::Index(i) => v.get(*i),
    })
}

fn get_mut<'a>(v: &'a mut Value, p: &[PathStep]) -> Option<&'a mut Value> {
    p.iter().try_fold(v, |v, s| match s {
        PathStep::Key(k) => v.get_mut(k),
        PathStep::Index(i) => v.get_mut(*i),
    })
}

/// A JSON document with `n` values replaced or removed.
fn mutate_json(base: &Value, picks: &[(usize, Value, bool)]) -> Value {
    let mut v = base.clone();
    let all = paths(base, 4000);
    for (i, new, remove) in picks {
        let p = &all[i % all.len()];
        if *remove && !p.is_empty() {
            let (last, parent) = p.split_last().unwrap();
            if let Some(node) = get_mut(&mut v, parent) {
                match (node, last) {
                    (Value::Object(m), PathStep::Key(k)) => {
                        m.remove(k);
                    }
                    (Value::Array(a), PathStep::Index(j)) if *j < a.len() => {
                        a.remove(*j);
                    }
                    _ => {}
                }
            }
        } else if let Some(node) = get_mut(&mut v, p) {
            *node = new.clone();
        }
    }
    v
}

/// `base`'s JSON with its bytes edited by `edits` when `bytes`, else with
/// the values `picks` names replaced or removed, written to a temporary
/// file `name` (see `write_temp`).
fn mangled_json_file(
    base: &Value,
    picks: &[(usize, Value, bool)],
    (edits, bytes): (&[ByteEdit], bool),
    name: &str,
) -> (tempfile::TempDir, std::path::PathBuf) {
    let text = if bytes {
        apply_edits(serde_json::to_vec(base).unwrap(), edits)
    } else {
        serde_json::to_vec(&mutate_json(base, picks)).unwrap()
    };
    write_temp(&text, name)
}

/// `text` with its bytes edited by `edits` (read back as UTF-8, lossily)
/// when `b`, else with the numbers `numbers` names replaced.
fn mangled_text(text: &str, edits: &[ByteEdit], numbers: &[(usize, String)], b: bool) -> String {
    if b {
        String::from_utf8_lossy(&apply_edits(text.as_bytes().to_vec(), edits)).into_owned()
    } else {
        replace_numbers(text, numbers)
    }
}

fn json_picks() -> impl Strategy<Value = Vec<(usize, Value, bool)>> {
    prop::collection::vec(
        (any::<usize>(), hostile_value(), prop::bool::weighted(0.2)),
        1..4,
    )
}

fn write_temp(bytes: &[u8], name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    (dir, p)
}

// ---- the valid files the mutations start from ----------------------------

fn base_profile() -> &'static Value {
    static V: OnceLock<Value> = OnceLock::new();
    V.get_or_init(|| {
        let m = preset("skin1").unwrap();
        let p = analytic::profile(
            &m,
            analytic::Model::Dipole,
            &RadialGrid::uniform(0.1, 3.0).unwrap(),
            &analytic::Options::default(),
        )
        .unwrap();
        serde_json::to_value(&p).unwrap()
    })
}

fn base_kernel() -> &'static Value {
    static V: OnceLock<Value> = OnceLock::new();
    V.get_or_init(|| {
        let text =
            std::fs::read_to_string(Path::new(REPO).join("kernels/marble-svd1.json")).unwrap();
        serde_json::from_str(&text).unwrap()
    })
}

/// Two shards of one small run (one channel, 2 chunks).
fn shards() -> &'static [Profile; 2] {
    static V: OnceLock<[Profile; 2]> = OnceLock::new();
    V.get_or_init(|| {
        let m = preset("skin1").unwrap();
        let cfg = McConfig {
            budget: PhotonBudget::Fixed(2 * mc::CHUNK),
            seed: 7,
            threads: Some(1),
            channels: vec![Channel::R],
            grid: Some(RadialGrid::uniform(0.2, 4.0).unwrap()),
        };
        let part = |k| {
            let opts = McOptions {
                shard: Some(Shard { k, n: 2 }),
                ..McOptions::default()
            };
            mc::simulate_with(&m, &cfg, &opts, &ssskit::progress::NoProgress).unwrap()
        };
        [part(1), part(2)]
    })
}

const MATERIAL: &str = "name = \"fuzz\"\nunit = \"mm\"\neta_above = 1.0\neta_below = 1.4\n\
[[layer]]\nsigma_a = [0.032, 0.17, 0.48]\nsigma_s_reduced = 0.74\ng = 0.8\neta = 1.4\n\
thickness = 0.2\n[[layer]]\nsigma_a = 0.01\nsigma_s = [2, 2.5, 3]\ng = [0.1, 0.2, 0.3]\neta = 1.37\n";

const MCI: &str = "1.0 # version\n2 # runs\nslab.mco A\n20000\n0.001 0.001\n10 100 1\n1\n1.0\n\
1.0 10 90 0.75 0.02\n1.0\n\nhalf.mco A\n1000\n0.01 0.01\n1 50 1\n1\n1.0\n\
1.4 1 100 0.9 1E8\n1.0\n";

/// A scene with every kind of object (the mesh is `cube.obj` beside it)
/// and both kinds of light.
const SCENE: &str = "unit = \"mm\"\n[camera]\ntype = \"perspective\"\nposition = [0, 0, 60]\n\
look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 30\nsize = [16, 12]\n[[light]]\ntype = \
\"directional\"\ntoward = [0.6, 0, 0.8]\nirradiance = 2\n[[light]]\ntype = \"environment\"\n\
radiance = 0.5\n[[object]]\nshape = \"sphere\"\ncenter = [0, 0, 0]\nradius = 4\nmaterial = \
\"skin1\"\neta = 1.3\n[[object]]\nname = \"slab\"\nshape = \"box\"\ncenter = [10, 0, 0]\n\
size = [3, 3, 3]\nmaterial = \"skin1\"\n[[object]]\nshape = \"mesh\"\nfile = \"cube.obj\"\n\
translate = [-10, 0, 0]\nmaterial = \"skin1\"\neta = 1\n[[object]]\nshape = \"cylinder\"\n\
center = [0, 10, 0]\nradius = 1\nheight = 2\naxis = [0, 1, 0]\nmaterial = \"skin1\"\neta = 1\n";

/// A closed cube of side 4 about the origin, faces as quads and a
/// comment, normals and texture coordinates that the reader skips.
const CUBE_OBJ: &str = "# cube\nv -2 -2 -2\nv 2 -2 -2\nv -2 2 -2\nv 2 2 -2\nv -2 -2 2\n\
v 2 -2 2\nv -2 2 2\nv 2 2 2\nvn 0 0 1\nvt 0 0\nf 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\n\
f 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

/// Longest a reader may take on one case. A case takes milliseconds; the
/// bound is far above that (a loaded CI machine) and far below a hang (a
/// reader that loops or waits on a pipe runs until the job is killed).
const CASE_SECONDS: f64 = 10.0;

/// Parses `scene` with `obj` as its `cube.obj`: an error, or a scene that
/// keeps its own rules (objects, finite bounds), within [`CASE_SECONDS`].
fn read_scene(scene: &str, obj: &[u8]) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), obj).unwrap();
    let start = std::time::Instant::now();
    let parsed = ssskit::scene::parse_scene_toml(scene, "fuzz.toml", dir.path());
    let secs = start.elapsed().as_secs_f64();
    prop_assert!(secs < CASE_SECONDS, "a case took {} s", secs);
    match parsed {
        Ok(s) => {
            prop_assert!(!s.objects.is_empty());
            let (lo, hi) = s.bounds();
            prop_assert!((0..3).all(|k| lo[k].is_finite() && hi[k].is_finite() && lo[k] < hi[k]));
        }
        Err(e) => prop_assert!(!e.to_string().is_empty()),
    }
    Ok(())
}

/// Numbers a hostile text puts where a number was.
fn hostile_number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("1e308".to_string()),
        Just("-1e308".to_string()),
        Just("1e-320".to_string()),
        Just("0".to_string()),
        Just("-0".to_string()),
        Just("99999999999999999999".to_string()),
        Just("18446744073709551615".to_string()),
        Just("1e19".to_string()),
        Just("0x10".to_string()),
        Just("[1, 2]".to_string()),
        Just("\"\\u001b[31m\"".to_string()),
        (-1e3f64..1e3).prop_map(|x| format!("{x}")),
    ]
}

/// `text` with its `k`-th numbers (by position among all numbers) replaced.
fn replace_numbers(text: &str, picks: &[(usize, String)]) -> String {
    let is_num = |c: char| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '-' | '+');
    let mut spans = Vec::new();
    let b: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() && (i == 0 || !b[i - 1].is_alphanumeric()) {
            let start = if i > 0 && b[i - 1] == '-' { i - 1 } else { i };
            let mut j = i;
            while j < b.len() && is_num(b[j]) {
                j += 1;
            }
            spans.push((start, j));
            i = j;
        } else {
            i += 1;
        }
    }
    if spans.is_empty() {
        return text.to_string();
    }
    let mut chosen: Vec<(usize, usize, &str)> = picks
        .iter()
        .map(|(k, s)| {
            let (a, z) = spans[k % spans.len()];
            (a, z, s.as_str())
        })
        .collect();
    chosen.sort_by_key(|c| std::cmp::Reverse(c.0));
    chosen.dedup_by_key(|c| c.0);
    let mut out = b;
    for (a, z, s) in chosen {
        out.splice(a..z, s.chars());
    }
    out.into_iter().collect()
}

fn number_picks() -> impl Strategy<Value = Vec<(usize, String)>> {
    prop::collection::vec((any::<usize>(), hostile_number()), 1..4)
}

/// A small image file of each kind, written by ssskit.
fn image_bytes(ext: &str) -> &'static [u8] {
    static EXR: OnceLock<Vec<u8>> = OnceLock::new();
    static PNG: OnceLock<Vec<u8>> = OnceLock::new();
    let make = |ext: &str| {
        let mut img = Image::new(9, 7);
        for (i, v) in img.rgb[1].iter_mut().enumerate() {
            *v = (i % 5) as f64 * 0.2;
        }
        img.alpha = Some(vec![0.5; 63]);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(format!("i.{ext}"));
        if ext == "exr" {
            write_exr(
                &p,
                &img,
                Some(&ssskit::filter::Plane {
                    width: 9,
                    height: 7,
                    data: vec![2.0; 63],
                }),
            )
            .unwrap();
        } else {
            write_image(&p, &img, PngDepth::Sixteen).unwrap();
        }
        std::fs::read(&p).unwrap()
    };
    match ext {
        "exr" => EXR.get_or_init(|| make("exr")),
        _ => PNG.get_or_init(|| make("png")),
    }
}

/// The scene and mesh the two scene properties start from are valid: the
/// properties mutate a file that parses, not one refused whatever the edit.
#[test]
fn the_base_scene_parses() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), CUBE_OBJ).unwrap();
    let s = ssskit::scene::parse_scene_toml(SCENE, "base.toml", dir.path()).unwrap();
    assert_eq!(s.objects.len(), 4);
}

// ---- the properties --------------------------------------------------------

proptest! {
    #![proptest_config(config())]

    /// Material TOML with bytes mangled or numbers replaced: an error, or
    /// a material that validates.
    #[test]
    fn material_toml(edits in byte_edits(), numbers in number_picks(), bytes in any::<bool>()) {
        let text = mangled_text(MATERIAL, &edits, &numbers, bytes);
        if let Ok(m) = parse_material_toml(&text, "fuzz.toml", "fuzz") {
            prop_assert!(m.validate("fuzz").is_ok());
            prop_assert!(!m.file_stem().contains('/'));
        }
    }

    /// Profile JSON with values replaced or removed, or bytes mangled:
    /// refused on read, or a profile that validates and fits a kernel (or
    /// refuses to).
    #[test]
    fn profile_json(picks in json_picks(), edits in byte_edits(), bytes in prop::bool::weighted(0.3)) {
        let (_d, path) = mangled_json_file(base_profile(), &picks, (&edits, bytes), "p.json");
        if let Ok(p) = Profile::read(&path) {
            prop_assert!(p.validate("again").is_ok());
            let spec = ssskit::kernel::Kernel2DSpec { size: Some(31), extent_mm: None };
            let svd = ssskit::kernel::Model::Svd { rank: 1, renormalize: false };
            if let Ok(k) = ssskit::kernel::fit_kernel_file(&p, &spec, &svd, 9) {
                prop_assert!(k.validate("fitted").is_ok());
            }
        }
    }

    /// Kernel JSON mutated: refused on read, or a kernel that validates and
    /// whose shader arrays hold no `inf` or `NaN` (or are refused).
    #[test]
    fn kernel_json(picks in json_picks(), edits in byte_edits(), bytes in prop::bool::weighted(0.3)) {
        let (_d, path) = mangled_json_file(base_kernel(), &picks, (&edits, bytes), "k.json");
        if let Ok(k) = KernelFile::read(&path) {
            prop_assert!(k.validate("again").is_ok());
            for lang in [Lang::Hlsl, Lang::Glsl, Lang::Wgsl] {
                if let Ok(src) = emit(&k, lang) {
                    prop_assert!(!src.contains("inf") && !src.contains("NaN"), "{}", src);
                }
            }
        }
    }

    /// A shard with its record mutated: the merge refuses it or gives the
    /// merged profile of the untouched shards (a mutation the record does
    /// not depend on).
    #[test]
    fn shard_json(picks in json_picks(), which in 0usize..2) {
        let [a, b] = shards();
        let mut parts = [serde_json::to_value(a).unwrap(), serde_json::to_value(b).unwrap()];
        let record = parts[which]["extra"]["shard"].clone();
        parts[which]["extra"]["shard"] = mutate_json(&record, &picks);
        let dir = tempfile::tempdir().unwrap();
        let mut merger = mc::ShardMerger::new();
        let mut refused = false;
        for (i, v) in parts.iter().enumerate() {
            let path = dir.path().join(format!("s{i}.json"));
            std::fs::write(&path, serde_json::to_vec(v).unwrap()).unwrap();
            match Profile::read(&path) {
                Ok(p) => refused |= merger.add(&path.display().to_string(), p).is_err(),
                Err(_) => refused = true,
            }
            if refused {
                break;
            }
        }
        if !refused {
            if let Ok(m) = merger.finish() {
                let clean = mc::merge_shards(&[("a".into(), a.clone()), ("b".into(), b.clone())]).unwrap();
                prop_assert_eq!(&m.rd, &clean.rd, "a changed shard merged into another result");
                prop_assert_eq!(&m.total_rd, &clean.total_rd);
            }
        }
    }

    /// MCML input with bytes mangled or numbers replaced: an error naming
    /// the file, or runs whose materials validate and whose grids are grids.
    #[test]
    fn mci(edits in byte_edits(), numbers in number_picks(), bytes in any::<bool>()) {
        let text = mangled_text(MCI, &edits, &numbers, bytes);
        match mc::mci::parse_mci(&text, "fuzz.mci") {
            Ok(runs) => {
                for r in runs {
                    prop_assert!(r.material.validate("run").is_ok());
                    prop_assert!(r.grid.check_edges().is_ok());
                    prop_assert!(r.photons > 0);
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("fuzz.mci"), "{}", e),
        }
    }

    /// EXR and PNG files with bytes mangled (headers first: most edits land
    /// in the first 200 bytes): an error, or an image within the size caps
    /// whose planes have its size.
    #[test]
    fn image_files(edits in byte_edits(), head in prop::collection::vec((0usize..200, any::<u8>()), 0..4), png in any::<bool>()) {
        let ext = if png { "png" } else { "exr" };
        let mut bytes = image_bytes(ext).to_vec();
        for (i, v) in head {
            let n = bytes.len();
            bytes[i % n] = v;
        }
        let bytes = apply_edits(bytes, &edits);
        let (_d, path) = write_temp(&bytes, &format!("i.{ext}"));
        if let Ok((img, _)) = read_image(&path, None) {
            let n = img.width * img.height;
            prop_assert!(ssskit::limits::check_image_size("i", img.width, img.height).is_ok());
            for c in 0..3 {
                prop_assert_eq!(img.rgb[c].len(), n);
            }
            if let Some(a) = &img.alpha {
                prop_assert_eq!(a.len(), n);
            }
        }
        let _ = ssskit::filter::image::read_plane(&path, None);
    }

    /// Scene TOML with bytes mangled or numbers replaced: an error, or a
    /// scene with objects and finite bounds, in bounded time.
    #[test]
    fn scene_toml(edits in byte_edits(), numbers in number_picks(), bytes in any::<bool>()) {
        let text = mangled_text(SCENE, &edits, &numbers, bytes);
        read_scene(&text, CUBE_OBJ.as_bytes())?;
    }

    /// The OBJ a scene names, bytes mangled or numbers replaced (a face
    /// index out of range, a coordinate of 1e308, a line cut): an error, or
    /// a scene that keeps its rules, in bounded time.
    #[test]
    fn obj_mesh(edits in byte_edits(), numbers in number_picks(), bytes in any::<bool>()) {
        let obj = if bytes {
            apply_edits(CUBE_OBJ.as_bytes().to_vec(), &edits)
        } else {
            replace_numbers(CUBE_OBJ, &numbers).into_bytes()
        };
        read_scene(SCENE, &obj)?;
    }
}
