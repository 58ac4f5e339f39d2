//! Enumeration of complementary bases: a complete method for small LCPs (Siconos' `ENUM`).
//!
//! A *complementary basis* assigns every row one state: at its lower bound, at its upper bound, or
//! free (`w_i = 0`). Each state is one linear equation, so a basis fixes `f` through an `n × n`
//! linear system:
//!
//! ```text
//! free:             (A f + b)_i = 0
//! lower / upper:    f_i = lo_i  /  f_i = hi_i                 (fixed bounds)
//!                   f_i = −mu f_k  /  f_i = mu f_k            (friction row i of normal row k)
//! ```
//!
//! Every solution of the boxed LCP solves the system of at least one basis, so trying all of them
//! and keeping the candidate whose local natural-map residual is smallest finds a solution
//! whenever one exists and the bases that carry it are non-singular (Murty 1988, §1.2;
//! Cottle–Pang–Stone 1992, §1.1). Bases are tried in order of the number of rows whose state
//! differs from a guess (a projected Jacobi step from the warm start), so a good guess ends the
//! search after a few systems.
//!
//! * **Problem class**: any `A` (no symmetry, definiteness or copositivity needed), standard and
//!   boxed LCP with friction rows, up to [`MAX_BASES`] complementary bases: a standard LCP up to
//!   `n = 15`; a row with two finite bounds or a friction row counts three states, a row with one
//!   finite bound two, a free or fixed row one. Larger problems are `Unsupported`.
//! * **Cost**: `O(n³)` per basis (a small Gaussian elimination), at most `2ⁿ` bases for the
//!   standard LCP: about 30 ms for an exhaustive search at `n = 15`. [`Settings::max_iterations`]
//!   counts bases (the default `10 000` is exhaustive up to `n = 13`; raise it for `n = 14, 15`).
//! * **Outcomes**: a candidate whose local relative residual is below `tolerance / 100` ends the
//!   search. After an exhaustive search that found none, `Stalled` when the best candidate is
//!   within round-off of a solution (local residual below `1e-10` of the scale, whatever the
//!   tolerance), else `NoSolution` when every basis was non-singular (that is a proof, up to
//!   rounding: a solution would have been one of the candidates); otherwise `Stalled`, since a
//!   solution may live on a singular basis. The best candidate is returned either way and the
//!   shared residual decides.
//! * **Warm start**: used only to order the search.
//!
//! The same kernel solves NSGS's per-contact blocks ([`crate::Nsgs`]).
//!
//! References: K. G. Murty, *Linear Complementarity, Linear and Nonlinear Programming*, 1988;
//! V. Acary, O. Bonnefon et al., Siconos numerics, `lcp_enum.c`.

use crate::problem::Problem;
use crate::solver::{
    initial_impulse, solve_by_islands, Monitor, Outcome, Settings, SolveResult, Solver,
};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "any LCP or boxed LCP with friction rows, per island up to 32768 complementary bases (standard LCP n <= 15); complete";

/// Largest number of complementary bases the solver enumerates (`2¹⁵`).
pub const MAX_BASES: usize = 1 << 15;

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
    fn solve_basis(&self, states: &[RowState], ws: &mut Workspace) -> bool {
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

/// Solve the row-major `m × m` system in place by Gaussian elimination with partial pivoting;
/// false when a pivot falls below `1e-13` times the largest entry of its column.
fn gauss_solve(a: &mut [f64], x: &mut [f64], m: usize) -> bool {
    let amax = a.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let tol = 1e-13 * amax.max(f64::MIN_POSITIVE);
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

/// Enumeration of complementary bases. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Enumeration;

impl Solver for Enumeration {
    fn name(&self) -> &'static str {
        "enum"
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        solve_by_islands(problem, settings, ISLAND_ROWS, |island, settings| {
            self.solve_dense(island, settings)
        })
    }
}

/// Largest island handed to the enumeration (its basis count is then checked against
/// [`MAX_BASES`]).
const ISLAND_ROWS: usize = 64;

impl Enumeration {
    /// One island.
    fn solve_dense(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let n = problem.n();
        let bounds: Vec<LocalBound> = (0..n)
            .map(|i| match problem.friction_of(i) {
                Some((normal, mu)) => LocalBound::Friction { normal, mu },
                None => LocalBound::Fixed(problem.lo()[i], problem.hi()[i]),
            })
            .collect();
        let total = basis_count(&bounds);
        if total > MAX_BASES {
            let shown = if total == usize::MAX {
                "more than 2^64".to_string()
            } else {
                total.to_string()
            };
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(format!(
                    "{shown} complementary bases; enumeration is limited to {MAX_BASES} \
                     (a standard LCP with n <= 15)"
                )),
            );
        }
        let mut mat = vec![0.0; n * n];
        for i in 0..n {
            for (j, v) in problem.row(i).iter() {
                mat[i * n + j] = v;
            }
        }
        let d = problem.diagonal_scale();
        let lcp = LocalLcp {
            m: n,
            mat: &mat,
            q: problem.b(),
            bounds: &bounds,
            d: &d,
        };
        let f0 = initial_impulse(problem, settings);
        let mut ws = Workspace::default();
        lcp.residual_and_guess(&f0, &mut ws);
        let guess = std::mem::take(&mut ws.guess);
        // Accept on the local residual relative to the shared scale's ingredients.
        let scale = (0..n)
            .map(|i| (problem.b()[i] / d[i]).abs())
            .chain(
                (0..n)
                    .filter(|&i| problem.friction_of(i).is_none())
                    .flat_map(|i| [problem.lo()[i], problem.hi()[i]])
                    .filter(|v| v.is_finite())
                    .map(f64::abs),
            )
            .fold(0.0_f64, f64::max);
        let scale = if scale > 0.0 { scale } else { 1.0 };
        let accept = 1e-2 * settings.tolerance * scale;
        let mut stop: Option<Outcome> = None;
        let result = enumerate(&lcp, &guess, accept, &mut ws, |tried| {
            if tried >= settings.max_iterations {
                stop = Some(Outcome::IterationLimit);
                false
            } else if tried % 64 == 0 && monitor.out_of_time() {
                stop = Some(Outcome::TimeLimit);
                false
            } else {
                true
            }
        });
        let f = if result.found { ws.best } else { f0 };
        // A claim of no solution must not follow from the tolerance: a best candidate within
        // round-off of a solution (1e-10 of the scale; the acceptance at the default 1e-8)
        // counts as one whatever the tolerance asked for.
        let claim = accept.max(1e-10 * scale);
        let outcome = match stop {
            Some(o) => o,
            None if result.residual <= accept => Outcome::Stopped,
            None if result.residual <= claim => Outcome::Stalled(format!(
                "the best of {} complementary bases solves the problem to a local residual of \
                 {:.3e} of the scale, within round-off but short of the tolerance",
                result.tried,
                result.residual / scale
            )),
            None if result.singular == 0 => Outcome::NoSolution(format!(
                "all {} complementary bases enumerated, every one non-singular, and none \
                 satisfies the complementarity conditions",
                result.tried
            )),
            None => Outcome::Stalled(format!(
                "all {} complementary bases enumerated; none satisfies the complementarity \
                 conditions, but {} were singular, so a solution on a singular basis is not \
                 excluded",
                result.tried, result.singular
            )),
        };
        monitor.record(result.tried, &f);
        monitor.finish(f, result.tried, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::{generate, Family};
    use crate::test_util::lcp;
    use crate::{FrictionRow, Status};
    use faer::Mat;

    #[test]
    fn finds_a_solution_where_lemke_ray_terminates() {
        let p = crate::test_util::three_solution_lcp();
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged, "{}", r.status);
        assert!(r.residuals.natural_map <= 1e-12);
        let hit = crate::test_util::THREE_SOLUTIONS
            .iter()
            .any(|s| s.iter().zip(&r.f).all(|(x, y)| (x - y).abs() < 1e-12));
        assert!(hit, "{:?} is none of the three solutions", r.f);
    }

    #[test]
    fn solves_planted_families() {
        for (family, n) in [
            (Family::Spd { cond: 1e3 }, 12),
            (Family::PMatrix, 12),
            (Family::PsdRankDeficient { rank: 5 }, 10),
            (Family::Murty, 8),
        ] {
            let g = generate(family, n, 3);
            let r = Enumeration.solve(&g.problem, &Settings::default());
            assert_eq!(r.status, Status::Converged, "{family:?}");
            if !matches!(family, Family::PsdRankDeficient { .. }) {
                for (x, y) in r.f.iter().zip(g.solution.as_ref().unwrap()) {
                    assert!((x - y).abs() < 1e-8, "{family:?}");
                }
            }
        }
    }

    /// A tolerance below round-off is not met, but it does not turn a solvable problem into a
    /// claim that there is no solution: an SPD problem always has one.
    #[test]
    fn a_tolerance_below_round_off_claims_nothing() {
        let settings = Settings {
            tolerance: 1e-300,
            ..Settings::default()
        };
        // Seeds whose solution leaves a round-off residual (others meet even 1e-300 exactly).
        for seed in [3, 4, 9] {
            let g = generate(Family::Spd { cond: 1e2 }, 5, seed);
            let r = Enumeration.solve(&g.problem, &settings);
            assert_ne!(r.status.name(), "no_solution", "seed {seed}: {}", r.status);
            for (x, y) in r.f.iter().zip(g.solution.as_ref().unwrap()) {
                assert!((x - y).abs() < 1e-12, "seed {seed}: {:?}", r.f);
            }
        }
    }

    #[test]
    fn proves_infeasibility_when_every_basis_is_regular() {
        // A = [[-1]], b = [-1]: w = -f - 1 < 0 for every f >= 0.
        let p = lcp(&[&[-1.0]], &[-1.0]);
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status.name(), "no_solution", "{}", r.status);
        // A singular basis: A = 0, b = -1 has no solution, but not by proof.
        let p = lcp(&[&[0.0]], &[-1.0]);
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status.name(), "stalled", "{}", r.status);
    }

    #[test]
    fn friction_rows_and_size_limit() {
        // Normal pushed in, tangent pushed hard (b_t = 2 drives f_t negative): it slides at
        // f_t = -mu f_n with f_n = 1, f_t = -0.5, w_t = 1.5 >= 0 at the lower bound.
        let p = Problem::boxed(
            Mat::identity(2, 2),
            vec![-1.0, 2.0],
            vec![0.0, 0.0],
            vec![f64::INFINITY, 0.0],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        let r = Enumeration.solve(&p, &Settings::default());
        assert_eq!(r.status, Status::Converged);
        assert!((r.f[0] - 1.0).abs() < 1e-12 && (r.f[1] + 0.5).abs() < 1e-12);
        let g = generate(Family::Spd { cond: 10.0 }, 16, 1);
        let r = Enumeration.solve(&g.problem, &Settings::default());
        assert_eq!(r.status.name(), "unsupported");
    }
}
