//! The Slurm recipe of docs/mc.md, run as written on a one-node cluster of
//! the test's own (munge and Slurm started in a temporary folder, stopped
//! when the test ends, passed or failed): `scripts/cluster/slurm-submit`
//! submits a job array of shards (`scripts/cluster/shard`) and a merge that
//! depends on them; the merged profile must equal the single run bit for
//! bit, and a shard that fails must be named by the merge. docs/mc.md
//! prints those two files (a `file:` block, tests/docs_files.rs), so the
//! docs and this test run the same lines.

mod common;
#[path = "common/slurm.rs"]
mod slurm;

use std::path::Path;
use std::time::Duration;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// A run small enough for a test (skin1, 60,000 photons per channel in 4
/// shards of 2 chunks each is a fraction of a second per shard) and the
/// same settings for the single run it must equal.
const MATERIAL: &str = "skin1";
const PHOTONS: &str = "60000";
const SEED: &str = "5";
const SHARDS: &str = "4";
/// The shard script's default work cap (`MAX_WORK`): the single run must
/// have the same, since the profile records it.
const MAX_WORK: &str = "1e11";

/// Jobs of a few seconds each on an idle node; a loaded CI machine gets
/// ample slack before the test calls the cluster stuck.
const JOB_TIMEOUT: Duration = Duration::from_secs(180);

/// Submits the recipe in `dir` with `ssskit` as the binary and returns the
/// array's and the merge's job ids.
fn submit(c: &slurm::Cluster, dir: &Path, ssskit: &Path) -> Vec<String> {
    let out = c
        .command(Path::new(ROOT).join("scripts/cluster/slurm-submit"))
        .current_dir(dir)
        .env("MATERIAL", MATERIAL)
        .env("PHOTONS", PHOTONS)
        .env("SEED", SEED)
        .env("SHARDS", SHARDS)
        .env("SSSKIT", ssskit)
        .output()
        .expect("slurm-submit runs");
    assert!(
        out.status.success(),
        "slurm-submit failed: {}\n{}",
        String::from_utf8_lossy(&out.stderr),
        c.logs()
    );
    let ids: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .map(str::to_string)
        .collect();
    assert_eq!(
        ids.len(),
        2,
        "slurm-submit prints the array's and the merge's job ids"
    );
    ids
}

#[test]
fn the_docs_slurm_recipe_merges_to_the_single_run() {
    let c = slurm::Cluster::start();
    let single = slurm::work_dir(&c, "single");
    common::ok_in(
        &single,
        &[
            "simulate",
            "--material",
            MATERIAL,
            "--photons",
            PHOTONS,
            "--seed",
            SEED,
            "--max-work",
            MAX_WORK,
            "--out",
            "single.json",
        ],
    );

    // The recipe as written: every shard, then the merge.
    let run = slurm::work_dir(&c, "run");
    let jobs = submit(&c, &run, Path::new(common::BIN));
    c.wait_jobs(&jobs, JOB_TIMEOUT);
    let merged = run.join(format!("{MATERIAL}.json"));
    let merge_log = std::fs::read_to_string(run.join("merge.log")).unwrap_or_default();
    assert!(
        merged.is_file(),
        "no merged profile; merge.log:\n{merge_log}\n{}",
        c.logs()
    );
    let shards: usize = SHARDS.parse().unwrap();
    for k in 1..=shards {
        assert!(
            run.join(format!("part-{k}.json")).is_file(),
            "part-{k}.json missing"
        );
    }
    common::assert_same_run(&merged, &single.join("single.json"));

    // Shard 3 fails (its binary exits 1 under Slurm): the merge still runs
    // (afterany) and names the shard by number and by the part it expected.
    let failing = slurm::work_dir(&c, "failing");
    let wrapper = failing.join("ssskit-fails-on-3");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/sh\n[ \"$SLURM_ARRAY_TASK_ID\" = 3 ] && exit 1\nexec '{}' \"$@\"\n",
            common::BIN
        ),
    )
    .unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    let jobs = submit(&c, &failing, &wrapper);
    c.wait_jobs(&jobs, JOB_TIMEOUT);
    let log = std::fs::read_to_string(failing.join("merge.log")).unwrap_or_default();
    assert!(
        log.contains("missing shard(s) 3 (part-3.json) of 4"),
        "the merge does not name the failed shard; merge.log:\n{log}"
    );
    assert!(
        !failing.join(format!("{MATERIAL}.json")).exists(),
        "a merge of 3 of 4 shards was written"
    );
}

/// Not a check: the scaling record of docs/mc.md (`docs/records/mc-scaling.json`),
/// which `scripts/bench-cluster` runs on an idle machine. The recipe as
/// written at a reference-grade photon count for several shard counts on
/// the one-node cluster, against one process using the whole node; each
/// merge is also checked against that single run, bit for bit.
#[test]
#[ignore = "a benchmark: scripts/bench-cluster"]
fn record_scaling() {
    use ssskit::report::present::record::{self, Record, RecordTable};
    use std::time::Instant;
    let env = |k: &str, d: &str| std::env::var(k).unwrap_or_else(|_| d.to_string());
    let material = env("MATERIAL", "marble");
    let photons = env("PHOTONS", "1e8");
    let counts: Vec<usize> = env("SHARD_COUNTS", "8,16,32,64")
        .split(',')
        .map(|s| s.trim().parse().expect("SHARD_COUNTS: numbers"))
        .collect();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let c = slurm::Cluster::start();
    let single = slurm::work_dir(&c, "single");
    let t0 = Instant::now();
    common::ok_in(
        &single,
        &[
            "simulate",
            "--material",
            &material,
            "--photons",
            &photons,
            "--seed",
            "7",
            "--max-work",
            MAX_WORK,
            "--threads",
            &cpus.to_string(),
            "--out",
            "single.json",
        ],
    );
    let one = t0.elapsed().as_secs_f64();
    let mut rows = vec![vec![
        "1 process".to_string(),
        format!("{cpus}"),
        format!("{one:.1}"),
        "-".into(),
        "-".into(),
        "1".into(),
    ]];
    let mut data = Vec::new();
    for n in counts {
        let dir = slurm::work_dir(&c, &format!("shards-{n}"));
        let t0 = Instant::now();
        let out = common::output_ok(
            c.command(Path::new(ROOT).join("scripts/cluster/slurm-submit"))
                .current_dir(&dir)
                .envs([
                    ("MATERIAL", material.as_str()),
                    ("PHOTONS", &photons),
                    ("SEED", "7"),
                ])
                .env("SHARDS", n.to_string())
                .env("SSSKIT", common::BIN),
            "slurm-submit",
        );
        let jobs: Vec<String> = String::from_utf8_lossy(&out.stdout)
            .split_whitespace()
            .map(str::to_string)
            .collect();
        c.wait_jobs(&jobs, Duration::from_secs(24 * 3600));
        let wall = t0.elapsed().as_secs_f64();
        let merged = dir.join(format!("{material}.json"));
        common::assert_same_run(&merged, &single.join("single.json"));
        let mut shard_s: Vec<f64> = (1..=n)
            .map(|k| {
                common::read_json(&dir.join(format!("part-{k}.json")))["elapsed_s"]
                    .as_f64()
                    .unwrap()
            })
            .collect();
        shard_s.sort_by(f64::total_cmp);
        // The merge once more outside Slurm, timed to the millisecond (the
        // scheduler's own times are whole seconds).
        let parts: Vec<String> = (1..=n).map(|k| format!("part-{k}.json")).collect();
        let mut args = vec!["merge"];
        args.extend(parts.iter().map(String::as_str));
        args.extend(["--out", "again.json"]);
        let t0 = Instant::now();
        common::ok_in(&dir, &args);
        let merge = t0.elapsed().as_secs_f64();
        rows.push(vec![
            format!("{n} shards"),
            format!("{cpus}"),
            format!("{wall:.1}"),
            format!(
                "{:.2} - {:.2} - {:.2}",
                shard_s[0],
                shard_s[n / 2],
                shard_s[n - 1]
            ),
            format!("{merge:.2}"),
            format!("{:.2}", one / wall),
        ]);
        data.push(
            serde_json::json!({"shards": n, "wall_s": wall, "shard_s": shard_s, "merge_s": merge}),
        );
    }
    let mut r = Record::new(
        &format!("MATERIAL={material} PHOTONS={photons} scripts/bench-cluster"),
        &record::machine_line(),
    );
    r.tables.insert(
        "scaling".into(),
        RecordTable {
            header: [
                "run",
                "CPUs",
                "wall s (submit to merged)",
                "shard wall s (min - median - max)",
                "merge s",
                "efficiency vs 1 process",
            ]
            .map(String::from)
            .to_vec(),
            rows,
        },
    );
    r.data = serde_json::json!({"material": material, "photons_per_channel": photons, "one_process_s": one, "runs": data});
    r.write(&record::docs_path("mc-scaling")).unwrap();
}
