//! The files of an output directory that sweeps share, and the rules lcpbench keeps there:
//!
//! * it never overwrites or removes a file it did not write: a table (`results.csv`,
//!   `histories.csv`) is lcpbench's when its header is; another file of that name, or a table
//!   of another lcpbench version, is refused with a message naming it and left as it is
//!   ([`table_origin`], [`check_own_table`]);
//! * it never follows a symbolic link for its lock or its tables ([`lock_dir`]);
//! * it reads a table strictly: a row that does not parse is refused with its line number,
//!   except the last row of a file an interrupted sweep tore, which must read as the start of
//!   a row ([`read_table`]);
//! * it never writes through a symbolic link to a directory of its own layout (`data/`,
//!   `tables/`, `plots/`, … of a report or shard: [`refuse_linked_dirs`]);
//! * no command writes an output onto one of its inputs or onto another of its outputs, judged
//!   by file identity (device and inode, so `./d/../p`, symbolic and hard links count as the
//!   same file): [`check_outputs`], which every subcommand with an output path calls.

use anyhow::{bail, Context, Result};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Name of the lock file a sweep holds in its output directory.
pub const LOCK_FILE: &str = ".lcpbench.lock";

/// Largest table read, bytes (a report's `results.csv` holds a few megabytes).
pub const MAX_TABLE_BYTES: u64 = 2_000_000_000;

/// Who wrote a table, judged by its header against the columns of this version.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TableOrigin {
    /// No file, or an empty one.
    Absent,
    /// This version of lcpbench: the same columns.
    Current,
    /// An older lcpbench: the first `columns` of this version's columns (columns are only ever
    /// appended).
    Older {
        /// Columns the file has.
        columns: usize,
    },
    /// A newer lcpbench: this version's columns and more after them.
    Newer {
        /// Columns the file has.
        columns: usize,
    },
    /// Not lcpbench: its header is not a prefix of this version's columns, nor they of it.
    Foreign {
        /// The file's first line, shortened.
        header: String,
    },
}

/// The header of a table whose rows are `sample`'s type, as the CSV writer writes it.
pub fn columns_of<T: serde::Serialize>(sample: &T) -> Vec<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    if w.serialize(sample).is_err() {
        return Vec::new();
    }
    let text = w
        .into_inner()
        .map(|b| String::from_utf8_lossy(&b).into_owned())
        .unwrap_or_default();
    header_cells(text.lines().next().unwrap_or_default())
}

/// The cells of a CSV header line (empty when it does not parse).
fn header_cells(line: &str) -> Vec<String> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(line.as_bytes())
        .records()
        .next()
        .and_then(Result::ok)
        .map(|r| r.iter().map(str::to_owned).collect())
        .unwrap_or_default()
}

/// Refuse a symbolic link at `path` (a table or the lock is never followed elsewhere).
fn refuse_link(path: &Path) -> Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_symlink() => bail!(
            "{} is a symbolic link; lcpbench does not follow links in an output directory \
             (remove it, or choose another output directory)",
            path.display()
        ),
        Ok(meta) if !meta.is_file() => bail!(
            "{} is not a regular file; lcpbench writes its own file there (remove it, or \
             choose another output directory)",
            path.display()
        ),
        _ => Ok(()),
    }
}

/// Refuse a symbolic link (or anything but a directory) at any of `subdirs` under `dir`: a
/// report or sweep writes its own files there, and a link would send them into another
/// directory. Missing ones are fine (they are created).
pub fn refuse_linked_dirs(dir: &Path, subdirs: &[&str]) -> Result<()> {
    for sub in subdirs {
        let path = dir.join(sub);
        match std::fs::symlink_metadata(&path) {
            Ok(meta) if meta.file_type().is_symlink() => bail!(
                "{} is a symbolic link; lcpbench writes its own files there and does not follow                  links in an output directory (remove the link, or choose another output                  directory)",
                path.display()
            ),
            Ok(meta) if !meta.is_dir() => bail!(
                "{} is not a directory; lcpbench writes its own files there (remove it, or                  choose another output directory)",
                path.display()
            ),
            _ => {}
        }
    }
    Ok(())
}

/// What makes two paths the same file: device and inode of an existing file (links followed,
/// so a symbolic or hard link is its target), else the canonical directory and the name a new
/// file would get there.
#[derive(Debug, Clone, PartialEq, Eq)]
enum FileIdentity {
    Inode(u64, u64),
    New(PathBuf),
}

/// The identity of `path` (see [`FileIdentity`]); `None` when its directory does not exist
/// either (then no file can be written there, and it equals no input).
fn file_identity(path: &Path) -> Option<FileIdentity> {
    if let Ok(meta) = std::fs::metadata(path) {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            return Some(FileIdentity::Inode(meta.dev(), meta.ino()));
        }
        #[cfg(not(unix))]
        {
            let _ = meta;
            return std::fs::canonicalize(path).ok().map(FileIdentity::New);
        }
    }
    // A dangling symbolic link is written through: it stands for its target.
    let target = match std::fs::read_link(path) {
        Ok(t) => path.parent().unwrap_or(Path::new(".")).join(t),
        Err(_) => path.to_owned(),
    };
    let name = target.file_name()?;
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::canonicalize(parent)
        .ok()
        .map(|dir| FileIdentity::New(dir.join(name)))
}

/// Refuse a command whose output would land on one of its inputs or on another of its
/// outputs: `inputs` and `outputs` are (option name, path) pairs, such as `("the scene", p)`
/// and `("--record", q)`. Files are compared by identity (device and inode; a file not yet
/// written by its canonical directory and name), so `./d/../p`, a symbolic link and a hard
/// link to an input are all refused. Call before anything is read or written.
pub fn check_outputs(inputs: &[(&str, &Path)], outputs: &[(&str, &Path)]) -> Result<()> {
    let inputs: Vec<_> = inputs
        .iter()
        .map(|&(what, p)| (what, p, file_identity(p)))
        .collect();
    let mut seen: Vec<(&str, &Path, Option<FileIdentity>)> = Vec::new();
    for &(what, path) in outputs {
        let id = file_identity(path);
        if id.is_some() {
            if let Some((input, ipath, _)) = inputs.iter().find(|(_, _, i)| *i == id) {
                bail!(
                    "{what} {} is the same file as {input} {} (through `..`, a symbolic link or                      a hard link, or the same name); writing it would destroy the input: choose                      another output path",
                    path.display(),
                    ipath.display()
                );
            }
            if let Some((other, opath, _)) = seen.iter().find(|(_, _, o)| *o == id) {
                bail!(
                    "{what} {} and {other} {} are the same file; each output needs its own path",
                    path.display(),
                    opath.display()
                );
            }
        }
        seen.push((what, path, id));
    }
    Ok(())
}

/// Whose table `path` is, from its header and `columns`, this version's header.
pub fn table_origin(path: &Path, columns: &[String]) -> Result<TableOrigin> {
    if !path.exists() && std::fs::symlink_metadata(path).is_err() {
        return Ok(TableOrigin::Absent);
    }
    refuse_link(path)?;
    let mut head = Vec::new();
    File::open(path)
        .and_then(|f| f.take(64 * 1024).read_to_end(&mut head))
        .with_context(|| format!("reading {}", path.display()))?;
    let first = head.split(|&c| c == b'\n').next().unwrap_or_default();
    let first = String::from_utf8_lossy(first).trim_end().to_owned();
    if first.trim().is_empty() && head.iter().all(u8::is_ascii_whitespace) {
        return Ok(TableOrigin::Absent);
    }
    let found = header_cells(&first);
    let common = found
        .iter()
        .zip(columns)
        .take_while(|(a, b)| a == b)
        .count();
    Ok(if common == found.len() && common == columns.len() {
        TableOrigin::Current
    } else if common == found.len() && common > 0 && found[0] == columns[0] {
        TableOrigin::Older {
            columns: found.len(),
        }
    } else if common == columns.len() {
        TableOrigin::Newer {
            columns: found.len(),
        }
    } else {
        let mut header: String = first.chars().take(80).collect();
        if first.chars().count() > 80 {
            header.push('…');
        }
        TableOrigin::Foreign { header }
    })
}

/// Refuse a table at `path` that is not this version's (or absent), before anything in the
/// directory is changed; `what` says what lcpbench was about to do with it.
pub fn check_own_table(path: &Path, columns: &[String], what: &str) -> Result<TableOrigin> {
    let origin = table_origin(path, columns)?;
    let n = columns.len();
    match &origin {
        TableOrigin::Absent | TableOrigin::Current => Ok(origin),
        TableOrigin::Foreign { header } => bail!(
            "{} is not a table lcpbench wrote (its header `{header}` is not lcpbench's); \
             lcpbench never overwrites a file it did not write, so it will not {what}: move the \
             file away or choose another output directory",
            path.display()
        ),
        TableOrigin::Older { columns } => bail!(
            "{} was written by an older lcpbench ({columns} of this version's {n} columns); it \
             is left as it is, and rows of two versions are not mixed: choose a new output \
             directory for this version (or move the file away)",
            path.display()
        ),
        TableOrigin::Newer { columns } => bail!(
            "{} was written by a newer lcpbench ({columns} columns, this version has {n}); it \
             is left as it is: use that version, or choose another output directory",
            path.display()
        ),
    }
}

/// A row type of an lcpbench table, with a sample row whose cells complete the start of a torn
/// row for [`read_table`]'s check that it is one.
pub trait TableRow: serde::de::DeserializeOwned + serde::Serialize {
    /// Any valid row.
    fn sample() -> Self;
}

impl TableRow for crate::harness::record::RunRecord {
    fn sample() -> Self {
        Self::default()
    }
}

impl TableRow for crate::harness::record::HistoryRow {
    fn sample() -> Self {
        Self {
            case: "spd:n=1:cond=1:seed=1".into(),
            solver: Default::default(),
            budget: Default::default(),
            iteration: 0,
            time_s: 0.0,
            residual: 0.0,
        }
    }
}

/// The column names lcpbench writes for `T`, in order (the header of a sample row).
fn column_names<T: TableRow>() -> Vec<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    if w.serialize(T::sample()).is_err() {
        return Vec::new();
    }
    let bytes = w.into_inner().unwrap_or_default();
    let mut r = csv::Reader::from_reader(&bytes[..]);
    r.headers()
        .map(|h| h.iter().map(str::to_owned).collect())
        .unwrap_or_default()
}

/// A table's header must be lcpbench's columns for `T` in order, or a leading part of them (a
/// file written before later columns were added): a damaged or foreign column name is an
/// error naming the column, not a column silently read as empty.
fn check_header<T: TableRow>(path: &Path, headers: &csv::ByteRecord) -> Result<()> {
    let known = column_names::<T>();
    if known.is_empty() {
        return Ok(());
    }
    if headers.len() > known.len() {
        bail!(
            "{}: line 1: the header has {} columns where lcpbench writes {}",
            path.display(),
            headers.len(),
            known.len()
        );
    }
    for (k, (got, want)) in headers.iter().zip(&known).enumerate() {
        if got != want.as_bytes() {
            bail!(
                "{}: line 1: column {} is `{}` where lcpbench writes `{want}`",
                path.display(),
                k + 1,
                String::from_utf8_lossy(got)
            );
        }
    }
    Ok(())
}

/// The rows of a table, read strictly, and whether its last row was torn.
#[derive(Debug, Clone)]
pub struct Table<T> {
    /// The rows that parse.
    pub rows: Vec<T>,
    /// 1-based line of a last row that an interrupted write tore (no final newline, or a quoted
    /// field cut short) and that reads as the start of a row; it is not in `rows`.
    pub torn_at: Option<u64>,
}

/// Read the table at `path` (a regular file of at most [`MAX_TABLE_BYTES`]). Only a
/// newline-terminated row counts as written. The one exception to strict reading is the last
/// row of an interrupted sweep (which appends one row at a time and flushes it): an unfinished
/// last line (no final newline, or a quote left open to the end) is dropped as torn when it
/// reads as the *start* of a row, its cells but the last valid values of their columns and the
/// last one the start of such a value. Any other line that is not a row (a wrong cell count, a
/// cell that is not a value of its column, a line of something else, even the last one) is an
/// error naming the file and line, and nothing is dropped silently.
pub fn read_table<T: TableRow>(path: &Path) -> Result<Table<T>> {
    refuse_link(path)?;
    let bytes = lcpbench_solvers::io::input::read_input_file(path, MAX_TABLE_BYTES)
        .with_context(|| format!("reading {}", path.display()))?;
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_reader(&bytes[..]);
    let headers = reader
        .byte_headers()
        .with_context(|| format!("{}: line 1: not a CSV header", path.display()))?
        .clone();
    check_header::<T>(path, &headers)?;
    let mut rows = Vec::new();
    let mut record = csv::ByteRecord::new();
    loop {
        let start = reader.position().clone();
        let read = reader.read_byte_record(&mut record);
        let at = start.byte() as usize;
        let line = start.line();
        let rest = &bytes[at.min(bytes.len())..];
        // Unfinished: the file ends inside this record (no newline after it, or an open quote).
        let unfinished = reader.position().byte() as usize >= bytes.len()
            && !rest.iter().all(u8::is_ascii_whitespace)
            && (bytes.last() != Some(&b'\n')
                || rest.iter().filter(|&&c| c == b'"').count() % 2 == 1);
        if unfinished {
            if starts_a_row::<T>(rest, &headers) {
                return Ok(Table {
                    rows,
                    torn_at: Some(line),
                });
            }
            bail!(
                "{}: line {line}: the line is unfinished (no final newline, or a quote left \
                 open to the end) and is not the start of a row, so no interrupted sweep tore \
                 it; the file is damaged (it was edited, or written by something else), and no \
                 line of it is dropped silently: repair or remove that line",
                path.display()
            );
        }
        let failure = match read {
            Ok(false) => break,
            Ok(true) if record.len() != headers.len() => format!(
                "the row has {} cells where the header has {}",
                record.len(),
                headers.len()
            ),
            Ok(true) => match record.deserialize::<T>(Some(&headers)) {
                Ok(row) => {
                    rows.push(row);
                    continue;
                }
                Err(e) => csv_problem(&e),
            },
            Err(e) => csv_problem(&e),
        };
        bail!(
            "{}: line {line}: {failure}; the file is damaged (it was edited, or written by \
             something else), and no row of it is dropped silently: repair or remove that line",
            path.display()
        );
    }
    Ok(Table {
        rows,
        torn_at: None,
    })
}

/// What is wrong with a row, without the reader's own position (the caller gives the line).
fn csv_problem(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("the row has {len} cells where the header has {expected_len}"),
        csv::ErrorKind::Deserialize { err, .. } => match err.field() {
            Some(k) => format!("cell {}: {}", k + 1, err.kind()),
            None => err.kind().to_string(),
        },
        csv::ErrorKind::Utf8 { err, .. } => format!("not UTF-8 text: {err}"),
        _ => e.to_string(),
    }
}

/// The cells of `row` as the CSV writer writes them.
pub(crate) fn cells_of<T: serde::Serialize>(row: &T) -> Vec<Vec<u8>> {
    let mut w = csv::WriterBuilder::new()
        .has_headers(false)
        .from_writer(Vec::new());
    let bytes = w
        .serialize(row)
        .ok()
        .and_then(|()| w.into_inner().ok())
        .unwrap_or_default();
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(&bytes[..])
        .byte_records()
        .next()
        .and_then(Result::ok)
        .map(|r| r.iter().map(<[u8]>::to_vec).collect())
        .unwrap_or_default()
}

/// True when `bytes` (one unfinished line, or a record whose quote is still open) reads as the
/// start of a row of the table with `headers`: at most as many cells as the header, each but
/// the last a valid value of its column, and the last one the start of a valid value (the
/// cells after it taken from [`TableRow::sample`]).
fn starts_a_row<T: TableRow>(bytes: &[u8], headers: &csv::ByteRecord) -> bool {
    let Some(Ok(found)) = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(bytes)
        .byte_records()
        .next()
    else {
        return false;
    };
    let sample = cells_of(&T::sample());
    let k = found.len();
    if k == 0 || k > headers.len() || sample.len() != headers.len() {
        return false;
    }
    let last = &found[k - 1];
    // Ways the cut last cell may end: as it is, or completed into a number, a special float,
    // a boolean or the sample's own value.
    let mut endings: Vec<Vec<u8>> = vec![last.to_vec()];
    for suffix in [&b"0"[..], b"e0", b".0"] {
        endings.push([last, suffix].concat());
    }
    for word in [
        &b"NaN"[..],
        b"inf",
        b"-inf",
        b"true",
        b"false",
        &sample[k - 1],
    ] {
        if word.starts_with(last) {
            endings.push(word.to_vec());
        }
    }
    endings.into_iter().any(|ending| {
        let mut candidate = csv::ByteRecord::new();
        for cell in found.iter().take(k - 1) {
            candidate.push_field(cell);
        }
        candidate.push_field(&ending);
        for cell in &sample[k..] {
            candidate.push_field(cell);
        }
        candidate.deserialize::<T>(Some(headers)).is_ok()
    })
}

/// Rewrite `path` with exactly `rows` (header included), through a new temporary file beside
/// it that is renamed over it.
pub fn rewrite_table<T: serde::Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    let name = path
        .file_name()
        .map_or("table".into(), |n| n.to_string_lossy().into_owned());
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let _ = std::fs::remove_file(&tmp);
    {
        let file = create_new(&tmp)?;
        let mut w = csv::Writer::from_writer(file);
        for r in rows {
            w.serialize(r)?;
        }
        w.flush()?;
    }
    std::fs::rename(&tmp, path).with_context(|| format!("replacing {}", path.display()))?;
    Ok(())
}

/// Open `path` for appending (a table this version wrote, or a new one); the returned writer
/// writes the header only if the file is new.
pub fn append_table(path: &Path) -> Result<csv::Writer<File>> {
    refuse_link(path)?;
    let exists = path.exists() && std::fs::metadata(path)?.len() > 0;
    let file = no_follow(OpenOptions::new().create(true).append(true))
        .open(path)
        .with_context(|| format!("opening {}", path.display()))?;
    Ok(csv::WriterBuilder::new()
        .has_headers(!exists)
        .from_writer(file))
}

/// Create `path`, which must not exist (not even as a link).
pub fn create_new(path: &Path) -> Result<File> {
    no_follow(OpenOptions::new().write(true).create_new(true))
        .open(path)
        .with_context(|| format!("creating {}", path.display()))
}

/// `options` that refuse to open a symbolic link (`O_NOFOLLOW` on unix).
fn no_follow(options: &mut OpenOptions) -> &mut OpenOptions {
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NOFOLLOW);
    }
    options
}

/// An exclusive lock on a sweep's output directory, held until dropped.
#[derive(Debug)]
pub struct DirLock {
    dir: PathBuf,
    _file: File,
}

impl DirLock {
    /// The locked directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

/// Lock `dir` (created if missing) for one sweep. Fails at once, naming the directory and the
/// process that holds it, when another sweep has it. The lock file is never a symbolic link or
/// another file's hard link: lcpbench writes its process id into it.
pub fn lock_dir(dir: &Path) -> Result<DirLock> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join(LOCK_FILE);
    refuse_link(&path)?;
    let mut file = no_follow(
        OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false),
    )
    .open(&path)
    .with_context(|| {
        format!(
            "opening the lock file {} (a symbolic link there is refused)",
            path.display()
        )
    })?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let links = file.metadata().map(|m| m.nlink()).unwrap_or(1);
        if links > 1 {
            bail!(
                "the lock file {} has {links} hard links; lcpbench writes into it, so it must be \
                 its own file (remove it)",
                path.display()
            );
        }
    }
    match file.try_lock() {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = (&file).take(64).read_to_string(&mut holder);
            let holder = holder.trim();
            let by = if holder.is_empty() {
                String::new()
            } else {
                format!(" (process {holder})")
            };
            bail!(
                "output directory {} is in use by another lcpbench sweep{by}; wait for it to \
                 finish or choose another output directory",
                dir.display()
            );
        }
        Err(TryLockError::Error(e)) => {
            return Err(e).with_context(|| format!("locking {}", path.display()));
        }
    }
    // Best effort: the process id helps whoever meets the lock.
    let _ = file.set_len(0);
    let _ = write!(file, "{}", std::process::id());
    let _ = file.flush();
    Ok(DirLock {
        dir: dir.to_owned(),
        _file: file,
    })
}
