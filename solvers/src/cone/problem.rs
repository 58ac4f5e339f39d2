//! The exact Coulomb cone: the three-dimensional frictional contact problem (FC3D, the form of
//! Siconos and FCLIB), its shared residual, and the interface of the solvers that take it.
//!
//! `n_c` contacts, each with three rows ordered (normal, tangent 1, tangent 2), a Delassus matrix
//! `W` (`3n_c × 3n_c`, dense or sparse), a free velocity `q` and a friction coefficient `mu_c`
//! per contact. Find reactions `r` and velocities `u = W r + q` satisfying Coulomb's law, in De
//! Saxcé's complementarity form, contact by contact:
//!
//! ```text
//! K_c ∋ r_c  ⟂  û_c ∈ K_c*,     û_c = u_c + mu_c ‖u_{c,T}‖ e_N,
//! K_c  = { r : ‖r_T‖ <= mu_c r_N },   K_c* = { v : mu_c ‖v_T‖ <= v_N }  (the dual cone).
//! ```
//!
//! A contact takes off (`r_c = 0`, `u_{c,N} >= 0`), sticks (`r_c ∈ K_c`, `u_c = 0`) or slides
//! (`‖r_T‖ = mu r_N`, `u_N = 0`, `r_T = −mu r_N u_T / ‖u_T‖`): the friction force opposes the
//! sliding velocity with the same magnitude in every tangent direction, which the box (and
//! pyramid) LCP approximations of [`crate::Problem`] do not.
//!
//! # The cone residual (the only status decider for cone solves)
//!
//! With the projection `P_K` onto the second-order cone ([`project_onto_cone`]), the natural map
//! `r − P_K(r − ρ û)` vanishes exactly at a solution, for any `ρ > 0`. Per contact `c`, with `d_c`
//! the [diagonal scale](crate::Problem::diagonal_scale_of) of its normal row (`W_nn` when
//! positive) and `ρ_c = 1 / d_c`:
//!
//! ```text
//! e_c   = ‖r_c − P_K(r_c − û_c / d_c)‖₂,
//! t_i   = |q_i| + Σ_j |W_ij r_j|                                  (i a row of c)
//! s_c   = ‖(t_N + mu_c ‖(t_1, t_2)‖₂,  t_1,  t_2)‖₂ / d_c,
//! rel   = max_c  e_c / s_c                                       (0/0 = 0, x/0 = ∞)
//! ```
//!
//! This is the per-row philosophy of [`crate::metrics`] lifted to contacts: each contact's step
//! is measured against the magnitudes of the terms that make up its own `û_c / d_c` (the
//! componentwise backward-error scale of Oettli and Prager, with `mu ‖u_T‖` bounded by
//! `mu ‖(t_1, t_2)‖`), so no other contact can hide a contact's error, and the measure is invariant
//! under positive scalings of each contact's rows and columns (`W → R W C`, `R`, `C` constant on
//! each contact's three rows: the cone is invariant under positive scaling). The absolute measure
//! reported next to it is Siconos' FC3D numerator `max_c ‖r_c − P_K(r_c − û_c)‖` (`ρ = 1`; Siconos
//! divides its sum by `1 + ‖q‖`). A cone result's [`Residuals`] hold:
//!
//! * `natural_map`: `max_c ‖r_c − P_K(r_c − û_c)‖₂`;
//! * `natural_map_rel`: `rel` above — `Converged` if and only if `rel <= tolerance`;
//! * `complementarity_gap`: `Σ_c |r_c · û_c|`;
//! * `bound_violation`: `max_c ‖r_c − P_K(r_c)‖₂`, the distance to the friction cone.
//!
//! References: G. De Saxcé, Z.-Q. Feng, *New inequality and functional for contact with
//! friction: the implicit standard material approach*, Mech. Struct. Mach. 19, 1991; P. Alart,
//! A. Curnier, *A mixed formulation for frictional contact problems prone to Newton like solution
//! methods*, CMAME 92, 1991; V. Acary, M. Brémond, O. Huber, *On solving contact problems with
//! Coulomb friction: formulations and numerical comparisons*, Advanced Topics in Nonsmooth
//! Dynamics, Springer 2018 (FC3D, FCLIB, the error measure).

use crate::problem::certificate::Certificate;
use crate::problem::metrics::Residuals;
use crate::problem::{FrictionRow, Problem, ProblemError};
use crate::solver::{Measured, Monitor, Settings, SolveResult, Status};
use faer::sparse::SparseRowMat;
use faer::Mat;
use thiserror::Error;

/// Invalid cone-problem data.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ConeError {
    /// `W` or `q` is invalid (not square, wrong length, not finite).
    #[error("Delassus matrix: {0}")]
    Delassus(#[from] ProblemError),
    /// The number of rows is not a multiple of three.
    #[error("{rows} rows do not come in (normal, tangent, tangent) triples")]
    NotTriples {
        /// Rows of `W`.
        rows: usize,
    },
    /// `mu` does not have one entry per contact.
    #[error("mu has {found} entries, but there are {contacts} contacts")]
    MuLength {
        /// Contacts (`rows / 3`).
        contacts: usize,
        /// Entries of `mu`.
        found: usize,
    },
    /// A negative or non-finite friction coefficient.
    #[error("contact {contact}: mu = {mu} must be finite and >= 0")]
    Coefficient {
        /// Contact index.
        contact: usize,
        /// The coefficient.
        mu: f64,
    },
    /// A box-friction problem whose rows are not (normal, tangent, tangent) triples.
    #[error("row {row}: {reason}")]
    NotContactTriples {
        /// The first offending row.
        row: usize,
        /// What is wrong.
        reason: String,
    },
}

/// A validated FC3D problem. Construct with [`ConeProblem::new`] (dense `W`),
/// [`ConeProblem::new_sparse`], or from a box-friction [`Problem`] with
/// [`ConeProblem::from_box`].
#[derive(Debug, Clone)]
pub struct ConeProblem {
    /// `W` and `q`, stored as a boxed problem with free bounds (for its dense/sparse row access).
    delassus: Problem,
    mu: Vec<f64>,
}

impl ConeProblem {
    /// An FC3D problem with dense `W`.
    pub fn new(w: Mat<f64>, q: Vec<f64>, mu: Vec<f64>) -> Result<Self, ConeError> {
        let n = q.len();
        let free = Problem::boxed(
            w,
            q,
            vec![f64::NEG_INFINITY; n],
            vec![f64::INFINITY; n],
            Vec::new(),
        )?;
        Self::assemble(free, mu)
    }

    /// An FC3D problem with sparse `W` (see [`crate::sparse_from_triplets`]).
    pub fn new_sparse(
        w: SparseRowMat<usize, f64>,
        q: Vec<f64>,
        mu: Vec<f64>,
    ) -> Result<Self, ConeError> {
        let n = q.len();
        let free = Problem::boxed_sparse(
            w,
            q,
            vec![f64::NEG_INFINITY; n],
            vec![f64::INFINITY; n],
            Vec::new(),
        )?;
        Self::assemble(free, mu)
    }

    fn assemble(delassus: Problem, mu: Vec<f64>) -> Result<Self, ConeError> {
        let rows = delassus.n();
        if !rows.is_multiple_of(3) {
            return Err(ConeError::NotTriples { rows });
        }
        if mu.len() != rows / 3 {
            return Err(ConeError::MuLength {
                contacts: rows / 3,
                found: mu.len(),
            });
        }
        if let Some(contact) = mu.iter().position(|m| !(m.is_finite() && *m >= 0.0)) {
            return Err(ConeError::Coefficient {
                contact,
                mu: mu[contact],
            });
        }
        Ok(Self { delassus, mu })
    }

    /// The cone form of a box-friction problem whose rows come in triples `(3c, 3c+1, 3c+2)`:
    /// a normal row with bounds `[0, ∞)` followed by its two friction rows with the same `mu`.
    /// The same `A`, `b` become `W`, `q`.
    pub fn from_box(problem: &Problem) -> Result<Self, ConeError> {
        let n = problem.n();
        if !n.is_multiple_of(3) {
            return Err(ConeError::NotTriples { rows: n });
        }
        let bad = |row: usize, reason: String| Err(ConeError::NotContactTriples { row, reason });
        let mut mu = Vec::with_capacity(n / 3);
        for c in 0..n / 3 {
            let k = 3 * c;
            if problem.friction_of(k).is_some() {
                return bad(k, "expected a normal row, found a friction row".into());
            }
            if problem.lo()[k] != 0.0 || problem.hi()[k] != f64::INFINITY {
                return bad(
                    k,
                    format!(
                        "a normal row needs bounds [0, ∞), found [{}, {}]",
                        problem.lo()[k],
                        problem.hi()[k]
                    ),
                );
            }
            let mut m = None;
            for t in [k + 1, k + 2] {
                match problem.friction_of(t) {
                    Some((normal, mu_t)) if normal == k => match m {
                        None => m = Some(mu_t),
                        Some(m0) if m0 == mu_t => {}
                        Some(m0) => {
                            return bad(t, format!("mu {mu_t} differs from its pair's {m0}"))
                        }
                    },
                    _ => return bad(t, format!("expected a friction row of normal row {k}")),
                }
            }
            mu.push(m.unwrap_or(0.0));
        }
        let free = |p: Result<Problem, ProblemError>| p.map_err(ConeError::from);
        let (q, lo, hi) = (
            problem.b().to_vec(),
            vec![f64::NEG_INFINITY; n],
            vec![f64::INFINITY; n],
        );
        let delassus = if problem.is_sparse() {
            free(Problem::boxed_sparse(
                problem.to_sparse(),
                q,
                lo,
                hi,
                Vec::new(),
            ))?
        } else {
            free(Problem::boxed(problem.to_dense(), q, lo, hi, Vec::new()))?
        };
        let delassus = match problem.name() {
            Some(name) => delassus.with_name(name),
            None => delassus,
        };
        Self::assemble(delassus, mu)
    }

    /// The box-friction LCP approximation of this problem (normal rows `[0, ∞)`, each tangent
    /// row a friction row `|r_t| <= mu r_N`): the inverse of [`ConeProblem::from_box`].
    pub fn to_box(&self) -> Problem {
        let n = self.n();
        let mut lo = vec![0.0; n];
        let hi = vec![f64::INFINITY; n];
        let mut friction = Vec::with_capacity(2 * self.contacts());
        for (c, &mu) in self.mu.iter().enumerate() {
            for t in [3 * c + 1, 3 * c + 2] {
                lo[t] = f64::NEG_INFINITY;
                friction.push(FrictionRow {
                    row: t,
                    normal: 3 * c,
                    mu,
                });
            }
        }
        let q = self.q().to_vec();
        let p = if self.delassus.is_sparse() {
            Problem::boxed_sparse(self.delassus.to_sparse(), q, lo, hi, friction)
        } else {
            Problem::boxed(self.delassus.to_dense(), q, lo, hi, friction)
        }
        .expect("a valid cone problem has a valid box form");
        match self.name() {
            Some(name) => p.with_name(name),
            None => p,
        }
    }

    /// Attach a name.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.delassus = self.delassus.with_name(name);
        self
    }

    /// The problem's name, if any.
    pub fn name(&self) -> Option<&str> {
        self.delassus.name()
    }

    /// Number of contacts.
    pub fn contacts(&self) -> usize {
        self.mu.len()
    }

    /// Number of rows, `3 · contacts`.
    pub fn n(&self) -> usize {
        self.delassus.n()
    }

    /// Friction coefficient of each contact.
    pub fn mu(&self) -> &[f64] {
        &self.mu
    }

    /// The free velocity `q`.
    pub fn q(&self) -> &[f64] {
        self.delassus.b()
    }

    /// `W` and `q` as a problem with free bounds (row access, dense or sparse storage; its
    /// bounds mean nothing here).
    pub fn delassus(&self) -> &Problem {
        &self.delassus
    }

    /// `u = W r + q`.
    pub fn velocity(&self, r: &[f64]) -> Vec<f64> {
        self.delassus.velocity(r)
    }

    /// The 3×3 diagonal block `W_cc` of contact `c`, row-major.
    pub(crate) fn block(&self, c: usize) -> [[f64; 3]; 3] {
        let mut m = [[0.0; 3]; 3];
        for (a, row) in m.iter_mut().enumerate() {
            for (j, v) in self.delassus.row(3 * c + a).iter() {
                if (3 * c..3 * c + 3).contains(&j) {
                    row[j - 3 * c] = v;
                }
            }
        }
        m
    }

    /// `d_c`, the diagonal scale of contact `c`'s normal row.
    pub(crate) fn scale_of(&self, c: usize) -> f64 {
        self.delassus.diagonal_scale_of(3 * c)
    }
}

/// The projection of `x = (x_N, x_T)` onto the cone `‖x_T‖ <= mu x_N` (Euclidean).
pub fn project_onto_cone(mu: f64, x: [f64; 3]) -> [f64; 3] {
    let t = x[1].hypot(x[2]);
    if t <= mu * x[0] {
        x
    } else if mu * t <= -x[0] {
        [0.0; 3]
    } else {
        let a = (x[0] + mu * t) / (1.0 + mu * mu);
        [a, mu * a * x[1] / t, mu * a * x[2] / t]
    }
}

/// De Saxcé's modified velocity `û = u + mu ‖u_T‖ e_N`.
#[inline]
pub fn de_saxce(mu: f64, u: [f64; 3]) -> [f64; 3] {
    [u[0] + mu * u[1].hypot(u[2]), u[1], u[2]]
}

#[inline]
fn norm3(x: [f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// `‖r − P_K(r − ρ û(u))‖` for one contact.
#[inline]
pub(crate) fn contact_natural_map(mu: f64, rho: f64, r: [f64; 3], u: [f64; 3]) -> f64 {
    let uh = de_saxce(mu, u);
    let p = project_onto_cone(
        mu,
        [r[0] - rho * uh[0], r[1] - rho * uh[1], r[2] - rho * uh[2]],
    );
    norm3([r[0] - p[0], r[1] - p[1], r[2] - p[2]])
}

#[inline]
fn relative(e: f64, s: f64) -> f64 {
    if e == 0.0 {
        0.0
    } else if s > 0.0 {
        e / s
    } else {
        f64::INFINITY
    }
}

/// The cone residuals of `r` (see the module doc), computing `u = W r + q`.
pub fn cone_residuals(problem: &ConeProblem, r: &[f64]) -> Residuals {
    let mut u = vec![0.0; problem.n()];
    cone_residuals_and_velocity(problem, r, &mut u)
}

/// The cone residuals of `r`, writing `u = W r + q` into `u` in the same pass over `W`.
pub fn cone_residuals_and_velocity(problem: &ConeProblem, r: &[f64], u: &mut [f64]) -> Residuals {
    let n = problem.n();
    if r.len() != n || u.len() != n || r.iter().any(|v| !v.is_finite()) {
        u.iter_mut().for_each(|v| *v = f64::NAN);
        return Residuals::INFINITE;
    }
    let mut res = Residuals::ZERO;
    for c in 0..problem.contacts() {
        let one = contact_residuals(problem, c, r, u);
        res.natural_map = res.natural_map.max(one.natural_map);
        res.natural_map_rel = res.natural_map_rel.max(one.natural_map_rel);
        res.complementarity_gap += one.complementarity_gap;
        res.bound_violation = res.bound_violation.max(one.bound_violation);
    }
    if !u.iter().all(|v| v.is_finite()) {
        return Residuals::INFINITE;
    }
    res
}

/// The relative cone residual `e_c / s_c` of each contact (see the module doc) at a finite `r`
/// of the right length.
pub(crate) fn contact_relative_residuals(problem: &ConeProblem, r: &[f64]) -> Vec<f64> {
    let mut u = vec![0.0; problem.n()];
    (0..problem.contacts())
        .map(|c| contact_residuals(problem, c, r, &mut u).natural_map_rel)
        .collect()
}

/// The four measures of the module doc for contact `c` alone, writing its rows of `u = W r + q`.
fn contact_residuals(problem: &ConeProblem, c: usize, r: &[f64], u: &mut [f64]) -> Residuals {
    let (w, q, mu) = (problem.delassus(), problem.q(), problem.mu()[c]);
    let mut uc = [0.0; 3];
    let mut t = [0.0; 3];
    for a in 0..3 {
        let i = 3 * c + a;
        let (wr, m) = w.row(i).dot_and_magnitude(r);
        uc[a] = wr + q[i];
        t[a] = q[i].abs() + m;
        u[i] = uc[a];
    }
    let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
    let d = problem.scale_of(c);
    let e = contact_natural_map(mu, 1.0 / d, rc, uc);
    let s = norm3([t[0] + mu * t[1].hypot(t[2]), t[1], t[2]]) / d;
    let uh = de_saxce(mu, uc);
    let p = project_onto_cone(mu, rc);
    Residuals {
        natural_map: contact_natural_map(mu, 1.0, rc, uc),
        natural_map_rel: relative(e, s),
        complementarity_gap: (rc[0] * uh[0] + rc[1] * uh[1] + rc[2] * uh[2]).abs(),
        bound_violation: norm3([rc[0] - p[0], rc[1] - p[1], rc[2] - p[2]]),
    }
}

/// A solver of the FC3D problem: takes a [`ConeProblem`], returns reactions `r` (in
/// [`SolveResult::f`]), velocities `u` (in [`SolveResult::w`]) and a status decided by the cone
/// residual alone.
///
/// Every cone solver is `Clone` (through [`dyn_clone::DynClone`]); none keeps a workspace between
/// solves, so a clone answers exactly as a fresh solver of the same parameters.
pub trait ConeSolver: dyn_clone::DynClone {
    /// Short name (`nsgs-cone`, `newton-ac`).
    fn name(&self) -> &'static str;
    /// Solve. Never panics on a valid [`ConeProblem`]; every outcome is a [`Status`].
    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult;
}

dyn_clone::clone_trait_object!(ConeSolver);

impl Measured for ConeProblem {
    const UNKNOWN: (&'static str, &'static str) = ("reaction", "r");
    const VELOCITY: &'static str = "u = W r + q";
    fn rows(&self) -> usize {
        self.n()
    }
    fn velocity_at(&self, r: &[f64]) -> Vec<f64> {
        self.velocity(r)
    }
    fn measure(&self, r: &[f64], u: &mut [f64]) -> Residuals {
        cone_residuals_and_velocity(self, r, u)
    }
    fn cancellation(&self, _r: &[f64], _u: &[f64]) -> Option<(Status, Option<Certificate>)> {
        None
    }
}

/// Clock, budget, history and the status decision for a cone solve: the shared
/// [`Monitor`](crate::solver::Monitor) judging by the cone residual.
pub(crate) type ConeMonitor<'a> = Monitor<'a, ConeProblem>;

/// Initial reaction: the warm start (when it has the right length and is finite) with each
/// contact projected onto its cone, else zero.
pub(crate) fn initial_reaction(problem: &ConeProblem, settings: &Settings) -> Vec<f64> {
    let n = problem.n();
    let mut r = match &settings.warm_start {
        Some(ws) if ws.len() == n && ws.iter().all(|v| v.is_finite()) => ws.clone(),
        _ => return vec![0.0; n],
    };
    for (c, &mu) in problem.mu().iter().enumerate() {
        let p = project_onto_cone(mu, [r[3 * c], r[3 * c + 1], r[3 * c + 2]]);
        r[3 * c..3 * c + 3].copy_from_slice(&p);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_data() {
        let eye = |n| Mat::<f64>::identity(n, n);
        assert!(matches!(
            ConeProblem::new(eye(4), vec![0.0; 4], vec![0.5]),
            Err(ConeError::NotTriples { rows: 4 })
        ));
        assert!(matches!(
            ConeProblem::new(eye(3), vec![0.0; 3], vec![0.5, 0.5]),
            Err(ConeError::MuLength { .. })
        ));
        assert!(matches!(
            ConeProblem::new(eye(3), vec![0.0; 3], vec![-0.5]),
            Err(ConeError::Coefficient { contact: 0, .. })
        ));
        let e = ConeProblem::new(eye(3), vec![f64::NAN, 0.0, 0.0], vec![0.5]).unwrap_err();
        assert_eq!(e.to_string(), "Delassus matrix: b[0] is not finite (NaN)");
        // A box problem whose tangent rows hang on another normal row.
        let p = Problem::boxed(
            eye(3),
            vec![0.0; 3],
            vec![0.0; 3],
            vec![f64::INFINITY; 3],
            vec![FrictionRow {
                row: 1,
                normal: 0,
                mu: 0.5,
            }],
        )
        .unwrap();
        assert!(matches!(
            ConeProblem::from_box(&p),
            Err(ConeError::NotContactTriples { row: 2, .. })
        ));
    }

    #[test]
    fn cone_projection_cases() {
        // Inside, polar, and onto the boundary.
        assert_eq!(project_onto_cone(0.5, [2.0, 0.3, 0.4]), [2.0, 0.3, 0.4]);
        assert_eq!(project_onto_cone(0.5, [-2.0, 0.3, 0.4]), [0.0; 3]);
        let p = project_onto_cone(0.5, [1.0, 3.0, 4.0]);
        assert!((p[1].hypot(p[2]) - 0.5 * p[0]).abs() < 1e-15);
        // Frictionless: the projection of x_N onto [0, ∞) and tangents zeroed.
        assert_eq!(project_onto_cone(0.0, [1.5, 3.0, 4.0]), [1.5, 0.0, 0.0]);
        // Moreau: x − P_K(x) lies in the polar cone and is orthogonal to P_K(x).
        let x = [0.2, -1.0, 0.7];
        let p = project_onto_cone(0.8, x);
        let y = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
        assert!((p[0] * y[0] + p[1] * y[1] + p[2] * y[2]).abs() < 1e-15);
        assert!(0.8 * y[1].hypot(y[2]) <= -y[0] + 1e-15);
    }

    #[test]
    fn box_round_trip() {
        let w = Mat::from_fn(6, 6, |i, j| if i == j { 2.0 } else { 0.1 });
        let q = vec![-1.0, 0.2, 0.3, 0.5, -0.1, 0.0];
        let p = ConeProblem::new(w, q.clone(), vec![0.3, 0.7])
            .unwrap()
            .with_name("two");
        let b = p.to_box();
        assert_eq!(b.friction().len(), 4);
        assert_eq!(b.friction_of(4), Some((3, 0.7)));
        let back = ConeProblem::from_box(&b).unwrap();
        assert_eq!(back.mu(), &[0.3, 0.7]);
        assert_eq!(back.q(), &q[..]);
        assert_eq!(back.name(), Some("two"));
        assert_eq!(back.delassus().to_dense(), p.delassus().to_dense());
    }

    fn two_contacts(scale: [f64; 2], col: [f64; 2]) -> (ConeProblem, Vec<f64>) {
        let w0 = [
            [2.0, 0.3, -0.1, 0.5, 0.0, 0.1],
            [0.3, 1.5, 0.2, 0.0, 0.2, 0.0],
            [-0.1, 0.2, 1.2, 0.1, 0.0, 0.3],
            [0.5, 0.0, 0.1, 3.0, 0.4, 0.0],
            [0.0, 0.2, 0.0, 0.4, 2.5, -0.2],
            [0.1, 0.0, 0.3, 0.0, -0.2, 2.0],
        ];
        let q0 = [-1.0, 0.4, -0.3, -0.5, 0.9, 0.2];
        let r0 = [0.4, -0.1, 0.05, 0.3, -0.2, 0.1];
        let (rs, cs) = (|i: usize| scale[i / 3], |j: usize| col[j / 3]);
        let w = Mat::from_fn(6, 6, |i, j| rs(i) * w0[i][j] * cs(j));
        let q = (0..6).map(|i| rs(i) * q0[i]).collect();
        let r = (0..6).map(|j| r0[j] / cs(j)).collect();
        (ConeProblem::new(w, q, vec![0.4, 0.8]).unwrap(), r)
    }

    /// The relative cone residual is invariant under positive scalings of each contact's rows
    /// and columns, over many decades.
    #[test]
    fn relative_cone_residual_is_scale_invariant() {
        let (p, r) = two_contacts([1.0, 1.0], [1.0, 1.0]);
        let base = cone_residuals(&p, &r).natural_map_rel;
        assert!(base > 1e-3);
        let (q, s) = two_contacts([1e9, 1e-7], [1e-6, 3e8]);
        let scaled = cone_residuals(&q, &s).natural_map_rel;
        assert!((scaled - base).abs() <= 1e-12 * base, "{base} vs {scaled}");
    }

    /// The shared monitor judges a cone solve by the cone residual and names its unknowns.
    #[test]
    fn cone_monitor_decides_by_the_cone_residual() {
        use crate::solver::Outcome;
        let (p, r) = two_contacts([1.0, 1.0], [1.0, 1.0]);
        let settings = Settings::default();
        let done = ConeMonitor::new(&p, &settings).finish(r.clone(), 3, Outcome::Stopped);
        assert_eq!(done.residuals, cone_residuals(&p, &r));
        assert_eq!(done.w, p.velocity(&r));
        assert_eq!(done.status.name(), "stalled");
        let mut bad = r;
        bad[1] = f64::NAN;
        let failed = ConeMonitor::new(&p, &settings).finish(bad, 3, Outcome::Stopped);
        assert_eq!(
            failed.status.reason(),
            Some("non-finite reaction r[1] = NaN")
        );
        let refused = ConeMonitor::new(&p, &settings).finish(
            Vec::new(),
            0,
            Outcome::Unsupported("no".into()),
        );
        assert_eq!(refused.f, vec![0.0; 6]);
        assert_eq!(refused.w, p.q());
        assert_eq!(refused.residuals, cone_residuals(&p, &[0.0; 6]));
    }

    #[test]
    fn sparse_and_dense_cone_problems_agree() {
        let (p, r) = two_contacts([1.0, 1.0], [1.0, 1.0]);
        let d = p.delassus().to_dense();
        let triplets: Vec<_> = (0..6)
            .flat_map(|i| (0..6).map(move |j| (i, j)))
            .filter(|&(i, j)| d[(i, j)] != 0.0)
            .map(|(i, j)| (i, j, d[(i, j)]))
            .collect();
        let sparse = ConeProblem::new_sparse(
            crate::problem::sparse_from_triplets(6, &triplets).unwrap(),
            p.q().to_vec(),
            p.mu().to_vec(),
        )
        .unwrap();
        assert_eq!(cone_residuals(&p, &r), cone_residuals(&sparse, &r));
        assert!(sparse.to_box().is_sparse());
    }
}
