//! Nonsmooth Gauss–Seidel over contacts (NSGS) on the exact Coulomb cone.
//!
//! A sweep visits the contacts in turn and solves each contact's problem exactly with the other
//! reactions fixed:
//!
//! ```text
//! u_c = W_cc r_c + q_c',   q_c' = q_c + Σ_{d ≠ c} W_cd r_d,   K_c ∋ r_c* ⟂ û_c ∈ K_c*,
//! r_c ← P_{K_c}((1 − ω) r_c + ω r_c*)                  (r_c ← r_c* for the default ω = 1),
//! ```
//!
//! taking off (`q_c'_N >= 0`) and sticking (`W_cc r_c = −q_c'` inside the cone) in closed form
//! and sliding by a local Alart–Curnier Newton with Armijo backtracking from the current
//! reaction (from the stick solution projected onto the cone when that is zero), with projected
//! fixed-point steps where the Newton step fails ([`ContactBlock::solve`]). The local solves are
//! exact: on `spheres-in-a-box-98-i10000-256-10` (FCLIB, 256 contacts, 170 sliding) every
//! contact's natural map after its local solve stayed within `5e-16` of its scale over 4,000
//! sweeps. Where NSGS needs thousands of sweeps (`Capsules-i125-1213`: 2,302 sweeps to `1e-6`,
//! Siconos' `NSGS` 2,303; `spheres-in-a-box`: plateaus near `8e-5` and `2e-5`, which Siconos'
//! `NSGS` does not leave in 10,000 sweeps either, ending at `9.5e-6` by its own measure), it is
//! the Gauss–Seidel iteration's own slow convergence, not the local solver.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]) with `W_cc` positive definite per contact.
//!   A fixed point without a general convergence proof (Coulomb friction is not a convex
//!   problem); it is the default solver of Siconos' FC3D and converges on the contact problems
//!   of rigid-body scenes in Acary, Brémond, Huber's comparison.
//! * **Cost**: per sweep one pass over the stored entries of `W` (three rows per contact, a
//!   dense row slice or a sparse row of the stored CSR `W`) for the `q_c'` and the magnitudes of
//!   their terms, plus `O(1)` 3×3 work per contact: each `W_cc` and its LU factors are extracted
//!   once per solve, and a sweep allocates nothing. The same cost per sweep as the matrix NSGS
//!   ([`crate::Nsgs`]).
//! * **Stopping rule**: the cone residual ([`crate::cone`]) is at most the tolerance. As each
//!   contact is visited, its term of the cone residual (`e_c / s_c`, the same formula) is taken at
//!   the running iterate from the row products the sweep computes anyway; the full residual (an
//!   extra pass over `W`) is computed only after a sweep in which every contact's running term
//!   was within [`MEASURE_WITHIN`] times the tolerance, after the first sweep, on the starting
//!   reaction, and every [`NsgsConeSettings::full_residual_every`] sweeps. The solve stops only
//!   on the full residual, and the [`ConeMonitor`] decides the status from it.
//! * **Never spins**: when the full residual has not reached a new low (1 % below the best) in
//!   [`FIRST_ORDER_STAGNATION_WINDOW`] sweeps, the solve stops `Stalled` ([`crate::solver`]'s
//!   stagnation rule, as [`crate::Nsgs`]); a sweep that leaves every reaction unchanged stops it
//!   `Stalled` too.
//! * **Options** ([`NsgsConeSettings`]): over-relaxation `ω` and a contact order shuffled afresh
//!   each sweep from a fixed seed, as Siconos' `NSGS` has them.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones.
//!
//! References: M. Jean, *The non-smooth contact dynamics method*, CMAME 177, 1999; V. Acary,
//! M. Brémond, O. Huber, 2018 (NSGS with the local Alart–Curnier Newton, Siconos' `NSGS` +
//! `ONECONTACT_NSN`, `fc3d_nsgs.c`: relaxation and shuffled contact order).

use crate::cone::alart_curnier::ContactBlock;
use crate::cone::residual::contact_relative_error;
use crate::cone::{
    cone_residuals_and_velocity, initial_reaction, project_onto_cone, ConeMonitor, ConeProblem,
    ConeSolver,
};
use crate::solver::{
    Outcome, Settings, SolveResult, Stagnation, FIRST_ORDER_STAGNATION_WINDOW,
    STAGNATION_MEASURE_EVERY,
};
use rand::seq::SliceRandom;
use rand::SeedableRng;

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone (exact Coulomb); each contact solved exactly per sweep (closed-form take-off/stick, local Alart–Curnier Newton for sliding)";

/// The registry's entry of `nsgs-cone`.
pub static NSGS_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "nsgs-cone",
    summary: "block Gauss-Seidel over contacts, each contact solved exactly on its cone",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "sweeps over the contacts",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(NsgsCone::default())),
};

/// The full cone residual is computed after a sweep whose contacts' running terms were all
/// within this many times the tolerance (the rule and factor of [`crate::Nsgs`]: the running
/// terms are taken mid-sweep and run a few times above the residual at the sweep's end).
pub const MEASURE_WITHIN: f64 = 10.0;

/// Options of [`NsgsCone`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NsgsConeSettings {
    /// Over-relaxation `ω` in `(0, 2)`: each contact's reaction becomes
    /// `P_K((1 − ω) r_c + ω r_c*)`, `r_c*` its exact local solution. Outside `(0, 2)` the solve
    /// is refused (`unsupported`). Default `1` (plain Gauss–Seidel).
    pub omega: f64,
    /// `Some(seed)`: visit the contacts in an order shuffled afresh before each sweep by a
    /// generator seeded once per solve with `seed` (repeatable). Default `None` (contact order).
    pub shuffle_seed: Option<u64>,
    /// The full cone residual is computed at least every this many sweeps (for the stagnation
    /// rule, and so that a stopping point the running terms overestimate is found); `0` counts
    /// as `1`. Default [`STAGNATION_MEASURE_EVERY`] (50).
    pub full_residual_every: usize,
}

impl Default for NsgsConeSettings {
    fn default() -> Self {
        Self {
            omega: 1.0,
            shuffle_seed: None,
            full_residual_every: STAGNATION_MEASURE_EVERY,
        }
    }
}

/// NSGS on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NsgsCone {
    /// Options. Default [`NsgsConeSettings::default`].
    pub settings: NsgsConeSettings,
}

impl NsgsCone {
    /// NSGS on the cone with these options.
    pub fn new(settings: NsgsConeSettings) -> Self {
        Self { settings }
    }

    /// One sweep over `order`, updating `r` in place. Returns the largest running term of the
    /// cone residual (each contact's `e_c / s_c` at the iterate as the contact is visited) and
    /// whether any reaction changed.
    fn sweep(
        &self,
        problem: &ConeProblem,
        blocks: &[ContactBlock],
        scales: &[f64],
        order: &[usize],
        r: &mut [f64],
    ) -> (f64, bool) {
        let (w, q, mu) = (problem.delassus(), problem.q(), problem.mu());
        let omega = self.settings.omega;
        let (mut worst, mut changed) = (0.0f64, false);
        for &c in order {
            let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
            let (mut uc, mut t) = ([0.0; 3], [0.0; 3]);
            for a in 0..3 {
                let i = 3 * c + a;
                let (wr, m) = w.row(i).dot_and_magnitude(r);
                uc[a] = wr + q[i];
                t[a] = m + q[i].abs();
            }
            let term = contact_relative_error(mu[c], scales[c], rc, uc, t);
            worst = worst.max(if term.is_nan() { f64::INFINITY } else { term });
            let wcc = blocks[c].w();
            let mut qc = uc;
            for (a, qa) in qc.iter_mut().enumerate() {
                *qa -= wcc[a][0] * rc[0] + wcc[a][1] * rc[1] + wcc[a][2] * rc[2];
            }
            let mut next = blocks[c].solve(mu[c], qc, rc);
            if omega != 1.0 {
                next =
                    project_onto_cone(mu[c], [0, 1, 2].map(|a| rc[a] + omega * (next[a] - rc[a])));
            }
            if next != rc {
                changed = true;
                r[3 * c..3 * c + 3].copy_from_slice(&next);
            }
        }
        (worst, changed)
    }
}

impl ConeSolver for NsgsCone {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &NSGS_CONE
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let omega = self.settings.omega;
        if !(omega > 0.0 && omega < 2.0) {
            let reason = format!("over-relaxation omega = {omega} is outside (0, 2)");
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        let contacts = problem.contacts();
        let blocks: Vec<ContactBlock> = (0..contacts)
            .map(|c| ContactBlock::new(problem.block(c)))
            .collect();
        let scales: Vec<f64> = (0..contacts).map(|c| problem.scale_of(c)).collect();
        let mut order: Vec<usize> = (0..contacts).collect();
        let mut rng = self
            .settings
            .shuffle_seed
            .map(rand_chacha::ChaCha8Rng::seed_from_u64);
        let every = self.settings.full_residual_every.max(1);
        let tol = settings.tolerance;
        let mut r = initial_reaction(problem, settings);
        let mut u = vec![0.0; problem.n()];
        let mut stagnation = Stagnation::new(FIRST_ORDER_STAGNATION_WINDOW);
        let mut iterations = 0;
        // The full residual is measured on the starting reaction, after the first sweep, after
        // each sweep whose running terms were all within `MEASURE_WITHIN` times the tolerance,
        // and every `every` sweeps (where it also feeds the stagnation rule).
        let mut measure = true;
        let outcome = loop {
            if measure {
                let residual = cone_residuals_and_velocity(problem, &r, &mut u).natural_map_rel;
                if residual <= tol {
                    break Outcome::Stopped;
                }
                if iterations > 0
                    && iterations % every == 0
                    && stagnation.stagnated(iterations, residual)
                {
                    break Outcome::Stalled(stagnation.reason("cone residual"));
                }
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            if let Some(rng) = rng.as_mut() {
                order.shuffle(rng);
            }
            let (worst, changed) = self.sweep(problem, &blocks, &scales, &order, &mut r);
            iterations += 1;
            monitor.record(iterations, &r);
            if r.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite reaction in sweep {iterations}"
                ));
            }
            if !changed {
                break Outcome::Stalled(format!(
                    "sweep {iterations} left every reaction unchanged (a fixed point of the \
                     contact sweep that is not a solution)"
                ));
            }
            measure = iterations == 1 || worst <= MEASURE_WITHIN * tol || iterations % every == 0;
        };
        monitor.finish(r, iterations, outcome)
    }
}
