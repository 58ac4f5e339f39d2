//! The cone problem ([`ConeProblem`]), its conversions to and from the box-friction LCP, and
//! the interface of its solvers ([`ConeSolver`]).

use super::residual::{cone_residuals_and_velocity, normal_unresolved, project_onto_cone};
use crate::problem::certificate::Certificate;
use crate::problem::metrics::Residuals;
use crate::problem::{DelassusFactors, FrictionRow, Problem, ProblemError};
use crate::solver::{decide, Measured, Monitor, Outcome, Settings, SolveResult, Status};
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
        let delassus = match problem.factors() {
            Some(factors) => delassus.with_factors(factors.clone())?,
            None => delassus,
        };
        Self::assemble(delassus, mu)
    }

    /// Attach the factors `W = J M⁻¹ Jᵀ` (a sparse Jacobian and a 6×6 inverse-mass block per
    /// body) of a problem that came from a contact scene, for solvers that work on the bodies
    /// ([`crate::Sap`]). They must describe the same `W` (the builder guarantees it; the number
    /// of rows is checked here). `W` itself is kept and still decides every residual.
    pub fn with_factors(mut self, factors: DelassusFactors) -> Result<Self, ConeError> {
        self.delassus = self.delassus.with_factors(factors)?;
        Ok(self)
    }

    /// The factors `J`, `M⁻¹` of `W`, when the problem came from a contact scene with them
    /// ([`ConeProblem::with_factors`], [`ConeProblem::from_box`] of a problem that has them).
    pub fn factors(&self) -> Option<&DelassusFactors> {
        self.delassus.factors()
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

/// A solver of the FC3D problem: takes a [`ConeProblem`], returns reactions `r` (in
/// [`SolveResult::f`]), velocities `u` (in [`SolveResult::w`]) and a status decided by the cone
/// residual alone.
///
/// Every cone solver is `Clone` (through [`dyn_clone::DynClone`]); none keeps a workspace between
/// solves, so a clone answers exactly as a fresh solver of the same parameters.
pub trait ConeSolver: dyn_clone::DynClone {
    /// The solver's entry in the [`registry`](crate::registry): its name, description and
    /// parameters.
    fn entry(&self) -> &'static crate::registry::SolverEntry;
    /// Short name (`nsgs-cone`, `newton-ac`), its entry's.
    fn name(&self) -> &'static str {
        self.entry().name
    }
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
    fn cancellation(
        &self,
        r: &[f64],
        u: &[f64],
        tol: f64,
    ) -> Option<(Status, Option<Certificate>)> {
        let x = normal_unresolved(self, r, u, tol)?;
        let reason = format!(
            "the cone residual meets the tolerance {tol:.1e}, but contact {} leaves its normal \
             complementarity unresolved: r_N = {:.3e}, u_N = {:.3e}, normal step {:.3e} above \
             {tol:.1e} of the contact's terms {:.3e} (mu = {}: the mu ‖u_T‖ term of De Saxcé's \
             velocity hides the normal velocity from the cone residual)",
            x.contact,
            x.r_n,
            x.u_n,
            x.step,
            x.scale,
            self.mu()[x.contact]
        );
        Some((Status::Stalled { reason }, None))
    }
}

/// The status of a finite cone reaction `r` with velocity `u = W r + q` and cone residuals
/// `residuals`, given the solver's own `outcome`: [`decide`] on the relative cone residual, then,
/// when that says `Converged`, the test of every contact's normal complementarity
/// ([`normal_unresolved`]), which turns an unresolved contact into `Stalled`. The rule every
/// cone solver's monitor applies, for answers computed elsewhere (the cone counterpart of
/// [`crate::judge`]).
pub fn judge_cone(
    problem: &ConeProblem,
    r: &[f64],
    u: &[f64],
    residuals: &Residuals,
    outcome: Outcome,
    tol: f64,
) -> Status {
    match decide(outcome, residuals.natural_map_rel, tol) {
        Status::Converged => problem
            .cancellation(r, u, tol)
            .map_or(Status::Converged, |(status, _)| status),
        status => status,
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
    use crate::cone::residual::*;

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
