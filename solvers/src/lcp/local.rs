//! Small dense boxed LCPs solved exactly by enumerating their complementary bases: the kernel of
//! [`crate::Enumeration`] (one island at a time) and of NSGS's per-contact blocks
//! ([`crate::Nsgs`], a normal row and its friction rows).
//!
//! A *complementary basis* assigns every row one state (at its lower bound, at its upper bound,
//! or free with `w_i = 0`); each basis fixes `f` through an `m × m` linear system, solved here by
//! Gaussian elimination. Bases are tried in order of the number of rows whose state differs from
//! a guess, and the first candidate within the acceptance residual ends the search.

use crate::problem::Problem;

/// Bounds of one row of a small local problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum LocalBound {
    /// Fixed bounds `[lo, hi]` (infinite allowed).
    Fixed(f64, f64),
    /// A friction row bounded by `±mu x[normal]` (`normal` a local index).
    Friction {
        /// Local index of the normal row.
        normal: usize,
        /// Friction coefficient.
        mu: f64,
    },
}

/// State of a row in a complementary basis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RowState {
    Lower,
    Free,
    Upper,
}

impl LocalBound {
    /// The states this row can take, in a fixed order.
    fn states(&self) -> &'static [RowState] {
        use RowState::*;
        match *self {
            LocalBound::Fixed(lo, hi) if lo == hi => &[Lower],
            LocalBound::Fixed(lo, hi) => match (lo.is_finite(), hi.is_finite()) {
                (true, true) => &[Lower, Free, Upper],
                (true, false) => &[Lower, Free],
                (false, true) => &[Free, Upper],
                (false, false) => &[Free],
            },
            LocalBound::Friction { mu: 0.0, .. } => &[Lower],
            LocalBound::Friction { .. } => &[Lower, Free, Upper],
        }
    }

    /// The bounds at `x`.
    fn at(&self, x: &[f64]) -> (f64, f64) {
        match *self {
            LocalBound::Fixed(lo, hi) => (lo, hi),
            LocalBound::Friction { normal, mu } => {
                let c = mu * x[normal].max(0.0);
                (-c, c)
            }
        }
    }
}

/// The bounds of every row of `problem` as local bounds (a friction row with the index of its
/// normal row), for a [`LocalLcp`] of the whole problem.
pub(crate) fn problem_bounds(problem: &Problem) -> Vec<LocalBound> {
    (0..problem.n())
        .map(|i| match problem.friction_of(i) {
            Some((normal, mu)) => LocalBound::Friction { normal, mu },
            None => LocalBound::Fixed(problem.lo()[i], problem.hi()[i]),
        })
        .collect()
}

/// `A` of `problem`, dense and row-major, for a [`LocalLcp`] of the whole problem.
pub(crate) fn dense_matrix(problem: &Problem) -> Vec<f64> {
    let n = problem.n();
    let mut mat = vec![0.0; n * n];
    for i in 0..n {
        for (j, v) in problem.row(i).iter() {
            mat[i * n + j] = v;
        }
    }
    mat
}

/// A small boxed LCP `w = M x + q` with row-major `M` (`m × m`).
pub(crate) struct LocalLcp<'a> {
    pub m: usize,
    pub mat: &'a [f64],
    pub q: &'a [f64],
    pub bounds: &'a [LocalBound],
    /// Diagonal scale of each row (never zero): the residual uses `w_i / d_i`.
    pub d: &'a [f64],
}

/// Result of an enumeration (the best candidate itself is in [`Workspace::best`]).
pub(crate) struct Enumerated {
    /// True when some basis was regular: [`Workspace::best`] then holds the candidate with the
    /// smallest local residual.
    pub found: bool,
    /// Its local residual `max_i |x_i − mid(lo_i, hi_i, x_i − w_i/d_i)|`.
    pub residual: f64,
    /// Bases tried.
    pub tried: usize,
    /// Bases whose system was singular.
    pub singular: usize,
    /// True when every basis was tried.
    pub exhausted: bool,
}

/// Total number of complementary bases, saturating at `usize::MAX`.
pub(crate) fn basis_count(bounds: &[LocalBound]) -> usize {
    bounds
        .iter()
        .fold(1usize, |n, b| n.saturating_mul(b.states().len()))
}

/// Workspace for [`enumerate`] (allocated once, reused across blocks and sweeps: block solvers
/// call it once per contact per sweep).
#[derive(Default)]
pub(crate) struct Workspace {
    sys: Vec<f64>,
    rhs: Vec<f64>,
    x: Vec<f64>,
    w: Vec<f64>,
    digits: Vec<usize>,
    radices: Vec<&'static [RowState]>,
    states: Vec<RowState>,
    /// The guessed basis ([`LocalLcp::residual_and_guess`]).
    pub guess: Vec<RowState>,
    /// The best candidate of the last [`enumerate`].
    pub best: Vec<f64>,
}

impl Workspace {
    /// The solution of the last [`LocalLcp::solve_basis`] that returned true.
    pub(crate) fn basis_solution(&self) -> &[f64] {
        &self.x
    }
}

impl LocalLcp<'_> {
    /// Local residual `max_i |x_i − mid(lo_i, hi_i, x_i − w_i / d_i)|` of `x`, and in
    /// `ws.guess` the basis `x` suggests: the state of `x_i − w_i / d_i` against the bounds at
    /// `x` (a state the row cannot take is replaced by its first one), from one product `M x`.
    pub(crate) fn residual_and_guess(&self, x: &[f64], ws: &mut Workspace) -> f64 {
        let m = self.m;
        let mut r: f64 = 0.0;
        ws.guess.clear();
        for i in 0..m {
            let wi = self.q[i] + dot(&self.mat[i * m..(i + 1) * m], x);
            let (lo, hi) = self.bounds[i].at(x);
            let t = x[i] - wi / self.d[i];
            let v = (x[i] - t.max(lo).min(hi)).abs();
            r = if v.is_nan() { f64::INFINITY } else { r.max(v) };
            let states = self.bounds[i].states();
            let want = if t <= lo {
                RowState::Lower
            } else if t >= hi {
                RowState::Upper
            } else {
                RowState::Free
            };
            ws.guess.push(if states.contains(&want) {
                want
            } else {
                states[0]
            });
        }
        r
    }

    /// Local residual of `x`, with `w` written.
    fn residual(&self, x: &[f64], w: &mut [f64]) -> f64 {
        let m = self.m;
        let mut r: f64 = 0.0;
        for i in 0..m {
            let wi = self.q[i] + dot(&self.mat[i * m..(i + 1) * m], x);
            w[i] = wi;
            let (lo, hi) = self.bounds[i].at(x);
            let v = (x[i] - (x[i] - wi / self.d[i]).max(lo).min(hi)).abs();
            r = if v.is_nan() { f64::INFINITY } else { r.max(v) };
        }
        r
    }

    /// Solve the system of basis `states` into `ws.x`; false when it is singular.
    pub(crate) fn solve_basis(&self, states: &[RowState], ws: &mut Workspace) -> bool {
        let m = self.m;
        ws.sys.clear();
        ws.sys.resize(m * m, 0.0);
        ws.rhs.clear();
        ws.rhs.resize(m, 0.0);
        for i in 0..m {
            let row = &mut ws.sys[i * m..(i + 1) * m];
            match (states[i], self.bounds[i]) {
                (RowState::Free, _) => {
                    row.copy_from_slice(&self.mat[i * m..(i + 1) * m]);
                    ws.rhs[i] = -self.q[i];
                }
                (s, LocalBound::Fixed(lo, hi)) => {
                    row[i] = 1.0;
                    ws.rhs[i] = if s == RowState::Lower { lo } else { hi };
                }
                (s, LocalBound::Friction { normal, mu }) => {
                    row[i] = 1.0;
                    row[normal] = if s == RowState::Lower { mu } else { -mu };
                }
            }
        }
        ws.x.clear();
        ws.x.extend_from_slice(&ws.rhs);
        gauss_solve(&mut ws.sys, &mut ws.x, m)
    }

    /// Solve basis `ws.states` and keep it in `ws.best` when its residual beats `out`'s; true
    /// when it is accepted (`<= accept`).
    fn try_basis(&self, accept: f64, ws: &mut Workspace, out: &mut Enumerated) -> bool {
        out.tried += 1;
        let states = std::mem::take(&mut ws.states);
        let regular = self.solve_basis(&states, ws);
        ws.states = states;
        if !regular {
            out.singular += 1;
            return false;
        }
        let mut w = std::mem::take(&mut ws.w);
        w.resize(self.m, 0.0);
        let r = self.residual(&ws.x, &mut w);
        ws.w = w;
        if r < out.residual || !out.found {
            out.residual = r;
            out.found = true;
            ws.best.clone_from(&ws.x);
        }
        r <= accept
    }
}

/// Try complementary bases of `lcp` in order of their distance from `guess` (the number of rows
/// whose state differs; the guess itself first) until one has a local residual `<= accept` or
/// `keep_going(tried)` says stop. The best candidate is left in `ws.best`.
pub(crate) fn enumerate(
    lcp: &LocalLcp<'_>,
    guess: &[RowState],
    accept: f64,
    ws: &mut Workspace,
    mut keep_going: impl FnMut(usize) -> bool,
) -> Enumerated {
    let m = lcp.m;
    let mut out = Enumerated {
        found: false,
        residual: f64::INFINITY,
        tried: 0,
        singular: 0,
        exhausted: false,
    };
    ws.radices.clear();
    ws.radices.extend(lcp.bounds.iter().map(|b| b.states()));
    // Distance 0 holds one basis, the guess, when every row can take its guessed state.
    if guess.iter().zip(&ws.radices).all(|(g, r)| r.contains(g)) {
        if !keep_going(out.tried) {
            return out;
        }
        ws.states.clear();
        ws.states.extend_from_slice(guess);
        if lcp.try_basis(accept, ws, &mut out) {
            return out;
        }
    }
    for distance in 1..=m {
        ws.digits.clear();
        ws.digits.resize(m, 0);
        'bases: loop {
            let differ = (0..m)
                .filter(|&i| ws.radices[i][ws.digits[i]] != guess[i])
                .count();
            if differ == distance {
                if !keep_going(out.tried) {
                    return out;
                }
                ws.states.clear();
                for i in 0..m {
                    ws.states.push(ws.radices[i][ws.digits[i]]);
                }
                if lcp.try_basis(accept, ws, &mut out) {
                    return out;
                }
            }
            // Next mixed-radix number.
            let mut i = 0;
            loop {
                if i == m {
                    break 'bases;
                }
                ws.digits[i] += 1;
                if ws.digits[i] < ws.radices[i].len() {
                    break;
                }
                ws.digits[i] = 0;
                i += 1;
            }
        }
    }
    out.exhausted = true;
    out
}

#[inline]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// A Gaussian-elimination pivot below `SINGULAR_PIVOT` times the matrix's largest entry marks
/// the matrix singular: about `450 ε`, the round-off a small dense elimination leaves on a pivot
/// that is zero in exact arithmetic (shared by the enumeration kernel and Lemke's basis
/// inversion).
pub(crate) const SINGULAR_PIVOT: f64 = 1e-13;

/// Solve the row-major `m × m` system in place by Gaussian elimination with partial pivoting;
/// false when a pivot falls below `1e-13` times the largest entry of its column.
fn gauss_solve(a: &mut [f64], x: &mut [f64], m: usize) -> bool {
    let amax = a.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let tol = SINGULAR_PIVOT * amax.max(f64::MIN_POSITIVE);
    for col in 0..m {
        let mut p = col;
        for r in col + 1..m {
            if a[r * m + col].abs() > a[p * m + col].abs() {
                p = r;
            }
        }
        let piv = a[p * m + col];
        if piv.is_nan() || piv.abs() <= tol {
            return false;
        }
        if p != col {
            for c in 0..m {
                a.swap(p * m + c, col * m + c);
            }
            x.swap(p, col);
        }
        for r in col + 1..m {
            let factor = a[r * m + col] / piv;
            if factor != 0.0 {
                for c in col..m {
                    a[r * m + c] -= factor * a[col * m + c];
                }
                x[r] -= factor * x[col];
            }
        }
    }
    for col in (0..m).rev() {
        let s: f64 = (col + 1..m).map(|c| a[col * m + c] * x[c]).sum();
        x[col] = (x[col] - s) / a[col * m + col];
    }
    x.iter().all(|v| v.is_finite())
}
