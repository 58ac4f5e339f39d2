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
//!   dense row slice or a sparse row of the stored CSR `W`) for the `q_c'`, plus `O(1)` 3×3
//!   work per contact: each `W_cc` and its LU factors are extracted once per solve, and a sweep
//!   allocates nothing. For a sparse `W` of 3×3 blocks a contact's three rows are copied once
//!   per solve into one column list with the three entries side by side, so the sweep loads
//!   each column index and `r_j` once per contact rather than once per row (Siconos' `NSGS`
//!   takes a contact's three rows block by block as well, `NM_row_prod_no_diag3`). On top of
//!   it, the running terms of the stopping rule below (the magnitudes `Σ_j |W_ij r_j|` of the
//!   row products and a cone-residual term per contact) only as far as they decide anything,
//!   and the stopping tests.
//! * **Stopping rule**: the cone residual ([`crate::cone`]) is at most the tolerance. As each
//!   contact is visited, its term of the cone residual (`e_c / s_c`, the same formula) is taken at
//!   the running iterate from the row products the sweep computes anyway, until the first term
//!   above [`MEASURE_WITHIN`] times the tolerance (the rest of that sweep takes plain row
//!   products: its answer is settled). The residual is tested after a sweep in which every
//!   contact's running term was within that bound, after the first sweep, on the starting
//!   reaction, and every [`NsgsConeSettings::full_residual_every`] sweeps. The solve stops only
//!   on that test, and the [`ConeMonitor`] decides the status from the full residual. The test
//!   (whether every contact's term is within the tolerance) starts at the contact that failed
//!   it last and stops at the first that fails, so while the residual is above tolerance it
//!   costs about one contact's rows instead of the full pass over `W` (an extra pass per
//!   measurement, which near convergence, where the running terms are within the bound, came
//!   after a third of the sweeps); every `full_residual_every` sweeps the full residual is
//!   computed, for the stagnation rule. The tests decide the same stopping sweep as a full
//!   residual after every sweep whose running terms are within the bound. (Siconos' `NSGS`,
//!   `fc3d_nsgs.c`, by its error-evaluation option either takes the change of `r` over a sweep,
//!   its "light" error, with the full error at the end, or the full error at an adaptive
//!   interval of sweeps.)
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
use crate::cone::residual::{contact_relative_error, within_tolerance};
use crate::cone::{
    cone_residuals_and_velocity, initial_reaction, project_onto_cone, ConeMonitor, ConeProblem,
    ConeSolver,
};
use crate::problem::Row;
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

    /// One sweep over `order`, updating `r` in place. With `within = Some(bound)`, also
    /// whether every contact's running term of the cone residual (its `e_c / s_c` at the
    /// iterate as the contact is visited) was at most `bound`: the terms are taken, with the
    /// magnitudes of the row products they need, only until the first one above it, which
    /// settles the answer (`false`); with `None` none is taken. Returns that answer (`false`
    /// for `None`) and whether any reaction changed.
    fn sweep(
        &self,
        problem: &ConeProblem,
        contacts: &Contacts,
        order: &[usize],
        within: Option<f64>,
        r: &mut [f64],
    ) -> (bool, bool) {
        let (w, q, mu) = (problem.delassus(), problem.q(), problem.mu());
        let (blocks, rows, scales) = (&contacts.blocks, &contacts.rows, &contacts.scales);
        let omega = self.settings.omega;
        let bound = within.unwrap_or(f64::NAN);
        let (mut all_within, mut changed) = (within.is_some(), false);
        for &c in order {
            let rc = [r[3 * c], r[3 * c + 1], r[3 * c + 2]];
            let mut uc = [0.0; 3];
            if all_within {
                let mut t = [0.0; 3];
                let products = rows.product::<true>(c, r);
                for a in 0..3 {
                    let i = 3 * c + a;
                    let (wr, m) = products
                        .map_or_else(|| w.row(i).dot_and_magnitude(r), |(s, m)| (s[a], m[a]));
                    uc[a] = wr + q[i];
                    t[a] = m + q[i].abs();
                }
                // A NaN term is not within.
                all_within = contact_relative_error(mu[c], scales[c], rc, uc, t) <= bound;
            } else if let Some((s, _)) = rows.product::<false>(c, r) {
                for (a, ua) in uc.iter_mut().enumerate() {
                    *ua = s[a] + q[3 * c + a];
                }
            } else {
                for (a, ua) in uc.iter_mut().enumerate() {
                    let i = 3 * c + a;
                    *ua = w.row(i).dot(r) + q[i];
                }
            }
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
        (all_within, changed)
    }
}

/// What a sweep reads of each contact, built once per solve: its diagonal block `W_cc` with
/// its factors, its rows of `W` ([`ContactRows`]) and its diagonal scale.
struct Contacts {
    blocks: Vec<ContactBlock>,
    rows: ContactRows,
    scales: Vec<f64>,
}

impl Contacts {
    fn new(problem: &ConeProblem) -> Self {
        let contacts = problem.contacts();
        Contacts {
            blocks: (0..contacts)
                .map(|c| ContactBlock::new(problem.block(c)))
                .collect(),
            rows: ContactRows::new(problem),
            scales: (0..contacts).map(|c| problem.scale_of(c)).collect(),
        }
    }
}

/// The three rows of `W` of each contact whose rows share one column pattern (sparse `W`
/// assembled from 3×3 blocks), stored together: per column, its index once and the three
/// entries side by side, so that a contact's three row products load each column index and
/// each `r_j` once instead of three times. Built once per solve (a copy of those rows of `W`);
/// a contact whose rows differ in pattern, and every contact of a dense `W`, keeps the row
/// products of [`Row`](crate::problem::Row).
struct ContactRows {
    /// Per contact, its range in `cols`/`values`, `None` for a contact left to the rows of `W`.
    ranges: Vec<Option<(usize, usize)>>,
    cols: Vec<usize>,
    values: Vec<[f64; 3]>,
}

impl ContactRows {
    fn new(problem: &ConeProblem) -> Self {
        let w = problem.delassus();
        let mut out = ContactRows {
            ranges: Vec::with_capacity(problem.contacts()),
            cols: Vec::new(),
            values: Vec::new(),
        };
        for c in 0..problem.contacts() {
            let rows = [0, 1, 2].map(|a| w.row(3 * c + a));
            let shared = match rows {
                [Row::Sparse {
                    cols: c0,
                    values: v0,
                }, Row::Sparse {
                    cols: c1,
                    values: v1,
                }, Row::Sparse {
                    cols: c2,
                    values: v2,
                }] if c0 == c1 && c0 == c2 => Some((c0, [v0, v1, v2])),
                _ => None,
            };
            out.ranges.push(shared.map(|(cols, values)| {
                let start = out.cols.len();
                out.cols.extend_from_slice(cols);
                out.values
                    .extend((0..cols.len()).map(|k| [values[0][k], values[1][k], values[2][k]]));
                (start, out.cols.len())
            }));
        }
        out
    }

    /// `(W r)_c` and, with `MAGNITUDE`, the magnitudes `Σ_j |W_ij r_j|` of its three rows,
    /// each summed in column order from `+0.0` as [`Row::dot`](crate::problem::Row::dot) and
    /// [`Row::dot_and_magnitude`](crate::problem::Row::dot_and_magnitude) sum a sparse row (the
    /// same values bit for bit); `None` for a contact left to the rows of `W`.
    #[inline]
    fn product<const MAGNITUDE: bool>(&self, c: usize, r: &[f64]) -> Option<([f64; 3], [f64; 3])> {
        let (start, end) = self.ranges[c]?;
        let (mut s, mut m) = ([0.0f64; 3], [0.0f64; 3]);
        for (&j, v) in self.cols[start..end].iter().zip(&self.values[start..end]) {
            let x = r[j];
            for ((sa, ma), va) in s.iter_mut().zip(m.iter_mut()).zip(v) {
                let t = va * x;
                *sa += t;
                if MAGNITUDE {
                    *ma += t.abs();
                }
            }
        }
        Some((s, m))
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
        let contacts = Contacts::new(problem);
        let mut order: Vec<usize> = (0..problem.contacts()).collect();
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
        // Where the stopping test starts: the contact that failed it last time.
        let mut first = 0;
        let outcome = loop {
            if measure {
                if iterations > 0 && iterations % every == 0 {
                    let residual = cone_residuals_and_velocity(problem, &r, &mut u).natural_map_rel;
                    if residual <= tol {
                        break Outcome::Stopped;
                    }
                    if stagnation.stagnated(iterations, residual) {
                        break Outcome::Stalled(stagnation.reason("cone residual"));
                    }
                } else if within_tolerance(problem, &r, tol, &mut first) {
                    break Outcome::Stopped;
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
            // The sweeps after which the residual is measured whatever the running terms say
            // take none.
            let next = iterations + 1;
            let certain = next == 1 || next % every == 0;
            let within = (!certain).then_some(MEASURE_WITHIN * tol);
            let (all_within, changed) = self.sweep(problem, &contacts, &order, within, &mut r);
            iterations = next;
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
            measure = certain || all_within;
        };
        monitor.finish(r, iterations, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cone::residual::cone_residuals;
    use faer::Mat;
    use rand::Rng;

    /// Random coupled contacts `W = J Jᵀ + 10⁻³ I` (a block band), stored dense or sparse.
    fn banded(contacts: usize, seed: u64, sparse: bool) -> ConeProblem {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = 3 * contacts;
        let dofs = 3 * contacts + 6;
        let mut j = Mat::<f64>::zeros(n, dofs);
        for i in 0..n {
            let c = i / 3;
            for k in 3 * c..(3 * c + 9).min(dofs) {
                j[(i, k)] = rng.random_range(-1.0..1.0);
            }
        }
        let mut w = &j * j.transpose();
        for i in 0..n {
            w[(i, i)] += 1e-3;
        }
        let q = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    rng.random_range(-1.0..0.2)
                } else {
                    rng.random_range(-0.5..0.5)
                }
            })
            .collect();
        let mu = (0..contacts).map(|_| rng.random_range(0.2..0.9)).collect();
        if !sparse {
            return ConeProblem::new(w, q, mu).unwrap();
        }
        let mut triplets = Vec::new();
        for r in 0..n {
            for c in 0..n {
                if w[(r, c)] != 0.0 {
                    triplets.push((r, c, w[(r, c)]));
                }
            }
        }
        ConeProblem::new_sparse(
            crate::problem::sparse_from_triplets(n, &triplets).unwrap(),
            q,
            mu,
        )
        .unwrap()
    }

    /// The stopping test agrees with the full residual at every iterate of a solve, from
    /// every starting contact, and leaves a failing contact for the next test.
    #[test]
    fn the_stopping_test_agrees_with_the_full_residual() {
        for sparse in [false, true] {
            let p = banded(12, 3, sparse);
            let solver = NsgsCone::default();
            let data = Contacts::new(&p);
            let order: Vec<usize> = (0..12).collect();
            let mut r = vec![0.0; p.n()];
            for _ in 0..40 {
                let full = cone_residuals(&p, &r).natural_map_rel;
                for tol in [full * 0.999, full, full * 1.001, 1e-3, 1e-6] {
                    for start in [0, 5, 11, 40] {
                        let mut first = start;
                        let within = within_tolerance(&p, &r, tol, &mut first);
                        assert_eq!(within, full <= tol, "tol {tol:e}, full {full:e}");
                        if !within {
                            let mut again = first;
                            assert!(!within_tolerance(&p, &r, tol, &mut again));
                            assert_eq!(again, first, "the failing contact fails first");
                        }
                    }
                }
                solver.sweep(&p, &data, &order, None, &mut r);
            }
            let mut bad = r.clone();
            bad[4] = f64::NAN;
            assert!(!within_tolerance(&p, &bad, 1e300, &mut 0));
        }
    }

    /// Taking the running terms or not leaves the sweep's iterates the same bit for bit, and
    /// the answer about the terms is the one the full set of terms gives.
    #[test]
    fn running_terms_do_not_change_the_iterates() {
        for sparse in [false, true] {
            let p = banded(15, 7, sparse);
            let solver = NsgsCone::default();
            let data = Contacts::new(&p);
            let order: Vec<usize> = (0..15).rev().collect();
            let mut plain = vec![0.0; p.n()];
            let mut terms = plain.clone();
            for sweep in 0..60 {
                // Every contact's running term, taken as the sweep goes, from a copy.
                let mut probe = terms.clone();
                let mut worst = 0.0f64;
                for &c in &order {
                    let mut one = probe.clone();
                    let (w, q, mu) = (p.delassus(), p.q(), p.mu());
                    let rc = [one[3 * c], one[3 * c + 1], one[3 * c + 2]];
                    let (mut uc, mut t) = ([0.0; 3], [0.0; 3]);
                    for a in 0..3 {
                        let (wr, m) = w.row(3 * c + a).dot_and_magnitude(&one);
                        uc[a] = wr + q[3 * c + a];
                        t[a] = m + q[3 * c + a].abs();
                    }
                    worst = worst.max(contact_relative_error(mu[c], data.scales[c], rc, uc, t));
                    solver.sweep(&p, &data, &[c], None, &mut one);
                    probe = one;
                }
                let bound = worst * if sweep % 2 == 0 { 1.0 } else { 0.5 };
                let (within, _) = solver.sweep(&p, &data, &order, Some(bound), &mut terms);
                solver.sweep(&p, &data, &order, None, &mut plain);
                assert_eq!(within, sweep % 2 == 0, "sweep {sweep}");
                assert_eq!(
                    plain.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    terms.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "sweep {sweep}"
                );
                assert_eq!(probe, terms);
            }
        }
    }

    /// The solve stops at the sweep the rule gives with the full residual as the stopping
    /// test and every sweep's running terms taken: the first sweep after which the full
    /// residual is within tolerance among the first, every 50th and those whose running terms
    /// were all within `MEASURE_WITHIN` times it.
    #[test]
    fn the_solve_stops_where_the_full_residual_says() {
        for (contacts, seed, tol) in [(20, 11, 1e-8), (30, 5, 1e-10), (8, 2, 1e-6)] {
            let p = banded(contacts, seed, seed % 2 == 1);
            let settings = Settings {
                tolerance: tol,
                max_iterations: 20_000,
                ..Settings::default()
            };
            let result = NsgsCone::default().solve_cone(&p, &settings);
            assert!(result.status.is_converged(), "{:?}", result.status);
            let solver = NsgsCone::default();
            let data = Contacts::new(&p);
            let order: Vec<usize> = (0..contacts).collect();
            let mut r = vec![0.0; p.n()];
            let (mut sweeps, mut measure) = (0, true);
            loop {
                if measure && cone_residuals(&p, &r).natural_map_rel <= tol {
                    break;
                }
                let (within, _) =
                    solver.sweep(&p, &data, &order, Some(MEASURE_WITHIN * tol), &mut r);
                sweeps += 1;
                measure = sweeps == 1 || within || sweeps % STAGNATION_MEASURE_EVERY == 0;
            }
            assert_eq!(sweeps, result.iterations, "{contacts} contacts");
            assert_eq!(r, result.f);
        }
    }

    /// The contact rows stored together give the sweep of the rows of `W` bit for bit, with and
    /// without the running terms; a sparse `W` of 3×3 blocks is stored that way, a dense one
    /// is not.
    #[test]
    fn contact_rows_give_the_row_products_bit_for_bit() {
        let p = banded(16, 9, true);
        let data = Contacts::new(&p);
        assert!(data.rows.ranges.iter().all(Option::is_some));
        assert!(ContactRows::new(&banded(4, 9, false))
            .ranges
            .iter()
            .all(Option::is_none));
        let by_rows = Contacts {
            rows: ContactRows {
                ranges: vec![None; 16],
                cols: Vec::new(),
                values: Vec::new(),
            },
            ..Contacts::new(&p)
        };
        let solver = NsgsCone::default();
        let order: Vec<usize> = (0..16).collect();
        let (mut a, mut b) = (vec![0.0; p.n()], vec![0.0; p.n()]);
        for sweep in 0..50 {
            let within = (sweep % 3 != 0).then_some(if sweep % 3 == 1 { 1e300 } else { 1e-3 });
            let x = solver.sweep(&p, &data, &order, within, &mut a);
            let y = solver.sweep(&p, &by_rows, &order, within, &mut b);
            assert_eq!(x, y, "sweep {sweep}");
            assert_eq!(
                a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                b.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "sweep {sweep}"
            );
        }
    }
}
