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
//!
//! # Reading and writing HDF5
//!
//! The HDF5 layer is [`hdf5_pure`], a pure-Rust reader and writer of the HDF5 format (The HDF
//! Group, *HDF5 File Format Specification*, version 3.0), so no C library is needed. It reads
//! superblocks 0 to 3, both object-header versions, old- and new-style groups, and contiguous,
//! compact and chunked storage with the deflate and shuffle filters: what FCLIB's C library
//! (superblock 0, contiguous `int32` and `float64` datasets) and h5py write. It treats a file as
//! untrusted input (bounds-checked reads, decompression-bomb limits, fuzz targets and
//! malformed-file regression tests in its suite; its files are checked against libhdf5 in its
//! CI), and one crate both reads and writes with one small dependency (`byteorder`, and `flate2`
//! for deflate). `hdf5-reader` is as carefully tested against corrupted input but reads only
//! (its sibling `hdf5-writer` writes) and brings `ndarray`, `memmap2`, `lru` and `parking_lot`.
//!
//! Limits, checked before anything is allocated from a size the file declares: the file is read
//! whole into memory; a dataset's declared size (elements × element size) is at most the file's
//! length when stored unfiltered and at most [`MAX_FILTER_RATIO`] times it when compressed; the
//! condensation of a global problem is refused when `M⁻¹ [H f]` (`nv × (nr + 1)` numbers), `W`
//! (`nr × nr`) or the Cholesky factor of `M` would hold more than [`MAX_CONDENSED_VALUES`]
//! numbers. A file that breaks a limit, or that the HDF5 reader rejects, gives a
//! [`ProblemFileError`] naming the file and the dataset.

use super::{check_friction_coefficients, contact_rows, ProblemFileError};
use crate::problem::{sparse_from_triplets, Problem};
use faer::sparse::linalg::cholesky::factorize_symbolic_cholesky;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use hdf5_pure::{File, FileBuilder, FormatError, Group, H5Element};
use std::path::Path;

/// A sparse matrix read from a file, as triplets `(row, column, value)`.
struct SparseData {
    rows: usize,
    cols: usize,
    triplets: Vec<(usize, usize, f64)>,
}

/// Largest ratio of a compressed dataset's declared size to the file's length: deflate's
/// maximum compression ratio (1032:1).
pub const MAX_FILTER_RATIO: u64 = 1032;

/// Most numbers the condensation of a global problem may hold in one array (`M⁻¹ [H f]`, `W`,
/// the Cholesky factor of `M`): 2²⁸, 2 GiB of `f64`.
pub const MAX_CONDENSED_VALUES: usize = 1 << 28;

/// An HDF5 group and its path in the file (`/fclib_local/W`), for messages.
struct Node {
    group: Group,
    name: String,
}

impl Node {
    /// The path of member `name`.
    fn member(&self, name: &str) -> String {
        format!("{}/{name}", self.name.trim_end_matches('/'))
    }
}

/// Reads datasets of one file, with errors that name the file and the dataset.
struct Reader<'a> {
    path: &'a Path,
    /// The file's length in bytes, which bounds what an unfiltered dataset can hold.
    file_len: u64,
}

impl Reader<'_> {
    fn err(&self, field: &str, message: impl Into<String>) -> ProblemFileError {
        ProblemFileError::field(self.path, field, message)
    }

    /// Whether `node` has a member (group or dataset) called `name`.
    fn has(&self, node: &Node, name: &str) -> Result<bool, ProblemFileError> {
        let listing =
            |e: hdf5_pure::Error| self.err(&node.name, format!("cannot list its members: {e}"));
        Ok(node
            .group
            .groups()
            .map_err(listing)?
            .iter()
            .any(|g| g == name)
            || node
                .group
                .datasets()
                .map_err(listing)?
                .iter()
                .any(|d| d == name))
    }

    fn group(&self, node: &Node, name: &str) -> Result<Node, ProblemFileError> {
        let field = node.member(name);
        let group = node
            .group
            .group(name)
            .map_err(|e| self.err(&field, format!("cannot open the group: {}", describe(e))))?;
        Ok(Node { group, name: field })
    }

    /// All of dataset `name` of `node` as `T`, after checking the size the file declares for it
    /// (see the module doc).
    fn read<T: H5Element>(&self, node: &Node, name: &str) -> Result<Vec<T>, ProblemFileError> {
        let field = node.member(name);
        let fail = |e: hdf5_pure::Error| self.err(&field, describe(e));
        let dataset = node.group.dataset(name).map_err(fail)?;
        let shape = dataset.shape().map_err(fail)?;
        let element = dataset.element_size().map_err(fail)?;
        let filtered = !dataset.filters().is_empty();
        let limit = if filtered {
            self.file_len.saturating_mul(MAX_FILTER_RATIO)
        } else {
            self.file_len
        };
        let bytes = shape
            .iter()
            .try_fold(element.max(1), |acc, &dim| acc.checked_mul(dim));
        if bytes.is_none_or(|b| b > limit) {
            let message = if filtered {
                format!(
                    "declares {shape:?} elements of {element} bytes, more than \
                     {MAX_FILTER_RATIO} times its file of {} bytes can decompress to",
                    self.file_len
                )
            } else {
                format!(
                    "declares {shape:?} elements of {element} bytes, more than its file of {} \
                     bytes can hold",
                    self.file_len
                )
            };
            return Err(self.err(&field, message));
        }
        dataset.read::<T>().map_err(fail)
    }

    fn ints(&self, node: &Node, name: &str) -> Result<Vec<i64>, ProblemFileError> {
        self.read::<i64>(node, name)
    }

    fn int(&self, node: &Node, name: &str) -> Result<i64, ProblemFileError> {
        let v = self.ints(node, name)?;
        v.first()
            .copied()
            .ok_or_else(|| self.err(&node.member(name), "is empty"))
    }

    fn size(&self, node: &Node, name: &str) -> Result<usize, ProblemFileError> {
        let v = self.int(node, name)?;
        usize::try_from(v).map_err(|_| self.err(&node.member(name), format!("is {v} < 0")))
    }

    fn numbers(&self, node: &Node, name: &str, len: usize) -> Result<Vec<f64>, ProblemFileError> {
        let v = self.read::<f64>(node, name)?;
        if v.len() != len {
            return Err(self.err(
                &node.member(name),
                format!("has {} entries, expected {len}", v.len()),
            ));
        }
        Ok(v)
    }

    /// Indices in `0..bound` from a dataset of at least `len` entries.
    fn indices(
        &self,
        node: &Node,
        name: &str,
        len: usize,
        bound: usize,
    ) -> Result<Vec<usize>, ProblemFileError> {
        let field = node.member(name);
        let v = self.ints(node, name)?;
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
        node: &Node,
        len: usize,
        nzmax: usize,
    ) -> Result<Vec<usize>, ProblemFileError> {
        let field = node.member("p");
        let p = self.indices(node, "p", len, nzmax + 1)?;
        if p[0] != 0 || p.windows(2).any(|w| w[0] > w[1]) {
            return Err(self.err(&field, "pointers must start at 0 and not decrease"));
        }
        Ok(p)
    }

    /// A CSparse matrix stored in `node`.
    fn matrix(&self, node: &Node) -> Result<SparseData, ProblemFileError> {
        let rows = self.size(node, "m")?;
        let cols = self.size(node, "n")?;
        let nzmax = self.size(node, "nzmax")?;
        let nz = self.int(node, "nz")?;
        let mut triplets = Vec::new();
        match nz {
            nz if nz >= 0 => {
                let nz = nz as usize;
                let i = self.indices(node, "i", nz, rows)?;
                let p = self.indices(node, "p", nz, cols)?;
                let x = self.values(node, nz)?;
                triplets.extend((0..nz).map(|k| (i[k], p[k], x[k])));
            }
            -1 => {
                let p = self.pointers(node, cols + 1, nzmax)?;
                let i = self.indices(node, "i", p[cols], rows)?;
                let x = self.values(node, p[cols])?;
                for j in 0..cols {
                    triplets.extend((p[j]..p[j + 1]).map(|k| (i[k], j, x[k])));
                }
            }
            -2 => {
                let p = self.pointers(node, rows + 1, nzmax)?;
                let i = self.indices(node, "i", p[rows], cols)?;
                let x = self.values(node, p[rows])?;
                for r in 0..rows {
                    triplets.extend((p[r]..p[r + 1]).map(|k| (r, i[k], x[k])));
                }
            }
            other => {
                return Err(self.err(
                    &node.member("nz"),
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
    fn values(&self, node: &Node, len: usize) -> Result<Vec<f64>, ProblemFileError> {
        let x = self.read::<f64>(node, "x")?;
        if x.len() < len {
            return Err(self.err(
                &node.member("x"),
                format!("has {} entries, expected at least {len}", x.len()),
            ));
        }
        Ok(x)
    }

    /// Refuse a condensation array of `rows × cols` numbers above [`MAX_CONDENSED_VALUES`].
    fn condensed_size(&self, what: &str, rows: usize, cols: usize) -> Result<(), ProblemFileError> {
        if rows
            .checked_mul(cols)
            .is_some_and(|n| n <= MAX_CONDENSED_VALUES)
        {
            return Ok(());
        }
        Err(self.err(
            "/fclib_global",
            format!(
                "condensing to the local form would hold {what} in {rows} × {cols} numbers, \
                 more than the limit of {MAX_CONDENSED_VALUES}"
            ),
        ))
    }

    fn spacedim(&self, node: &Node) -> Result<usize, ProblemFileError> {
        let d = self.int(node, "spacedim")?;
        if d != 2 && d != 3 {
            return Err(self.err(&node.member("spacedim"), format!("is {d}, expected 2 or 3")));
        }
        Ok(d as usize)
    }
}

/// Read an FCLIB file (local or global form) as a box-friction LCP.
pub fn read_fclib(path: &Path) -> Result<Problem, ProblemFileError> {
    let bytes = std::fs::read(path).map_err(|source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_fclib(bytes, path)
}

/// Read the bytes of an FCLIB file (local or global form) as a box-friction LCP; `path` names
/// the file in messages and the problem.
pub fn parse_fclib(bytes: Vec<u8>, path: &Path) -> Result<Problem, ProblemFileError> {
    let r = Reader {
        path,
        file_len: bytes.len() as u64,
    };
    let file = File::from_bytes(bytes).map_err(|e| ProblemFileError::Unsupported {
        path: path.to_owned(),
        message: format!("cannot open as HDF5: {e}"),
    })?;
    let root = Node {
        group: file.root(),
        name: "/".into(),
    };
    let (w, q, mu, d) = if r.has(&root, "fclib_local")? {
        read_local(&r, &root)?
    } else if r.has(&root, "fclib_global")? {
        read_global(&r, &root)?
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
    root: &Node,
) -> Result<(SparseData, Vec<f64>, Vec<f64>, usize), ProblemFileError> {
    let local = r.group(root, "fclib_local")?;
    if r.has(&local, "V")? || r.has(&local, "R")? {
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
    check_friction_coefficients(r.path, "/fclib_local/vectors/mu", &mu)?;
    Ok((w, q, mu, d))
}

/// The global form condensed to the local one: `W = Hᵀ M⁻¹ H`, `q = Hᵀ M⁻¹ f + w`.
fn read_global(
    r: &Reader,
    root: &Node,
) -> Result<(SparseData, Vec<f64>, Vec<f64>, usize), ProblemFileError> {
    let global = r.group(root, "fclib_global")?;
    if r.has(&global, "G")? {
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
    check_friction_coefficients(r.path, "/fclib_global/vectors/mu", &mu)?;
    r.condensed_size("M⁻¹ [H f]", nv, nr + 1)?;
    r.condensed_size("W", nr, nr)?;
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
    let symbolic = factorize_symbolic_cholesky(
        m_csc.symbolic(),
        Side::Lower,
        Default::default(),
        Default::default(),
    )
    .map_err(|e| r.err("/fclib_global/M", format!("{e:?}")))?;
    r.condensed_size("the Cholesky factor of M", symbolic.len_val(), 1)?;
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
/// problems with one normal and `d - 1` friction rows per contact into FCLIB files. Sizes and
/// indices are written as FCLIB's 32-bit integers.
pub fn write_fclib_local(
    path: &Path,
    d: usize,
    w: &SparseColMat<usize, f64>,
    q: &[f64],
    mu: &[f64],
) -> Result<(), ProblemFileError> {
    let int = |what: &str, v: usize| {
        i32::try_from(v).map_err(|_| ProblemFileError::Unsupported {
            path: path.to_owned(),
            message: format!("{what} = {v} does not fit FCLIB's 32-bit integers"),
        })
    };
    let ints = |what: &str, v: &[usize]| {
        v.iter()
            .map(|&x| int(what, x))
            .collect::<Result<Vec<_>, _>>()
    };
    let sym = w.symbolic();
    let nnz = sym.col_ptr()[w.ncols()];
    let mut file = FileBuilder::new();
    let mut local = file.create_group("fclib_local");
    local
        .create_dataset("spacedim")
        .with_i32_data(&[int("spacedim", d)?]);
    let mut wg = local.create_group("W");
    wg.create_dataset("m")
        .with_i32_data(&[int("W rows", w.nrows())?]);
    wg.create_dataset("n")
        .with_i32_data(&[int("W columns", w.ncols())?]);
    wg.create_dataset("nzmax")
        .with_i32_data(&[int("W entries", nnz)?]);
    wg.create_dataset("nz").with_i32_data(&[-1]);
    wg.create_dataset("p")
        .with_i32_data(&ints("W column pointer", sym.col_ptr())?);
    wg.create_dataset("i")
        .with_i32_data(&ints("W row index", &sym.row_idx()[..nnz])?);
    wg.create_dataset("x").with_f64_data(&w.val()[..nnz]);
    local.add_group(wg.finish());
    let mut vectors = local.create_group("vectors");
    vectors.create_dataset("q").with_f64_data(q);
    vectors.create_dataset("mu").with_f64_data(mu);
    local.add_group(vectors.finish());
    file.add_group(local.finish());
    let bytes = file.finish().map_err(|e| ProblemFileError::Unsupported {
        path: path.to_owned(),
        message: format!("writing HDF5: {e}"),
    })?;
    std::fs::write(path, bytes).map_err(|source| ProblemFileError::Io {
        path: path.to_owned(),
        source,
    })
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

/// An HDF5 error as a message: a missing object reads "is missing".
fn describe(e: hdf5_pure::Error) -> String {
    match e {
        hdf5_pure::Error::Format(FormatError::PathNotFound(_)) => "is missing".into(),
        e => e.to_string(),
    }
}

#[cfg(test)]
mod tests;
