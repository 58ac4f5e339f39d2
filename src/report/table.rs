//! The building blocks every section uses: a [`Table`] written both as Markdown (into the
//! README) and as CSV (under `tables/`), and the cell formats of times and small numbers.

use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A table: header and rows of cells, written both as Markdown and as CSV (`<name>.csv`).
pub(super) struct Table {
    pub(super) name: String,
    pub(super) header: Vec<String>,
    pub(super) rows: Vec<Vec<String>>,
}

impl Table {
    /// An empty table with these column headers.
    pub(super) fn new(name: impl Into<String>, header: &[&str]) -> Self {
        Self::with_header(name, header.iter().map(|s| s.to_string()).collect())
    }

    /// An empty table with computed column headers.
    pub(super) fn with_header(name: impl Into<String>, header: Vec<String>) -> Self {
        Self {
            name: name.into(),
            header,
            rows: Vec::new(),
        }
    }

    pub(super) fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "| {} |", self.header.join(" | "));
        let _ = writeln!(
            s,
            "|{}|",
            self.header
                .iter()
                .map(|_| "---")
                .collect::<Vec<_>>()
                .join("|")
        );
        for r in &self.rows {
            let _ = writeln!(s, "| {} |", r.join(" | "));
        }
        s
    }

    pub(super) fn write_csv(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join(format!("{}.csv", self.name));
        let mut w = csv::Writer::from_path(&path)?;
        w.write_record(&self.header)?;
        for r in &self.rows {
            w.write_record(r)?;
        }
        w.flush()?;
        Ok(path)
    }
}

/// A duration in seconds as `µs`, `ms` or `s`; `–` for none.
pub(super) fn fmt_time(s: Option<f64>) -> String {
    match s {
        None => "–".into(),
        Some(s) if s < 1e-3 => format!("{:.1} µs", s * 1e6),
        Some(s) if s < 1.0 => format!("{:.2} ms", s * 1e3),
        Some(s) => format!("{s:.2} s"),
    }
}

/// A number in scientific notation with one decimal; `0` and `–` as such.
pub(super) fn fmt_sci(v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(0.0) => "0".into(),
        Some(v) => format!("{v:.1e}"),
    }
}

/// ✓ all, ~ some, ✗ none of `total`.
pub(super) fn mark(ok: usize, total: usize) -> &'static str {
    if ok == total {
        "✓"
    } else if ok == 0 {
        "✗"
    } else {
        "~"
    }
}

/// A file-name-safe form of a case key or scene name.
pub(super) fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .trim_matches('_')
        .to_owned()
}
