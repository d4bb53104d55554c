//! The advice's peak-memory record (`docs/records/advise-memory.json`,
//! written by `scripts/bench-memory advise` from `/usr/bin/time -v`): its
//! table is its data, and `advise` at 0.1 and 0.05 mm per pixel and the
//! main job each stay within the bound.

use ssskit::report::present::record::{docs_path, Record};

/// What the advice and the main job may hold at once on a small machine:
/// the bound the memory work was held to (at 0.05 mm per pixel a skin1
/// reference kernel is 801 pixels wide and the bootstrap replicates' 16
/// kernels and transforms, made all at once, took more than twice this).
const MAX_BYTES: f64 = 300.0 * 1024.0 * 1024.0;

/// The commands the script measures, as it records them.
const COMMANDS: [&str; 3] = [
    "advise --material skin1 --mm-per-pixel 0.1",
    "advise --material skin1 --mm-per-pixel 0.05",
    "kernels --material skin1 --out-dir DIR",
];

#[test]
fn the_advice_memory_record_is_its_data_and_within_the_bound() {
    let r = Record::read(&docs_path("advise-memory")).unwrap();
    assert_eq!(r.command, "scripts/bench-memory advise");
    let table = &r.tables["peak"];
    assert_eq!(table.rows.len(), COMMANDS.len());
    for (row, cmd) in table.rows.iter().zip(COMMANDS) {
        let peak = r.data["commands"][cmd]["peak_bytes"]
            .as_u64()
            .unwrap_or_else(|| panic!("no peak for {cmd}")) as f64;
        // The table shows the data, as the script rounds it.
        assert_eq!(row[0], format!("`ssskit {cmd}`"));
        assert_eq!(row[1], format!("{:.0}", peak / 1024.0 / 1024.0), "{cmd}");
        // A process that ran at all: the measure is not vacuous.
        assert!(peak > 1024.0 * 1024.0, "{cmd}: {peak}");
        assert!(
            peak <= MAX_BYTES,
            "{cmd}: peak {peak} B above {MAX_BYTES} B"
        );
    }
}
