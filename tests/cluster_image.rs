//! The image the Kubernetes recipe names, built by `scripts/image` with
//! buildah from scratch, and the recipe itself (`scripts/cluster/k8s-jobs`,
//! which docs/mc.md prints): the manifest parses as YAML into an indexed
//! Job and a merge Job; shard 1 of 2 runs in the image with the Job's own
//! command and environment (`buildah run`, JOB_COMPLETION_INDEX = 0), shard
//! 2 runs outside with `scripts/cluster/shard`, the merge Job's command
//! merges them in the image, and the result equals the single run outside,
//! bit for bit. The GPU path (Mesa's software Vulkan in the image) runs a
//! Monte Carlo on the GPU inside the container.
//!
//! buildah's storage lives in the test's temporary folder (vfs driver,
//! chroot isolation: no daemon, no registry, nothing outside the folder).

mod common;

use std::path::Path;
use std::process::Command;
use yaml_rust2::{Yaml, YamlLoader};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");
const TAG: &str = "localhost/ssskit-test:latest";

/// The run: small enough for a test, the same for every shard.
const SETTINGS: [(&str, &str); 5] = [
    ("MATERIAL", "skin1"),
    ("PHOTONS", "60000"),
    ("SEED", "5"),
    ("MAX_WORK", "1e11"),
    ("THREADS", "1"),
];
const SHARDS: usize = 2;

struct Buildah<'a> {
    storage: &'a Path,
}

impl Buildah<'_> {
    fn cmd(&self) -> Command {
        let mut c = Command::new("buildah");
        c.arg("--root")
            .arg(self.storage.join("root"))
            .arg("--runroot")
            .arg(self.storage.join("runroot"))
            .args(["--storage-driver", "vfs"]);
        c
    }

    fn ok(&self, args: &[&str]) -> String {
        let out = self.cmd().args(args).output().expect("buildah runs");
        assert!(
            out.status.success(),
            "buildah {args:?} failed:\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).trim().to_string()
    }
}

fn str_of<'a>(y: &'a Yaml, what: &str) -> &'a str {
    y.as_str()
        .unwrap_or_else(|| panic!("{what} is not a string: {y:?}"))
}

/// A container's command and environment from a Job of the manifest.
fn container(job: &Yaml) -> (Vec<String>, Vec<(String, String)>) {
    let c = &job["spec"]["template"]["spec"]["containers"][0];
    let command = c["command"]
        .as_vec()
        .expect("a command list")
        .iter()
        .map(|w| str_of(w, "a command word").to_string())
        .collect();
    let env = c["env"]
        .as_vec()
        .map(|v| {
            v.iter()
                .map(|e| {
                    (
                        str_of(&e["name"], "env name").to_string(),
                        str_of(&e["value"], "env value").to_string(),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    assert_eq!(
        c["volumeMounts"][0]["mountPath"].as_str(),
        Some("/out"),
        "the parts volume is mounted at /out"
    );
    assert_eq!(str_of(&c["image"], "image"), TAG);
    (command, env)
}

#[test]
fn a_shard_in_the_image_merges_with_one_outside() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let b = Buildah {
        storage: &d.join("storage"),
    };

    // The image, as scripts/image builds it (from this test's binary).
    let out = common::output_ok(
        Command::new(Path::new(ROOT).join("scripts/image"))
            .arg(TAG)
            .env("SSSKIT_IMAGE_STORAGE", b.storage)
            .env("SSSKIT_BIN", common::BIN),
        "scripts/image",
    );
    check_size_record(String::from_utf8_lossy(&out.stdout).trim());

    // The manifest of docs/mc.md for this run.
    let mut gen = Command::new(Path::new(ROOT).join("scripts/cluster/k8s-jobs"));
    gen.envs(SETTINGS)
        .env("SHARDS", SHARDS.to_string())
        .env("IMAGE", TAG);
    let yaml = String::from_utf8(gen.output().expect("k8s-jobs runs").stdout).unwrap();
    let docs = YamlLoader::load_from_str(&yaml).expect("the manifest is YAML");
    assert_eq!(docs.len(), 2, "an indexed Job and a merge Job");
    for (job, name) in docs.iter().zip(["ssskit-shards", "ssskit-merge"]) {
        assert_eq!(job["apiVersion"].as_str(), Some("batch/v1"));
        assert_eq!(job["kind"].as_str(), Some("Job"));
        assert_eq!(job["metadata"]["name"].as_str(), Some(name));
    }
    let shards = &docs[0];
    assert_eq!(shards["spec"]["completionMode"].as_str(), Some("Indexed"));
    assert_eq!(shards["spec"]["completions"].as_i64(), Some(SHARDS as i64));
    let (shard_cmd, env) = container(shards);
    let (merge_cmd, _) = container(&docs[1]);
    for (k, v) in SETTINGS {
        assert!(
            env.contains(&(k.to_string(), v.to_string())),
            "the Job sets {k}={v}: {env:?}"
        );
    }

    // Shard 1 in the image: the Job's command, index 0, the parts in /out.
    let parts = d.join("parts");
    std::fs::create_dir(&parts).unwrap();
    let ctr = b.ok(&["from", "--pull-never", TAG]);
    let volume = format!("{}:/out", parts.display());
    let run = |extra_env: &[(String, String)], cmd: &[String]| {
        let mut a: Vec<String> = ["run", "--isolation", "chroot", "-v", &volume]
            .iter()
            .map(|s| s.to_string())
            .collect();
        for (k, v) in extra_env {
            a.push("--env".into());
            a.push(format!("{k}={v}"));
        }
        a.push(ctr.clone());
        a.push("--".into());
        a.extend(cmd.iter().cloned());
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        b.ok(&a)
    };
    let mut shard_env = env.clone();
    shard_env.push(("JOB_COMPLETION_INDEX".into(), "0".into()));
    run(&shard_env, &shard_cmd);
    assert!(
        parts.join("part-1.json").is_file(),
        "the shard in the image wrote no part"
    );

    // Shard 2 outside, with the same script and settings.
    common::output_ok(
        Command::new(Path::new(ROOT).join("scripts/cluster/shard"))
            .args(["2", &SHARDS.to_string()])
            .envs(SETTINGS)
            .env("PARTS", &parts)
            .env("SSSKIT", common::BIN),
        "shard 2 outside",
    );

    // The merge Job's command in the image, against the single run outside.
    run(&[], &merge_cmd);
    let single = ["--max-work", "1e11", "--out", "single.json"];
    common::ok_in(d, &[&common::SHARDED_RUN[..], &single].concat());
    common::assert_same_run(&parts.join("skin1.json"), &d.join("single.json"));

    // The GPU path in the image: Mesa's software Vulkan, no GPU needed.
    let gpu = [
        "ssskit",
        "simulate",
        "--material",
        "skin1",
        "--photons",
        "20000",
        "--backend",
        "gpu",
        "--out",
        "/out/gpu.json",
    ]
    .map(String::from);
    run(&[], &gpu);
    let g = common::read_json(&parts.join("gpu.json"));
    assert_eq!(
        g["source"]["params"]["backend"].as_str(),
        Some("gpu"),
        "{}",
        g["source"]
    );
    b.ok(&["rm", &ctr]);
}

/// How far the image's size may move from the size docs/mc.md states
/// (record `image`) before the record must be renewed: Debian's point
/// releases of the libraries move it by a few MiB; a change in what goes in
/// (lavapipe's LLVM alone is over half of it) moves it far more.
const SIZE_TOLERANCE: f64 = 0.10;

/// `scripts/image` says "TAG ID SIZE MiB in N files"; the size docs/mc.md
/// states comes from record `image`, which `SSSKIT_BLESS=1` rewrites.
fn check_size_record(said: &str) {
    use ssskit::report::present::record::{self, Record, RecordTable};
    let words: Vec<&str> = said.split_whitespace().collect();
    assert!(
        words.len() == 7 && words[0] == TAG && words[3] == "MiB",
        "scripts/image says what it built: {said}"
    );
    let (mib, files): (f64, u64) = (words[2].parse().unwrap(), words[5].parse().unwrap());
    let path = record::docs_path("image");
    if common::bless() {
        let mut r = Record::new("scripts/image", &record::machine_line());
        r.tables.insert(
            "image".into(),
            RecordTable {
                header: ["image", "size MiB", "files"].map(String::from).to_vec(),
                rows: vec![vec![
                    "ssskit:latest".into(),
                    format!("{mib:.0}"),
                    files.to_string(),
                ]],
            },
        );
        r.write(&path).unwrap();
    }
    let r = Record::read(&path).unwrap();
    let stated: f64 = r.tables["image"].rows[0][1].parse().unwrap();
    assert!(
        (mib - stated).abs() <= SIZE_TOLERANCE * stated,
        "the image is {mib} MiB, docs/mc.md states {stated} MiB (SSSKIT_BLESS=1 cargo test --release --test cluster_image renews the record)"
    );
}
