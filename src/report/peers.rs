//! Figures of peer engines on lcpbench's scenes, quoted beside lcpbench's rows: the
//! `docs/peers/*.csv` files, one row per (scene, setting) measured with the programs of
//! `../shared/peers/`.
//!
//! A peer file is a CSV table after one or more comment lines starting with `#` (what was
//! measured, with which program, on which machine), with the header [`PEER_COLUMNS`]: the
//! scene (file stem), the peer's substeps and iterations, its whole step time, the sag, lateral
//! drift, joint drift and largest displacement it reached (metres), the date of the
//! measurement and the command that measures it. An empty cell was not measured; a cell
//! written `<=x` (or `≤x`) is a bound. The files are built into lcpbench (so a report always
//! shows the figures of its checkout); [`parse_peers`] reads one and refuses a damaged one,
//! naming the file, line and column.

use anyhow::{bail, Result};

/// Rapier's figures: `docs/peers/rapier.csv`.
pub const RAPIER_FILE: &str = "docs/peers/rapier.csv";

/// The text of [`RAPIER_FILE`] as built into this lcpbench.
pub const RAPIER_TEXT: &str = include_str!("../../docs/peers/rapier.csv");

/// The name the report gives Rapier's rows.
pub const RAPIER_NAME: &str = "Rapier 0.36";

/// The header of a peer file, in order.
pub const PEER_COLUMNS: [&str; 10] = [
    "scene",
    "substeps",
    "iterations",
    "step_time_s",
    "sag_m",
    "drift_m",
    "joint_drift_m",
    "max_displacement_m",
    "measured",
    "command",
];

/// Largest peer file read, bytes (a few rows per scene).
const MAX_PEER_BYTES: usize = 1 << 20;

/// A measured value, or a bound on it (`<=x`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeerValue {
    /// The value (or the bound).
    pub value: f64,
    /// True when the file gives only an upper bound.
    pub bound: bool,
}

/// One row of a peer file.
#[derive(Debug, Clone, PartialEq)]
pub struct PeerRow {
    /// Scene (file stem, as lcpbench's case names it).
    pub scene: String,
    /// The peer's substeps per step.
    pub substeps: Option<usize>,
    /// Its solver iterations per substep.
    pub iterations: Option<usize>,
    /// Its whole step's wall time, seconds.
    pub step_time_s: Option<PeerValue>,
    /// Sag (stacks: the top body's drop; chains: the end mass's), metres.
    pub sag_m: Option<PeerValue>,
    /// Lateral drift of the top body, metres.
    pub drift_m: Option<PeerValue>,
    /// Largest joint error, metres.
    pub joint_drift_m: Option<PeerValue>,
    /// Largest displacement of a body from its start, metres.
    pub max_displacement_m: Option<PeerValue>,
    /// Date of the measurement (`YYYY-MM-DD`).
    pub measured: String,
    /// The command that measures the row.
    pub command: String,
}

/// The header comment of a peer file: its lines starting with `#`, without the `#`, joined.
pub fn peer_source(text: &str) -> String {
    text.lines()
        .take_while(|l| l.starts_with('#'))
        .map(|l| l.trim_start_matches('#').trim())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Read the rows of a peer file's `text`; `file` names it in errors. A header that is not
/// [`PEER_COLUMNS`], a row with another cell count, a number that is not a finite
/// non-negative value (or a bound on one), a count that is not a whole number, or a date that
/// is not `YYYY-MM-DD` is refused with the file, line and column named.
pub fn parse_peers(text: &str, file: &str) -> Result<Vec<PeerRow>> {
    if text.len() > MAX_PEER_BYTES {
        bail!(
            "{file}: {} bytes, above the limit of {MAX_PEER_BYTES} for a peer file",
            text.len()
        );
    }
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .flexible(true)
        .from_reader(text.as_bytes());
    let header: Vec<String> = match reader.headers() {
        Ok(h) => h.iter().map(str::to_owned).collect(),
        Err(e) => bail!("{file}: the header does not read: {e}"),
    };
    if header != PEER_COLUMNS {
        bail!(
            "{file}: the header is `{}`, expected `{}`",
            header.join(","),
            PEER_COLUMNS.join(",")
        );
    }
    let mut rows = Vec::new();
    for record in reader.records() {
        let record = match record {
            Ok(r) => r,
            Err(e) => bail!("{file}: {e}"),
        };
        let line = record.position().map_or(0, |p| p.line());
        if record.len() != PEER_COLUMNS.len() {
            bail!(
                "{file}: line {line}: {} cells where the header has {}",
                record.len(),
                PEER_COLUMNS.len()
            );
        }
        let cell = |k: usize| record.get(k).unwrap_or("").trim();
        let value = |k: usize| -> Result<Option<PeerValue>> {
            parse_value(cell(k))
                .map_err(|e| anyhow::anyhow!("{file}: line {line}: `{}`: {e}", PEER_COLUMNS[k]))
        };
        let count = |k: usize| -> Result<Option<usize>> {
            let c = cell(k);
            if c.is_empty() {
                return Ok(None);
            }
            c.parse::<usize>().map(Some).map_err(|_| {
                anyhow::anyhow!(
                    "{file}: line {line}: `{}`: `{c}` is not a whole number",
                    PEER_COLUMNS[k]
                )
            })
        };
        let scene = cell(0);
        if scene.is_empty() {
            bail!("{file}: line {line}: `scene` is empty");
        }
        let measured = cell(8);
        if !is_date(measured) {
            bail!("{file}: line {line}: `measured`: `{measured}` is not a date YYYY-MM-DD");
        }
        rows.push(PeerRow {
            scene: scene.to_owned(),
            substeps: count(1)?,
            iterations: count(2)?,
            step_time_s: value(3)?,
            sag_m: value(4)?,
            drift_m: value(5)?,
            joint_drift_m: value(6)?,
            max_displacement_m: value(7)?,
            measured: measured.to_owned(),
            command: cell(9).to_owned(),
        });
    }
    Ok(rows)
}

/// A cell: empty, a finite non-negative number, or `<=x` / `≤x` for a bound.
fn parse_value(cell: &str) -> Result<Option<PeerValue>, String> {
    if cell.is_empty() {
        return Ok(None);
    }
    let (text, bound) = match cell.strip_prefix("<=").or_else(|| cell.strip_prefix('≤')) {
        Some(rest) => (rest.trim(), true),
        None => (cell, false),
    };
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(Some(PeerValue { value: v, bound })),
        _ => Err(format!(
            "`{cell}` is not a finite non-negative number (or `<=` one)"
        )),
    }
}

/// `YYYY-MM-DD` with a month 1–12 and a day 1–31.
fn is_date(s: &str) -> bool {
    let parts: Vec<&str> = s.split('-').collect();
    let [y, m, d] = parts[..] else {
        return false;
    };
    let num = |t: &str, len: usize| -> Option<u32> {
        (t.len() == len && t.bytes().all(|b| b.is_ascii_digit()))
            .then(|| t.parse().ok())
            .flatten()
    };
    matches!(
        (num(y, 4), num(m, 2), num(d, 2)),
        (Some(_), Some(1..=12), Some(1..=31))
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The file built in reads, with its source comment and the quoted figures.
    #[test]
    fn the_rapier_file_reads() {
        let rows = parse_peers(RAPIER_TEXT, RAPIER_FILE).unwrap();
        assert!(!rows.is_empty());
        assert!(peer_source(RAPIER_TEXT).contains("rapier_scenes.rs"));
        let tower = rows.iter().find(|r| r.scene == "tower_40_60hz").unwrap();
        assert!(tower.step_time_s.is_some() && tower.sag_m.is_some());
        let pyramid = rows.iter().find(|r| r.scene == "pyramid_3d_1015").unwrap();
        assert!(pyramid.max_displacement_m.is_some_and(|v| v.value < 0.01));
        // A bound is written `<=x`.
        let text = format!(
            "# quoted\n{}\npyramid_3d_1015,4,1,5.3e-3,,,,<=0.005,2026-12-05,cmd\n",
            RAPIER_TEXT.lines().nth(1).unwrap()
        );
        let bound = parse_peers(&text, RAPIER_FILE)
            .unwrap()
            .into_iter()
            .find_map(|r| r.max_displacement_m.filter(|v| v.bound));
        assert_eq!(
            bound,
            Some(PeerValue {
                value: 0.005,
                bound: true
            })
        );
    }

    /// Damaged files are refused with the file, line and column named.
    #[test]
    fn damaged_peer_files_are_refused_naming_line_and_column() {
        let head = format!("# a peer\n{}\n", PEER_COLUMNS.join(","));
        let ok = format!("{head}tower,4,1,5e-5,0.4,,,,2026-12-05,run it\n");
        assert_eq!(parse_peers(&ok, "p.csv").unwrap().len(), 1);
        for (row, column) in [
            ("tower,4,1,-5e-5,0.4,,,,2026-12-05,x", "`step_time_s`"),
            ("tower,4,1,5e-5,NaN,,,,2026-12-05,x", "`sag_m`"),
            ("tower,4.5,1,5e-5,0.4,,,,2026-12-05,x", "`substeps`"),
            ("tower,4,1,5e-5,0.4,,,,05/12/2026,x", "`measured`"),
            ("tower,4,1,5e-5,0.4,,,,2026-13-05,x", "`measured`"),
            ("tower,4,1,5e-5", "4 cells"),
            (",4,1,5e-5,0.4,,,,2026-12-05,x", "`scene`"),
        ] {
            let err = parse_peers(&format!("{head}{row}\n"), "p.csv")
                .unwrap_err()
                .to_string();
            assert!(
                err.starts_with("p.csv: line 3") && err.contains(column),
                "{row}: {err}"
            );
        }
        let err = parse_peers("scene,substeps\n", "p.csv")
            .unwrap_err()
            .to_string();
        assert!(err.contains("the header is `scene,substeps`"), "{err}");
    }
}
