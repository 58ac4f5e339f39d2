//! FCLIB frictional-contact problems (HDF5), read as box-friction LCPs.
//!
//! FCLIB (Acary, Brémond, Koziara, Pérignon, *FCLIB: a collection of discrete 3D frictional
//! contact problems*, JOTA 2014) stores a **local** problem in the group `/fclib_local`:
//!
//! ```text
//! /fclib_local/spacedim        2 or 3 (d)
//! /fclib_local/W/{nzmax,m,n,nz,p,i,x}   the Delassus matrix (m = n = d · contacts)
//! /fclib_local/vectors/q       m numbers
//! /fclib_local/vectors/mu      m / d friction coefficients
//! ```
//!
//! with `u = W r + q`, contact `c`'s rows `d·c` (normal) and `d·c + 1 …` (tangential), and the
//! Coulomb cone `‖r_t‖ <= mu_c r_n`. A **global** problem (`/fclib_global`: `M`, `H`, vectors
//! `f`, `w`, `mu`) states `M v = H r + f`, `u = Hᵀ v + w`; it is condensed here to the local one,
//! `W = Hᵀ M⁻¹ H`, `q = Hᵀ M⁻¹ f + w`, with a sparse Cholesky factorisation of `M`. Problems with
//! equality constraints (`G`, `b` in the global form; `V`, `R`, `s` in the local one) are not
//! read.
//!
//! A sparse matrix is CSparse's: `nz >= 0` is `nz` triplets (`i` rows, `p` columns), `nz = -1`
//! compressed columns (`p` has `n + 1` column pointers, `i` row indices), `nz = -2` compressed
//! rows (`p` has `m + 1` row pointers, `i` column indices); `x` holds the values.
//!
//! The Coulomb cone becomes the box-friction LCP that lcpbench's solvers take (ODE's and Bullet's
//! `findex`): `A = W`, `b = q`, per contact one normal row (`0 <= f_n`) and `d - 1` friction rows
//! bounded by `±mu_c f_n`. The box is an outer approximation of the cone (its corners allow
//! `‖f_t‖ = √2 mu f_n` in 3-D), so a solution of the LCP is a solution of the FCLIB problem only
//! where the friction is inside the cone or a single tangent direction slides.

use super::{contact_rows, ProblemFileError};
use crate::problem::{sparse_from_triplets, Problem};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use hdf5::{File, Group};
use std::path::Path;

/// A sparse matrix read from a file, as triplets `(row, column, value)`.
struct SparseData {
    rows: usize,
    cols: usize,
    triplets: Vec<(usize, usize, f64)>,
}

/// Reads datasets of one file, with errors that name the file and the dataset.
struct Reader<'a> {
    path: &'a Path,
}

impl Reader<'_> {
    fn err(&self, field: &str, message: impl Into<String>) -> ProblemFileError {
        ProblemFileError::field(self.path, field, message)
    }

    fn ints(&self, group: &Group, name: &str) -> Result<Vec<i64>, ProblemFileError> {
        let field = format!("{}/{name}", group.name());
        group
            .dataset(name)
            .and_then(|d| d.read_raw::<i64>())
            .map_err(|e| self.err(&field, e.to_string()))
    }

    fn int(&self, group: &Group, name: &str) -> Result<i64, ProblemFileError> {
        let v = self.ints(group, name)?;
        v.first()
            .copied()
            .ok_or_else(|| self.err(&format!("{}/{name}", group.name()), "is empty"))
    }

    fn size(&self, group: &Group, name: &str) -> Result<usize, ProblemFileError> {
        let v = self.int(group, name)?;
        usize::try_from(v)
            .map_err(|_| self.err(&format!("{}/{name}", group.name()), format!("is {v} < 0")))
    }

    fn numbers(&self, group: &Group, name: &str, len: usize) -> Result<Vec<f64>, ProblemFileError> {
        let field = format!("{}/{name}", group.name());
        let v = group
            .dataset(name)
            .and_then(|d| d.read_raw::<f64>())
            .map_err(|e| self.err(&field, e.to_string()))?;
        if v.len() != len {
            return Err(self.err(&field, format!("has {} entries, expected {len}", v.len())));
        }
        Ok(v)
    }

    fn group(&self, file: &Group, name: &str) -> Result<Group, ProblemFileError> {
        file.group(name)
            .map_err(|e| self.err(name, format!("cannot open the group: {e}")))
    }

    /// Indices in `0..bound` from a dataset of at least `len` entries.
    fn indices(
        &self,
        group: &Group,
        name: &str,
        len: usize,
        bound: usize,
    ) -> Result<Vec<usize>, ProblemFileError> {
        let field = format!("{}/{name}", group.name());
        let v = self.ints(group, name)?;
        if v.len() < len {
            return Err(self.err(
                &field,
                format!("has {} entries, expected at least {len}", v.len()),
            ));
        }
        v[..len]
            .iter()
            .enumerate()
            .map(|(k, &x)| {
                usize::try_from(x)
                    .ok()
                    .filter(|&x| x < bound)
                    .ok_or_else(|| {
                        self.err(&field, format!("entry {k} is {x}, outside 0..{bound}"))
                    })
            })
            .collect()
    }

    /// Compressed pointers: `len` entries from 0, non-decreasing, ending at most at `nzmax`.
    fn pointers(
        &self,
        group: &Group,
        len: usize,
        nzmax: usize,
    ) -> Result<Vec<usize>, ProblemFileError> {
        let field = format!("{}/p", group.name());
        let p = self.indices(group, "p", len, nzmax + 1)?;
        if p[0] != 0 || p.windows(2).any(|w| w[0] > w[1]) {
            return Err(self.err(&field, "pointers must start at 0 and not decrease"));
        }
        Ok(p)
    }

    /// A CSparse matrix stored in `group`.
    fn matrix(&self, group: &Group) -> Result<SparseData, ProblemFileError> {
        let rows = self.size(group, "m")?;
        let cols = self.size(group, "n")?;
        let nzmax = self.size(group, "nzmax")?;
        let nz = self.int(group, "nz")?;
        let mut triplets = Vec::new();
        match nz {
            nz if nz >= 0 => {
                let nz = nz as usize;
                let i = self.indices(group, "i", nz, rows)?;
                let p = self.indices(group, "p", nz, cols)?;
                let x = self.values(group, nz)?;
                triplets.extend((0..nz).map(|k| (i[k], p[k], x[k])));
            }
            -1 => {
                let p = self.pointers(group, cols + 1, nzmax)?;
                let i = self.indices(group, "i", p[cols], rows)?;
                let x = self.values(group, p[cols])?;
                for j in 0..cols {
                    triplets.extend((p[j]..p[j + 1]).map(|k| (i[k], j, x[k])));
                }
            }
            -2 => {
                let p = self.pointers(group, rows + 1, nzmax)?;
                let i = self.indices(group, "i", p[rows], cols)?;
                let x = self.values(group, p[rows])?;
                for r in 0..rows {
                    triplets.extend((p[r]..p[r + 1]).map(|k| (r, i[k], x[k])));
                }
            }
            other => {
                return Err(self.err(
                    &format!("{}/nz", group.name()),
                    format!("is {other}: expected >= 0 (triplets), -1 (CSC) or -2 (CSR)"),
                ))
            }
        }
        Ok(SparseData {
            rows,
            cols,
            triplets,
        })
    }

    /// The first `len` values of `x`.
    fn values(&self, group: &Group, len: usize) -> Result<Vec<f64>, ProblemFileError> {
        let field = format!("{}/x", group.name());
        let x = group
            .dataset("x")
            .and_then(|d| d.read_raw::<f64>())
            .map_err(|e| self.err(&field, e.to_string()))?;
        if x.len() < len {
            return Err(self.err(
                &field,
                format!("has {} entries, expected at least {len}", x.len()),
            ));
        }
        Ok(x)
    }

    fn spacedim(&self, group: &Group) -> Result<usize, ProblemFileError> {
        let d = self.int(group, "spacedim")?;
        if d != 2 && d != 3 {
            return Err(self.err(
                &format!("{}/spacedim", group.name()),
                format!("is {d}, expected 2 or 3"),
            ));
        }
        Ok(d as usize)
    }
}

/// Read an FCLIB file (local or global form) as a box-friction LCP.
pub fn read_fclib(path: &Path) -> Result<Problem, ProblemFileError> {
    let file = File::open(path).map_err(|e| ProblemFileError::Unsupported {
        path: path.to_owned(),
        message: format!("cannot open as HDF5: {e}"),
    })?;
    let r = Reader { path };
    let (w, q, mu, d) = if file.link_exists("fclib_local") {
        read_local(&r, &file)?
    } else if file.link_exists("fclib_global") {
        read_global(&r, &file)?
    } else {
        return Err(ProblemFileError::Unsupported {
            path: path.to_owned(),
            message: "an HDF5 file without /fclib_local or /fclib_global is not an FCLIB problem"
                .into(),
        });
    };
    let problem = box_friction_lcp(path, w, q, &mu, d)?;
    Ok(match path.file_stem() {
        Some(stem) => problem.with_name(stem.to_string_lossy()),
        None => problem,
    })
}

/// The local form: `W`, `q`, `mu`, `d`.
fn read_local(
    r: &Reader,
    file: &File,
) -> Result<(SparseData, Vec<f64>, Vec<f64>, usize), ProblemFileError> {
    let local = r.group(file, "fclib_local")?;
    if local.link_exists("V") || local.link_exists("R") {
        return Err(ProblemFileError::Unsupported {
            path: r.path.to_owned(),
            message: "FCLIB local problems with equality constraints (V, R, s) are not supported"
                .into(),
        });
    }
    let d = r.spacedim(&local)?;
    let w = r.matrix(&r.group(&local, "W")?)?;
    if w.rows != w.cols || w.rows % d != 0 {
        return Err(r.err(
            "/fclib_local/W",
            format!(
                "is {}×{}; expected square with a multiple of spacedim = {d} rows",
                w.rows, w.cols
            ),
        ));
    }
    let vectors = r.group(&local, "vectors")?;
    let q = r.numbers(&vectors, "q", w.rows)?;
    let mu = r.numbers(&vectors, "mu", w.rows / d)?;
    Ok((w, q, mu, d))
}

/// The global form condensed to the local one: `W = Hᵀ M⁻¹ H`, `q = Hᵀ M⁻¹ f + w`.
fn read_global(
    r: &Reader,
    file: &File,
) -> Result<(SparseData, Vec<f64>, Vec<f64>, usize), ProblemFileError> {
    let global = r.group(file, "fclib_global")?;
    if global.link_exists("G") {
        return Err(ProblemFileError::Unsupported {
            path: r.path.to_owned(),
            message: "FCLIB global problems with equality constraints (G, b) are not supported"
                .into(),
        });
    }
    let d = r.spacedim(&global)?;
    let m = r.matrix(&r.group(&global, "M")?)?;
    let h = r.matrix(&r.group(&global, "H")?)?;
    let (nv, nr) = (m.rows, h.cols);
    if m.cols != nv || h.rows != nv || nr % d != 0 {
        return Err(r.err(
            "/fclib_global",
            format!(
                "M is {}×{} and H is {}×{}; expected M square, H with as many rows, and H's \
                 columns a multiple of spacedim = {d}",
                m.rows, m.cols, h.rows, h.cols
            ),
        ));
    }
    let vectors = r.group(&global, "vectors")?;
    let f = r.numbers(&vectors, "f", nv)?;
    let w_vec = r.numbers(&vectors, "w", nr)?;
    let mu = r.numbers(&vectors, "mu", nr / d)?;
    let to_csc = |s: &SparseData, what: &str| {
        let t: Vec<_> = s
            .triplets
            .iter()
            .map(|&(i, j, v)| Triplet::new(i, j, v))
            .collect();
        SparseColMat::<usize, f64>::try_new_from_triplets(s.rows, s.cols, &t)
            .map_err(|e| r.err(what, format!("{e:?}")))
    };
    let m_csc = to_csc(&m, "/fclib_global/M")?;
    let llt = m_csc.sp_cholesky(Side::Lower).map_err(|e| {
        r.err(
            "/fclib_global/M",
            format!("is not symmetric positive definite ({e:?})"),
        )
    })?;
    // X = M⁻¹ [H f] column by column of a dense right-hand side.
    let mut rhs = Mat::<f64>::zeros(nv, nr + 1);
    for &(i, j, v) in &h.triplets {
        rhs[(i, j)] += v;
    }
    for (i, &fi) in f.iter().enumerate() {
        rhs[(i, nr)] = fi;
    }
    {
        use faer::linalg::solvers::SolveCore;
        llt.solve_in_place_with_conj(faer::Conj::No, rhs.as_mut());
    }
    // Hᵀ X, one column of H at a time.
    let mut h_cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nr];
    for &(i, j, v) in &h.triplets {
        h_cols[j].push((i, v));
    }
    let mut triplets = Vec::new();
    let mut q = w_vec;
    for (a, col) in h_cols.iter().enumerate() {
        for b in 0..nr {
            let v: f64 = col.iter().map(|&(i, hv)| hv * rhs[(i, b)]).sum();
            if v != 0.0 || a == b {
                triplets.push((a, b, v));
            }
        }
        q[a] += col.iter().map(|&(i, hv)| hv * rhs[(i, nr)]).sum::<f64>();
    }
    Ok((
        SparseData {
            rows: nr,
            cols: nr,
            triplets,
        },
        q,
        mu,
        d,
    ))
}

/// The box-friction LCP of `u = W r + q` with `d`-dimensional contacts.
fn box_friction_lcp(
    path: &Path,
    w: SparseData,
    q: Vec<f64>,
    mu: &[f64],
    d: usize,
) -> Result<Problem, ProblemFileError> {
    let (lo, hi, friction) = contact_rows(mu, d);
    let invalid = ProblemFileError::invalid(path);
    let a = sparse_from_triplets(w.rows, &w.triplets).map_err(&invalid)?;
    Problem::boxed_sparse(a, q, lo, hi, friction).map_err(&invalid)
}

/// Write a local FCLIB problem (`W` as compressed columns): for tests and for turning lcpbench
/// problems with one normal and `d - 1` friction rows per contact into FCLIB files.
pub fn write_fclib_local(
    path: &Path,
    d: usize,
    w: &SparseColMat<usize, f64>,
    q: &[f64],
    mu: &[f64],
) -> Result<(), ProblemFileError> {
    let hdf = |e: hdf5::Error| ProblemFileError::Unsupported {
        path: path.to_owned(),
        message: format!("writing HDF5: {e}"),
    };
    let file = File::create(path).map_err(hdf)?;
    let local = file.create_group("fclib_local").map_err(hdf)?;
    let int = |g: &Group, name: &str, v: i32| {
        g.new_dataset_builder()
            .with_data(&[v][..])
            .create(name)
            .map(|_| ())
    };
    int(&local, "spacedim", d as i32).map_err(hdf)?;
    let wg = local.create_group("W").map_err(hdf)?;
    let sym = w.symbolic();
    let nnz = sym.col_ptr()[w.ncols()];
    int(&wg, "m", w.nrows() as i32).map_err(hdf)?;
    int(&wg, "n", w.ncols() as i32).map_err(hdf)?;
    int(&wg, "nzmax", nnz as i32).map_err(hdf)?;
    int(&wg, "nz", -1).map_err(hdf)?;
    let p: Vec<i32> = sym.col_ptr().iter().map(|&v| v as i32).collect();
    let i: Vec<i32> = sym.row_idx()[..nnz].iter().map(|&v| v as i32).collect();
    let data = |g: &Group, name: &str, v: &[f64]| {
        g.new_dataset_builder()
            .with_data(v)
            .create(name)
            .map(|_| ())
    };
    wg.new_dataset_builder()
        .with_data(&p[..])
        .create("p")
        .map_err(hdf)?;
    wg.new_dataset_builder()
        .with_data(&i[..])
        .create("i")
        .map_err(hdf)?;
    data(&wg, "x", &w.val()[..nnz]).map_err(hdf)?;
    let vectors = local.create_group("vectors").map_err(hdf)?;
    data(&vectors, "q", q).map_err(hdf)?;
    data(&vectors, "mu", mu).map_err(hdf)?;
    Ok(())
}

/// Write a box-friction problem as a local FCLIB file: every row must be a normal row with
/// `lo = 0`, `hi = ∞` and exactly `d - 1` friction rows of one `mu`, or one of those friction
/// rows (`d` is 3 when the first normal row has two friction rows, 2 when it has one). Rows are
/// reordered contact by contact (normal first, then its friction rows in order); the returned
/// permutation gives, for each FCLIB row, the problem's row.
pub fn write_problem_as_fclib(
    problem: &Problem,
    path: &Path,
) -> Result<Vec<usize>, ProblemFileError> {
    let unsupported = |message: String| ProblemFileError::Unsupported {
        path: path.to_owned(),
        message,
    };
    let n = problem.n();
    let mut tangents: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for fr in problem.friction() {
        tangents[fr.normal].push((fr.row, fr.mu));
    }
    let normals: Vec<usize> = (0..n)
        .filter(|&i| problem.friction_of(i).is_none())
        .collect();
    let d = normals.first().map_or(3, |&k| tangents[k].len() + 1);
    if d != 2 && d != 3 {
        return Err(unsupported(format!(
            "FCLIB contacts are 2-D or 3-D, but row {} has {} friction rows",
            normals[0],
            d - 1
        )));
    }
    let mut perm = Vec::with_capacity(n);
    let mut mu = Vec::with_capacity(normals.len());
    for &k in &normals {
        let t = &tangents[k];
        if t.len() != d - 1 || t.iter().any(|&(_, m)| m != t[0].1) {
            return Err(unsupported(format!(
                "row {k} has {} friction rows (of one mu each contact); FCLIB needs {} per contact",
                t.len(),
                d - 1
            )));
        }
        if problem.lo()[k] != 0.0 || problem.hi()[k] != f64::INFINITY {
            return Err(unsupported(format!(
                "normal row {k} has bounds [{}, {}]; FCLIB normal rows are [0, ∞)",
                problem.lo()[k],
                problem.hi()[k]
            )));
        }
        perm.push(k);
        perm.extend(t.iter().map(|&(r, _)| r));
        mu.push(t[0].1);
    }
    let mut inv = vec![0; n];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    let mut triplets = Vec::with_capacity(problem.nnz());
    for (new, &old) in perm.iter().enumerate() {
        for (j, v) in problem.row(old).iter() {
            if v != 0.0 || j == old {
                triplets.push(Triplet::new(new, inv[j], v));
            }
        }
    }
    let w = SparseColMat::try_new_from_triplets(n, n, &triplets)
        .map_err(|e| unsupported(format!("building W: {e:?}")))?;
    let q: Vec<f64> = perm.iter().map(|&i| problem.b()[i]).collect();
    write_fclib_local(path, d, &w, &q, &mu)?;
    Ok(perm)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::residuals;
    use crate::problem::FrictionRow;
    use crate::{Settings, SolverKind, Status};
    use faer::linalg::solvers::Solve;

    /// How a test writes a sparse matrix.
    #[derive(Clone, Copy)]
    enum Storage {
        Triplet,
        Csc,
        Csr,
    }

    fn write_ints(g: &Group, name: &str, v: &[i32]) {
        g.new_dataset_builder().with_data(v).create(name).unwrap();
    }

    fn write_numbers(g: &Group, name: &str, v: &[f64]) {
        g.new_dataset_builder().with_data(v).create(name).unwrap();
    }

    /// Write a dense `rows × cols` matrix (row-major `a`, zeros dropped) in CSparse's layout.
    fn write_matrix(g: &Group, rows: usize, cols: usize, a: &[f64], storage: Storage) {
        let entries: Vec<(usize, usize, f64)> = (0..rows * cols)
            .map(|k| (k / cols, k % cols, a[k]))
            .filter(|e| e.2 != 0.0)
            .collect();
        let nnz = entries.len() as i32;
        write_ints(g, "m", &[rows as i32]);
        write_ints(g, "n", &[cols as i32]);
        write_ints(g, "nzmax", &[nnz]);
        let (nz, p, i, x): (i32, Vec<i32>, Vec<i32>, Vec<f64>) = match storage {
            Storage::Triplet => {
                // Any order: reversed.
                let e: Vec<_> = entries.iter().rev().collect();
                (
                    nnz,
                    e.iter().map(|e| e.1 as i32).collect(),
                    e.iter().map(|e| e.0 as i32).collect(),
                    e.iter().map(|e| e.2).collect(),
                )
            }
            Storage::Csc => {
                let mut e = entries.clone();
                e.sort_by_key(|e| (e.1, e.0));
                let p = (0..=cols)
                    .map(|j| e.iter().filter(|e| e.1 < j).count() as i32)
                    .collect();
                (
                    -1,
                    p,
                    e.iter().map(|e| e.0 as i32).collect(),
                    e.iter().map(|e| e.2).collect(),
                )
            }
            Storage::Csr => {
                let p = (0..=rows)
                    .map(|r| entries.iter().filter(|e| e.0 < r).count() as i32)
                    .collect();
                (
                    -2,
                    p,
                    entries.iter().map(|e| e.1 as i32).collect(),
                    entries.iter().map(|e| e.2).collect(),
                )
            }
        };
        write_ints(g, "nz", &[nz]);
        write_ints(g, "p", &p);
        write_ints(g, "i", &i);
        write_numbers(g, "x", &x);
    }

    /// Two contacts on a plane, uncoupled: contact 0 (`W` block `2 I`, `mu = 0.5`) is pushed
    /// tangentially by less than friction holds, so it sticks: `r = (1, 0.2, 0)`, `u = 0`;
    /// contact 1 (`W` block `I`, `mu = 0.3`) is pushed harder and slides: `r = (1, -0.3, 0)`,
    /// `u_t = 1.7`. A small coupling between the two tangent directions of contact 0 keeps `W`
    /// from being diagonal.
    fn plane_contacts(path: &Path, storage: Storage) {
        let n = 6;
        let mut w = vec![0.0; n * n];
        for (i, d) in [2.0, 2.0, 2.0, 1.0, 1.0, 1.0].into_iter().enumerate() {
            w[i * n + i] = d;
        }
        w[n + 2] = 0.1;
        w[2 * n + 1] = 0.1;
        // Contact 0's second tangent has q = -0.1 · 0.2 so that r_t2 = 0 is exact.
        let q = [-2.0, -0.4, -0.02, -1.0, 2.0, 0.0];
        let file = File::create(path).unwrap();
        let local = file.create_group("fclib_local").unwrap();
        write_ints(&local, "spacedim", &[3]);
        write_matrix(&local.create_group("W").unwrap(), n, n, &w, storage);
        let vectors = local.create_group("vectors").unwrap();
        write_numbers(&vectors, "q", &q);
        write_numbers(&vectors, "mu", &[0.5, 0.3]);
    }

    #[test]
    fn local_problem_reads_as_box_friction_lcp_and_solves() {
        let dir = tempfile::tempdir().unwrap();
        for (k, storage) in [Storage::Triplet, Storage::Csc, Storage::Csr]
            .into_iter()
            .enumerate()
        {
            let path = dir.path().join(format!("plane{k}.hdf5"));
            plane_contacts(&path, storage);
            let p = read_fclib(&path).unwrap();
            assert_eq!(p.n(), 6);
            assert!(p.is_sparse());
            assert_eq!(p.name(), Some(format!("plane{k}").as_str()));
            assert_eq!(p.entry(1, 2), 0.1);
            assert_eq!(p.entry(0, 0), 2.0);
            let fr: Vec<_> = p
                .friction()
                .iter()
                .map(|f| (f.row, f.normal, f.mu))
                .collect();
            assert_eq!(fr, [(1, 0, 0.5), (2, 0, 0.5), (4, 3, 0.3), (5, 3, 0.3)]);
            assert_eq!((p.lo()[0], p.hi()[0], p.lo()[3]), (0.0, f64::INFINITY, 0.0));
            let expected = [1.0, 0.2, 0.0, 1.0, -0.3, 0.0];
            assert!(residuals(&p, &expected).natural_map < 1e-15);
            for kind in [SolverKind::Pgs, SolverKind::Sor, SolverKind::Dantzig] {
                let r = kind.create().solve(&p, &Settings::default());
                assert_eq!(r.status, Status::Converged, "{}", kind.name());
                for (a, b) in r.f.iter().zip(expected) {
                    assert!((a - b).abs() < 1e-6, "{}: {:?}", kind.name(), r.f);
                }
            }
        }
    }

    #[test]
    fn written_local_files_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.hdf5");
        let t = [(0, 0, 2.0), (1, 1, 1.0), (0, 1, 0.5), (1, 0, 0.5)];
        let t: Vec<_> = t.iter().map(|&(i, j, v)| Triplet::new(i, j, v)).collect();
        let w = SparseColMat::try_new_from_triplets(2, 2, &t).unwrap();
        write_fclib_local(&path, 2, &w, &[-1.0, 0.5], &[0.4]).unwrap();
        let p = read_fclib(&path).unwrap();
        assert_eq!(p.to_dense(), w.to_dense());
        assert_eq!(p.b(), &[-1.0, 0.5]);
        assert_eq!(
            p.friction(),
            &[FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.4
            }]
        );
    }

    #[test]
    fn box_friction_problems_write_as_fclib_and_read_back() {
        // Rows out of contact order: normal 2 with friction rows 0 and 1, normal 3 with 4, 5.
        let n = 6;
        let a = Mat::from_fn(n, n, |i, j| {
            if i == j {
                2.0
            } else if i.abs_diff(j) == 1 {
                0.5
            } else {
                0.0
            }
        });
        let fr = |row, normal, mu| FrictionRow { row, normal, mu };
        let mut lo = vec![0.0; n];
        lo[0] = -1.0;
        let p = Problem::boxed(
            a,
            vec![0.1, 0.2, -1.0, -2.0, 0.3, 0.4],
            lo,
            vec![f64::INFINITY; n],
            vec![fr(0, 2, 0.5), fr(1, 2, 0.5), fr(4, 3, 0.2), fr(5, 3, 0.2)],
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.hdf5");
        let perm = write_problem_as_fclib(&p, &path).unwrap();
        assert_eq!(perm, [2, 0, 1, 3, 4, 5]);
        let back = read_fclib(&path).unwrap();
        let restored = back.permuted(
            &(0..n)
                .map(|i| perm.iter().position(|&k| k == i).unwrap())
                .collect::<Vec<_>>(),
        );
        assert_eq!(restored.to_dense(), p.to_dense());
        assert_eq!(restored.b(), p.b());
        // The same solution, row for row.
        let r = SolverKind::Dantzig.create().solve(&p, &Settings::default());
        let f_back: Vec<f64> = perm.iter().map(|&k| r.f[k]).collect();
        assert!(residuals(&back, &f_back).natural_map_rel < 1e-8);
        // A normal row without friction rows cannot be written.
        let lcp = Problem::lcp(Mat::identity(2, 2), vec![1.0, 1.0]).unwrap();
        let e = write_problem_as_fclib(&lcp, &path).unwrap_err().to_string();
        assert!(e.contains("row 0 has 0 friction rows"), "{e}");
    }

    #[test]
    fn global_problem_is_condensed_to_the_delassus_matrix() {
        // M SPD (5×5, tridiagonal), H 5×3 (one 3-D contact), f, w: W = Hᵀ M⁻¹ H, q = Hᵀ M⁻¹ f + w.
        let nv = 5;
        let m = Mat::from_fn(nv, nv, |i, j| match i.abs_diff(j) {
            0 => 3.0 + i as f64,
            1 => -1.0,
            _ => 0.0,
        });
        let h = Mat::from_fn(nv, 3, |i, j| {
            [
                [1., 0., 0.],
                [0.5, 1., 0.],
                [0., 0., 1.],
                [0., -0.5, 0.],
                [0.2, 0., 0.3],
            ][i][j]
        });
        let f = [1.0, -2.0, 0.5, 0.0, 1.5];
        let w = [0.1, -0.2, 0.3];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.hdf5");
        {
            let file = File::create(&path).unwrap();
            let g = file.create_group("fclib_global").unwrap();
            write_ints(&g, "spacedim", &[3]);
            let row_major = |a: &Mat<f64>| {
                (0..a.nrows())
                    .flat_map(|i| (0..a.ncols()).map(move |j| (i, j)))
                    .map(|(i, j)| a[(i, j)])
                    .collect::<Vec<_>>()
            };
            write_matrix(
                &g.create_group("M").unwrap(),
                nv,
                nv,
                &row_major(&m),
                Storage::Csc,
            );
            write_matrix(
                &g.create_group("H").unwrap(),
                nv,
                3,
                &row_major(&h),
                Storage::Triplet,
            );
            let v = g.create_group("vectors").unwrap();
            write_numbers(&v, "f", &f);
            write_numbers(&v, "w", &w);
            write_numbers(&v, "mu", &[0.6]);
        }
        let p = read_fclib(&path).unwrap();
        let minv_h = m.partial_piv_lu().solve(&h);
        let expected_w = h.transpose() * &minv_h;
        let fcol = Mat::from_fn(nv, 1, |i, _| f[i]);
        let minv_f = m.partial_piv_lu().solve(&fcol);
        let expected_q = h.transpose() * &minv_f;
        let a = p.to_dense();
        for i in 0..3 {
            assert!((p.b()[i] - expected_q[(i, 0)] - w[i]).abs() < 1e-12);
            for j in 0..3 {
                assert!((a[(i, j)] - expected_w[(i, j)]).abs() < 1e-12, "{a:?}");
            }
        }
        assert_eq!(p.friction().len(), 2);
    }

    #[test]
    fn errors_name_the_dataset() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.hdf5");
        {
            let file = File::create(&path).unwrap();
            let local = file.create_group("fclib_local").unwrap();
            write_ints(&local, "spacedim", &[3]);
            write_matrix(
                &local.create_group("W").unwrap(),
                3,
                3,
                &[1., 0., 0., 0., 1., 0., 0., 0., 1.],
                Storage::Csc,
            );
            let v = local.create_group("vectors").unwrap();
            write_numbers(&v, "q", &[1.0, 2.0]);
            write_numbers(&v, "mu", &[0.5]);
        }
        let e = read_fclib(&path).unwrap_err().to_string();
        assert!(
            e.ends_with("field `/fclib_local/vectors/q`: has 2 entries, expected 3"),
            "{e}"
        );
        let path = dir.path().join("none.hdf5");
        File::create(&path).unwrap().create_group("other").unwrap();
        let e = read_fclib(&path).unwrap_err().to_string();
        assert!(e.contains("without /fclib_local or /fclib_global"), "{e}");
        let path = dir.path().join("text.hdf5");
        std::fs::write(&path, "not hdf5").unwrap();
        let e = read_fclib(&path).unwrap_err().to_string();
        assert!(e.contains("cannot open as HDF5"), "{e}");
    }
}
