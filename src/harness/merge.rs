//! Merging the directories of a sharded sweep ([`shard`](crate::harness::shard)) into one,
//! with exactly the rows of the unsharded sweep: `results.csv` in the sweep's job order,
//! `histories.csv`, and for a report sweep the exported LCPs under `lcps/`, laid out as the
//! unsharded sweep lays them out, plus `merged.json` ([`MergedManifest`]).
//!
//! Refused, with the directories named: a directory without `shard.json`; shards of different
//! sweeps, kinds, shard counts or commits; a shard given twice or missing; keys that do not make
//! up the sweep; a row that is no run of the sweep; two different rows for one run (identical
//! copies are dropped); a run without a row; an exported LCP that differs between shards or that
//! no shard has; a table, manifest or exported problem that is not a regular file within its
//! size bound; a `histories.csv` or `results.csv` with a damaged line or a torn last line (an
//! interrupted shard: resume it first); a `host` or `cpu_model` with control characters (the
//! report prints them). A shard count is never used to allocate: only the shards given are.
//! Nothing is written until every check has passed, and then into a temporary directory beside
//! the output that is renamed onto it (a new name, or an empty directory) when complete, so a
//! failure leaves no partial output.

use crate::harness::outdir::{cells_of, read_table, TableRow};
use crate::harness::record::{HistoryRow, RunKey, RunRecord};
use crate::harness::shard::{
    portable_case, read_manifest, rooted_case, sweep_id, ShardError, ShardManifest, SweepKind,
    MANIFEST, MAX_MANIFEST_BYTES, OUT_PLACEHOLDER,
};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Most missing shard numbers named in an error.
const MISSING_LISTED: usize = 10;

/// File name of a merged directory's manifest.
pub const MERGED: &str = "merged.json";

/// Why shards were not merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// No directories were given.
    #[error("nothing to merge: give the shard directories")]
    NoShards,
    /// The output exists and is not an empty directory.
    #[error(
        "{0} exists and is not an empty directory; merge writes only into a new or empty directory"
    )]
    OutNotEmpty(PathBuf),
    /// A directory has no manifest.
    #[error("{0} has no shard.json: it is not the output of `bench --shard` or `report --shard`")]
    NotAShard(PathBuf),
    /// A manifest could not be read.
    #[error(transparent)]
    Manifest(#[from] ShardError),
    /// Two shards belong to different sweeps.
    #[error("{a} and {b} are shards of different sweeps: {what}")]
    DifferentSweeps {
        /// First directory.
        a: PathBuf,
        /// Second directory.
        b: PathBuf,
        /// What differs.
        what: String,
    },
    /// Two shards ran at different commits.
    #[error(
        "{a} and {b} ran at different lcpbench commits ({commit_a} and {commit_b}); run every \
         shard of a sweep at one commit"
    )]
    DifferentCommits {
        /// First directory.
        a: PathBuf,
        /// Second directory.
        b: PathBuf,
        /// Its commit.
        commit_a: String,
        /// The other's.
        commit_b: String,
    },
    /// The same shard was given twice.
    #[error("shard {shard} is given twice: {a} and {b}")]
    RepeatedShard {
        /// K/N.
        shard: String,
        /// First directory.
        a: PathBuf,
        /// Second directory.
        b: PathBuf,
    },
    /// Shards are missing.
    #[error("shard(s) {missing} of {count} missing: merge needs every shard of the sweep")]
    MissingShards {
        /// Their numbers, comma-separated.
        missing: String,
        /// N.
        count: usize,
    },
    /// The shards' keys do not make up their sweep.
    #[error("the keys listed by the shards do not make up sweep {sweep}: {detail}")]
    BadKeys {
        /// The sweep.
        sweep: String,
        /// What is wrong.
        detail: String,
    },
    /// A row is not a run of the sweep.
    #[error("{path}: the row of {key} is not a run of sweep {sweep}")]
    ForeignRow {
        /// The results file.
        path: PathBuf,
        /// The row's run.
        key: String,
        /// The sweep.
        sweep: String,
    },
    /// Two different rows of one run.
    #[error("run {key} has different rows in {a} and {b} (columns {columns})")]
    ConflictingRows {
        /// The run.
        key: String,
        /// First results file.
        a: PathBuf,
        /// Second results file.
        b: PathBuf,
        /// The columns that differ.
        columns: String,
    },
    /// Runs without a row.
    #[error(
        "{missing} run(s) of the sweep have no row, e.g. {key} of shard {shard} ({dir}); resume \
         that shard with the command that started it"
    )]
    MissingRows {
        /// How many.
        missing: usize,
        /// One of them.
        key: String,
        /// Its shard.
        shard: String,
        /// That shard's directory.
        dir: PathBuf,
    },
    /// An exported LCP differs between shards.
    #[error("the exported problem {name} differs between {a} and {b}")]
    ExportsDiffer {
        /// File name under `lcps/`.
        name: String,
        /// First directory.
        a: PathBuf,
        /// Second directory.
        b: PathBuf,
    },
    /// No shard has an exported LCP the sweep runs.
    #[error("no shard has {path}, which run {key} solves")]
    MissingExport {
        /// Its path under the output directory.
        path: String,
        /// A run of it.
        key: String,
    },
    /// A file could not be read.
    #[error("{path}: {message}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A file could not be written.
    #[error("writing {path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

/// `merged.json`: what a merged directory holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MergedManifest {
    /// Identity of the sweep.
    pub sweep: String,
    /// Kind of sweep.
    pub kind: SweepKind,
    /// The lcpbench commit its shards ran at.
    pub commit: String,
    /// How many shards were merged.
    pub shards: usize,
    /// Runs of the sweep (rows of `results.csv`).
    pub jobs: usize,
    /// The shard directories, in shard order.
    pub from: Vec<String>,
}

/// The manifest of a merged directory, if it has one.
pub fn read_merged(dir: &Path) -> Result<Option<MergedManifest>, MergeError> {
    let path = dir.join(MERGED);
    let text = match lcpbench_solvers::io::input::read_input_file(&path, MAX_MANIFEST_BYTES) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(read_error(&path, e)),
    };
    serde_json::from_slice(&text)
        .map(Some)
        .map_err(|e| read_error(&path, e))
}

/// What a merge did.
#[derive(Debug, Clone, PartialEq)]
pub struct MergeSummary {
    /// The merged directory's manifest.
    pub manifest: MergedManifest,
    /// Rows written (one per run of the sweep).
    pub rows: usize,
    /// Rows dropped as identical copies of another shard's row of the same run.
    pub identical_duplicates: usize,
    /// History rows written.
    pub histories: usize,
    /// Exported LCPs copied.
    pub exports: usize,
}

/// A run's row and the shard that gave it (its position among the shards, in shard order).
type SourcedRow = (RunRecord, usize);

/// Exported problems by file name: their bytes and the shard directory that gave them.
type Exports = BTreeMap<String, (Vec<u8>, PathBuf)>;

/// One shard directory and its manifest.
struct ShardDir {
    dir: PathBuf,
    manifest: ShardManifest,
}

impl ShardDir {
    fn results(&self) -> PathBuf {
        self.manifest.kind.data_dir(&self.dir).join("results.csv")
    }

    fn histories(&self) -> PathBuf {
        self.manifest.kind.data_dir(&self.dir).join("histories.csv")
    }

    /// A case key of this shard's rows as the merged directory `out` names it.
    fn case_in(&self, case: &str, out: &Path) -> String {
        match self.manifest.kind {
            SweepKind::Bench => case.to_owned(),
            _ => rooted_case(&portable_case(case, &self.manifest.out_dir()), out),
        }
    }
}

/// Merge the shard directories `dirs` into `out` (new, or an empty directory).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeSummary, MergeError> {
    check_out(out)?;
    let shards = read_shards(dirs)?;
    // Run keys as the merged directory names them, by position in the sweep.
    let keys = sweep_keys(&shards, out)?;
    let index: HashMap<&RunKey, usize> = keys.iter().enumerate().map(|(i, k)| (k, i)).collect();
    let (rows, identical_duplicates) = collect_rows(&shards, &keys, &index, out)?;
    let exports = collect_exports(&shards, &keys)?;
    // Every check has passed: write into a temporary directory beside `out`, renamed onto it
    // when complete (and removed on failure), so no partial output is left.
    let staging = staging_dir(out)?;
    let written = write_merged(&shards, &keys, &index, &rows, &exports, out, &staging);
    let (manifest, histories) = match written {
        Ok(done) => done,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&staging);
            return Err(e);
        }
    };
    if let Err(e) = std::fs::rename(&staging, out) {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(write_error(out, e));
    }
    Ok(MergeSummary {
        manifest,
        rows: rows.len(),
        identical_duplicates,
        histories,
        exports: exports.len(),
    })
}

/// A new, empty directory beside `out` for the merged files.
fn staging_dir(out: &Path) -> Result<PathBuf, MergeError> {
    let name = out
        .file_name()
        .map_or("merged".into(), |n| n.to_string_lossy().into_owned());
    let staging = out.with_file_name(format!(".{name}.merge-{}.tmp", std::process::id()));
    if let Some(parent) = staging.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| write_error(parent, e))?;
    }
    std::fs::create_dir(&staging).map_err(|e| write_error(&staging, e))?;
    Ok(staging)
}

/// Write the merged files into `dir` (the staging directory of `out`, whose name the run keys
/// use); returns the manifest and the history rows written.
fn write_merged(
    shards: &[ShardDir],
    keys: &[RunKey],
    index: &HashMap<&RunKey, usize>,
    rows: &[SourcedRow],
    exports: &Exports,
    out: &Path,
    dir: &Path,
) -> Result<(MergedManifest, usize), MergeError> {
    let first = &shards[0].manifest;
    let kind = first.kind;
    let data = kind.data_dir(dir);
    std::fs::create_dir_all(&data).map_err(|e| write_error(&data, e))?;
    if let Some(lcps) = kind.exports_dir(dir) {
        std::fs::create_dir_all(&lcps).map_err(|e| write_error(&lcps, e))?;
        for (name, (bytes, _)) in exports {
            write_new(&lcps.join(name), bytes)?;
        }
    }
    let histories = write_histories(shards, rows, index, out, &data.join("histories.csv"))?;
    write_results(&data.join("results.csv"), rows)?;
    let manifest = MergedManifest {
        sweep: first.sweep.clone(),
        kind,
        commit: first.commit.clone(),
        shards: shards.len(),
        jobs: keys.len(),
        from: shards
            .iter()
            .map(|s| s.dir.to_string_lossy().into_owned())
            .collect(),
    };
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| write_error(out, e))? + "\n";
    write_new(&dir.join(MERGED), text.as_bytes())?;
    Ok((manifest, histories))
}

fn read_error(path: &Path, e: impl std::fmt::Display) -> MergeError {
    MergeError::Read {
        path: path.to_owned(),
        message: e.to_string(),
    }
}

fn write_error(path: &Path, e: impl std::fmt::Display) -> MergeError {
    MergeError::Write {
        path: path.to_owned(),
        message: e.to_string(),
    }
}

/// `out` must not exist, or be an empty directory.
fn check_out(out: &Path) -> Result<(), MergeError> {
    match std::fs::symlink_metadata(out) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(read_error(out, e)),
        Ok(m) if m.is_dir() => {
            let mut entries = std::fs::read_dir(out).map_err(|e| read_error(out, e))?;
            match entries.next() {
                None => Ok(()),
                Some(_) => Err(MergeError::OutNotEmpty(out.to_owned())),
            }
        }
        Ok(_) => Err(MergeError::OutNotEmpty(out.to_owned())),
    }
}

/// The shards of `dirs`, sorted by shard number, checked to be every shard of one sweep once.
fn read_shards(dirs: &[PathBuf]) -> Result<Vec<ShardDir>, MergeError> {
    let mut shards = Vec::new();
    for dir in dirs {
        let manifest = read_manifest(dir)?.ok_or_else(|| MergeError::NotAShard(dir.clone()))?;
        shards.push(ShardDir {
            dir: dir.clone(),
            manifest,
        });
    }
    let first = shards.first().ok_or(MergeError::NoShards)?;
    for other in &shards[1..] {
        let (a, b) = (&first.manifest, &other.manifest);
        let what = if a.kind != b.kind {
            Some(format!("{} and {}", a.kind, b.kind))
        } else if a.sweep != b.sweep {
            Some(format!("sweep {} and sweep {}", a.sweep, b.sweep))
        } else if a.shards != b.shards || a.jobs != b.jobs {
            Some(format!(
                "{} shards of {} runs and {} shards of {} runs",
                a.shards, a.jobs, b.shards, b.jobs
            ))
        } else {
            None
        };
        if let Some(what) = what {
            return Err(MergeError::DifferentSweeps {
                a: first.dir.clone(),
                b: other.dir.clone(),
                what,
            });
        }
        if a.commit != b.commit {
            return Err(MergeError::DifferentCommits {
                a: first.dir.clone(),
                b: other.dir.clone(),
                commit_a: a.commit.clone(),
                commit_b: b.commit.clone(),
            });
        }
    }
    let count = first.manifest.shards;
    let mut by_number: BTreeMap<usize, &ShardDir> = BTreeMap::new();
    for s in &shards {
        if s.manifest.shard == 0 || s.manifest.shard > count {
            return Err(MergeError::BadKeys {
                sweep: s.manifest.sweep.clone(),
                detail: format!(
                    "{} says it is shard {} of {count}",
                    s.dir.join(MANIFEST).display(),
                    s.manifest.shard
                ),
            });
        }
        if let Some(earlier) = by_number.insert(s.manifest.shard, s) {
            return Err(MergeError::RepeatedShard {
                shard: s.manifest.shard().to_string(),
                a: earlier.dir.clone(),
                b: s.dir.clone(),
            });
        }
    }
    // The first few missing numbers only: the count comes from a file and may be huge.
    let mut missing: Vec<String> = (1..=count)
        .filter(|k| !by_number.contains_key(k))
        .take(MISSING_LISTED)
        .map(|k| k.to_string())
        .collect();
    let absent = count.saturating_sub(by_number.len());
    if absent > MISSING_LISTED {
        missing.push(format!("… ({absent} in all)"));
    }
    if !missing.is_empty() || shards.len() != count {
        return Err(MergeError::MissingShards {
            missing: missing.join(", "),
            count,
        });
    }
    shards.sort_by_key(|s| s.manifest.shard);
    Ok(shards)
}

/// The sweep's run keys in order, from the shards' manifests (checked to cover every position
/// once and to hash to the sweep's identity), as the merged directory `out` names them.
fn sweep_keys(shards: &[ShardDir], out: &Path) -> Result<Vec<RunKey>, MergeError> {
    let first = &shards[0].manifest;
    let bad = |detail: String| MergeError::BadKeys {
        sweep: first.sweep.clone(),
        detail,
    };
    let listed: usize = shards.iter().map(|s| s.manifest.keys.len()).sum();
    if listed != first.jobs {
        return Err(bad(format!(
            "they list {listed} runs, the sweep has {}",
            first.jobs
        )));
    }
    let mut portable: Vec<Option<RunKey>> = vec![None; listed];
    for s in shards {
        for k in &s.manifest.keys {
            let slot = portable.get_mut(k.index).ok_or_else(|| {
                bad(format!(
                    "{} lists position {} of {} runs",
                    s.dir.display(),
                    k.index,
                    first.jobs
                ))
            })?;
            if slot.is_some() {
                return Err(bad(format!(
                    "position {} ({}) is listed by more than one shard",
                    k.index,
                    k.key()
                )));
            }
            *slot = Some(k.key());
        }
    }
    let portable: Vec<RunKey> = portable
        .into_iter()
        .enumerate()
        .map(|(i, k)| k.ok_or_else(|| bad(format!("no shard lists position {i}"))))
        .collect::<Result<_, _>>()?;
    if sweep_id(first.kind, &portable) != first.sweep {
        return Err(bad(
            "they hash to another identity (a shard.json was edited, or the shards split the \
             sweep differently)"
                .into(),
        ));
    }
    Ok(portable
        .into_iter()
        .map(|k| match first.kind {
            SweepKind::Bench => k,
            _ => RunKey::new(&rooted_case(&k.case, out), &k.solver, &k.budget),
        })
        .collect())
}

/// A row's cells as the CSV writes them (so NaN equals NaN and a row compares as written).
fn cells(r: &RunRecord) -> Vec<String> {
    cells_of(r)
        .into_iter()
        .map(|c| String::from_utf8_lossy(&c).into_owned())
        .collect()
}

/// The column names of `results.csv`.
fn columns() -> Vec<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let bytes = w
        .serialize(RunRecord::default())
        .ok()
        .and_then(|()| w.into_inner().ok())
        .unwrap_or_default();
    let text = String::from_utf8_lossy(&bytes);
    text.lines()
        .next()
        .unwrap_or_default()
        .split(',')
        .map(str::to_owned)
        .collect()
}

/// One row per run of the sweep, by position, each with the shard it came from (the first
/// shard that has it; identical copies in later shards are counted and dropped).
fn collect_rows(
    shards: &[ShardDir],
    keys: &[RunKey],
    index: &HashMap<&RunKey, usize>,
    out: &Path,
) -> Result<(Vec<SourcedRow>, usize), MergeError> {
    let mut rows: Vec<Option<(RunRecord, usize, Vec<String>)>> = vec![None; keys.len()];
    let mut identical = 0;
    for (s_index, s) in shards.iter().enumerate() {
        let path = s.results();
        let shard_rows: Vec<RunRecord> = if path.exists() || path.symlink_metadata().is_ok() {
            read_finished(&path)?
        } else {
            Vec::new()
        };
        for (n, mut row) in shard_rows.into_iter().enumerate() {
            check_machine_text(&path, n + 1, &row)?;
            row.case = s.case_in(&row.case, out);
            let key = row.key();
            let &i = index.get(&key).ok_or_else(|| MergeError::ForeignRow {
                path: path.clone(),
                key: key.to_string(),
                sweep: s.manifest.sweep.clone(),
            })?;
            let row_cells = cells(&row);
            match &rows[i] {
                None => rows[i] = Some((row, s_index, row_cells)),
                Some((_, _, earlier_cells)) if *earlier_cells == row_cells => identical += 1,
                Some((_, earlier, earlier_cells)) => {
                    let names = columns();
                    let differing: Vec<&str> = earlier_cells
                        .iter()
                        .zip(&row_cells)
                        .zip(&names)
                        .filter(|((a, b), _)| a != b)
                        .map(|(_, name)| name.as_str())
                        .collect();
                    return Err(MergeError::ConflictingRows {
                        key: key.to_string(),
                        a: shards[*earlier].results(),
                        b: path,
                        columns: differing.join(", "),
                    });
                }
            }
        }
    }
    let missing: Vec<usize> = (0..keys.len()).filter(|&i| rows[i].is_none()).collect();
    if let Some(&i) = missing.first() {
        let owner = shards
            .iter()
            .find(|s| s.manifest.keys.iter().any(|k| k.index == i))
            .unwrap_or(&shards[0]);
        return Err(MergeError::MissingRows {
            missing: missing.len(),
            key: keys[i].to_string(),
            shard: owner.manifest.shard().to_string(),
            dir: owner.dir.clone(),
        });
    }
    let rows = rows
        .into_iter()
        .flatten()
        .map(|(row, s, _)| (row, s))
        .collect();
    Ok((rows, identical))
}

/// The exported LCPs of a report sweep's shards, by file name, with the shard that gave each;
/// the same name must hold the same bytes in every shard, and every exported case of the sweep
/// must be among them.
fn collect_exports(shards: &[ShardDir], keys: &[RunKey]) -> Result<Exports, MergeError> {
    let mut exports = Exports::new();
    if shards[0].manifest.kind == SweepKind::Bench {
        return Ok(exports);
    }
    for s in shards {
        let Some(dir) = s.manifest.kind.exports_dir(&s.dir) else {
            continue;
        };
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries
            .flatten()
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .map(|e| e.path())
            .collect();
        files.sort();
        for path in files {
            let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
                continue;
            };
            let bytes = lcpbench_solvers::io::input::read_input_file(
                &path,
                lcpbench_solvers::io::MAX_PROBLEM_FILE_BYTES,
            )
            .map_err(|e| read_error(&path, e))?;
            match exports.get(&name) {
                Some((earlier, from)) if *earlier != bytes => {
                    return Err(MergeError::ExportsDiffer {
                        name,
                        a: from.clone(),
                        b: s.dir.clone(),
                    })
                }
                Some(_) => {}
                None => {
                    exports.insert(name, (bytes, s.dir.clone()));
                }
            }
        }
    }
    // Every exported case of the sweep (`file:$OUT/lcps/NAME` in the manifests).
    let prefix = format!("file:{OUT_PLACEHOLDER}/lcps/");
    for s in shards {
        for k in &s.manifest.keys {
            if let Some(name) = k.case.strip_prefix(&prefix) {
                if !exports.contains_key(name) {
                    return Err(MergeError::MissingExport {
                        path: format!("lcps/{name}"),
                        key: keys[k.index].to_string(),
                    });
                }
            }
        }
    }
    Ok(exports)
}

/// The rows of the table at `path` (a regular file, read strictly), refusing a torn last row:
/// its shard was interrupted, and merging it would lose the run or some of its history.
fn read_finished<T: TableRow>(path: &Path) -> Result<Vec<T>, MergeError> {
    let table = read_table::<T>(path).map_err(|e| {
        // The message names the file already; the error adds it once.
        let message = format!("{e:#}");
        let prefix = format!("{}: ", path.display());
        read_error(path, message.strip_prefix(&prefix).unwrap_or(&message))
    })?;
    match table.torn_at {
        Some(line) => Err(read_error(
            path,
            format!(
                "line {line}: the last row was torn (the shard was interrupted); resume that \
                 shard with the command that started it, then merge"
            ),
        )),
        None => Ok(table.rows),
    }
}

/// Refuse a `host` or `cpu_model` with control characters (a newline, an escape): the report
/// prints them in its header and tables.
fn check_machine_text(path: &Path, row: usize, r: &RunRecord) -> Result<(), MergeError> {
    for (column, value) in [("host", &r.host), ("cpu_model", &r.cpu_model)] {
        if let Some(v) = value {
            if let Some(c) = v.chars().find(|c| c.is_control()) {
                return Err(read_error(
                    path,
                    format!(
                        "row {row} (run {}): column {column} holds the control character \
                         {c:?}; a machine's name is one line of text",
                        r.key()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Create `path` (refusing an existing file) with `bytes`.
fn write_new(path: &Path, bytes: &[u8]) -> Result<(), MergeError> {
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.flush()))
        .map_err(|e| write_error(path, e))
}

/// A CSV writer on a new file `path`.
fn new_csv(path: &Path) -> Result<csv::Writer<std::fs::File>, MergeError> {
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(|e| write_error(path, e))?;
    Ok(csv::Writer::from_writer(file))
}

fn write_results(path: &Path, rows: &[SourcedRow]) -> Result<(), MergeError> {
    let mut w = new_csv(path)?;
    if rows.is_empty() {
        w.write_record(columns())
            .map_err(|e| write_error(path, e))?;
    }
    for (row, _) in rows {
        w.serialize(row).map_err(|e| write_error(path, e))?;
    }
    w.flush().map_err(|e| write_error(path, e))
}

/// Stream each shard's history rows of the runs whose row it gave into `path`; returns how many.
fn write_histories(
    shards: &[ShardDir],
    rows: &[SourcedRow],
    index: &HashMap<&RunKey, usize>,
    out: &Path,
    path: &Path,
) -> Result<usize, MergeError> {
    let mut w = new_csv(path)?;
    let mut written = 0;
    for (s_index, s) in shards.iter().enumerate() {
        let source = s.histories();
        if !source.exists() && source.symlink_metadata().is_err() {
            continue;
        }
        for mut h in read_finished::<HistoryRow>(&source)? {
            h.case = s.case_in(&h.case, out);
            let from_here = index.get(&h.key()).is_some_and(|&i| rows[i].1 == s_index);
            if from_here {
                w.serialize(&h).map_err(|e| write_error(path, e))?;
                written += 1;
            }
        }
    }
    if written == 0 {
        w.write_record([
            "case",
            "solver",
            "budget",
            "iteration",
            "time_s",
            "residual",
        ])
        .map_err(|e| write_error(path, e))?;
    }
    w.flush().map_err(|e| write_error(path, e))?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::shard::{Shard, ShardPlan};
    use crate::harness::sweep::read_results;
    use crate::harness::{cross_product, Case, Job};

    /// The jobs of a report sweep written to `dir`: two exported LCPs under `dir/lcps` and a
    /// generated one, two solvers.
    fn jobs(dir: &Path) -> Vec<Job> {
        let cases = [
            Case::File(dir.join("lcps").join("a_step3.json")),
            Case::File(dir.join("lcps").join("b_step3.json")),
            "spd:n=8:cond=1e2:seed=1".parse().unwrap(),
        ];
        let solvers = ["pgs".parse().unwrap(), "lemke".parse().unwrap()];
        cross_product(&cases, &solvers, &["default".parse().unwrap()])
    }

    /// Shard `index` of 2 in `root/name`, as `report --shard` lays it out, with a row for each
    /// of its runs and both exported problems.
    fn shard(root: &Path, name: &str, index: usize) -> PathBuf {
        let dir = root.join(name);
        std::fs::create_dir_all(dir.join("data")).unwrap();
        std::fs::create_dir_all(dir.join("lcps")).unwrap();
        let plan = ShardPlan::new(SweepKind::ReportQuick, jobs(&dir), &dir);
        let shard = Shard { index, count: 2 };
        plan.manifest(shard, "abc").write(&dir).unwrap();
        let mut w = csv::Writer::from_path(dir.join("data/results.csv")).unwrap();
        for job in plan.jobs(shard) {
            let mut row = crate::harness::record::base_record(&job.case, &job.solver, &job.budget);
            row.iterations = Some(7);
            w.serialize(row).unwrap();
        }
        w.flush().unwrap();
        for name in ["a_step3.json", "b_step3.json"] {
            std::fs::write(
                dir.join("lcps").join(name),
                format!("{{\"name\": \"{name}\"}}"),
            )
            .unwrap();
        }
        dir
    }

    /// Report shards in two directories merge into the layout of an unsharded report in the
    /// output directory: exported cases keyed under it, their files copied once.
    #[test]
    fn report_shards_merge_with_their_exported_problems_under_the_output_directory() {
        let root = tempfile::tempdir().unwrap();
        let dirs = [shard(root.path(), "one", 1), shard(root.path(), "two", 2)];
        let out = root.path().join("merged");
        let summary = merge(&dirs, &out).unwrap();
        assert_eq!((summary.rows, summary.exports), (6, 2));
        let rows = read_results(&out.join("data/results.csv")).unwrap();
        let keys: Vec<String> = rows.iter().map(|r| r.key().to_string()).collect();
        let expected: Vec<String> = jobs(&out).iter().map(|j| j.key().to_string()).collect();
        assert_eq!(keys, expected);
        assert!(out.join("lcps/a_step3.json").exists() && out.join("merged.json").exists());
        assert_eq!(
            read_merged(&out).unwrap().unwrap().kind,
            SweepKind::ReportQuick
        );
    }

    #[test]
    fn exported_problems_must_agree_and_be_present() {
        let root = tempfile::tempdir().unwrap();
        let dirs = [shard(root.path(), "one", 1), shard(root.path(), "two", 2)];
        std::fs::write(dirs[1].join("lcps/b_step3.json"), "{}").unwrap();
        let err = merge(&dirs, &root.path().join("m1")).unwrap_err();
        assert!(
            matches!(err, MergeError::ExportsDiffer { ref name, .. } if name == "b_step3.json")
        );
        for d in &dirs {
            std::fs::remove_file(d.join("lcps/b_step3.json")).unwrap();
        }
        let err = merge(&dirs, &root.path().join("m2")).unwrap_err();
        assert!(
            err.to_string().contains("no shard has lcps/b_step3.json"),
            "{err}"
        );
        assert!(!root.path().join("m1").exists() && !root.path().join("m2").exists());
    }

    #[test]
    fn keys_that_do_not_make_up_the_sweep_are_refused() {
        let root = tempfile::tempdir().unwrap();
        let dirs = [shard(root.path(), "one", 1), shard(root.path(), "two", 2)];
        let mut manifest = read_manifest(&dirs[1]).unwrap().unwrap();
        manifest.keys[0].solver = "pgs+warm".into();
        manifest.write(&dirs[1]).unwrap();
        let err = merge(&dirs, &root.path().join("m"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("hash to another identity"), "{err}");
        manifest.keys.pop();
        manifest.write(&dirs[1]).unwrap();
        let err = merge(&dirs, &root.path().join("m"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("they list 5 runs, the sweep has 6"), "{err}");
        manifest.jobs = usize::MAX;
        manifest.write(&dirs[1]).unwrap();
        assert!(matches!(
            merge(&dirs, &root.path().join("m")),
            Err(MergeError::DifferentSweeps { .. })
        ));
    }
}
