//! The 8K peak-memory record (`docs/records/filter-memory.json`, written by
//! `scripts/bench-memory` from `/usr/bin/time -v`): its table is its data,
//! and every CLI path it measures (all filter in place) stays within the
//! bound docs/filter.md states.

use ssskit::report::present::record::{docs_path, Record};

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
