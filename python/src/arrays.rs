//! Python arrays into lcpbench's matrices and vectors, every shape and index checked (with the
//! argument and field named) before anything of the declared size is allocated.

use crate::errors::bad;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use faer::Mat;
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// A matrix argument: dense, or compressed sparse rows with sorted, distinct column indices.
pub enum Matrix {
    /// A dense matrix.
    Dense(Mat<f64>),
    /// Compressed sparse rows.
    Sparse(SparseRowMat<usize, f64>),
}

/// The 1-D float64 array `obj` (argument `what`) as a vector.
pub fn vector(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let arr: PyReadonlyArrayDyn<'_, f64> = obj
        .extract()
        .map_err(|_| bad(format!("{what} must be an array of float64 numbers")))?;
    if arr.ndim() != 1 {
        return Err(bad(format!(
            "{what} must be one-dimensional, but its shape is {:?}",
            arr.shape()
        )));
    }
    Ok(match arr.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => arr.as_array().iter().copied().collect(),
    })
}

/// The matrix argument `what`: a 2-D float64 array, or the tuple
/// `(format, (rows, cols), data, indices, indptr)` of a scipy CSR (`format = "csr"`) or CSC
/// (`"csc"`) matrix. Must be square.
pub fn matrix(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Matrix> {
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

/// A compressed sparse matrix from its parts (see [`matrix`]).
fn sparse(what: &str, t: &Bound<'_, PyTuple>) -> PyResult<Matrix> {
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
    let csc = match format.as_str() {
        "csr" => false,
        "csc" => true,
        other => {
            return Err(bad(format!(
                "{what}: sparse format `{other}` is not read directly (csr and csc are); \
                 convert it with .tocsr()"
            )))
        }
    };
    let data = vector(&format!("{what}.data"), &t.get_item(2)?)?;
    let indices = index_vector(&format!("{what}.indices"), &t.get_item(3)?)?;
    let indptr = index_vector(&format!("{what}.indptr"), &t.get_item(4)?)?;
    let (major, minor) = if csc {
        ("column", "row")
    } else {
        ("row", "column")
    };
    let n = rows;
    if indptr.len() != n + 1 {
        return Err(bad(format!(
            "{what}.indptr has {} entries for {n} {major}s (expected {})",
            indptr.len(),
            n + 1
        )));
    }
    if indices.len() != data.len() {
        return Err(bad(format!(
            "{what}.indices has {} entries but {what}.data has {}",
            indices.len(),
            data.len()
        )));
    }
    if indptr[0] != 0 {
        return Err(bad(format!("{what}.indptr[0] is {}, not 0", indptr[0])));
    }
    if let Some(k) = (0..n).find(|&k| indptr[k + 1] < indptr[k]) {
        return Err(bad(format!(
            "{what}.indptr decreases at {major} {k} ({} then {})",
            indptr[k],
            indptr[k + 1]
        )));
    }
    let nnz = indptr[n];
    if nnz > indices.len() {
        return Err(bad(format!(
            "{what}.indptr[{n}] = {nnz} exceeds the {} stored entries",
            indices.len()
        )));
    }
    let mut canonical = true;
    for k in 0..n {
        let idx = &indices[indptr[k]..indptr[k + 1]];
        if let Some(&j) = idx.iter().find(|&&j| j >= n) {
            return Err(bad(format!(
                "{what}.indices: {major} {k} names {minor} {j}, outside the {n}×{n} matrix"
            )));
        }
        canonical &= idx.windows(2).all(|w| w[0] < w[1]);
    }
    let (indptr, mut indices, mut data) = if canonical {
        (indptr, indices, data)
    } else {
        canonical_form(&indptr, &indices, &data, n)
    };
    let nnz = indptr[n];
    indices.truncate(nnz);
    data.truncate(nnz);
    // Checked above: indptr starts at 0, never decreases, ends within the entries, and each
    // compressed row's indices are in range and strictly increasing.
    let symbolic = SymbolicSparseRowMat::new_checked(n, n, indptr, None, indices);
    let stored = SparseRowMat::new(symbolic, data);
    if !csc {
        return Ok(Matrix::Sparse(stored));
    }
    // A CSC matrix's arrays are the compressed rows of its transpose.
    let a = stored
        .as_ref()
        .transpose()
        .to_row_major()
        .map_err(|e| bad(format!("{what}: cannot convert CSC to rows ({e:?})")))?;
    Ok(Matrix::Sparse(a))
}

/// The compressed rows with each row's indices sorted and repeated indices summed (scipy's
/// `sum_duplicates`, done here in one pass over the stored entries instead of on a copy in
/// Python). `indptr` and `indices` are checked (in range, non-decreasing) before.
fn canonical_form(
    indptr: &[usize],
    indices: &[usize],
    data: &[f64],
    n: usize,
) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let nnz = indptr[n];
    let mut ptr = Vec::with_capacity(n + 1);
    let mut idx = Vec::with_capacity(nnz);
    let mut val = Vec::with_capacity(nnz);
    let mut row: Vec<(usize, f64)> = Vec::new();
    ptr.push(0);
    for k in 0..n {
        row.clear();
        row.extend((indptr[k]..indptr[k + 1]).map(|e| (indices[e], data[e])));
        row.sort_unstable_by_key(|&(j, _)| j);
        for &(j, v) in &row {
            match idx.last() {
                Some(&last) if last == j && idx.len() > ptr[k] => {
                    *val.last_mut().expect("a value per index") += v;
                }
                _ => {
                    idx.push(j);
                    val.push(v);
                }
            }
        }
        ptr.push(idx.len());
    }
    (ptr, idx, val)
}

/// A 1-D integer array (int32 or int64, as scipy stores indices) as non-negative indices.
fn index_vector(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<usize>> {
    let negative = |k: usize, v: i64| bad(format!("{what}[{k}] = {v} is negative"));
    let one_dim = |shape: &[usize]| {
        if shape.len() == 1 {
            Ok(())
        } else {
            Err(bad(format!(
                "{what} must be one-dimensional, but its shape is {shape:?}"
            )))
        }
    };
    if let Ok(a) = obj.extract::<PyReadonlyArrayDyn<'_, i32>>() {
        one_dim(a.shape())?;
        return a
            .as_array()
            .iter()
            .enumerate()
            .map(|(k, &v)| usize::try_from(v).map_err(|_| negative(k, v.into())))
            .collect();
    }
    if let Ok(a) = obj.extract::<PyReadonlyArrayDyn<'_, i64>>() {
        one_dim(a.shape())?;
        return a
            .as_array()
            .iter()
            .enumerate()
            .map(|(k, &v)| usize::try_from(v).map_err(|_| negative(k, v)))
            .collect();
    }
    Err(bad(format!("{what} must be an array of int32 or int64")))
}
