//! What a benchmark does with its results at the end: the record
//! `docs/records/NAME.json` that the docs' `record:` blocks show (see
//! `ssskit::report::present::record`).

use ssskit::report::present::record::{docs_path, Record};
use ssskit::report::present::table::Table;

/// Adds `tables` (name, table) and the raw `data` to `record`, writes it
/// as `docs/records/NAME.json` and says where on stderr.
pub fn write(mut record: Record, name: &str, tables: &[(&str, &Table)], data: serde_json::Value) {
    for (key, table) in tables {
        record.tables.insert(key.to_string(), (*table).into());
    }
    record.data = data;
    let path = docs_path(name);
    record.write(&path).expect("record written");
    eprintln!("wrote {}", path.display());
}
