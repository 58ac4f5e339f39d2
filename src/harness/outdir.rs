//! The files of an output directory that sweeps share, and the rules lcpbench keeps there:
//!
//! * it never overwrites or removes a file it did not write: a table (`results.csv`,
//!   `histories.csv`) is lcpbench's when its header is; another file of that name, or a table
//!   of another lcpbench version, is refused with a message naming it and left as it is
//!   ([`table_origin`], [`check_own_table`]);
//! * it never follows a symbolic link for its lock or its tables ([`lock_dir`]);
//! * it reads a table strictly: a row that does not parse is refused with its line number,
//!   except the last row of a file an interrupted sweep tore ([`read_table`]).

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

/// The rows of a table, read strictly, and whether its last row was torn.
#[derive(Debug, Clone)]
pub struct Table<T> {
    /// The rows that parse.
    pub rows: Vec<T>,
    /// 1-based line of a last row that an interrupted write tore (no final newline, or a quoted
    /// field cut short), which is not in `rows`.
    pub torn_at: Option<u64>,
}

/// Read the table at `path`. Only a newline-terminated row counts as written, and only the last
/// row may be incomplete (an interrupted sweep appends one row at a time and flushes it):
/// any other row that does not parse (a wrong column count, a cell that is not a value of its
/// column, a quote left open so that it swallows the rows after it) is an error naming its
/// line, and nothing is dropped silently.
pub fn read_table<T: serde::de::DeserializeOwned>(path: &Path) -> Result<Table<T>> {
    refuse_link(path)?;
    let bytes = lcpbench_solvers::io::input::read_input_file(path, MAX_TABLE_BYTES)
        .with_context(|| format!("reading {}", path.display()))?;
    let complete = bytes.iter().rposition(|&c| c == b'\n').map_or(0, |i| i + 1);
    let tail_torn = bytes[complete..].iter().any(|c| !c.is_ascii_whitespace());
    let lines_before = |offset: usize| 1 + bytes[..offset].iter().filter(|&&c| c == b'\n').count();
    let mut reader = csv::ReaderBuilder::new()
        .flexible(false)
        .from_reader(&bytes[..complete]);
    let headers = reader
        .byte_headers()
        .with_context(|| format!("{}: line 1: not a CSV header", path.display()))?
        .clone();
    let mut rows = Vec::new();
    let mut record = csv::ByteRecord::new();
    loop {
        let start = reader.position().clone();
        let failure = match reader.read_byte_record(&mut record) {
            Ok(false) => break,
            Ok(true) => match record.deserialize::<T>(Some(&headers)) {
                Ok(row) => {
                    rows.push(row);
                    continue;
                }
                Err(e) => csv_problem(&e),
            },
            Err(e) => csv_problem(&e),
        };
        let at = start.byte() as usize;
        let line = start.line();
        // A torn last row spans to the end of the file and nothing after its first line parses
        // as a row; an open quote in the middle swallows complete rows.
        let rest = &bytes[at..complete];
        let after_first_line = rest
            .iter()
            .position(|&c| c == b'\n')
            .map_or(&rest[rest.len()..], |i| &rest[i + 1..]);
        let reaches_end = reader.is_done() || reader.position().byte() as usize >= complete;
        if reaches_end && !parses_a_row::<T>(after_first_line, &headers) {
            return Ok(Table {
                rows,
                torn_at: Some(line),
            });
        }
        bail!(
            "{}: line {line}: {failure}; the file is damaged (it was edited, or written by \
             something else), and no row of it is dropped silently: repair or remove that line",
            path.display()
        );
    }
    Ok(Table {
        rows,
        torn_at: tail_torn.then(|| lines_before(complete) as u64),
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

/// True when some line of `bytes`, read as rows of the table with `headers`, makes a row.
fn parses_a_row<T: serde::de::DeserializeOwned>(bytes: &[u8], headers: &csv::ByteRecord) -> bool {
    bytes.split(|&c| c == b'\n').any(|line| {
        csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(false)
            .from_reader(line)
            .byte_records()
            .next()
            .and_then(Result::ok)
            .filter(|r| r.len() == headers.len())
            .is_some_and(|r| r.deserialize::<T>(Some(headers)).is_ok())
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
