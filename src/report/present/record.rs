//! Recorded measurements: numbers that a test cannot reproduce (wall times,
//! throughput, ratios against an external program) but that README.md and
//! docs/ must not copy by hand.
//!
//! A benchmark writes a record, `docs/records/NAME.json`, holding the command
//! that produced it, the machine, the date, its raw numbers and the tables it
//! renders. A markdown file shows table TABLE of record NAME between
//! `<!-- BEGIN record:NAME/TABLE -->` and `<!-- END record:NAME/TABLE -->`;
//! `tests/docs_fresh.rs` fails when a block differs from
//! [`Record::block`] of the committed record (`scripts/regen-docs` rewrites
//! the blocks), so every published timing traces back to one run.

use crate::error::{Error, Result};
use crate::report::present::table::Table;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

pub const SCHEMA: &str = "ssskit.record/1";

/// A table as recorded: a header and rows of already formatted cells.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct RecordTable {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl From<&Table> for RecordTable {
    fn from(t: &Table) -> RecordTable {
        RecordTable {
            header: t.header.clone(),
            rows: t.rows.clone(),
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Record {
    pub schema: String,
    /// The command line that produced the record, as a user would type it.
    pub command: String,
    /// UTC date of the run, YYYY-MM-DD.
    pub date: String,
    /// CPU model, cores, load, GPU adapter: whatever the numbers depend on.
    pub machine: String,
    /// Tables by name, as they appear in the docs.
    pub tables: BTreeMap<String, RecordTable>,
    /// The raw measurements behind the tables (free form, per benchmark).
    #[serde(default)]
    pub data: serde_json::Value,
}

impl Record {
    pub fn new(command: &str, machine: &str) -> Record {
        Record {
            schema: SCHEMA.to_string(),
            command: command.to_string(),
            date: today_utc(),
            machine: machine.to_string(),
            tables: BTreeMap::new(),
            data: serde_json::Value::Null,
        }
    }

    pub fn read(path: &Path) -> Result<Record> {
        let text = crate::io::read_text(path)?;
        let r: Record = serde_json::from_str(&text)
            .map_err(|e| Error::format(path, format!("not a record: {e}")))?;
        if r.schema != SCHEMA {
            return Err(Error::format(
                path,
                format!("schema '{}', expected '{SCHEMA}'", r.schema),
            ));
        }
        for (name, t) in &r.tables {
            if t.rows.iter().any(|row| row.len() != t.header.len()) {
                return Err(Error::format(
                    path,
                    format!("table '{name}': a row's length differs from the header's"),
                ));
            }
        }
        Ok(r)
    }

    /// Writes atomically (creating the folder) and reads the file back.
    pub fn write(&self, path: &Path) -> Result<()> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let text =
            serde_json::to_string_pretty(self).map_err(|e| Error::format(path, e.to_string()))?;
        crate::io::write_atomic(path, (text + "\n").as_bytes())?;
        let back = Record::read(path)?;
        if back.tables != self.tables {
            return Err(Error::format(
                path,
                "read back differs from what was written",
            ));
        }
        Ok(())
    }

    /// The body of block `table`: the markdown table and a provenance line.
    pub fn block(&self, table: &str) -> Option<String> {
        let t = self.tables.get(table)?;
        let md = Table {
            header: t.header.clone(),
            rows: t.rows.clone(),
        }
        .markdown();
        Some(format!(
            "{md}\n<sub>Recorded {} with `{}` on {}.</sub>\n",
            self.date, self.command, self.machine
        ))
    }
}

/// Where record `name` lives in this source tree:
/// `docs/records/<name>.json` (the benchmarks write there).
pub fn docs_path(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs/records")
        .join(format!("{name}.json"))
}

/// Today's UTC date from the system clock.
pub fn today_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    civil_date(secs.div_euclid(86_400))
}

/// The proleptic Gregorian date `days` after 1970-01-01, as YYYY-MM-DD
/// (civil-from-days, Hinnant 2013).
pub fn civil_date(days: i64) -> String {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// A one-line description of this machine for a record: CPU model and
/// logical cores, and the 1-minute load average (a loaded machine slows
/// every timing).
pub fn machine_line() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".to_string());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "?".to_string());
    format!("{cpu}, {cores} logical cores, load average {load} at the start")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_read_block() {
        let dir = tempfile::tempdir().unwrap();
        let mut r = Record::new("cargo bench --bench x", "test machine");
        let mut t = Table::new(&["a", "b"]);
        t.push(vec!["1".into(), "2".into()]);
        r.tables.insert("speed".into(), (&t).into());
        let p = dir.path().join("x.json");
        r.write(&p).unwrap();
        let back = Record::read(&p).unwrap();
        assert_eq!(back, r);
        let b = back.block("speed").unwrap();
        assert!(b.starts_with("| a | b |\n"), "{b}");
        assert!(b.contains("`cargo bench --bench x`"));
        assert!(back.block("other").is_none());
    }
}
