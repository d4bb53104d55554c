//! Shards of one Monte Carlo run merge into exactly the single run (the real
//! binary), and merges of parts that are not one run are refused.

mod common;

use common::{fails_with_in as fails_with, ok_in as ok};
use std::path::Path;

/// The JSON of a profile without its wall time.
fn json_without_time(path: &Path) -> serde_json::Value {
    let mut v = common::read_json(path);
    v["elapsed_s"] = serde_json::json!(0.0);
    v
}

const RUN: [&str; 7] = common::SHARDED_RUN;

fn run_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v: Vec<&str> = RUN.to_vec();
    v.extend_from_slice(extra);
    v
}

#[test]
fn shards_merge_bit_identically() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(d, &run_args(&["--out", "full.json"]));
    let full = json_without_time(&d.join("full.json"));
    for n in [1usize, 2, 7] {
        let mut parts = Vec::new();
        for k in 1..=n {
            let shard = format!("{k}/{n}");
            let out = format!("part-{k}-{n}.json");
            // Shards on one thread, the single run on all: sums are exact.
            ok(
                d,
                &run_args(&["--shard", &shard, "--threads", "1", "--out", &out]),
            );
            parts.push(out);
        }
        // Any order.
        parts.reverse();
        let merged = format!("merged-{n}.json");
        let mut args = vec!["merge"];
        args.extend(parts.iter().map(|s| s.as_str()));
        args.extend(["--out", &merged]);
        ok(d, &args);
        assert_eq!(
            json_without_time(&d.join(&merged)),
            full,
            "{n} shards differ from the single run"
        );
        // A shard alone is a valid, smaller profile that says what it is.
        let p = ssskit::profile::Profile::read(&d.join(&parts[0])).unwrap();
        assert!(p.warnings().unwrap().join("\n").contains("partial profile"));
    }
}

#[test]
fn bad_merges_and_shards_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shard = |k: &str, photons: &str, seed: &str, extra: &[&str], out: &str| {
        let mut a = vec![
            "simulate",
            "--material",
            "skin1",
            "--photons",
            photons,
            "--seed",
            seed,
            "--shard",
            k,
            "--out",
            out,
        ];
        a.extend_from_slice(extra);
        ok(d, &a);
    };
    shard("1/2", "60000", "5", &[], "a1.json");
    shard("2/2", "60000", "6", &[], "seed.json");
    shard("2/2", "70000", "5", &[], "photons.json");
    shard("2/2", "60000", "5", &["--dr", "0.01"], "grid.json");
    shard(
        "2/2",
        "60000",
        "5",
        &["--roulette", "0.05"],
        "roulette.json",
    );
    shard("1/3", "60000", "5", &[], "b1.json");
    ok(
        d,
        &[
            "simulate",
            "--material",
            "marble",
            "--photons",
            "60000",
            "--seed",
            "5",
            "--shard",
            "2/2",
            "--out",
            "marble.json",
        ],
    );
    ok(d, &run_args(&["--out", "full.json"]));
    // `merge PARTS --out m.json` must fail naming `needles`.
    let merge_fails = |parts: &[&str], needles: &[&str]| {
        fails_with(
            d,
            &[&["merge"][..], parts, &["--out", "m.json"]].concat(),
            needles,
        );
    };
    // Parts that are not the shards of one run.
    #[rustfmt::skip] // one line a case: the table reads as one
    let mixed: [(&[&str], &[&str]); 8] = [
        (&["a1.json", "seed.json"], &["seed.json", "different seeds"]),
        (&["a1.json", "marble.json"], &["different materials"]),
        (&["a1.json", "photons.json"], &["different photon totals"]),
        (&["a1.json", "grid.json"], &["different radial grids"]),
        (&["a1.json", "roulette.json"], &["different simulation settings", "roulette"]),
        (&["a1.json", "b1.json"], &["different numbers of shards"]),
        (&["a1.json", "a1.json"], &["1/2 given twice", "overlap"]),
        (&["a1.json"], &["missing shard(s) 2 (a2.json) of 2"]),
    ];
    for (parts, needles) in mixed {
        merge_fails(parts, needles);
    }
    // An empty part (a shard killed before an atomic write could not leave
    // one, but a copy can) and a part of an older schema are refused by name.
    std::fs::write(d.join("a2.json"), "").unwrap();
    merge_fails(&["a1.json", "a2.json"], &["a2.json"]);
    let mut old: serde_json::Value = common::read_json(&d.join("a1.json"));
    old["schema"] = "ssskit.profile/0".into();
    std::fs::write(d.join("old.json"), old.to_string()).unwrap();
    merge_fails(&["old.json", "seed.json"], &["old.json", "schema"]);
    merge_fails(&["a1.json", "full.json"], &["full.json", "not a shard"]);
    merge_fails(&["a1.json", "none.json"], &["none.json"]);
    assert!(!d.join("m.json").exists());
    // Shards need a fixed total and a valid K/N.
    fails_with(
        d,
        &["simulate", "--material", "skin1", "--shard", "1/2"],
        &["--shard needs --photons"],
    );
    fails_with(d, &run_args(&["--shard", "3/2"]), &["--shard", "3/2"]);
    fails_with(d, &run_args(&["--shard", "0/2"]), &["--shard"]);
    fails_with(
        d,
        &run_args(&["--shard", "1/100"]),
        &["--shard", "1/100", "chunks"],
    );
}
