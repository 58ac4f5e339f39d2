//! The cone problem file format (JSON), next to the LCP format of [`crate::read_problem`]:
//!
//! ```json
//! { "name": "one contact", "W": [[0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]],
//!   "q": [-0.16, 0.08, 0.0], "mu": [0.5] }
//! ```
//!
//! `W` is `3n_c × 3n_c` (rows per contact: normal, tangent 1, tangent 2), `q` its free velocity,
//! `mu` one coefficient per contact. A file is a cone problem when it has a `mu` key. `W` takes
//! the forms of the LCP format's `A` (an array of rows, or `{"n", "triplets"}` or
//! `{"n", "row_ptr", "col_idx", "values"}`, see [`crate::io`]); [`cone_problem_to_json`] writes
//! the smaller of rows and compressed rows, so a large scene's sparse `W` stays sparse.

use crate::cone::ConeProblem;
use crate::io::{matrix_data, matrix_out, MatrixData, MatrixField, MatrixOut, ProblemFileError};
use crate::problem::sparse_from_triplets;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Deserialize)]
struct ConeFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(rename = "W")]
    w: MatrixField,
    q: Vec<f64>,
    mu: Vec<f64>,
}

#[derive(Serialize)]
struct ConeFileOut<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<&'a str>,
    #[serde(rename = "W")]
    w: MatrixOut,
    q: &'a [f64],
    mu: &'a [f64],
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
    let n = file.q.len();
    crate::io::check_friction_coefficients(path, "mu", &file.mu)?;
    let p = match matrix_data(path, file.w, "W", "q", n)? {
        MatrixData::Dense(w) => ConeProblem::new(w, file.q, file.mu),
        MatrixData::Triplets(triplets) => {
            let w = sparse_from_triplets(n, &triplets).map_err(|e| field("W", e.to_string()))?;
            ConeProblem::new_sparse(w, file.q, file.mu)
        }
    }
    .map_err(|e| field("W/q/mu", e.to_string()))?;
    Ok(match file.name {
        Some(name) => p.with_name(name),
        None => p,
    })
}

/// Serialise a cone problem to JSON text (`W` as rows or compressed rows, whichever is smaller).
pub fn cone_problem_to_json(problem: &ConeProblem) -> String {
    let file = ConeFileOut {
        name: problem.name(),
        w: matrix_out(problem.delassus()),
        q: problem.q(),
        mu: problem.mu(),
    };
    serde_json::to_string(&file).expect("a validated problem serialises")
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

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
            "c.json: field `mu[0]`: contact 0: mu = -1e0 must be finite, >= 0 and at most 1e3 \
             (the limit for friction coefficients in problem files: above it the cone residual \
             is blind to the normal velocity)"
        );
        // The limit itself is accepted, anything above it refused with the contact's index.
        let at = |mu: &str| {
            let text = format!(
                r#"{{"W":[[1,0,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,1]],"q":[-1,0,0,-1,0,0],"mu":[0.5,{mu}]}}"#
            );
            parse_cone_problem(&text, Path::new("m.json"))
        };
        assert!(at("1000").is_ok());
        let e = at("1000.5").unwrap_err().to_string();
        assert!(
            e.starts_with("m.json: field `mu[1]`: contact 1: mu = 1.0005e3"),
            "{e}"
        );
        assert!(e.contains("at most 1e3"), "{e}");
    }

    /// Two contacts coupled in one entry pair: W is written as compressed rows (smaller than
    /// its 36 dense numbers) and reads back entry for entry; triplets read the same; a sparse
    /// size that disagrees with q is named.
    #[test]
    fn sparse_w_round_trips_sparse() {
        let mut w = Mat::from_fn(6, 6, |i, j| if i == j { 2.0 } else { 0.0 });
        w[(0, 3)] = 0.5;
        w[(3, 0)] = 0.5;
        let triplets: Vec<(usize, usize, f64)> = (0..6)
            .flat_map(|i| (0..6).map(move |j| (i, j)))
            .filter(|&(i, j)| w[(i, j)] != 0.0)
            .map(|(i, j)| (i, j, w[(i, j)]))
            .collect();
        let sparse = sparse_from_triplets(6, &triplets).unwrap();
        let q = vec![-1.0, 0.1, 0.0, -2.0, 0.0, 0.3];
        let p = ConeProblem::new_sparse(sparse, q.clone(), vec![0.5, 0.3]).unwrap();
        let text = cone_problem_to_json(&p);
        assert!(text.contains("row_ptr"), "{text}");
        let back = parse_cone_problem(&text, Path::new("s.json")).unwrap();
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(back.delassus().entry(i, j), w[(i, j)], "({i},{j})");
            }
        }
        assert_eq!(back.q(), &q[..]);
        let t = r#"{"W":{"n":6,"triplets":[[0,0,2],[1,1,2],[2,2,2],[3,3,2],[4,4,2],[5,5,2],[0,3,0.5],[3,0,0.5]]},"q":[-1,0.1,0,-2,0,0.3],"mu":[0.5,0.3]}"#;
        let from_triplets = parse_cone_problem(t, Path::new("t.json")).unwrap();
        assert_eq!(from_triplets.delassus().entry(0, 3), 0.5);
        let bad = r#"{"W":{"n":3,"triplets":[[0,0,1]]},"q":[-1,0,0,-1,0,0],"mu":[0.5,0.5]}"#;
        let e = parse_cone_problem(bad, Path::new("b.json")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "b.json: field `W.n`: is 3, but q has 6 entries"
        );
    }
}
