//! `jacobi`: projected Jacobi on accumulated impulses, the parallel baseline of Catto's solver
//! comparison (Solver2D, `s2Solve_Jacobi` in `src/solve_jacobi.c`, which is Jacobi across
//! contacts and Gauss–Seidel within one contact's points; here every row is Jacobi), made
//! convergent by a row scaling: the absolute row sums of `A` (default) or mass splitting
//! (Tonge, Benevolenski and Voroshilov, "Mass splitting for jitter-free parallel rigid body
//! simulation", SIGGRAPH 2012).
//!
//! Each of `substeps` substeps of `h = dt / substeps` runs, in order:
//!
//! 1. **integrate velocities**: `v += h g` (one body pass);
//! 2. **targets**: every row's bias from the pose at the substep's start ([`super::bias`]):
//!    restitution `e v⁻` for a bouncing contact, the speculative `C/h` of an open one, else
//!    Baumgarte `β/h · min(0, C + slop)` (joint rows `β/h · C`); with `hertz > 0`, soft contacts
//!    instead of Baumgarte (`bias = max(bias_rate C, −3 m/s)` with the spring's mass and impulse
//!    scales, Catto 2011);
//!    A soft row is a row of the regularised LCP `A + Γ` (`γ = k · impulse_scale / mass_scale`,
//!    the fixed point of Box2D v3's soft update) and is scaled by `D + γ`, so the spring is
//!    Box2D v3's whatever the row scaling;
//! 3. **warm start**: apply the accumulated impulses `λ` together (one body pass);
//! 4. **`iterations` Jacobi sweeps**: from the same velocities `v`, every row's candidate
//!    `λᵢ* = proj(λᵢ − mᵢ (Jᵢ v + biasᵢ))`, `mᵢ = 1/Dᵢ` of the row scaling below (normal `≥ 0`, friction within `±μ λ_n` of the
//!    previous sweep's normal impulse, joint unbounded), the increment `Δᵢ = ω (λᵢ* − λᵢ)`, then
//!    all increments applied together, `v += Σᵢ M⁻¹ Jᵢᵀ Δᵢ` (one body pass per sweep);
//! 5. **integrate positions**: `Δx += h v` (one body pass).
//!
//! **Why a row scaling.** Plain Jacobi (`mᵢ = 1 / Aᵢᵢ`, `ω = 1`) is the iteration
//! `λ ← proj(λ − D⁻¹ (A λ + b))` with `D = diag(A)`, which converges for a symmetric `A` only
//! when `2D − A` is positive definite; a box resting on four contacts already breaks that (four
//! normal rows pushing the same body each remove the whole approach speed, so a sweep
//! overshoots) and stacks diverge. Any diagonal `D ≽ A` makes `2D/ω − A ≻ 0` for every
//! `ω ∈ (0, 2)`, so the projected iteration converges (Cottle, Pang and Stone 1992, the
//! symmetric splitting theorem) whatever the stack. Two such `D` (`split`):
//!
//! * `split = 2` (default), **row sums**: `Dᵢ = Σ_b Σ_j |Jᵢ_b M_b⁻¹ J_j_bᵀ|` over the dynamic
//!   bodies `b` of row `i` and the swept rows `j` on `b`. `A = Σ_b J_b M_b⁻¹ J_bᵀ`, and each
//!   body's term `P_b` is dominated by the diagonal of its absolute row sums
//!   (`diag(Σ_j |P_ij|) − P` is diagonally dominant, hence positive semidefinite), so
//!   `A ≼ D`. Rows that do not couple (a sphere's normal and friction rows) keep their full
//!   mass: one sweep solves a lone contact exactly.
//! * `split = 1`, **mass splitting** (Tonge et al. 2012): each body touched by `n_b` swept rows
//!   lends each of them the mass `m_b / n_b`: `Dᵢ = Σ_b n_b Jᵢ_b M_b⁻¹ Jᵢ_bᵀ`. Each `P_b` is the
//!   Gram matrix of `n_b` vectors, and Cauchy–Schwarz gives `xᵀ P_b x ≤ n_b Σᵢ xᵢ² (P_b)ᵢᵢ`,
//!   so `A ≼ D` too; it counts rows that do not couple as if they did, and is slower.
//! * `split = 0`: plain Jacobi, relaxed by `omega` (divergent on stacks at `ω = 1`, kept for
//!   the comparison).
//!
//! Convergent is not fast: a sweep moves each row by a share of its own correction, so a body
//! with many rows (a box in a tower has 24) or a long chain of joints with a mass ratio needs
//! many more sweeps than Gauss–Seidel, and at a fixed 8 sweeps per step stacks sink and jitter
//! (Catto's comparison finds the same).

//! **What it solves.** With `hertz = 0` the fixed point of the sweeps is the step's LCP with
//! the bias above (relaxation and splitting change the path, not the fixed point). The reported
//! last solve ([`SubstepOutcome::last`]) is the last substep's: `f` its accumulated impulses,
//! `b` = `J v` after gravity and before the warm start plus the bias, so `w = A f + b` is the
//! velocity after the sweeps plus the bias. A fixed number of sweeps rarely meets a tight
//! tolerance: the status is then `iteration_limit`, `converged` only when the shared residual of
//! that LCP meets it. With `hertz > 0` the solve is of a soft problem, measured against the
//! rigid LCP (`residual_of` says `soft`). Row order does not change the answer beyond
//! round-off (the sum of the increments on a body is the only order-dependent operation).
//!
//! **Failure modes.** Few sweeps per step on many rows per body: stacks sink by centimetres and
//! jitter (a 5-box tower at 8 sweeps), and long chains of joints stretch. On chains the
//! Baumgarte term of the joint rows, fed through a solve that is far from converged and
//! integrated over the steps by the warm start, can grow into an oscillation that tears the
//! chain (a 20-link chain at 8 sweeps; `baumgarte = 0` keeps it bounded but sagging; more
//! substeps make the per-substep `β/h` stiffer and it worse).
//!
//! **Not done**: graph colouring or threads (the sweep is serial code of a parallel method),
//! Tonge's per-body velocity copies (the splitting is applied through the row masses, which
//! gives the same fixed point and the same convergence bound), and pyramid friction rows.
//!
//! **Budgets.** `settings.max_iterations` caps the sweeps of the whole step (once spent, the
//! remaining substeps apply their warm start and integrate); `settings.time_budget` is checked
//! between substeps (once spent, the remaining substeps only integrate; `timed_out`).

use super::bias::{is_swept, projected_update, row_targets, warm_impulses, Feedback, RowTarget};
use super::params::{ParamSpec, Params};
use super::softness::Softness;
use super::state::{RowRole, SolverState, StepCost};
use super::{LastSolve, SubstepInput, SubstepOutcome};
use crate::body_solvers::{BodySolver, BodySolverKind, BodySweep};
use crate::builder::ContactSystem;
use lcpbench_solvers::Settings;
use nalgebra::Vector3;
use std::time::Instant;

/// The parameters of `jacobi`.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec::count("substeps", 1, 1, 64, "substeps per step"),
    ParamSpec::count("iterations", 8, 1, 10_000, "Jacobi sweeps per substep"),
    ParamSpec::real(
        "baumgarte",
        0.2,
        0.0,
        1.0,
        "share of the position error fed back per substep (Box2D 2.x's 0.2)",
    ),
    ParamSpec::real(
        "slop",
        0.005,
        0.0,
        1.0,
        "penetration left uncorrected, m (Box2D's linear slop)",
    ),
    ParamSpec::count(
        "split",
        2,
        0,
        2,
        "row scaling: 2 row sums of |A| (convergent), 1 mass splitting (Tonge et al. 2012, \
         convergent), 0 plain Jacobi (diverges on stacks)",
    ),
    ParamSpec::real(
        "omega",
        1.0,
        0.01,
        1.99,
        "relaxation of each increment (with split = 1 or 2 convergent on (0, 2))",
    ),
    ParamSpec::real(
        "hertz",
        0.0,
        0.0,
        1e4,
        "soft contact stiffness, Hz (0: rigid with Baumgarte)",
    ),
    ParamSpec::real("zeta", 1.0, 0.0, 1e3, "soft contact damping ratio"),
];

/// The `jacobi` solver with its parameters ([`PARAMS`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jacobi {
    params: Params,
}

impl Default for Jacobi {
    fn default() -> Self {
        Self::new(Params::defaults(PARAMS))
    }
}

impl Jacobi {
    /// The solver with `params` (which follow [`PARAMS`]).
    pub fn new(params: Params) -> Self {
        Self { params }
    }

    /// Advance the bodies over the step of `system` (see the module doc).
    pub fn step(
        &self,
        system: &ContactSystem,
        gravity: Vector3<f64>,
        settings: &Settings,
    ) -> SubstepOutcome {
        let p = &self.params;
        let substeps = p.count("substeps").max(1);
        let iterations = p.count("iterations");
        let omega = p.get("omega");
        let h = system.h / substeps as f64;
        let baumgarte = Feedback::Baumgarte {
            beta: p.get("baumgarte"),
            slop: p.get("slop"),
        };
        let feedback = Feedback::soft_or(p.get("hertz"), p.get("zeta"), h, baumgarte);
        let deadline = settings.time_budget.map(|b| Instant::now() + b);

        let mut state = SolverState::new(system, &gravity);
        let n = state.rows.len();
        let swept: Vec<usize> = (0..n).filter(|&i| is_swept(&state.rows[i])).collect();
        let mass = match p.count("split") {
            2 => row_sum_masses(&state),
            1 => split_masses(&state),
            _ => state.rows.iter().map(|r| r.mass).collect(),
        };
        let mut lambda = warm_impulses(&state, settings.warm_start.as_deref());
        let mut delta = vec![0.0; n];
        let mut f_step = vec![0.0; n];
        let mut cost = StepCost::default();
        let mut budget = settings.max_iterations;
        let mut sweeps_done = 0;
        let mut last = None;
        let mut timed_out = false;

        for s in 0..substeps {
            if s > 0 && deadline.is_some_and(|d| Instant::now() >= d) {
                timed_out = true;
            }
            state.integrate_velocities(&gravity, h);
            cost.body_passes += 1;
            if !timed_out {
                let targets = row_targets(&state, feedback, h, system.restitution_threshold);
                let (targets, row_mass) = regularised(&state, &targets, &mass);
                let b: Vec<f64> = state
                    .rates()
                    .iter()
                    .zip(&targets)
                    .map(|(r, t)| r + t.bias)
                    .collect();
                state.apply_all(&lambda);
                cost.body_passes += 1;
                cost.row_updates += swept.len() as u64;
                let sweeps = iterations.min(budget);
                for _ in 0..sweeps {
                    // Every increment from the same velocities and the previous sweep's
                    // impulses (friction bounds included) ...
                    for &i in &swept {
                        let row = &state.rows[i];
                        let bound = match row.role {
                            RowRole::Friction { normal } => row.mu * lambda[normal],
                            _ => 0.0,
                        };
                        let rate = row.rate(&state.bodies);
                        let new = projected_update(
                            row.role,
                            lambda[i],
                            rate,
                            &targets[i],
                            row_mass[i],
                            bound,
                        );
                        delta[i] = omega * (new - lambda[i]);
                    }
                    // ... then all applied together.
                    for &i in &swept {
                        if delta[i] != 0.0 {
                            lambda[i] += delta[i];
                            state.rows[i].apply(delta[i], &mut state.bodies);
                        }
                    }
                    cost.row_updates += swept.len() as u64;
                    cost.body_passes += 1;
                }
                budget -= sweeps;
                sweeps_done += sweeps;
                for (total, l) in f_step.iter_mut().zip(&lambda) {
                    *total += l;
                }
                let soft = matches!(feedback, Feedback::Soft(_));
                last = Some(LastSolve {
                    f: lambda.clone(),
                    b,
                    what: format!(
                        "{}Jacobi sweeps of substep {} of {substeps} ({sweeps} sweeps)",
                        if soft { "soft " } else { "" },
                        s + 1
                    ),
                });
            }
            state.integrate_positions(h);
            cost.body_passes += 1;
        }
        // The first substep always solves (the deadline is checked from the second on).
        let last = last.unwrap_or_else(|| LastSolve {
            f: vec![0.0; n],
            b: state.rates(),
            what: "no solve".into(),
        });
        SubstepOutcome {
            state,
            f_step,
            warm: lambda,
            last,
            iterations: sweeps_done,
            substeps,
            cost,
            timed_out,
        }
    }
}

/// The soft rows as rows of a regularised LCP under the row scaling. A soft row's update
/// (Box2D v3) `Δ = −m s_m (J v + bias) − s_i λ` with `m = 1/k` has the fixed point
/// `J v + bias + γ λ = 0`, `γ = k s_i / s_m`: the row of `A + Γ`. Jacobi on `A + Γ` with the
/// dominating diagonal `D + Γ` is `λ ← λ − (J v + bias + γ λ) / (D + γ)`, i.e. the update with
/// `m' = 1/(D + γ)`, `s_m' = 1`, `s_i' = γ/(D + γ)` (for `D = k` it is Box2D's own); scaling
/// the soft update's `m` instead would solve a softer spring. Rigid rows keep `1/D`.
fn regularised(
    state: &SolverState,
    targets: &[RowTarget],
    mass: &[f64],
) -> (Vec<RowTarget>, Vec<f64>) {
    let mut row_mass = mass.to_vec();
    let targets = targets
        .iter()
        .zip(&state.rows)
        .zip(row_mass.iter_mut())
        .map(|((t, row), m)| {
            let s = t.softness;
            if s.impulse_scale == 0.0 || s.mass_scale <= 0.0 || *m <= 0.0 {
                return *t;
            }
            let gamma = row.k * s.impulse_scale / s.mass_scale;
            let d = 1.0 / *m + gamma;
            *m = 1.0 / d;
            RowTarget {
                bias: t.bias,
                softness: Softness {
                    bias_rate: s.bias_rate,
                    mass_scale: 1.0,
                    impulse_scale: gamma / d,
                },
            }
        })
        .collect();
    (targets, row_mass)
}

/// The row masses under mass splitting: `mᵢ = 1 / Σ_b n_b Jᵢ_b M_b⁻¹ Jᵢ_bᵀ`, `n_b` the number
/// of swept rows on body `b` (0 for a row that is not swept).
pub fn split_masses(state: &SolverState) -> Vec<f64> {
    let mut count = vec![0usize; state.bodies.len()];
    for row in state.rows.iter().filter(|r| is_swept(r)) {
        for b in &row.blocks[..row.sides as usize] {
            count[b.body] += 1;
        }
    }
    state
        .rows
        .iter()
        .map(|row| {
            if !is_swept(row) {
                return 0.0;
            }
            let k: f64 = row.blocks[..row.sides as usize]
                .iter()
                .zip(&row.response)
                .map(|(b, (lin, ang))| {
                    count[b.body] as f64 * (b.linear.dot(lin) + b.angular.dot(ang))
                })
                .sum();
            if k > 0.0 {
                1.0 / k
            } else {
                0.0
            }
        })
        .collect()
}

/// The row masses of the row-sum scaling: `mᵢ = 1 / Σ_b Σ_j |Jᵢ_b M_b⁻¹ J_j_bᵀ|`, the sum
/// over the dynamic bodies `b` of row `i` and every swept row `j` on `b` (`j = i` included);
/// 0 for a row that is not swept.
pub fn row_sum_masses(state: &SolverState) -> Vec<f64> {
    let mut on_body: Vec<Vec<(usize, usize)>> = vec![Vec::new(); state.bodies.len()];
    for (i, row) in state.rows.iter().enumerate().filter(|(_, r)| is_swept(r)) {
        for (side, b) in row.blocks[..row.sides as usize].iter().enumerate() {
            if !state.bodies[b.body].is_static() {
                on_body[b.body].push((i, side));
            }
        }
    }
    let mut sum = vec![0.0; state.rows.len()];
    for rows in &on_body {
        for &(i, si) in rows {
            let bi = &state.rows[i].blocks[si];
            sum[i] += rows
                .iter()
                .map(|&(j, sj)| {
                    let (lin, ang) = &state.rows[j].response[sj];
                    (bi.linear.dot(lin) + bi.angular.dot(ang)).abs()
                })
                .sum::<f64>();
        }
    }
    sum.iter()
        .map(|&d| if d > 0.0 { 1.0 / d } else { 0.0 })
        .collect()
}

/// The registry's entry of `jacobi`.
pub static JACOBI: lcpbench_solvers::registry::SolverEntry =
    lcpbench_solvers::registry::SolverEntry {
        name: "jacobi",
        summary:
            "projected Jacobi: every row's impulse from the same velocities, applied together, \
                 scaled by |A|'s row sums (or mass splitting) to converge, Baumgarte bias",
        problem_classes:
            "scenes only; frictionless and box friction (no pyramid, no cone), joints; moves \
                 the bodies (substeps); a fixed number of Jacobi sweeps, order-independent and \
                 parallel, slower per sweep than Gauss-Seidel (its row scaling keeps it \
                 convergent): stacks sink and jitter at few sweeps; warm-startable",
        iteration_unit: "Jacobi sweeps, summed over the substeps",
        iterative: true,
        relaxation: None,
        params: PARAMS,
        make: lcpbench_solvers::registry::Make::Body(&crate::body_solvers::BodyMake {
            make: |params| Box::new(Jacobi::new(*params)),
            takes_joints: true,
            substeps: true,
        }),
    };

impl BodySolver for Jacobi {
    fn kind(&self) -> BodySolverKind {
        BodySolverKind::Jacobi
    }

    fn params(&self) -> Params {
        self.params
    }

    /// The step on the system alone: its free velocities already hold gravity, so gravity is
    /// zero here; the impulse is the step's total.
    fn sweep(&mut self, system: &ContactSystem, settings: &Settings) -> BodySweep {
        let out = self.step(system, Vector3::zeros(), settings);
        BodySweep::from(out)
    }

    fn advance(&mut self, input: &SubstepInput<'_>) -> Option<SubstepOutcome> {
        Some(self.step(input.system, input.gravity, input.settings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A body with `n` rows gets `1/n` of its mass in each: one row on one body of unit
    /// inverse mass along x keeps `m = 1`; the same row on a body that carries two has `1/2`.
    #[test]
    fn split_masses_divide_by_the_rows_on_each_body() {
        use crate::builder::JacobianBlock;
        use crate::substep::state::{SolverBody, SolverRow};
        use nalgebra::{Matrix3, UnitQuaternion};
        let body = SolverBody {
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            inv_mass: 1.0,
            inv_inertia: Matrix3::identity(),
            dp: Vector3::zeros(),
            dtheta: Vector3::zeros(),
            dq: UnitQuaternion::identity(),
        };
        let row = |body: usize| SolverRow {
            role: RowRole::Normal(0),
            blocks: [
                JacobianBlock {
                    body,
                    linear: Vector3::x(),
                    angular: Vector3::zeros(),
                },
                JacobianBlock::default(),
            ],
            response: [
                (Vector3::x(), Vector3::zeros()),
                (Vector3::zeros(), Vector3::zeros()),
            ],
            sides: 1,
            k: 1.0,
            mass: 1.0,
            c0: 0.0,
            mu: 0.0,
            restitution: 0.0,
            approach: 0.0,
        };
        let state = SolverState {
            bodies: vec![body, body],
            rows: vec![row(0), row(1), row(1)],
        };
        assert_eq!(split_masses(&state), vec![1.0, 0.5, 0.5]);
    }
}
