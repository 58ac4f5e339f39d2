//! The problem file format (JSON).
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
//! `A` is an array of rows, `b` a vector. `lo`/`hi` are optional (absent: `lo = 0`, `hi = +∞`, the
//! standard LCP); a `null` entry is unbounded (`-∞` in `lo`, `+∞` in `hi`). `friction` lists
//! `[row, normal_row, mu]` entries; a friction row's `lo`/`hi` are ignored. `name` is optional.
//! Unknown keys are ignored so files can carry metadata.

use crate::problem::{FrictionRow, Problem, ProblemError};
use faer::Mat;
use serde::{Deserialize, Serialize};
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
    /// The file is not valid JSON of the expected shape.
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
        /// The field (`A`, `lo`, ...).
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
}

#[derive(Deserialize, Serialize)]
#[serde(expecting = "a problem object with fields `A` and `b`")]
struct ProblemFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(rename = "A")]
    a: Vec<Vec<f64>>,
    b: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lo: Option<Vec<Option<f64>>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    hi: Option<Vec<Option<f64>>>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    friction: Vec<(usize, usize, f64)>,
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
    let field = |field: &str, message: String| ProblemFileError::Field {
        path: path.to_owned(),
        field: field.to_owned(),
        message,
    };
    let n = file.a.len();
    if let Some((i, row)) = file.a.iter().enumerate().find(|(_, r)| r.len() != n) {
        return Err(field(
            "A",
            format!("row {i} has {} entries, but A has {n} rows", row.len()),
        ));
    }
    let a = Mat::from_fn(n, n, |i, j| file.a[i][j]);
    let bounds = |name: &str, v: Option<Vec<Option<f64>>>, default: f64, unbounded: f64| match v {
        None => Ok(vec![default; file.b.len()]),
        Some(v) => {
            if v.len() != file.b.len() {
                return Err(field(
                    name,
                    format!("has {} entries, but b has {}", v.len(), file.b.len()),
                ));
            }
            Ok(v.into_iter().map(|x| x.unwrap_or(unbounded)).collect())
        }
    };
    let lo = bounds("lo", file.lo, 0.0, f64::NEG_INFINITY)?;
    let hi = bounds("hi", file.hi, f64::INFINITY, f64::INFINITY)?;
    let friction = file
        .friction
        .into_iter()
        .map(|(row, normal, mu)| FrictionRow { row, normal, mu })
        .collect();
    let problem = Problem::boxed(a, file.b, lo, hi, friction).map_err(|source| {
        ProblemFileError::Invalid {
            path: path.to_owned(),
            source,
        }
    })?;
    Ok(match file.name {
        Some(name) => problem.with_name(name),
        None => problem,
    })
}

/// Read a problem file.
pub fn read_problem(path: &Path) -> Result<Problem, ProblemFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_problem(&text, path)
}

/// Serialise a problem to JSON text (infinite bounds as `null`).
pub fn problem_to_json(problem: &Problem) -> String {
    let n = problem.n();
    let opt = |v: f64| v.is_finite().then_some(v);
    let standard = problem.is_standard();
    let file = ProblemFile {
        name: problem.name().map(str::to_owned),
        a: (0..n)
            .map(|i| (0..n).map(|j| problem.entry(i, j)).collect())
            .collect(),
        b: problem.b().to_vec(),
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

/// Write a problem file.
pub fn write_problem(problem: &Problem, path: &Path) -> Result<(), ProblemFileError> {
    std::fs::write(path, problem_to_json(problem)).map_err(|source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
