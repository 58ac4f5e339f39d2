//! The step's contact system as solver problems: the boxed LCP of the whole step or of one
//! island with `A` assembled or held as its factors ([`DelassusForm`]), the exact Coulomb cone
//! problems, and the normal-row problem of the split-impulse position solve.

use super::assembly::DENSE_ROWS;
use super::{BodyVelocity, ContactSystem, Partition, RowKind};
use lcpbench_solvers::{ConeError, ConeProblem, FrictionRow, Problem, ProblemError};

/// How a [`Problem`] built from a [`ContactSystem`] holds its `A = J M⁻¹ Jᵀ`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DelassusForm {
    /// Assembled: dense for at most [`DENSE_ROWS`] rows, else compressed sparse rows, with the
    /// factors attached unless pyramid slack rows couple outside `J M⁻¹ Jᵀ`.
    Assembled,
    /// Held as its factors `J`, `M⁻¹` ([`Problem::boxed_factored`]), for solvers that sweep on
    /// them ([`lcpbench_solvers::Solver::works_on_factors`]); `A` is assembled only if a row of
    /// it is asked for. Problems of at most [`DENSE_ROWS`] rows and those with pyramid slack
    /// rows are assembled as with [`DelassusForm::Assembled`].
    Factored,
}

/// A set of rows and bodies with their local numbering, for assembling a sub-problem.
pub(super) struct Subset<'a> {
    pub(super) rows: &'a [usize],
    pub(super) bodies: &'a [usize],
    /// Global row → local row (`usize::MAX` outside the subset).
    pub(super) local_row: &'a [usize],
    /// Global body → local body.
    pub(super) local_body: &'a [usize],
}

impl ContactSystem {
    /// The step's LCP as a solver [`Problem`]: `A` sparse (dense when tiny), with the factors
    /// `J`, `M⁻¹` attached for matrix-free solvers unless pyramid slack rows are present (their
    /// coupling entries are not of the form `J M⁻¹ Jᵀ`).
    pub fn problem(&self) -> Result<Problem, ProblemError> {
        self.problem_in(DelassusForm::Assembled)
    }

    /// [`ContactSystem::problem`] with `A` held in `form`.
    pub fn problem_in(&self, form: DelassusForm) -> Result<Problem, ProblemError> {
        let (rows, bodies) = self.identity();
        let all = Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        };
        self.subset_problem(&all, self.friction.clone(), self.b(), form)
    }

    /// The step's rows and bounds with another `b` (one entry per row): the LCP a substep
    /// solved, whose `A = J M⁻¹ Jᵀ` is the step's (anchors held over the step) and whose `b` is
    /// the substep's `J v` plus its bias.
    pub fn problem_with_b(&self, b: Vec<f64>, form: DelassusForm) -> Result<Problem, ProblemError> {
        let (rows, bodies) = self.identity();
        let all = Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        };
        self.subset_problem(&all, self.friction.clone(), b, form)
    }

    /// The LCP of island `k` of `partition` (rows and bodies renumbered in the island's order).
    pub fn island_problem(&self, partition: &Partition, k: usize) -> Result<Problem, ProblemError> {
        self.island_problem_in(partition, k, DelassusForm::Assembled)
    }

    /// [`ContactSystem::island_problem`] with `A` held in `form`.
    pub fn island_problem_in(
        &self,
        partition: &Partition,
        k: usize,
        form: DelassusForm,
    ) -> Result<Problem, ProblemError> {
        let island = &partition.islands[k];
        let subset = Subset {
            rows: &island.rows,
            bodies: &island.bodies,
            local_row: &partition.local_row,
            local_body: &partition.local_body,
        };
        let mut friction = Vec::new();
        for &c in &island.contacts {
            let info = &self.info[c];
            if info.slack_row.is_none() {
                for r in info.friction_rows.clone() {
                    friction.push(FrictionRow {
                        row: subset.local_row[r],
                        normal: subset.local_row[info.normal_row],
                        mu: info.mu,
                    });
                }
            }
        }
        let b = island
            .rows
            .iter()
            .map(|&i| self.free_rate[i] + self.bias[i])
            .collect();
        self.subset_problem(&subset, friction, b, form)
    }

    /// The step's contact problem as the exact Coulomb cone: `W = A`, `q = b` and `mu` of each
    /// contact (`W` sparse, dense when tiny), with the factors `J`, `M⁻¹` of `W` attached. Needs every contact to have the three rows of the
    /// cone (or box) model, normal then two tangents; otherwise
    /// [`ConeError::NotContactTriples`] names the first contact that has not.
    pub fn cone_problem(&self) -> Result<ConeProblem, ConeError> {
        let (rows, bodies) = self.identity();
        let contacts: Vec<usize> = (0..self.contacts.len()).collect();
        let subset = Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &rows,
            local_body: &bodies,
        };
        self.subset_cone_problem(&subset, &contacts, self.b())
    }

    /// The cone problem of island `k` of `partition` (see [`ContactSystem::cone_problem`]).
    pub fn island_cone_problem(
        &self,
        partition: &Partition,
        k: usize,
    ) -> Result<ConeProblem, ConeError> {
        let island = &partition.islands[k];
        let subset = Subset {
            rows: &island.rows,
            bodies: &island.bodies,
            local_row: &partition.local_row,
            local_body: &partition.local_body,
        };
        let b = island
            .rows
            .iter()
            .map(|&i| self.free_rate[i] + self.bias[i])
            .collect();
        self.subset_cone_problem(&subset, &island.contacts, b)
    }

    fn subset_cone_problem(
        &self,
        subset: &Subset,
        contacts: &[usize],
        q: Vec<f64>,
    ) -> Result<ConeProblem, ConeError> {
        if let Some(&i) = subset
            .rows
            .iter()
            .find(|&&i| matches!(self.rows[i].kind, RowKind::Joint { .. }))
        {
            return Err(ConeError::NotContactTriples {
                row: subset.local_row[i],
                reason: "the problem has joint (equality) rows, which the FC3D cone problem \
                         has no place for: use a matrix solver or `si` on scenes with joints"
                    .into(),
            });
        }
        for &c in contacts {
            let info = &self.info[c];
            let triple = info.slack_row.is_none()
                && info.friction_rows.len() == 2
                && info.friction_rows.start == info.normal_row + 1;
            if !triple {
                return Err(ConeError::NotContactTriples {
                    row: subset.local_row[info.normal_row],
                    reason: format!(
                        "contact {c} has {} friction rows{}; the cone takes a normal and two \
                         tangent rows per contact (friction_model \"cone\")",
                        info.friction_rows.len(),
                        if info.slack_row.is_some() {
                            " and a pyramid slack row"
                        } else {
                            ""
                        }
                    ),
                });
            }
        }
        let mu = contacts.iter().map(|&c| self.info[c].mu).collect();
        let w = self.assemble_delassus(subset);
        let problem = if subset.rows.len() <= DENSE_ROWS {
            ConeProblem::new(w.to_dense(), q, mu)?
        } else {
            ConeProblem::new_sparse(w, q, mu)?
        };
        // The factors ride along for the solvers that work on the bodies (`sap`).
        problem.with_factors(self.factors(subset)?)
    }

    fn subset_problem(
        &self,
        subset: &Subset,
        friction: Vec<FrictionRow>,
        b: Vec<f64>,
        form: DelassusForm,
    ) -> Result<Problem, ProblemError> {
        let lo = subset.rows.iter().map(|&i| self.lo[i]).collect();
        let hi = subset.rows.iter().map(|&i| self.hi[i]).collect();
        let pyramid = subset
            .rows
            .iter()
            .any(|&i| matches!(self.rows[i].kind, RowKind::Slack { .. }));
        let small = subset.rows.len() <= DENSE_ROWS;
        if form == DelassusForm::Factored && !pyramid && !small {
            return Problem::boxed_factored(self.factors(subset)?, b, lo, hi, friction);
        }
        let a = self.assemble_delassus(subset);
        let problem = if small {
            Problem::boxed(a.to_dense(), b, lo, hi, friction)?
        } else {
            Problem::boxed_sparse(a, b, lo, hi, friction)?
        };
        if pyramid {
            Ok(problem)
        } else {
            problem.with_factors(self.factors(subset)?)
        }
    }

    /// The normal and joint rows only, with `b = J u + position_bias` for a split-impulse
    /// position solve given velocities `u`: `(A of those rows, b_p, their row indices)`. `None`
    /// when no contact penetrates past the slop and no joint has an error.
    pub fn position_problem(&self, u: &[BodyVelocity]) -> Option<(Problem, Vec<usize>)> {
        let rows: Vec<usize> = self
            .info
            .iter()
            .map(|c| c.normal_row)
            .chain(self.joint_rows_start()..self.n())
            .collect();
        // A contact asks for correction when its term is negative (penetration past the slop),
        // a joint when its term is non-zero (an error of either sign).
        let contacts_clear = self
            .info
            .iter()
            .all(|c| self.position_bias[c.normal_row] >= 0.0);
        let joints_clear =
            (self.joint_rows_start()..self.n()).all(|i| self.position_bias[i] == 0.0);
        if contacts_clear && joints_clear {
            return None;
        }
        let op = self.operator();
        let b = rows
            .iter()
            .map(|&i| op.row_dot(i, u) + self.position_bias[i])
            .collect();
        let mut local_row = vec![usize::MAX; self.n()];
        for (k, &i) in rows.iter().enumerate() {
            local_row[i] = k;
        }
        let (_, bodies) = self.identity();
        let subset = Subset {
            rows: &rows,
            bodies: &bodies,
            local_row: &local_row,
            local_body: &bodies,
        };
        self.subset_problem(&subset, Vec::new(), b, DelassusForm::Assembled)
            .ok()
            .map(|p| (p, rows))
    }
}
