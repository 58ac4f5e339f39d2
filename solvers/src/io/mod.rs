//! Problem files: lcpbench's JSON form (dense or sparse `A`), Siconos numerics LCP `.dat` files
//! ([`siconos`]) and FCLIB HDF5 frictional-contact files ([`fclib`]).
//!
//! [`read_problem`] reads a file that opens with the HDF5 signature as FCLIB whatever its name,
//! and picks the reader of any other by extension (`.json`; `.dat`; `.hdf5`, `.h5`) and, for
//! `.dat` and unknown extensions, by content: a file that opens with `{` is JSON, anything else
//! is read as a Siconos file.
//!
//! # JSON
//!
//! ```json
//! {
//!   "name": "two contacts",
//!   "A": [[2.0, 1.0], [1.0, 2.0]],
//!   "b": [-1.0, 1.0],
//!   "lo": [0.0, null],
//!   "hi": [null, null],
//!   "friction": [[1, 0, 0.5]]
//! }
//! ```
//!
//! `A` is either an array of rows (dense) or an object holding a sparse matrix, in one of two
//! forms:
//!
//! ```json
//! "A": {"n": 3, "triplets": [[0, 0, 2.0], [0, 1, -1.0], [1, 0, -1.0], [1, 1, 2.0], [2, 2, 1.0]]}
//! "A": {"n": 3, "row_ptr": [0, 2, 4, 5], "col_idx": [0, 1, 0, 1, 2],
//!       "values": [2.0, -1.0, -1.0, 2.0, 1.0]}
//! ```
//!
//! Triplets are `[row, column, value]` with 0-based indices, in any order; duplicates are summed.
//! The second form is compressed sparse rows: row `i`'s entries are `values[k]` in column
//! `col_idx[k]` for `k` in `row_ptr[i]..row_ptr[i+1]` (`row_ptr` has `n + 1` entries, starts at
//! 0 and ends at the number of entries). Entries not listed are zero. A file with a sparse `A`
//! gives a problem stored sparse.
//!
//! `b` is a vector. `lo`/`hi` are optional (absent: `lo = 0`, `hi = +∞`, the standard LCP); a
//! `null` entry is unbounded (`-∞` in `lo`, `+∞` in `hi`). `friction` lists `[row, normal_row,
//! mu]` entries; a friction row's `lo`/`hi` are ignored. `name` is optional. Unknown keys are
//! ignored so files can carry metadata.
//!
//! [`problem_to_json`] writes whichever form of `A` is smaller: dense when `n²` numbers are
//! fewer than the `2 nnz + n + 1` numbers of the compressed-row form, compressed rows otherwise.

pub(crate) mod cone;
pub mod fclib;
pub mod input;
pub mod siconos;

use crate::problem::{sparse_from_triplets, FrictionRow, Problem, ProblemError, Row};
use faer::Mat;
use serde::de::{self, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Failure to read or write a problem file.
#[derive(Debug, Error)]
pub enum ProblemFileError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid text of the expected shape.
    #[error("{path}:{line}:{column}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A field has the wrong shape.
    #[error("{path}: field `{field}`: {message}")]
    Field {
        /// The file.
        path: PathBuf,
        /// The field (`A`, `lo`, `/fclib_local/W/x`, ...).
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The data parse but do not make a valid problem.
    #[error("{path}: {source}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The validation error.
        source: ProblemError,
    },
    /// The file is of a kind or variant this build does not read.
    #[error("{path}: {message}")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is not supported, and why.
        message: String,
    },
}

impl ProblemFileError {
    pub(crate) fn field(path: &Path, field: &str, message: impl Into<String>) -> Self {
        Self::Field {
            path: path.to_owned(),
            field: field.to_owned(),
            message: message.into(),
        }
    }

    pub(crate) fn invalid(path: &Path) -> impl Fn(ProblemError) -> Self + '_ {
        move |source| Self::Invalid {
            path: path.to_owned(),
            source,
        }
    }
}

/// The kinds of problem file lcpbench reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProblemFormat {
    /// lcpbench's JSON form.
    Json,
    /// A Siconos numerics LCP text file.
    Siconos,
    /// An FCLIB HDF5 frictional-contact file.
    Fclib,
}

/// The HDF5 file signature.
const HDF5_SIGNATURE: &[u8] = b"\x89HDF\r\n\x1a\n";

impl ProblemFormat {
    /// The format of `path`: FCLIB when the first bytes (`head`) are the HDF5 signature,
    /// whatever the name; else by extension for `.json`, `.hdf5`, `.h5`; by the first bytes
    /// otherwise.
    pub fn detect(path: &Path, head: &[u8]) -> Self {
        if head.starts_with(HDF5_SIGNATURE) {
            return Self::Fclib;
        }
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("json") => return Self::Json,
            Some("hdf5" | "h5") => return Self::Fclib,
            _ => {}
        }
        if head.starts_with(HDF5_SIGNATURE) {
            Self::Fclib
        } else if head
            .iter()
            .find(|c| !c.is_ascii_whitespace())
            .is_some_and(|&c| c == b'{')
        {
            Self::Json
        } else {
            Self::Siconos
        }
    }
}

/// The sparse forms of `A` in a file, or its rows.
pub(crate) enum MatrixField {
    Dense(Vec<Vec<f64>>),
    Triplets {
        n: usize,
        triplets: Vec<(usize, usize, f64)>,
    },
    Csr {
        n: usize,
        row_ptr: Vec<usize>,
        col_idx: Vec<usize>,
        values: Vec<f64>,
    },
}

impl<'de> Deserialize<'de> for MatrixField {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(MatrixVisitor)
    }
}

struct MatrixVisitor;

impl<'de> Visitor<'de> for MatrixVisitor {
    type Value = MatrixField;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(
            "an array of rows, {\"n\", \"triplets\"} or {\"n\", \"row_ptr\", \"col_idx\", \"values\"}",
        )
    }

    fn visit_seq<S: SeqAccess<'de>>(self, mut seq: S) -> Result<MatrixField, S::Error> {
        let mut rows = Vec::new();
        while let Some(row) = seq.next_element::<Vec<f64>>()? {
            rows.push(row);
        }
        Ok(MatrixField::Dense(rows))
    }

    fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<MatrixField, M::Error> {
        let (mut n, mut triplets, mut row_ptr, mut col_idx, mut values) =
            (None, None, None, None, None);
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "n" => n = Some(map.next_value::<usize>()?),
                "triplets" => triplets = Some(map.next_value::<Vec<(usize, usize, f64)>>()?),
                "row_ptr" => row_ptr = Some(map.next_value::<Vec<usize>>()?),
                "col_idx" => col_idx = Some(map.next_value::<Vec<usize>>()?),
                "values" => values = Some(map.next_value::<Vec<f64>>()?),
                other => {
                    return Err(de::Error::custom(format!(
                        "A: unknown key `{other}` (a sparse A has `n` and either `triplets` or \
                         `row_ptr`, `col_idx`, `values`)"
                    )))
                }
            }
        }
        let n = n.ok_or_else(|| de::Error::custom("A: a sparse A needs its size `n`"))?;
        match (triplets, row_ptr, col_idx, values) {
            (Some(triplets), None, None, None) => Ok(MatrixField::Triplets { n, triplets }),
            (None, Some(row_ptr), Some(col_idx), Some(values)) => Ok(MatrixField::Csr {
                n,
                row_ptr,
                col_idx,
                values,
            }),
            _ => Err(de::Error::custom(
                "A: a sparse A has either `triplets` or all of `row_ptr`, `col_idx` and `values`",
            )),
        }
    }
}

#[derive(Deserialize)]
#[serde(expecting = "a problem object with fields `A` and `b`")]
struct ProblemFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(rename = "A")]
    a: MatrixField,
    b: Vec<f64>,
    #[serde(default)]
    lo: Option<Vec<Option<f64>>>,
    #[serde(default)]
    hi: Option<Vec<Option<f64>>>,
    #[serde(default)]
    friction: Vec<(usize, usize, f64)>,
}

/// How `A` is written: rows, or compressed sparse rows.
#[derive(Serialize)]
#[serde(untagged)]
pub(crate) enum MatrixOut {
    Dense(Vec<Vec<f64>>),
    Csr {
        n: usize,
        row_ptr: Vec<usize>,
        col_idx: Vec<usize>,
        values: Vec<f64>,
    },
}

#[derive(Serialize)]
struct ProblemFileOut<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<&'a str>,
    #[serde(rename = "A")]
    a: MatrixOut,
    b: &'a [f64],
    #[serde(skip_serializing_if = "Option::is_none")]
    lo: Option<Vec<Option<f64>>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    hi: Option<Vec<Option<f64>>>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    friction: Vec<(usize, usize, f64)>,
}

/// The bounds vectors of a file (`None` entries are unbounded), checked against `n`.
fn bounds(
    path: &Path,
    name: &str,
    v: Option<Vec<Option<f64>>>,
    n: usize,
    default: f64,
    unbounded: f64,
) -> Result<Vec<f64>, ProblemFileError> {
    match v {
        None => Ok(vec![default; n]),
        Some(v) if v.len() != n => Err(ProblemFileError::field(
            path,
            name,
            format!("has {} entries, but b has {n}", v.len()),
        )),
        Some(v) => Ok(v.into_iter().map(|x| x.unwrap_or(unbounded)).collect()),
    }
}

/// Check a compressed-row `A` and turn it into triplets.
pub(crate) fn csr_triplets(
    path: &Path,
    n: usize,
    row_ptr: &[usize],
    col_idx: &[usize],
    values: &[f64],
) -> Result<Vec<(usize, usize, f64)>, ProblemFileError> {
    let err = |field: &str, message: String| ProblemFileError::field(path, field, message);
    if row_ptr.len() != n + 1 {
        return Err(err(
            "A.row_ptr",
            format!("has {} entries, but n + 1 = {}", row_ptr.len(), n + 1),
        ));
    }
    if col_idx.len() != values.len() {
        return Err(err(
            "A.col_idx",
            format!(
                "has {} entries, but A.values has {}",
                col_idx.len(),
                values.len()
            ),
        ));
    }
    if row_ptr[0] != 0 || row_ptr[n] != values.len() {
        return Err(err(
            "A.row_ptr",
            format!(
                "must start at 0 and end at the number of entries ({}), but runs from {} to {}",
                values.len(),
                row_ptr[0],
                row_ptr[n]
            ),
        ));
    }
    if let Some(i) = (0..n).find(|&i| row_ptr[i] > row_ptr[i + 1]) {
        return Err(err(
            "A.row_ptr",
            format!("decreases at row {i} ({} > {})", row_ptr[i], row_ptr[i + 1]),
        ));
    }
    if let Some(k) = col_idx.iter().position(|&j| j >= n) {
        return Err(err(
            "A.col_idx",
            format!("entry {k} is column {}, outside 0..{n}", col_idx[k]),
        ));
    }
    let mut triplets = Vec::with_capacity(values.len());
    for i in 0..n {
        for k in row_ptr[i]..row_ptr[i + 1] {
            triplets.push((i, col_idx[k], values[k]));
        }
    }
    Ok(triplets)
}

/// Parse a problem from JSON text; `path` is used in error messages only.
pub fn parse_problem(text: &str, path: &Path) -> Result<Problem, ProblemFileError> {
    let parse_error = |e: serde_json::Error| ProblemFileError::Parse {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    };
    if !text.trim_start().starts_with('{') {
        // Name what the file holds instead of the internal type serde expected.
        let value: serde_json::Value = serde_json::from_str(text).map_err(parse_error)?;
        let found = match value {
            serde_json::Value::Null => "null",
            serde_json::Value::Bool(_) => "a boolean",
            serde_json::Value::Number(_) => "a number",
            serde_json::Value::String(_) => "a string",
            serde_json::Value::Array(_) => "an array",
            serde_json::Value::Object(_) => "an object",
        };
        return Err(ProblemFileError::Parse {
            path: path.to_owned(),
            line: 1,
            column: 1,
            message: format!("expected one JSON object with fields `A` and `b`, found {found}"),
        });
    }
    let file: ProblemFile = serde_json::from_str(text).map_err(parse_error)?;
    let n = file.b.len();
    let lo = bounds(path, "lo", file.lo, n, 0.0, f64::NEG_INFINITY)?;
    let hi = bounds(path, "hi", file.hi, n, f64::INFINITY, f64::INFINITY)?;
    let friction = file
        .friction
        .into_iter()
        .map(|(row, normal, mu)| FrictionRow { row, normal, mu })
        .collect();
    let invalid = ProblemFileError::invalid(path);
    let problem = match matrix_data(path, file.a, "A", "b", n)? {
        MatrixData::Dense(a) => Problem::boxed(a, file.b, lo, hi, friction).map_err(&invalid)?,
        MatrixData::Triplets(triplets) => {
            let a = sparse_from_triplets(n, &triplets).map_err(&invalid)?;
            Problem::boxed_sparse(a, file.b, lo, hi, friction).map_err(&invalid)?
        }
    };
    Ok(match file.name {
        Some(name) => problem.with_name(name),
        None => problem,
    })
}

/// Largest problem file read, bytes: a dense `n = 10,000` problem as `lcpbench gen` writes it
/// is about 2.5 GB of JSON. Devices, pipes and directories are refused whatever their size.
pub const MAX_PROBLEM_FILE_BYTES: u64 = 4_000_000_000;

/// Read a problem file of any supported format (see the module doc for how the format is
/// chosen).
pub fn read_problem(path: &Path) -> Result<Problem, ProblemFileError> {
    let io_err = |source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    };
    let bytes = input::read_input_file(path, MAX_PROBLEM_FILE_BYTES).map_err(io_err)?;
    let format = ProblemFormat::detect(path, &bytes[..bytes.len().min(64)]);
    match format {
        ProblemFormat::Fclib => fclib::parse_fclib(bytes, path),
        ProblemFormat::Json | ProblemFormat::Siconos => {
            let text = String::from_utf8(bytes).map_err(|e| ProblemFileError::Unsupported {
                path: path.to_owned(),
                message: format!(
                    "not UTF-8 text ({e}), and not an HDF5 file either; expected a JSON, \
                     Siconos .dat or FCLIB .hdf5 problem file"
                ),
            })?;
            if format == ProblemFormat::Json {
                parse_problem(&text, path)
            } else {
                siconos::parse_siconos(&text, path)
            }
        }
    }
}

/// The largest friction coefficient a problem file may give a contact (cone JSON, FCLIB,
/// Siconos friction-contact files; scene files stop at 100).
///
/// The cone residual measures each contact against the magnitudes of the terms of De Saxcé's
/// velocity `û = u + mu ‖u_T‖ e_N` (see [`crate::cone`]), so `mu ‖u_T‖` sets its scale as `mu`
/// grows: at `mu = 1e5` a reaction of zero under a normal velocity of `-0.16` and a tangential
/// one of `0.08` meets a tolerance of `1e-9`. Up to `1e3` the scale exceeds the normal row's own
/// terms by at most that factor, which the normal-complementarity test of a converged cone
/// result ([`crate::cone::normal_unresolved`]) still resolves at the tolerances lcpbench uses
/// (down to `1e-12` against data of order 1); physical friction coefficients are below 10.
pub const MAX_FILE_MU: f64 = 1e3;

/// The one check of the friction coefficients read from a problem file: each finite, `>= 0`
/// and at most [`MAX_FILE_MU`]. The error names the file, the field with the contact's index,
/// and the limit.
pub(crate) fn check_friction_coefficients(
    path: &Path,
    field: &str,
    mu: &[f64],
) -> Result<(), ProblemFileError> {
    match mu
        .iter()
        .position(|m| !(m.is_finite() && (0.0..=MAX_FILE_MU).contains(m)))
    {
        None => Ok(()),
        Some(c) => Err(ProblemFileError::Field {
            path: path.to_owned(),
            field: format!("{field}[{c}]"),
            message: format!(
                "contact {c}: mu = {:e} must be finite, >= 0 and at most {MAX_FILE_MU:e} (the \
                 limit for friction coefficients in problem files: above it the cone residual \
                 is blind to the normal velocity)",
                mu[c]
            ),
        }),
    }
}

/// Bounds and friction rows of a frictional-contact problem with `mu.len()` contacts of
/// dimension `d` (rows `d·c` normal, `d·c + 1 …` tangential): `0 <= f_n`, `|f_t| <= mu_c f_n`
/// (the box-friction LCP shared by the FCLIB and Siconos friction-contact readers).
pub(crate) fn contact_rows(mu: &[f64], d: usize) -> (Vec<f64>, Vec<f64>, Vec<FrictionRow>) {
    let n = d * mu.len();
    let mut lo = vec![f64::NEG_INFINITY; n];
    let hi = vec![f64::INFINITY; n];
    let mut friction = Vec::with_capacity(n - mu.len());
    for (c, &mu_c) in mu.iter().enumerate() {
        let normal = d * c;
        lo[normal] = 0.0;
        friction.extend((1..d).map(|t| FrictionRow {
            row: normal + t,
            normal,
            mu: mu_c,
        }));
    }
    (lo, hi, friction)
}

/// Numbers in the compressed-row encoding of a problem's `A` (`2 nnz + n + 1`), where `nnz`
/// counts nonzeros and diagonal entries.
fn sparse_encoding_len(problem: &Problem) -> usize {
    let n = problem.n();
    let nnz: usize = (0..n)
        .map(|i| {
            problem
                .row(i)
                .iter()
                .filter(|&(j, v)| v != 0.0 || j == i)
                .count()
        })
        .sum();
    2 * nnz + n + 1
}

/// A matrix read from a file: dense, or the triplets of a sparse one.
pub(crate) enum MatrixData {
    Dense(Mat<f64>),
    Triplets(Vec<(usize, usize, f64)>),
}

/// The matrix field `name` of a file at `path`, checked to be square and, when sparse, of size
/// `n` (the length of the vector field `vector`); compressed rows are checked and read as
/// triplets.
pub(crate) fn matrix_data(
    path: &Path,
    field: MatrixField,
    name: &str,
    vector: &str,
    n: usize,
) -> Result<MatrixData, ProblemFileError> {
    let sized = |size: usize| {
        if size == n {
            Ok(())
        } else {
            Err(ProblemFileError::field(
                path,
                &format!("{name}.n"),
                format!("is {size}, but {vector} has {n} entries"),
            ))
        }
    };
    match field {
        MatrixField::Dense(rows) => {
            let rows_n = rows.len();
            if let Some((i, row)) = rows.iter().enumerate().find(|(_, r)| r.len() != rows_n) {
                return Err(ProblemFileError::field(
                    path,
                    name,
                    format!(
                        "row {i} has {} entries, but {name} has {rows_n} rows",
                        row.len()
                    ),
                ));
            }
            Ok(MatrixData::Dense(Mat::from_fn(rows_n, rows_n, |i, j| {
                rows[i][j]
            })))
        }
        MatrixField::Triplets { n: size, triplets } => {
            sized(size)?;
            Ok(MatrixData::Triplets(triplets))
        }
        MatrixField::Csr {
            n: size,
            row_ptr,
            col_idx,
            values,
        } => {
            let triplets = csr_triplets(path, size, &row_ptr, &col_idx, &values)?;
            sized(size)?;
            Ok(MatrixData::Triplets(triplets))
        }
    }
}

/// `A` in the smaller of the two written forms.
pub(crate) fn matrix_out(problem: &Problem) -> MatrixOut {
    let n = problem.n();
    if n * n <= sparse_encoding_len(problem) {
        return MatrixOut::Dense(
            (0..n)
                .map(|i| (0..n).map(|j| problem.entry(i, j)).collect())
                .collect(),
        );
    }
    let (mut row_ptr, mut col_idx, mut values) = (vec![0], Vec::new(), Vec::new());
    for i in 0..n {
        let row: Row<'_> = problem.row(i);
        for (j, v) in row.iter() {
            if v != 0.0 || j == i {
                col_idx.push(j);
                values.push(v);
            }
        }
        row_ptr.push(values.len());
    }
    MatrixOut::Csr {
        n,
        row_ptr,
        col_idx,
        values,
    }
}

/// Serialise a problem to JSON text (infinite bounds as `null`; `A` dense or compressed rows,
/// whichever is smaller).
pub fn problem_to_json(problem: &Problem) -> String {
    let opt = |v: f64| v.is_finite().then_some(v);
    let standard = problem.is_standard();
    let file = ProblemFileOut {
        name: problem.name(),
        a: matrix_out(problem),
        b: problem.b(),
        lo: (!standard).then(|| problem.lo().iter().map(|&v| opt(v)).collect()),
        hi: (!standard).then(|| problem.hi().iter().map(|&v| opt(v)).collect()),
        friction: problem
            .friction()
            .iter()
            .map(|fr| (fr.row, fr.normal, fr.mu))
            .collect(),
    };
    serde_json::to_string(&file).expect("a validated problem serialises")
}

/// Write a problem file (JSON).
pub fn write_problem(problem: &Problem, path: &Path) -> Result<(), ProblemFileError> {
    std::fs::write(path, problem_to_json(problem)).map_err(|source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::metrics::residuals;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn round_trip_keeps_bounds_and_friction() {
        let text = r#"{"name":"t","A":[[2,1],[1,2]],"b":[-1,1],"lo":[0,null],
                      "hi":[null,null],"friction":[[1,0,0.5]],"meta":{"x":1}}"#;
        let p = parse_problem(text, Path::new("t.json")).unwrap();
        assert_eq!(p.name(), Some("t"));
        assert_eq!(p.friction()[0].mu, 0.5);
        let q = parse_problem(&problem_to_json(&p), Path::new("u.json")).unwrap();
        assert_eq!(q.to_dense(), p.to_dense());
        assert_eq!(q.hi()[0], f64::INFINITY);
        assert_eq!(q.lo()[1], f64::NEG_INFINITY);
    }

    #[test]
    fn errors_name_file_field_and_line() {
        let e = parse_problem("{\"A\": [[1,2],[3]],\n \"b\": [1, 2]}", Path::new("p.json"))
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.json: field `A`: row 1 has 1 entries, but A has 2 rows"
        );
        let e = parse_problem("{\"A\": [[1]],\n \"b\": [1,]}", Path::new("p.json")).unwrap_err();
        assert!(e.to_string().starts_with("p.json:2:"), "{e}");
        let e = parse_problem(
            "{\"A\": [[1]], \"b\": [1], \"lo\": [2], \"hi\": [1]}",
            Path::new("p.json"),
        )
        .unwrap_err();
        assert!(e.to_string().contains("row 0: bounds [2, 1]"), "{e}");
        let e = parse_problem("{\"A\": [[1]]}", Path::new("p.json")).unwrap_err();
        assert!(e.to_string().contains("missing field `b`"), "{e}");
    }

    #[test]
    fn sparse_forms_read_the_same_matrix() {
        let dense = r#"{"A": [[2,-1,0],[-1,2,0],[0,0,1]], "b": [-1,0,1]}"#;
        let triplets = r#"{"A": {"n": 3, "triplets": [[2,2,1],[0,0,2],[0,1,-1],[1,0,-1],
                            [1,1,1.5],[1,1,0.5]]}, "b": [-1,0,1]}"#;
        let csr = r#"{"A": {"n": 3, "row_ptr": [0,2,4,5], "col_idx": [0,1,0,1,2],
                       "values": [2,-1,-1,2,1]}, "b": [-1,0,1]}"#;
        let d = parse_problem(dense, Path::new("d.json")).unwrap();
        assert!(!d.is_sparse());
        for text in [triplets, csr] {
            let s = parse_problem(text, Path::new("s.json")).unwrap();
            assert!(s.is_sparse());
            assert_eq!(s.to_dense(), d.to_dense());
            assert_eq!(s.nnz(), 5);
        }
    }

    #[test]
    fn sparse_errors_name_file_field_and_position() {
        let p = Path::new("s.json");
        let cases = [
            (
                r#"{"A": {"n": 2, "triplets": [[0,2,1]]}, "b": [1,1]}"#,
                "s.json: triplet 0: (0, 2) is outside the 2×2 matrix",
            ),
            (
                r#"{"A": {"n": 3, "triplets": []}, "b": [1,1]}"#,
                "s.json: field `A.n`: is 3, but b has 2 entries",
            ),
            (
                r#"{"A": {"n": 2, "row_ptr": [0,1], "col_idx": [0], "values": [1]}, "b": [1,1]}"#,
                "s.json: field `A.row_ptr`: has 2 entries, but n + 1 = 3",
            ),
            (
                r#"{"A": {"n": 2, "row_ptr": [0,1,1], "col_idx": [0,1], "values": [1,1]}, "b": [1,1]}"#,
                "s.json: field `A.row_ptr`: must start at 0 and end at the number of entries (2), \
                 but runs from 0 to 1",
            ),
            (
                r#"{"A": {"n": 2, "row_ptr": [0,2,1], "col_idx": [0], "values": [1]}, "b": [1,1]}"#,
                "s.json: field `A.row_ptr`: decreases at row 1 (2 > 1)",
            ),
            (
                r#"{"A": {"n": 2, "row_ptr": [0,1,2], "col_idx": [0,5], "values": [1,1]}, "b": [1,1]}"#,
                "s.json: field `A.col_idx`: entry 1 is column 5, outside 0..2",
            ),
            (
                r#"{"A": {"n": 2, "row_ptr": [0,1,2], "col_idx": [0], "values": [1,1]}, "b": [1,1]}"#,
                "s.json: field `A.col_idx`: has 1 entries, but A.values has 2",
            ),
        ];
        for (text, message) in cases {
            let e = parse_problem(text, p).unwrap_err();
            assert_eq!(e.to_string(), message);
        }
        // Shape errors inside A come from the JSON reader, with line and column.
        let e = parse_problem("{\"A\": {\"n\": 2,\n \"rows\": []}, \"b\": [1]}", p).unwrap_err();
        let m = e.to_string();
        assert!(
            m.starts_with("s.json:2:") && m.contains("unknown key `rows`"),
            "{m}"
        );
        let e = parse_problem("{\"A\": {\"n\": 2, \"row_ptr\": [0]}, \"b\": [1]}", p).unwrap_err();
        assert!(e.to_string().contains("either `triplets` or all of"), "{e}");
        let e = parse_problem("{\"A\": {\"triplets\": []}, \"b\": []}", p).unwrap_err();
        assert!(e.to_string().contains("needs its size `n`"), "{e}");
        let e = parse_problem("{\"A\": {\"n\": 1, \"triplets\": [[0, 0]]}, \"b\": [1]}", p)
            .unwrap_err();
        assert!(e.to_string().starts_with("s.json:1:"), "{e}");
    }

    /// A random sparse boxed problem with friction rows: SPD `A = L Lᵀ + I` from a banded `L`.
    fn random_sparse(n: usize, seed: u64) -> Problem {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut l = Mat::<f64>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(2)..=i {
                if rng.random_bool(0.7) {
                    l[(i, j)] = rng.random_range(-1.0..1.0);
                }
            }
        }
        let a = &l * l.transpose() + Mat::<f64>::identity(n, n);
        let mut triplets = Vec::new();
        for i in 0..n {
            for j in 0..n {
                if a[(i, j)] != 0.0 {
                    triplets.push((i, j, a[(i, j)]));
                }
            }
        }
        let b = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut lo = vec![0.0; n];
        let hi = vec![f64::INFINITY; n];
        let mut friction = Vec::new();
        for k in (0..n.saturating_sub(2)).step_by(3) {
            friction.push(FrictionRow {
                row: k + 1,
                normal: k,
                mu: 0.5,
            });
            lo[k + 2] = -1.0;
        }
        let a = sparse_from_triplets(n, &triplets).unwrap();
        Problem::boxed_sparse(a, b, lo, hi, friction).unwrap()
    }

    #[test]
    fn export_writes_the_smaller_form_and_round_trips() {
        for (seed, n) in [(1, 3), (2, 12), (3, 60)] {
            let sparse = random_sparse(n, seed);
            let dense = Problem::boxed(
                sparse.to_dense(),
                sparse.b().to_vec(),
                sparse.lo().to_vec(),
                sparse.hi().to_vec(),
                sparse.friction().to_vec(),
            )
            .unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
            let f: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..2.0)).collect();
            let r0 = residuals(&sparse, &f);
            for p in [&sparse, &dense] {
                let text = problem_to_json(p);
                let back = parse_problem(&text, Path::new("r.json")).unwrap();
                // The smaller form is chosen whatever the storage it came from.
                let written_sparse = text.contains("\"row_ptr\"");
                assert_eq!(written_sparse, n * n > sparse_encoding_len(p), "n = {n}");
                assert_eq!(back.is_sparse(), written_sparse);
                assert_eq!(back.to_dense(), p.to_dense());
                assert_eq!(back.b(), p.b());
                assert_eq!(back.friction(), p.friction());
                let r = residuals(&back, &f);
                assert!(
                    (r.natural_map_rel - r0.natural_map_rel).abs() <= 1e-12,
                    "{r:?} vs {r0:?}"
                );
                assert!((r.natural_map - r0.natural_map).abs() <= 1e-12);
            }
        }
    }

    #[test]
    fn formats_are_detected_by_extension_then_content() {
        use ProblemFormat::*;
        let d = |p: &str, head: &[u8]| ProblemFormat::detect(Path::new(p), head);
        assert_eq!(d("a.json", b"3\n0"), Json);
        assert_eq!(d("a.hdf5", b"{"), Fclib);
        assert_eq!(d("a.H5", b""), Fclib);
        assert_eq!(d("a.dat", b"  \n{\"A\""), Json);
        assert_eq!(d("a.dat", b"2\n0\n2\n2\n"), Siconos);
        assert_eq!(d("a", HDF5_SIGNATURE), Fclib);
        // The signature wins over the name: an HDF5 file called `.json` is read as FCLIB.
        assert_eq!(d("a.json", HDF5_SIGNATURE), Fclib);
        assert_eq!(d("a.txt", b"2 0 2 2"), Siconos);
    }
}
