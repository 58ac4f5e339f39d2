//! Siconos numerics problem files (`.dat`). LCP files, as written by
//! `linearComplementarity_printInFile` and read by `linearComplementarity_newFromFile`, hold the
//! standard LCP `0 <= z ⟂ M z + q >= 0`, read as `A = M`, `b = q`. Friction-contact files
//! (`frictionContact_newFromFile`) hold `d`, the number of contacts, `M`, `q` and `mu`, and are
//! read as box-friction LCPs like FCLIB files ([`super::fclib`]); [`parse_siconos`] tells the two
//! apart by their first numbers.
//!
//! An LCP file is whitespace-separated text:
//!
//! ```text
//! n                      problem size
//! storage size0 size1    the matrix M (NumericsMatrix): storage type 0, 1 or 2, rows, columns
//! ...                    the matrix data, by storage type (below)
//! q_0 ... q_{n-1}        the vector q
//! ...                    anything after q (comments) is ignored
//! ```
//!
//! * **0, dense**: `size0 size1` once more, then the `size0 · size1` entries *column by column*
//!   (`M[i][j]` is entry `i + j · size0`; the writer breaks lines every `size1` numbers, so each
//!   line of a square matrix is a column).
//! * **1, sparse block** (`SparseBlockStructuredMatrix`): `nbblocks`, `blocknumber0`,
//!   `blocknumber1`, the cumulative block row sizes (`blocknumber0` numbers) and column sizes
//!   (`blocknumber1`), `filled1`, `filled2`, `index1_data` (`filled1` numbers: the first block of
//!   each block row, compressed-row style), `index2_data` (`filled2`: each block's block
//!   column), then per block its number followed by its entries column by column.
//! * **2, sparse** (CSparse, through `NSM_new_from_file`): the origin (triplet, CSC or CSR), then
//!   CSparse's text print: a version line, a size line `m-by-n, nzmax: … nnz: …` (prefixed
//!   `triplet:` for triplets) and either per column `col j : locations a to b` followed by
//!   `i : value` lines, or `i j : value` lines. CSparse prints values with `%g` (six significant
//!   digits), so such files carry less precision than the other two.
//!
//! Errors name the file, line and column of the offending token.
//!
//! Reference: the Siconos numerics sources, `LinearComplementarityProblem.c`,
//! `NumericsMatrix.c` (`NM_new_from_file`), `SparseBlockMatrix.c` (`SBM_new_from_file`),
//! `CSparseMatrix.c` (`CSparseMatrix_new_from_file`).

use super::ProblemFileError;
use crate::problem::{sparse_from_triplets, Problem};
use faer::Mat;
use std::path::Path;

/// One whitespace-separated token with its 1-based line and column.
struct Token<'a> {
    text: &'a str,
    line: usize,
    column: usize,
}

/// The token stream of a file, with errors that point into it.
struct Tokens<'a> {
    tokens: Vec<Token<'a>>,
    next: usize,
    path: &'a Path,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str, path: &'a Path) -> Self {
        let mut tokens = Vec::new();
        let mut last_line = 1;
        for (l, line) in text.lines().enumerate() {
            last_line = l + 1;
            let mut rest = line;
            while let Some(start) = rest.find(|c: char| !c.is_whitespace()) {
                let after = &rest[start..];
                let len = after.find(char::is_whitespace).unwrap_or(after.len());
                tokens.push(Token {
                    text: &after[..len],
                    line: l + 1,
                    column: line.len() - after.len() + 1,
                });
                rest = &after[len..];
            }
        }
        Self {
            tokens,
            next: 0,
            path,
            last_line,
        }
    }

    /// An error at the current token (or at the end of the file).
    fn error_here(&self, message: String) -> ProblemFileError {
        let (line, column) = match self.tokens.get(self.next) {
            Some(t) => (t.line, t.column),
            None => (self.last_line, 1),
        };
        ProblemFileError::Parse {
            path: self.path.to_owned(),
            line,
            column,
            message,
        }
    }

    /// An error at the token just read.
    fn error_at_last(&self, message: String) -> ProblemFileError {
        let t = &self.tokens[self.next - 1];
        ProblemFileError::Parse {
            path: self.path.to_owned(),
            line: t.line,
            column: t.column,
            message,
        }
    }

    fn next_token(&mut self, what: &str) -> Result<&'a str, ProblemFileError> {
        match self.tokens.get(self.next) {
            Some(t) => {
                self.next += 1;
                Ok(t.text)
            }
            None => Err(self.error_here(format!("the file ends before {what}"))),
        }
    }

    fn peek(&self) -> Option<&'a str> {
        self.tokens.get(self.next).map(|t| t.text)
    }

    fn int(&mut self, what: &str) -> Result<i64, ProblemFileError> {
        let t = self.next_token(what)?;
        t.trim_end_matches(',')
            .parse()
            .map_err(|_| self.error_at_last(format!("expected {what} (an integer), found `{t}`")))
    }

    fn count(&mut self, what: &str) -> Result<usize, ProblemFileError> {
        let v = self.int(what)?;
        usize::try_from(v)
            .map_err(|_| self.error_at_last(format!("{what} must be >= 0, found {v}")))
    }

    fn number(&mut self, what: &str) -> Result<f64, ProblemFileError> {
        let t = self.next_token(what)?;
        t.parse()
            .map_err(|_| self.error_at_last(format!("expected {what} (a number), found `{t}`")))
    }

    fn expect(&mut self, word: &str, context: &str) -> Result<(), ProblemFileError> {
        let t = self.next_token(context)?;
        if t == word {
            Ok(())
        } else {
            Err(self.error_at_last(format!("expected `{word}` in {context}, found `{t}`")))
        }
    }
}

/// The matrix `M` as read: dense column-major data or triplets.
enum Matrix {
    Dense(Vec<f64>),
    Triplets(Vec<(usize, usize, f64)>),
}

/// True when the header reads as a friction-contact file (`d nc storage size0 size1` with
/// `d` 2 or 3 and `size0 = size1 = d · nc`) and not as an LCP file (`n storage n n`).
fn is_friction_contact(t: &Tokens) -> bool {
    let int = |k: usize| t.tokens.get(k).and_then(|t| t.text.parse::<u64>().ok());
    let (Some(a), Some(b), Some(c), Some(d)) = (int(0), int(1), int(2), int(3)) else {
        return false;
    };
    let lcp = b <= 2 && c == a && d == a;
    let fc = (a == 2 || a == 3) && c <= 2 && d == a * b && int(4) == Some(d);
    fc && !lcp
}

/// Read `storage size0 size1` and the matrix data; returns the matrix and its size, with the
/// token index of the storage type for later errors.
fn read_matrix(t: &mut Tokens) -> Result<(Matrix, usize, usize, usize), ProblemFileError> {
    let storage = t.int("the storage type of M (0 dense, 1 sparse block, 2 sparse)")?;
    let size0 = t.count("the number of rows of M")?;
    let size1 = t.count("the number of columns of M")?;
    let storage_at = t.next - 3;
    let matrix = match storage {
        0 => read_dense(t, size0, size1)?,
        1 => read_sparse_block(t, size0, size1)?,
        2 => read_csparse(t, size0, size1)?,
        other => {
            t.next = storage_at;
            return Err(t.error_here(format!(
                "unknown storage type {other} (0 dense, 1 sparse block, 2 sparse)"
            )));
        }
    };
    Ok((matrix, size0, size1, storage_at))
}

/// `count` numbers named `name[i]`.
fn read_vector(t: &mut Tokens, name: &str, count: usize) -> Result<Vec<f64>, ProblemFileError> {
    let mut v = Vec::with_capacity(count.min(t.tokens.len()));
    for i in 0..count {
        v.push(t.number(&format!("{name}[{i}]"))?);
    }
    Ok(v)
}

/// The problem named after the file stem.
fn named(problem: Problem, path: &Path) -> Problem {
    match path.file_stem() {
        Some(stem) => problem.with_name(stem.to_string_lossy()),
        None => problem,
    }
}

/// Parse a Siconos numerics file: an LCP (`linearComplementarity_newFromFile`) or a
/// friction-contact problem (`frictionContact_newFromFile`: `d`, the number of contacts, `M`,
/// `q`, `mu`), told apart by the header. A friction-contact problem becomes the box-friction
/// LCP with `A = M`, `b = q`, one normal row and `d - 1` friction rows per contact (as FCLIB
/// files do). `path` names the file in errors and gives the problem its name.
pub fn parse_siconos(text: &str, path: &Path) -> Result<Problem, ProblemFileError> {
    let mut t = Tokens::new(text, path);
    if !is_friction_contact(&t) {
        return parse_lcp(t, path);
    }
    let d = t.count("the contact dimension")?;
    let contacts = t.count("the number of contacts")?;
    let (matrix, n, _, _) = read_matrix(&mut t)?;
    let q = read_vector(&mut t, "q", n)?;
    let mu = read_vector(&mut t, "mu", contacts)?;
    super::check_friction_coefficients(path, "mu", &mu)?;
    let (lo, hi, friction) = super::contact_rows(&mu, d);
    let invalid = ProblemFileError::invalid(path);
    let problem = match matrix {
        Matrix::Dense(data) => {
            let a = Mat::from_fn(n, n, |i, j| data[i + j * n]);
            Problem::boxed(a, q, lo, hi, friction)
        }
        Matrix::Triplets(triplets) => {
            let a = sparse_from_triplets(n, &triplets).map_err(&invalid)?;
            Problem::boxed_sparse(a, q, lo, hi, friction)
        }
    }
    .map_err(&invalid)?;
    Ok(named(problem, path))
}

/// Parse a Siconos LCP file (see the module doc).
pub fn parse_siconos_lcp(text: &str, path: &Path) -> Result<Problem, ProblemFileError> {
    parse_lcp(Tokens::new(text, path), path)
}

fn parse_lcp(mut t: Tokens, path: &Path) -> Result<Problem, ProblemFileError> {
    let n = t.count("the problem size n")?;
    let (matrix, size0, size1, storage_at) = read_matrix(&mut t)?;
    if size0 != size1 || size0 != n {
        t.next = storage_at + 1;
        return Err(t.error_here(format!(
            "M is {size0}×{size1}, but an LCP of size n = {n} needs an n×n matrix"
        )));
    }
    let q = read_vector(&mut t, "q", n)?;
    let invalid = ProblemFileError::invalid(path);
    let problem = match matrix {
        Matrix::Dense(data) => Problem::lcp(Mat::from_fn(n, n, |i, j| data[i + j * n]), q),
        Matrix::Triplets(triplets) => {
            Problem::lcp_sparse(sparse_from_triplets(n, &triplets).map_err(&invalid)?, q)
        }
    }
    .map_err(&invalid)?;
    Ok(named(problem, path))
}

/// Storage 0: the size repeated, then the entries column by column.
fn read_dense(t: &mut Tokens, size0: usize, size1: usize) -> Result<Matrix, ProblemFileError> {
    let rows = t.count("the number of rows of M (repeated for dense storage)")?;
    let cols = t.count("the number of columns of M (repeated for dense storage)")?;
    if (rows, cols) != (size0, size1) {
        return Err(t.error_at_last(format!(
            "the dense matrix is {rows}×{cols}, but the header says {size0}×{size1}"
        )));
    }
    let len = size0
        .checked_mul(size1)
        .filter(|&l| l <= t.tokens.len())
        .ok_or_else(|| {
            t.error_here(format!(
                "a {size0}×{size1} dense matrix needs more numbers than the file holds"
            ))
        })?;
    let mut data = Vec::with_capacity(len);
    for k in 0..len {
        let (i, j) = (k % size0.max(1), k / size0.max(1));
        data.push(t.number(&format!("M[{i}][{j}] (dense, column by column)"))?);
    }
    Ok(Matrix::Dense(data))
}

/// Cumulative block sizes: strictly increasing, ending at `total`.
fn read_block_sizes(
    t: &mut Tokens,
    count: usize,
    total: usize,
    what: &str,
) -> Result<Vec<usize>, ProblemFileError> {
    let mut sizes = Vec::with_capacity(count.min(t.tokens.len()));
    for k in 0..count {
        let s = t.count(&format!("{what} {k} (cumulative)"))?;
        let previous = sizes.last().copied().unwrap_or(0);
        if s <= previous || s > total {
            return Err(t.error_at_last(format!(
                "{what}s are cumulative: they must increase and stay within {total}, found \
                 {s} after {previous}"
            )));
        }
        sizes.push(s);
    }
    if sizes.last().copied().unwrap_or(0) != total {
        return Err(t.error_here(format!(
            "the {what}s add up to {}, but M has {total}",
            sizes.last().copied().unwrap_or(0)
        )));
    }
    Ok(sizes)
}

/// Storage 1: a sparse block matrix.
fn read_sparse_block(
    t: &mut Tokens,
    size0: usize,
    size1: usize,
) -> Result<Matrix, ProblemFileError> {
    let nbblocks = t.count("the number of blocks")?;
    if nbblocks == 0 {
        return Ok(Matrix::Triplets(Vec::new()));
    }
    let block_rows = t.count("the number of block rows")?;
    let block_cols = t.count("the number of block columns")?;
    let row_end = read_block_sizes(t, block_rows, size0, "block row size")?;
    let col_end = read_block_sizes(t, block_cols, size1, "block column size")?;
    let filled1 = t.count("filled1 (block rows + 1)")?;
    let filled2 = t.count("filled2 (stored blocks)")?;
    if filled1 == 0 || filled1 > block_rows + 1 {
        return Err(t.error_at_last(format!(
            "filled1 = {filled1} must be in 1..={} (block rows + 1)",
            block_rows + 1
        )));
    }
    let mut index1 = Vec::with_capacity(filled1);
    for k in 0..filled1 {
        let v = t.count(&format!("index1_data[{k}]"))?;
        if v > filled2 || index1.last().is_some_and(|&l| v < l) {
            return Err(t.error_at_last(format!(
                "index1_data must be non-decreasing and at most filled2 = {filled2}, found {v}"
            )));
        }
        index1.push(v);
    }
    let mut index2 = Vec::with_capacity(filled2.min(t.tokens.len()));
    for k in 0..filled2 {
        let v = t.count(&format!("index2_data[{k}]"))?;
        if v >= block_cols {
            return Err(t.error_at_last(format!(
                "block {k} sits in block column {v}, but there are {block_cols}"
            )));
        }
        index2.push(v);
    }
    let start = |ends: &[usize], k: usize| if k == 0 { 0 } else { ends[k - 1] };
    let mut triplets = Vec::new();
    for row in 0..filled1 - 1 {
        for (block, &col) in index2
            .iter()
            .enumerate()
            .take(index1[row + 1])
            .skip(index1[row])
        {
            let (r0, c0) = (start(&row_end, row), start(&col_end, col));
            let (rows, cols) = (row_end[row] - r0, col_end[col] - c0);
            // The block's number, as Siconos writes it; its reader only warns on a mismatch.
            t.count(&format!("the number of block {block}"))?;
            for k in 0..rows * cols {
                let (i, j) = (r0 + k % rows, c0 + k / rows);
                let v = t.number(&format!("entry {k} of block {block} (M[{i}][{j}])"))?;
                triplets.push((i, j, v));
            }
        }
    }
    Ok(Matrix::Triplets(triplets))
}

/// Storage 2: CSparse's text print of a triplet or compressed-column matrix.
fn read_csparse(t: &mut Tokens, size0: usize, size1: usize) -> Result<Matrix, ProblemFileError> {
    t.int("the sparse matrix origin")?;
    // Skip the version line up to the `m-by-n,` size token.
    let mut triplet = false;
    let (m, n) = loop {
        let tok = t.next_token("the sparse matrix size (`m-by-n`)")?;
        if let Some((m, n)) = tok.trim_end_matches(',').split_once("-by-") {
            let (m, n) = m
                .parse::<usize>()
                .ok()
                .zip(n.parse::<usize>().ok())
                .ok_or_else(|| {
                    t.error_at_last(format!("expected the sparse size `m-by-n`, found `{tok}`"))
                })?;
            break (m, n);
        }
        triplet = tok == "triplet:";
    };
    if (m, n) != (size0, size1) {
        return Err(t.error_at_last(format!(
            "the sparse matrix is {m}×{n}, but the header says {size0}×{size1}"
        )));
    }
    while t.next_token("`nnz:`")? != "nnz:" {}
    let nnz = t.count("the number of entries")?;
    let mut triplets = Vec::with_capacity(nnz.min(t.tokens.len()));
    let index = |t: &mut Tokens, what: &str, bound: usize| -> Result<usize, ProblemFileError> {
        let v = t.count(what)?;
        if v >= bound {
            return Err(t.error_at_last(format!("{what} is {v}, outside 0..{bound}")));
        }
        Ok(v)
    };
    if triplet {
        for k in 0..nnz {
            let i = index(t, &format!("the row of entry {k}"), m)?;
            let j = index(t, &format!("the column of entry {k}"), n)?;
            t.expect(":", &format!("entry {k}"))?;
            triplets.push((i, j, t.number(&format!("the value of entry {k}"))?));
        }
        return Ok(Matrix::Triplets(triplets));
    }
    // Compressed columns: skip the rest of the size line (`1-norm: …`) up to the first column.
    while t.peek().is_some_and(|s| s != "col") {
        t.next += 1;
    }
    for j in 0..n {
        let context = format!("the header of column {j}");
        t.expect("col", &context)?;
        let col = t.count(&context)?;
        if col != j {
            return Err(t.error_at_last(format!("expected column {j}, found column {col}")));
        }
        t.expect(":", &context)?;
        t.expect("locations", &context)?;
        let first = t.int(&format!("the first location of column {j}"))?;
        t.expect("to", &context)?;
        let last = t.int(&format!("the last location of column {j}"))?;
        if first != triplets.len() as i64 || last < first - 1 || last >= nnz as i64 {
            return Err(t.error_at_last(format!(
                "column {j} holds locations {first} to {last}, which do not follow on from \
                 {} entries read of {nnz}",
                triplets.len()
            )));
        }
        for _ in first..=last {
            let k = triplets.len();
            let i = index(t, &format!("the row of entry {k}"), m)?;
            t.expect(":", &format!("entry {k}"))?;
            triplets.push((i, j, t.number(&format!("the value of entry {k}"))?));
        }
    }
    if triplets.len() != nnz {
        return Err(t.error_here(format!(
            "the columns hold {} entries, but the size line says nnz = {nnz}",
            triplets.len()
        )));
    }
    Ok(Matrix::Triplets(triplets))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Problem, ProblemFileError> {
        parse_siconos_lcp(text, Path::new("t.dat"))
    }

    fn dense(p: &Problem) -> Vec<Vec<f64>> {
        let a = p.to_dense();
        (0..p.n())
            .map(|i| (0..p.n()).map(|j| a[(i, j)]).collect())
            .collect()
    }

    #[test]
    fn dense_storage_is_column_by_column() {
        // M = [[1, 2], [3, 4]] is written as the columns (1, 3) and (2, 4).
        let p = parse("2\n0\n2\n2\n2\t2\n1 3\n2 4\n-1 -2\n\nA comment.\n").unwrap();
        assert_eq!(dense(&p), vec![vec![1.0, 2.0], vec![3.0, 4.0]]);
        assert_eq!(p.b(), &[-1.0, -2.0]);
        assert!(p.is_standard());
        assert_eq!(p.name(), Some("t"));
        assert!(!p.is_sparse());
    }

    #[test]
    fn sparse_block_storage() {
        // Two block rows and columns of sizes 1 and 2 (cumulative 1, 3); blocks (0,0), (0,1),
        // (1,1), each column by column. M = [[5, 1, 2], [0, 6, 7], [0, 8, 9]].
        let text = "3\n1\n3\n3\n3\n2\n2\n1\t3\t\n1\t3\t\n3\n3\n0\t2\t3\t\n0\t1\t1\t\n\
                    0\n5\n1\n1\n2\n2\n6\n8\n7\n9\n1 2 3\n";
        let p = parse(text).unwrap();
        assert!(p.is_sparse());
        assert_eq!(
            dense(&p),
            vec![vec![5., 1., 2.], vec![0., 6., 7.], vec![0., 8., 9.]]
        );
        assert_eq!(p.b(), &[1.0, 2.0, 3.0]);
    }

    #[test]
    fn csparse_storage_compressed_columns_and_triplets() {
        // M = [[4, 0], [1, 3]].
        let csc = "2\n2\n2\n2\n2\nCSparse Version 3.1.4, Oct 10, 2014.  Copyright (c) Timothy \
                   A. Davis, 2006-2014\n2-by-2, nzmax: 3 nnz: 3, 1-norm: 5\n    col 0 : \
                   locations 0 to 1\n      0 : 4\n      1 : 1\n    col 1 : locations 2 to 2\n      \
                   1 : 3\n-1 -1\n";
        let triplet = "2\n2\n2\n2\n0\nCSparse Version 3.1.4, Oct 10, 2014.\ntriplet: 2-by-2, \
                       nzmax: 3 nnz: 3\n    1 1 : 3\n    0 0 : 4\n    1 0 : 1\n-1 -1\n";
        for text in [csc, triplet] {
            let p = parse(text).unwrap();
            assert_eq!(dense(&p), vec![vec![4.0, 0.0], vec![1.0, 3.0]]);
            assert_eq!(p.b(), &[-1.0, -1.0]);
        }
        // An empty column still has its header.
        let empty = "2\n2\n2\n2\n2\nCSparse\n2-by-2, nzmax: 1 nnz: 1, 1-norm: 1\n col 0 : \
                     locations 0 to -1\n col 1 : locations 0 to 0\n 1 : 2\n 5 6\n";
        let p = parse(empty).unwrap();
        assert_eq!(dense(&p), vec![vec![0.0, 0.0], vec![0.0, 2.0]]);
    }

    #[test]
    fn friction_contact_files_become_box_friction_lcps() {
        // d = 3, one contact, M = 2 I (dense), q, mu = 0.5.
        let text = "3\n1\n0\n3\n3\n3\t3\n2 0 0\n0 2 0\n0 0 2\n-2 -0.4 0\n0.5\n";
        let p = parse_siconos(text, Path::new("fc.dat")).unwrap();
        assert_eq!(p.n(), 3);
        assert_eq!(p.friction().len(), 2);
        assert_eq!(p.friction()[0].mu, 0.5);
        assert_eq!((p.lo()[0], p.hi()[0]), (0.0, f64::INFINITY));
        assert_eq!(p.b(), &[-2.0, -0.4, 0.0]);
        // An LCP whose header could be mistaken for one is still an LCP.
        let lcp = "3\n0\n3\n3\n3 3\n1 0 0\n0 1 0\n0 0 1\n1 2 3\n";
        assert!(parse_siconos(lcp, Path::new("l.dat"))
            .unwrap()
            .is_standard());
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let cases = [
            (
                "2\n0\n2\n2\n2 2\n1 3\n2 x\n-1 -2\n",
                "t.dat:7:3: expected M[1][1]",
            ),
            (
                "2\n0\n2\n2\n2 2\n1 3\n2 4\n-1\n",
                "t.dat:8:1: the file ends before q[1]",
            ),
            ("2\n7\n2\n2\n", "t.dat:2:1: unknown storage type 7"),
            (
                "3\n0\n2\n2\n2 2\n1 3\n2 4\n-1 -2 0\n",
                "t.dat:3:1: M is 2×2, but an LCP of size",
            ),
            (
                "2\n0\n2\n2\n3 2\n",
                "t.dat:5:3: the dense matrix is 3×2, but the header",
            ),
            ("-2\n", "t.dat:1:1: the problem size n must be >= 0"),
            (
                "3\n1\n3\n3\n1\n1\n1\n3\n2\n",
                "t.dat:9:1: the block column sizes add up to 2, but M has 3",
            ),
            (
                "2\n2\n2\n2\n2\nCSparse\n2-by-2, nzmax: 1 nnz: 1, 1-norm: 1\n col 0 : \
                 locations 0 to 0\n 2 : 1\n",
                "t.dat:9:2: the row of entry 0 is 2, outside 0..2",
            ),
            (
                "2\n0\n2\n2\n2 2\n1 3\n2 nan\n-1 -2\n",
                "t.dat: A[1][1] is not finite",
            ),
        ];
        for (text, start) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with(start), "{e}\n  should start with\n{start}");
        }
    }
}
