//! The 8K peak-memory record (`docs/records/filter-memory.json`, written by
//! `scripts/bench-memory` from `/usr/bin/time -v`): its table is its data,
//! and every CLI path it measures (all filter in place) stays within the
//! bound docs/filter.md states. The paths are rerun here, from the
//! record's own arguments, on two small images: the memory they add per
//! byte of image, measured now, stays within the same bound.

mod common;

use ssskit::report::present::record::{docs_path, Record};
use std::path::Path;

/// Every path's bound, in units of the image's own f32 RGB size
/// (7680 x 4320 x 3 x 4 B = 398 MB): the f64 image itself is 2 of them,
/// and reading the EXR holds its decoded f32 planes (1 more) while they are
/// converted plane by plane, the largest moment of a fixed-kernel run; the
/// depth-aware path's f64 depth plane is 2/3 of a unit, and the per-pixel
/// paths' windows of rows a few hundredths.
const IN_PLACE_MAX_RATIO: f64 = 3.0;

/// The paths the script measures, by the names it records them under.
const PATHS: [&str; 5] = ["default", "f64", "full-factors", "depth-aware", "disk"];

#[test]
fn the_memory_record_is_its_data_and_every_path_stays_within_three_images() {
    let r = Record::read(&docs_path("filter-memory")).unwrap();
    assert_eq!(r.command, "scripts/bench-memory");
    let d = &r.data;
    let (w, h) = (d["width"].as_u64().unwrap(), d["height"].as_u64().unwrap());
    let image = d["image_f32_rgb_bytes"].as_u64().unwrap();
    assert_eq!((w, h, image), (7680, 4320, w * h * 3 * 4));
    let table = &r.tables["peak"];
    assert_eq!(table.rows.len(), PATHS.len());
    for (row, path) in table.rows.iter().zip(PATHS) {
        let peak = d["paths"][path]["peak_bytes"].as_u64().unwrap_or_else(|| {
            panic!("no peak for path {path}");
        }) as f64;
        // The table shows the data, as the script rounds it.
        assert_eq!(row[1], format!("{:.0}", peak / 1e6), "{path}");
        assert_eq!(row[2], format!("{:.2}", peak / image as f64), "{path}");
        // At least the f64 image itself: the measure is not vacuous.
        assert!(peak >= 2.0 * image as f64, "{path}: {peak}");
        assert!(
            peak <= IN_PLACE_MAX_RATIO * image as f64,
            "{path}: peak {peak} B is above {IN_PLACE_MAX_RATIO} x {image} B"
        );
    }
}

/// The images of the rerun, of one width: what a path holds per row of
/// the image (the per-pixel paths' windows of rows, the kernel's span)
/// is the same in both, so their difference, 960 x 840 pixels of f32 RGB
/// (9.7 MB), is what the slope is measured over; the small one also holds
/// what does not grow with the image (the binary, thread stacks).
const SMALL: (u64, u64) = (960, 120);
const LARGE: (u64, u64) = (960, 960);

/// Peak resident memory of `ssskit args...` in bytes, from the kernel's
/// own count (getrusage of the child, `ru_maxrss` in KiB on Linux), read
/// through python3 as /usr/bin/time does it.
fn peak_rss(dir: &Path, args: &[String]) -> f64 {
    let o = std::process::Command::new("python3")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "-c",
            "import resource, subprocess, sys\n\
             r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)\n\
             sys.stderr.write(r.stderr.decode())\n\
             print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n\
             sys.exit(r.returncode)",
            common::BIN,
        ])
        .args(args)
        .env("TMPDIR", dir)
        .output()
        .expect("python3 runs");
    assert!(o.status.success(), "{args:?}: {}", common::stderr(&o));
    common::stdout(&o).trim().parse::<f64>().unwrap() * 1024.0
}

#[test]
fn every_recorded_path_adds_at_most_three_images_now() {
    let r = Record::read(&docs_path("filter-memory")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let disk = out.join("disk.json");
    common::ok(&[
        "fit",
        "--profile",
        "profiles/reference/skin1.json",
        "--model",
        "disk",
        "--samples",
        "32",
        "--out",
        common::p(&disk),
    ]);
    let image = |(w, h): (u64, u64)| {
        let f = out.join(format!("in{w}x{h}.exr"));
        common::ok(&[
            "signal",
            "checker",
            "--image-size",
            &format!("{w}x{h}"),
            "--out",
            common::p(&f),
        ]);
        (f, (w * h * 3 * 4) as f64)
    };
    let (small, large) = (image(SMALL), image(LARGE));
    let grown = large.1 - small.1;
    for path in PATHS {
        let recorded = r.data["paths"][path]["args"].as_str().unwrap();
        let peak = |(input, _): &(std::path::PathBuf, f64)| {
            // The record's arguments, OUT its folder (here: this one, the
            // depth read from the input itself as the script does).
            let mut args: Vec<String> = vec!["apply".into()];
            for a in recorded.split(' ') {
                args.push(if a == "OUT/in.exr" {
                    input.display().to_string()
                } else {
                    a.replace("OUT", &out.display().to_string())
                });
            }
            let rest = ["--input", common::p(input), "--out"];
            args.extend(rest.map(String::from));
            args.push(out.join("out.exr").display().to_string());
            args.extend(["--mm-per-pixel", "0.1", "--backend", "cpu"].map(String::from));
            peak_rss(out, &args)
        };
        let slope = (peak(&large) - peak(&small)) / grown;
        eprintln!("{path}: {slope:.2} bytes per byte of f32 RGB image");
        // The f64 image itself is 2: a path that holds less measured
        // nothing.
        assert!(slope >= 2.0, "{path}: {slope}");
        assert!(
            slope <= IN_PLACE_MAX_RATIO,
            "{path}: {slope} bytes per image byte, above {IN_PLACE_MAX_RATIO}"
        );
    }
}
