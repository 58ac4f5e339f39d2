//! The cone problem file format (JSON), next to the LCP format of [`crate::read_problem`]:
//!
//! ```json
//! { "name": "one contact", "W": [[0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]],
//!   "q": [-0.16, 0.08, 0.0], "mu": [0.5] }
//! ```
//!
//! `W` is `3n_c × 3n_c` (rows per contact: normal, tangent 1, tangent 2), `q` its free velocity,
//! `mu` one coefficient per contact. A file is a cone problem when it has a `mu` key.

use crate::cone::ConeProblem;
use crate::io::ProblemFileError;
use faer::Mat;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Deserialize, Serialize)]
struct ConeFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(rename = "W")]
    w: Vec<Vec<f64>>,
    q: Vec<f64>,
    mu: Vec<f64>,
}

/// True when the JSON text is an object with a `mu` key (a cone problem file).
pub fn is_cone_file(text: &str) -> bool {
    serde_json::from_str::<serde_json::Value>(text)
        .ok()
        .and_then(|v| v.as_object().map(|o| o.contains_key("mu")))
        .unwrap_or(false)
}

/// Parse a cone problem from JSON text; `path` is used in error messages only.
pub fn parse_cone_problem(text: &str, path: &Path) -> Result<ConeProblem, ProblemFileError> {
    let file: ConeFile = serde_json::from_str(text).map_err(|e| ProblemFileError::Parse {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    let field = |field: &str, message: String| ProblemFileError::Field {
        path: path.to_owned(),
        field: field.to_owned(),
        message,
    };
    let n = file.w.len();
    if let Some((i, row)) = file.w.iter().enumerate().find(|(_, r)| r.len() != n) {
        return Err(field(
            "W",
            format!("row {i} has {} entries, but W has {n} rows", row.len()),
        ));
    }
    let w = Mat::from_fn(n, n, |i, j| file.w[i][j]);
    let p = ConeProblem::new(w, file.q, file.mu).map_err(|e| field("W/q/mu", e.to_string()))?;
    Ok(match file.name {
        Some(name) => p.with_name(name),
        None => p,
    })
}

/// Serialise a cone problem to JSON text.
pub fn cone_problem_to_json(problem: &ConeProblem) -> String {
    let d = problem.delassus();
    let n = problem.n();
    let file = ConeFile {
        name: problem.name().map(str::to_owned),
        w: (0..n)
            .map(|i| (0..n).map(|j| d.entry(i, j)).collect())
            .collect(),
        q: problem.q().to_vec(),
        mu: problem.mu().to_vec(),
    };
    serde_json::to_string(&file).expect("a validated problem serialises")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors() {
        let text = r#"{"name":"c","W":[[1,0,0],[0,1,0],[0,0,1]],"q":[-1,0.2,0],"mu":[0.5]}"#;
        assert!(is_cone_file(text));
        assert!(!is_cone_file(r#"{"A":[[1]],"b":[1]}"#));
        let p = parse_cone_problem(text, Path::new("c.json")).unwrap();
        assert_eq!(p.name(), Some("c"));
        let q = parse_cone_problem(&cone_problem_to_json(&p), Path::new("d.json")).unwrap();
        assert_eq!(q.mu(), &[0.5]);
        assert_eq!(q.q(), p.q());
        let e = parse_cone_problem(
            r#"{"W":[[1,0,0],[0,1,0],[0,0,1]],"q":[-1,0,0],"mu":[-1]}"#,
            Path::new("c.json"),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "c.json: field `W/q/mu`: contact 0: mu = -1 must be finite and >= 0"
        );
    }
}
