//! Python arrays into lcpbench's matrices and vectors, every shape and index checked (with the
//! argument and field named) before anything of the declared size is allocated.
//!
//! A scipy CSR or CSC matrix is not copied here: its numpy buffers are borrowed and read once,
//! straight into the problem's own compressed rows (`Problem::boxed_csr`, `boxed_csc`), in one
//! pass over the stored entries that copies and checks them together. `b`, `lo` and `hi` are
//! copied once each.

use crate::errors::bad;
use faer::sparse::SparseRowMat;
use faer::Mat;
use lcpbench_solvers::{FrictionRow, Problem, ProblemError};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::borrow::Cow;

/// A matrix argument: dense, or the compressed sparse parts of a scipy matrix, borrowed from
/// its numpy arrays (read once, by [`SparseParts::problem`] or [`SparseParts::matrix`]).
pub enum Matrix<'py> {
    /// A dense matrix.
    Dense(Mat<f64>),
    /// Compressed sparse rows or columns.
    Sparse(SparseParts<'py>),
}

/// scipy's `(indptr, indices, data)` of a square CSR or CSC matrix, as numpy holds them: the
/// shape and the number of offsets are checked here, everything else where the parts are read
/// into lcpbench's own compressed rows (`Problem::boxed_csr` and its kin), in one pass.
pub struct SparseParts<'py> {
    /// CSC (the parts are the compressed rows of the transpose) rather than CSR.
    columns: bool,
    indptr: Indices<'py>,
    indices: Indices<'py>,
    data: PyReadonlyArrayDyn<'py, f64>,
}

/// An index array in the integer width numpy stores it in (scipy uses int32 or int64).
enum Indices<'py> {
    I32(PyReadonlyArrayDyn<'py, i32>),
    I64(PyReadonlyArrayDyn<'py, i64>),
}

/// The contents of a 1-D array, borrowed when contiguous (as scipy's always are), else copied.
fn contents<'a, T: numpy::Element + Copy>(a: &'a PyReadonlyArrayDyn<'_, T>) -> Cow<'a, [T]> {
    match a.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
    }
}

/// `$body` with `$parts` bound to the `(indptr, indices, data)` slices of `$sparse`, in their
/// stored integer widths (four combinations, each a direct read of the numpy buffers).
macro_rules! with_parts {
    ($sparse:expr, |$parts:ident| $body:expr) => {{
        let data = contents(&$sparse.data);
        match (&$sparse.indptr, &$sparse.indices) {
            (Indices::I32(p), Indices::I32(j)) => {
                let (p, j) = (contents(p), contents(j));
                let $parts = (&p[..], &j[..], &data[..]);
                $body
            }
            (Indices::I32(p), Indices::I64(j)) => {
                let (p, j) = (contents(p), contents(j));
                let $parts = (&p[..], &j[..], &data[..]);
                $body
            }
            (Indices::I64(p), Indices::I32(j)) => {
                let (p, j) = (contents(p), contents(j));
                let $parts = (&p[..], &j[..], &data[..]);
                $body
            }
            (Indices::I64(p), Indices::I64(j)) => {
                let (p, j) = (contents(p), contents(j));
                let $parts = (&p[..], &j[..], &data[..]);
                $body
            }
        }
    }};
}

impl SparseParts<'_> {
    /// The boxed LCP with these parts as `A`: the parts read once, straight into the problem's
    /// compressed rows.
    pub fn problem(
        &self,
        b: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        friction: Vec<FrictionRow>,
    ) -> Result<Problem, ProblemError> {
        with_parts!(self, |parts| if self.columns {
            Problem::boxed_csc(parts, b, lo, hi, friction)
        } else {
            Problem::boxed_csr(parts, b, lo, hi, friction)
        })
    }

    /// The matrix alone, in lcpbench's compressed rows.
    pub fn matrix(&self) -> Result<SparseRowMat<usize, f64>, ProblemError> {
        with_parts!(self, |parts| if self.columns {
            Problem::sparse_from_csc(parts)
        } else {
            Problem::sparse_from_csr(parts)
        })
    }
}

/// The 1-D float64 array `obj` (argument `what`) as a vector.
pub fn vector(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let arr = one_dimensional(what, obj)?;
    Ok(contents(&arr).into_owned())
}

/// The matrix argument `what`: a 2-D float64 array, or the tuple
/// `(format, (rows, cols), data, indices, indptr)` of a scipy CSR (`format = "csr"`) or CSC
/// (`"csc"`) matrix. Must be square.
pub fn matrix<'py>(what: &str, obj: &Bound<'py, PyAny>) -> PyResult<Matrix<'py>> {
    if let Ok(t) = obj.cast::<PyTuple>() {
        return sparse(what, t);
    }
    let arr: PyReadonlyArrayDyn<'_, f64> = obj.extract().map_err(|_| {
        bad(format!(
            "{what} must be a 2-D array of float64 numbers or a scipy.sparse matrix"
        ))
    })?;
    let shape = arr.shape();
    if shape.len() != 2 {
        return Err(bad(format!(
            "{what} must be two-dimensional, but its shape is {shape:?}"
        )));
    }
    if shape[0] != shape[1] {
        return Err(bad(format!(
            "{what} must be square, but it is {}×{}",
            shape[0], shape[1]
        )));
    }
    let n = shape[0];
    let view = arr.as_array();
    Ok(Matrix::Dense(Mat::from_fn(n, n, |i, j| view[[i, j]])))
}

/// A compressed sparse matrix from its parts (see [`matrix`]), borrowed: the square shape and
/// the number of offsets are checked here; the offsets themselves, the indices (range, order,
/// repeats) and the values (finite) are checked as they are read ([`SparseParts`]).
fn sparse<'py>(what: &str, t: &Bound<'py, PyTuple>) -> PyResult<Matrix<'py>> {
    let shape_err = || {
        bad(format!(
            "{what}: a sparse matrix is passed as (format, (rows, cols), data, indices, indptr)"
        ))
    };
    if t.len() != 5 {
        return Err(shape_err());
    }
    let format: String = t.get_item(0)?.extract().map_err(|_| shape_err())?;
    let (rows, cols): (usize, usize) = t.get_item(1)?.extract().map_err(|_| shape_err())?;
    if rows != cols {
        return Err(bad(format!(
            "{what} must be square, but it is {rows}×{cols}"
        )));
    }
    let columns = match format.as_str() {
        "csr" => false,
        "csc" => true,
        other => {
            return Err(bad(format!(
                "{what}: sparse format `{other}` is not read directly (csr and csc are); \
                 convert it with .tocsr()"
            )))
        }
    };
    let data = one_dimensional(&format!("{what}.data"), &t.get_item(2)?)?;
    let indices = index_array(&format!("{what}.indices"), &t.get_item(3)?)?;
    let indptr = index_array(&format!("{what}.indptr"), &t.get_item(4)?)?;
    let offsets = match &indptr {
        Indices::I32(a) => a.len(),
        Indices::I64(a) => a.len(),
    };
    if offsets != rows + 1 {
        let major = if columns { "column" } else { "row" };
        return Err(bad(format!(
            "{what}.indptr has {offsets} entries for {rows} {major}s (expected {})",
            rows + 1
        )));
    }
    Ok(Matrix::Sparse(SparseParts {
        columns,
        indptr,
        indices,
        data,
    }))
}

/// The float64 array `obj` (argument `what`), which must be one-dimensional.
fn one_dimensional<'py>(
    what: &str,
    obj: &Bound<'py, PyAny>,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let arr: PyReadonlyArrayDyn<'py, f64> = obj
        .extract()
        .map_err(|_| bad(format!("{what} must be an array of float64 numbers")))?;
    if arr.ndim() != 1 {
        return Err(bad(format!(
            "{what} must be one-dimensional, but its shape is {:?}",
            arr.shape()
        )));
    }
    Ok(arr)
}

/// A 1-D integer array (int32 or int64, as scipy stores indices), borrowed.
fn index_array<'py>(what: &str, obj: &Bound<'py, PyAny>) -> PyResult<Indices<'py>> {
    let one_dim = |shape: &[usize]| {
        if shape.len() == 1 {
            Ok(())
        } else {
            Err(bad(format!(
                "{what} must be one-dimensional, but its shape is {shape:?}"
            )))
        }
    };
    if let Ok(a) = obj.extract::<PyReadonlyArrayDyn<'py, i32>>() {
        one_dim(a.shape())?;
        return Ok(Indices::I32(a));
    }
    if let Ok(a) = obj.extract::<PyReadonlyArrayDyn<'py, i64>>() {
        one_dim(a.shape())?;
        return Ok(Indices::I64(a));
    }
    Err(bad(format!("{what} must be an array of int32 or int64")))
}
