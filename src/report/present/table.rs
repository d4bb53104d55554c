//! Tables as markdown and CSV, written atomically.

use crate::error::Result;
use std::path::Path;

/// A table of strings with a header row.
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new(header: &[&str]) -> Table {
        Table {
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    /// GitHub markdown; numbers are right-aligned by the caller's format.
    pub fn markdown(&self) -> String {
        let mut s = format!("| {} |\n", self.header.join(" | "));
        s += &format!("|{}\n", " --- |".repeat(self.header.len()));
        for r in &self.rows {
            s += &format!("| {} |\n", r.join(" | "));
        }
        s
    }

    /// RFC 4180 CSV (fields with commas, quotes or newlines are quoted).
    pub fn csv(&self) -> String {
        let field = |f: &String| {
            if f.contains([',', '"', '\n']) {
                format!("\"{}\"", f.replace('"', "\"\""))
            } else {
                f.clone()
            }
        };
        let line = |r: &Vec<String>| r.iter().map(field).collect::<Vec<_>>().join(",");
        let mut s = line(&self.header) + "\n";
        for r in &self.rows {
            s += &(line(r) + "\n");
        }
        s
    }

    pub fn write_markdown(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, self.markdown().as_bytes())
    }

    pub fn write_csv(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, self.csv().as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_and_markdown_shape() {
        let mut t = Table::new(&["a", "b"]);
        t.push(vec!["1,5".into(), "x\"y".into()]);
        assert_eq!(t.csv(), "a,b\n\"1,5\",\"x\"\"y\"\n");
        assert_eq!(t.markdown().lines().count(), 3);
    }
}
