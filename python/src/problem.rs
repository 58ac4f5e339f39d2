//! The problem object: a boxed LCP with friction rows or an exact Coulomb-cone problem, built
//! from arrays or read from a JSON, Siconos `.dat` or FCLIB HDF5 file, and written back.

use crate::arrays::{matrix, vector, Matrix};
use crate::errors::{bad, file_error, os_error};
use lcpbench_solvers::io::{input::read_input_file, MAX_PROBLEM_FILE_BYTES};
use lcpbench_solvers::{
    cone_problem_to_json, is_cone_file, parse_cone_problem, parse_fclib, parse_problem,
    parse_siconos, write_fclib_local, write_problem_as_fclib, ConeProblem, FrictionRow, Problem,
    ProblemFileError, ProblemFormat,
};
use numpy::{PyArray1, PyArray2, ToPyArray};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::path::{Path, PathBuf};

/// What a problem object holds.
pub enum Inner {
    /// `w = A f + b`, `lo <= f <= hi`, friction rows bounded by `±mu f_normal`.
    Lcp(Problem),
    /// `u = W r + q`, `r` in the Coulomb cones, De Saxcé's complementarity.
    Cone(ConeProblem),
}

/// A contact problem: `kind` is `"lcp"` (boxed LCP with friction rows) or `"cone"` (FC3D).
#[pyclass(name = "_Problem", module = "lcpbench", frozen)]
pub struct PyProblem {
    pub inner: Inner,
}

impl PyProblem {
    /// The LCP, or the cone problem's Delassus part (`W`, `q` with free bounds).
    fn matrix_problem(&self) -> &Problem {
        match &self.inner {
            Inner::Lcp(p) => p,
            Inner::Cone(c) => c.delassus(),
        }
    }
}

#[pymethods]
impl PyProblem {
    /// `"lcp"` or `"cone"`.
    #[getter]
    fn kind(&self) -> &'static str {
        match self.inner {
            Inner::Lcp(_) => "lcp",
            Inner::Cone(_) => "cone",
        }
    }

    /// Number of rows.
    #[getter]
    fn n(&self) -> usize {
        self.matrix_problem().n()
    }

    /// The problem's name, from its file.
    #[getter]
    fn name(&self) -> Option<String> {
        self.matrix_problem().name().map(str::to_owned)
    }

    /// `b` (LCP) or `q` (cone).
    #[getter]
    fn b<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.matrix_problem().b().to_pyarray(py)
    }

    /// Lower bounds (LCP only; `-inf` for a free row, and `-mu f_normal` is not stored here:
    /// friction rows take their bounds from `friction`).
    #[getter]
    fn lo<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        match &self.inner {
            Inner::Lcp(p) => Some(p.lo().to_pyarray(py)),
            Inner::Cone(_) => None,
        }
    }

    /// Upper bounds (LCP only).
    #[getter]
    fn hi<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        match &self.inner {
            Inner::Lcp(p) => Some(p.hi().to_pyarray(py)),
            Inner::Cone(_) => None,
        }
    }

    /// Friction rows `(row, normal_row, mu)` (LCP only).
    #[getter]
    fn friction(&self) -> Option<Vec<(usize, usize, f64)>> {
        match &self.inner {
            Inner::Lcp(p) => Some(
                p.friction()
                    .iter()
                    .map(|f| (f.row, f.normal, f.mu))
                    .collect(),
            ),
            Inner::Cone(_) => None,
        }
    }

    /// Friction coefficient of each contact (cone only).
    #[getter]
    fn mu<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        match &self.inner {
            Inner::Lcp(_) => None,
            Inner::Cone(c) => Some(c.mu().to_pyarray(py)),
        }
    }

    /// The matrix `A` (or `W`): `("dense", array)` for dense storage, else
    /// `("csr", (n, n), data, indices, indptr)` (assembled from the factors when the problem
    /// holds `A = J M⁻¹ Jᵀ` factored).
    fn matrix_parts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let p = self.matrix_problem();
        let n = p.n();
        if let Some(a) = p.dense() {
            let m = PyArray2::from_owned_array(
                py,
                numpy::ndarray::Array2::from_shape_fn((n, n), |(i, j)| a[(i, j)]),
            );
            return ("dense", m).into_pyobject(py);
        }
        let s = p.to_sparse();
        let sym = s.symbolic();
        let (ptr, nnz_per, idx, val) = (sym.row_ptr(), sym.row_nnz(), sym.col_idx(), s.val());
        let mut indptr = Vec::with_capacity(n + 1);
        let mut indices = Vec::new();
        let mut data = Vec::new();
        indptr.push(0i64);
        for i in 0..n {
            let start = ptr[i];
            let end = nnz_per.map_or(ptr[i + 1], |z| start + z[i]);
            indices.extend(idx[start..end].iter().map(|&j| j as i64));
            data.extend_from_slice(&val[start..end]);
            indptr.push(indices.len() as i64);
        }
        (
            "csr",
            (n, n),
            PyArray1::from_vec(py, data),
            PyArray1::from_vec(py, indices),
            PyArray1::from_vec(py, indptr),
        )
            .into_pyobject(py)
    }

    fn __repr__(&self) -> String {
        let p = self.matrix_problem();
        let name = p.name().map(|n| format!("{n:?}, ")).unwrap_or_default();
        let storage = if p.dense().is_some() {
            "dense"
        } else {
            "sparse"
        };
        match &self.inner {
            Inner::Lcp(p) => format!(
                "Problem({name}kind=\"lcp\", n={}, {storage}, friction rows={})",
                p.n(),
                p.friction().len()
            ),
            Inner::Cone(c) => format!(
                "Problem({name}kind=\"cone\", n={}, contacts={}, {storage})",
                c.n(),
                c.contacts()
            ),
        }
    }
}

/// Friction rows `[(row, normal_row, mu), …]` from Python.
fn friction_rows(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<FrictionRow>> {
    let Some(obj) = obj else {
        return Ok(Vec::new());
    };
    let rows: Vec<(i64, i64, f64)> = obj.extract().map_err(|_| {
        bad("friction must be a sequence of (row, normal_row, mu) with integer rows and a float mu")
    })?;
    rows.into_iter()
        .enumerate()
        .map(|(k, (row, normal, mu))| {
            let index = |what: &str, v: i64| {
                usize::try_from(v)
                    .map_err(|_| bad(format!("friction[{k}]: {what} = {v} is negative")))
            };
            Ok(FrictionRow {
                row: index("row", row)?,
                normal: index("normal_row", normal)?,
                mu,
            })
        })
        .collect()
}

/// A boxed LCP from arrays: `a` a float64 matrix or sparse parts (see `arrays::matrix`), `lo`
/// and `hi` default to `0` and `+inf` (the standard LCP).
#[pyfunction]
#[pyo3(signature = (a, b, lo=None, hi=None, friction=None, name=None))]
pub fn lcp_problem(
    a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
    lo: Option<&Bound<'_, PyAny>>,
    hi: Option<&Bound<'_, PyAny>>,
    friction: Option<&Bound<'_, PyAny>>,
    name: Option<String>,
) -> PyResult<PyProblem> {
    let b = vector("b", b)?;
    let n = b.len();
    let lo = match lo {
        Some(v) => vector("lo", v)?,
        None => vec![0.0; n],
    };
    let hi = match hi {
        Some(v) => vector("hi", v)?,
        None => vec![f64::INFINITY; n],
    };
    let friction = friction_rows(friction)?;
    let problem = match matrix("A", a)? {
        Matrix::Dense(m) => Problem::boxed(m, b, lo, hi, friction),
        Matrix::Sparse(parts) => parts.problem(b, lo, hi, friction),
    }
    .map_err(|e| bad(e.to_string()))?;
    let problem = match name {
        Some(n) => problem.with_name(n),
        None => problem,
    };
    Ok(PyProblem {
        inner: Inner::Lcp(problem),
    })
}

/// An exact Coulomb-cone problem (FC3D) from arrays: `w` the Delassus matrix of `3 m` rows in
/// (normal, tangent, tangent) triples, `q` the free velocity, `mu` one coefficient per contact.
#[pyfunction]
#[pyo3(signature = (w, q, mu, name=None))]
pub fn cone_problem(
    w: &Bound<'_, PyAny>,
    q: &Bound<'_, PyAny>,
    mu: &Bound<'_, PyAny>,
    name: Option<String>,
) -> PyResult<PyProblem> {
    let q = vector("q", q)?;
    let mu = vector("mu", mu)?;
    let cone = match matrix("W", w)? {
        Matrix::Dense(m) => ConeProblem::new(m, q, mu),
        Matrix::Sparse(parts) => {
            let s = parts
                .matrix()
                .map_err(|e| bad(format!("cone problem (W, q, mu): {e}")))?;
            ConeProblem::new_sparse(s, q, mu)
        }
    }
    .map_err(|e| bad(format!("cone problem (W, q, mu): {e}")))?;
    let cone = match name {
        Some(n) => cone.with_name(n),
        None => cone,
    };
    Ok(PyProblem {
        inner: Inner::Cone(cone),
    })
}

/// Read a problem file as `lcpbench solve` does: the format by extension, then by content
/// (JSON, Siconos `.dat`, FCLIB `.hdf5`/`.h5`); a JSON file with a `mu` key is a cone problem.
/// The file's size is checked before it is read, and every declared size before allocation.
#[pyfunction]
pub fn read(py: Python<'_>, path: PathBuf) -> PyResult<PyProblem> {
    let inner = py.detach(|| read_file(&path)).map_err(file_error)?;
    Ok(PyProblem { inner })
}

fn read_file(path: &Path) -> Result<Inner, ProblemFileError> {
    let bytes =
        read_input_file(path, MAX_PROBLEM_FILE_BYTES).map_err(|source| ProblemFileError::Io {
            path: path.to_owned(),
            source,
        })?;
    let format = ProblemFormat::detect(path, &bytes[..bytes.len().min(64)]);
    if format == ProblemFormat::Fclib {
        return parse_fclib(bytes, path).map(Inner::Lcp);
    }
    let text = String::from_utf8(bytes).map_err(|e| ProblemFileError::Unsupported {
        path: path.to_owned(),
        message: format!(
            "not UTF-8 text ({e}), and not an HDF5 file either; expected a JSON, Siconos .dat \
             or FCLIB .hdf5 problem file"
        ),
    })?;
    match format {
        ProblemFormat::Json if is_cone_file(&text) => {
            parse_cone_problem(&text, path).map(Inner::Cone)
        }
        ProblemFormat::Json => parse_problem(&text, path).map(Inner::Lcp),
        _ => parse_siconos(&text, path).map(Inner::Lcp),
    }
}

/// Write `problem` to `path`: FCLIB HDF5 for `.hdf5`/`.h5` (an LCP only when its rows are
/// contacts in (normal, tangent, tangent) triples), JSON otherwise. An existing file is kept
/// unless `overwrite` is true.
#[pyfunction]
#[pyo3(signature = (problem, path, overwrite=false))]
pub fn write(py: Python<'_>, problem: &PyProblem, path: PathBuf, overwrite: bool) -> PyResult<()> {
    if !overwrite && path.exists() {
        return Err(os_error(
            std::io::ErrorKind::AlreadyExists,
            format!(
                "{}: the file exists; pass overwrite=True to replace it",
                path.display()
            ),
        ));
    }
    let hdf5 = matches!(
        path.extension().and_then(|e| e.to_str()),
        Some("hdf5" | "h5")
    );
    py.detach(|| write_file(&problem.inner, &path, hdf5))
        .map_err(file_error)
}

fn write_file(inner: &Inner, path: &Path, hdf5: bool) -> Result<(), ProblemFileError> {
    let io = |source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    };
    match (inner, hdf5) {
        (Inner::Lcp(p), true) => write_problem_as_fclib(p, path).map(|_| ()),
        (Inner::Lcp(p), false) => lcpbench_solvers::write_problem(p, path),
        (Inner::Cone(c), true) => write_fclib_local(path, 3, &c.delassus().to_csc(), c.q(), c.mu()),
        (Inner::Cone(c), false) => std::fs::write(path, cone_problem_to_json(c)).map_err(io),
    }
}
