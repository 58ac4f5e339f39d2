//! The convex relaxation of the Coulomb cone problem as a second-order cone program, solved by
//! Clarabel's interior-point method.
//!
//! For symmetric positive semidefinite `W` the program
//!
//! ```text
//! minimise ½ rᵀ W r + qᵀ r   subject to   r_c ∈ K_c = { ‖r_{c,T}‖ <= mu_c r_{c,N} }  (each contact)
//! ```
//!
//! is convex, and its optimality conditions are the conic complementarity
//! `K_c ∋ r_c ⟂ u_c ∈ K_c*` with `u = W r + q`: the FC3D problem of [`crate::cone`] with De
//! Saxcé's `û_c = u_c + mu_c ‖u_{c,T}‖ e_N` replaced by `u_c` itself (Anitescu's relaxation). The
//! two agree where a contact sticks (`u_c = 0`) or takes off with a velocity inside the dual cone
//! (`r_c = 0`, `mu_c ‖u_{c,T}‖ <= u_{c,N}`). A *sliding* contact of the relaxation has
//! `u_{c,N} = mu_c ‖u_{c,T}‖ > 0` while `r_{c,N} > 0`: it pushes and separates at once, a spurious
//! normal velocity ("lift-off") that Coulomb's law (`u_N = 0` while sliding) does not have.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]) with positive semidefinite `W` symmetric
//!   up to assembly noise: a `W` with `max |W_ij − W_ji| / max |W_ij|` within
//!   [`SYMMETRISE_WITHIN`] (`1e-2`; FCLIB's capsule piles measure `1.3e-3`) is solved through its
//!   symmetric part `(W + Wᵀ)/2`, and the cone residual that decides the status is that of the
//!   original `W`. A `W` further from symmetric is refused as `Unsupported` with its measured
//!   asymmetry in the reason, and so is an indefinite one (the same sparse Cholesky test as
//!   [`crate::ClarabelQp`], on the symmetric part), before Clarabel runs. The answer is the relaxation's: the status is decided, as for
//!   every cone solver, by the exact cone residual, so a problem whose solution slides comes back
//!   `Stalled`, not `Converged`, with the lift-off in the reason: the contacts whose exact
//!   residual is above the tolerance while their residual in the relaxation itself (the natural
//!   map of `r ⟂ u` without De Saxcé's term, on the same scale) is within it, their number and
//!   the largest normal velocity created. Contacts that miss the tolerance in the relaxation too
//!   (the interior point's accuracy, seen on degenerate problems with redundant contacts) are
//!   counted apart. Problems where every contact sticks or takes off as above are solved exactly.
//! * **Clarabel's form**: Clarabel solves `min ½ xᵀ P x + qᵀ x` s.t. `A x + s = b`, `s ∈ K`. Each
//!   contact with `mu_c > 0` is one `SecondOrderConeT(3)` with `s_c = (mu_c r_N, r_T1, r_T2)`,
//!   i.e. `b = 0` and `A = −diag(mu_c, 1, 1)` on its columns; a frictionless contact is one
//!   nonnegative row `r_N >= 0` and two zero-cone rows `r_T = 0`. `P` is the upper triangle of
//!   the scaled `W` in CSC, built from the stored entries (a sparse `W` stays sparse).
//! * **Scaling**: `r_c = τ e_c h_c` with `e_c = 1/√d_c` (`d_c` the diagonal scale of the
//!   contact's normal row; one factor per contact keeps each cone a cone) and
//!   `τ = max_i e_i |q_i|`, the objective divided by `τ²`: the program in `h` has a unit normal
//!   diagonal and a linear term of size one, the same for `(W, q)` and `(σW, σq)`. `q = 0` has
//!   the exact answer `r = 0` and is returned without a solve.
//! * **Tolerances**: Clarabel's gap and feasibility tolerances are
//!   `tolerance_factor · Settings::tolerance` (default factor `1e-2`), floored at
//!   `min_ipm_tolerance` (default `1e-13`). The returned `r` is projected onto the cones (an
//!   interior-point iterate can sit a rounding error outside).
//! * **Cost**: one sparse `LDLᵀ` factorisation of the KKT matrix per interior-point iteration,
//!   whose fill follows that of `W`. `Settings::max_iterations` counts interior-point iterations
//!   and is capped at `max_ipm_iterations` (default 200). `Settings::warm_start` is ignored and the
//!   history holds one point, the final iterate.
//! * **Failure modes**: the relaxation is always feasible (`r = 0`); a certificate of
//!   unboundedness (a direction `d` in the cones with `W d = 0` and `qᵀ d < 0`) concerns the
//!   relaxation, is no proof that the Coulomb problem has no solution, and is reported as
//!   `Stalled` at `r = 0` with the reason. Clarabel's iteration and time limits map to
//!   `IterationLimit` and `TimeLimit`, its numerical errors, insufficient progress and a panic
//!   to `NumericalFailure`.
//!
//! References: M. Anitescu, *Optimization-based simulation of nonsmooth rigid multibody
//! dynamics*, Math. Program. 105, 2006 (the cone-complementarity relaxation and its spurious
//! normal velocity); V. Acary, M. Brémond, O. Huber, *On solving contact problems with Coulomb
//! friction: formulations and numerical comparisons*, Advanced Topics in Nonsmooth Dynamics,
//! Springer 2018 (the relaxation as the convex SOCP next to the exact FC3D solvers); P. J. Goulart,
//! Y. Chen, *Clarabel: An interior-point solver for conic programs with quadratic objectives*,
//! arXiv:2405.12762, 2024.

use crate::cone::{
    cone_residuals, contact_natural_map, contact_relative_residuals, project_onto_cone,
    ConeMonitor, ConeProblem, ConeSolver,
};
use crate::lcp::clarabel_qp::{
    is_psd, run_clarabel, scaled_symmetric_part, upper_triangle, InteriorPoint, IpmLimits, IpmRun,
};
use crate::linalg::cholesky_fill;
use crate::solver::{Outcome, Settings, SolveResult};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{SolverStatus, SupportedConeT};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone with PSD W (symmetric to 1e-2 relative; its symmetric part is solved) as Anitescu's convex relaxation (SOCP, interior point, sparse P); exact where contacts stick or take off, sliding contacts lift off";

/// The registry's entry of `clarabel-socp`.
pub static CLARABEL_SOCP: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "clarabel-socp",
    summary: "Anitescu's convex relaxation as a second-order cone program, through Clarabel",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "interior-point iterations",
    iterative: false,
    relaxation: Some(
        "Anitescu's convex relaxation of the Coulomb cone (sliding contacts lift off)",
    ),
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(ClarabelSocp::default())),
};

/// The convex relaxation of the Coulomb cone problem, solved by Clarabel. See the module
/// documentation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClarabelSocp {
    /// The acceptance tests on `W` and the limits of the interior-point run.
    /// Default [`InteriorPoint::default`].
    pub ipm: InteriorPoint,
}

/// Clarabel's constraints `A h + s = 0`, `s ∈ cones`: zero rows (frictionless tangents) first,
/// then nonnegative rows (frictionless normals), then one second-order cone per contact.
fn cone_constraints(mu: &[f64]) -> (CscMatrix<f64>, Vec<f64>, Vec<SupportedConeT<f64>>) {
    let (mut ii, mut jj, mut vv) = (Vec::new(), Vec::new(), Vec::new());
    let mut row = 0;
    let mut push = |cols: &[(usize, f64)]| {
        for &(j, v) in cols {
            ii.push(row);
            jj.push(j);
            vv.push(v);
        }
        row += 1;
    };
    let frictionless: Vec<usize> = (0..mu.len()).filter(|&c| mu[c] == 0.0).collect();
    for &c in &frictionless {
        push(&[(3 * c + 1, 1.0)]);
        push(&[(3 * c + 2, 1.0)]);
    }
    for &c in &frictionless {
        push(&[(3 * c, -1.0)]);
    }
    let mut cones = Vec::new();
    if !frictionless.is_empty() {
        cones.push(SupportedConeT::ZeroConeT(2 * frictionless.len()));
        cones.push(SupportedConeT::NonnegativeConeT(frictionless.len()));
    }
    for (c, &m) in mu.iter().enumerate().filter(|(_, &m)| m > 0.0) {
        push(&[(3 * c, -m)]);
        push(&[(3 * c + 1, -1.0)]);
        push(&[(3 * c + 2, -1.0)]);
        cones.push(SupportedConeT::SecondOrderConeT(3));
    }
    let n = 3 * mu.len();
    let a = CscMatrix::new_from_triplets(row, n, ii, jj, vv);
    (a, vec![0.0; row], cones)
}

/// Why the relaxation's answer `r` misses Coulomb's law, contact by contact: `None` when no
/// contact's exact cone residual is above `tol`, else the reason of a `Stalled` result.
///
/// A contact whose exact residual is above `tol` while its residual in the relaxation itself
/// (the natural map of `K ∋ r ⟂ u ∈ K*`, no De Saxcé term, on the same scale) is within `tol`
/// is *lifted off*: the relaxation solved it, and it pushes and separates at `u_N = mu ‖u_T‖`.
/// Any other failing contact is one where the interior point met the relaxation only roughly.
fn diagnose(problem: &ConeProblem, r: &[f64], tol: f64) -> Option<String> {
    let u = problem.velocity(r);
    let exact = contact_relative_residuals(problem, r);
    let mut lifted: Vec<usize> = Vec::new();
    let (mut rough, mut roughest) = (0, 0.0_f64);
    for (c, &mu) in problem
        .mu()
        .iter()
        .enumerate()
        .filter(|(c, _)| exact[*c] > tol)
    {
        let (rc, uc) = (&r[3 * c..3 * c + 3], &u[3 * c..3 * c + 3]);
        let rho = 1.0 / problem.scale_of(c);
        let x = [0, 1, 2].map(|a| rc[a] - rho * uc[a]);
        let p = project_onto_cone(mu, x);
        let relaxed = (0..3).map(|a| (rc[a] - p[a]).powi(2)).sum::<f64>().sqrt();
        let e = contact_natural_map(mu, rho, [rc[0], rc[1], rc[2]], [uc[0], uc[1], uc[2]]);
        // Both residuals share the contact's scale s_c: relaxed_rel = exact_rel · relaxed / e.
        let relaxed_rel = exact[c] * relaxed / e;
        if relaxed_rel <= tol {
            lifted.push(c);
        } else {
            rough += 1;
            roughest = roughest.max(relaxed_rel);
        }
    }
    if lifted.is_empty() && rough == 0 {
        return None;
    }
    let total = cone_residuals(problem, r).natural_map_rel;
    let mut parts = Vec::new();
    if let Some(&c) = lifted
        .iter()
        .max_by(|&&a, &&b| u[3 * a].total_cmp(&u[3 * b]))
    {
        let slip = u[3 * c + 1].hypot(u[3 * c + 2]);
        parts.push(format!(
            "solved Anitescu's convex relaxation (an SOCP in which sliding contacts separate at \
             u_N = mu ‖u_T‖), not the Coulomb problem: the relaxation lifts off {} of {} contacts, \
             largest normal velocity {:.3e} at contact {c} (sliding speed {slip:.3e}, mu ‖u_T‖ = \
             {:.3e}) where Coulomb's law has u_N = 0",
            lifted.len(),
            problem.contacts(),
            u[3 * c],
            problem.mu()[c] * slip,
        ));
    }
    if rough > 0 {
        parts.push(format!(
            "{rough} of {} contacts miss the tolerance in the relaxation itself (the interior \
             point's accuracy; relaxed residual up to {roughest:.3e})",
            problem.contacts()
        ));
    }
    Some(format!(
        "{}; relative residual on the exact Coulomb problem {total:.3e} > tolerance {tol:.1e}",
        parts.join("; ")
    ))
}

/// Largest relative asymmetry `max_ij |W_ij − W_ji| / max_ij |W_ij|` of a `W` that
/// [`ClarabelSocp`] accepts and solves through its symmetric part `(W + Wᵀ)/2`.
///
/// Real Delassus matrices are symmetric only up to their assembly: of the FCLIB files in
/// `bench_scenes/fclib`, `Capsules-i125-1213` measures `1.3e-3` (the capsule piles of FCLIB's
/// `Capsules` series are all near `1e-3`), while `Box_Stacks`, `LMGC_100_PR_PerioBox`, `Spheres`
/// and `spheres-in-a-box` measure `0` to `2e-16` (round-off), and `W = J M⁻¹ Jᵀ` exported from
/// lcpbench's scenes is exactly symmetric (`sphere_pile_1000`, step 0: `0`). `1e-2` covers that
/// assembly noise with a margin of seven and still refuses a `W` whose skew part is a sizeable
/// share of it (a non-associated or wrongly assembled operator). Accepting costs
/// nothing in honesty: the status is decided by the cone residual on the original `W`, so a
/// symmetrised solve that does not solve the real problem does not read `converged`.
pub const SYMMETRISE_WITHIN: f64 = 1e-2;

/// `max_ij |W_ij − W_ji| / max_ij |W_ij|` of the `W` of `problem` (every stored entry against its
/// mirror, a missing mirror reading 0; `0` for `W = 0`).
pub fn delassus_asymmetry(problem: &ConeProblem) -> f64 {
    let w = problem.delassus();
    let mut skew = 0.0f64;
    for i in 0..w.n() {
        for (j, v) in w.row(i).iter() {
            if j != i {
                skew = skew.max((v - w.entry(j, i)).abs());
            }
        }
    }
    let big = w.max_abs_entry();
    if skew == 0.0 {
        0.0
    } else {
        skew / big
    }
}

impl ClarabelSocp {
    /// The reason `W` cannot be handed to Clarabel, if any.
    fn refusal(&self, problem: &ConeProblem, e: &[f64]) -> Option<String> {
        let w = problem.delassus();
        let asymmetry = delassus_asymmetry(problem);
        if asymmetry.is_nan() || asymmetry > SYMMETRISE_WITHIN {
            return Some(format!(
                "W is not symmetric: max |W_ij − W_ji| / max |W_ij| = {asymmetry:.3e}, above the \
                 {SYMMETRISE_WITHIN:.0e} within which its symmetric part is solved; the \
                 relaxation is a convex program only for symmetric PSD W"
            ));
        }
        let scaled = scaled_symmetric_part(w, e);
        let fill = cholesky_fill(scaled.symbolic());
        if fill.is_none_or(|f| f > self.ipm.max_factor_entries) {
            return Some(format!(
                "the Cholesky factor of W would hold {} entries (symbolic analysis, AMD ordering), \
                 above the {} an interior-point iteration is allowed to factorise: a factorisation \
                 cannot be interrupted, so the solve would overrun its time budget",
                fill.map_or("too many".to_owned(), |f| f.to_string()),
                self.ipm.max_factor_entries
            ));
        }
        if !is_psd(&scaled, self.ipm.psd_tolerance) {
            return Some(format!(
                "W is indefinite (Cholesky of the scaled W + {:.0e}·‖W‖_F·I failed); the relaxation is not convex",
                self.ipm.psd_tolerance
            ));
        }
        None
    }

    fn limits(
        &self,
        settings: &Settings,
        elapsed: std::time::Duration,
    ) -> Result<IpmLimits, Outcome> {
        IpmLimits::new(settings, elapsed, &self.ipm)
    }
}

impl ConeSolver for ClarabelSocp {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        &CLARABEL_SOCP
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let n = problem.n();
        let e: Vec<f64> = (0..n)
            .map(|i| 1.0 / problem.scale_of(i / 3).sqrt())
            .collect();
        if let Some(reason) = self.refusal(problem, &e) {
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        let q = problem.q();
        let tau = (0..n).fold(0.0_f64, |m, i| m.max((e[i] * q[i]).abs()));
        if tau == 0.0 {
            // q = 0 (or no contacts): r = 0 is the exact solution.
            return monitor.finish(vec![0.0; n], 0, Outcome::Stopped);
        }
        let limits = match self.limits(settings, monitor.elapsed()) {
            Ok(limits) => limits,
            Err(outcome) => return monitor.finish(vec![0.0; n], 0, outcome),
        };
        let p = upper_triangle(&scaled_symmetric_part(problem.delassus(), &e));
        let q_h: Vec<f64> = (0..n).map(|i| e[i] * q[i] / tau).collect();
        let (a, b, cones) = cone_constraints(problem.mu());
        let IpmRun {
            x: h,
            status,
            iterations,
        } = match run_clarabel(&p, &q_h, &a, &b, &cones, &limits) {
            Ok(run) => run,
            Err(reason) => {
                return monitor.finish(vec![0.0; n], 0, Outcome::NumericalFailure(reason))
            }
        };
        let mut r: Vec<f64> = h.iter().zip(&e).map(|(hi, ei)| tau * ei * hi).collect();
        let outcome = match status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => Outcome::Stopped,
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                r = vec![0.0; n];
                Outcome::Stalled(format!(
                    "Clarabel: {status:?}, the relaxation is unbounded below (a direction in the \
                     cones with W d = 0 and qᵀd < 0); no proof for the Coulomb problem"
                ))
            }
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                r = vec![0.0; n];
                Outcome::NumericalFailure(format!(
                    "Clarabel: {status:?}, although r = 0 is feasible"
                ))
            }
            SolverStatus::MaxIterations => Outcome::IterationLimit,
            SolverStatus::MaxTime => Outcome::TimeLimit,
            SolverStatus::NumericalError
            | SolverStatus::InsufficientProgress
            | SolverStatus::Unsolved
            | SolverStatus::CallbackTerminated => {
                Outcome::NumericalFailure(format!("Clarabel: {status:?}"))
            }
        };
        let outcome = if r.iter().all(|v| v.is_finite()) {
            for (c, &mu) in problem.mu().iter().enumerate() {
                let p = project_onto_cone(mu, [r[3 * c], r[3 * c + 1], r[3 * c + 2]]);
                r[3 * c..3 * c + 3].copy_from_slice(&p);
            }
            match outcome {
                Outcome::Stopped => diagnose(problem, &r, settings.tolerance)
                    .map_or(Outcome::Stopped, Outcome::Stalled),
                other => other,
            }
        } else {
            outcome
        };
        monitor.record(iterations, &r);
        monitor.finish(r, iterations, outcome)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Status;
    use faer::Mat;

    fn solve(p: &ConeProblem) -> SolveResult {
        ClarabelSocp::default().solve_cone(p, &Settings::default())
    }

    /// One contact, `W = I`: the relaxation's answer is the projection `r = P_K(−q)`.
    #[test]
    fn single_contact_is_the_projection_of_minus_q() {
        // Sticks: (2, 0.3, -0.4) is inside the cone of mu = 0.5.
        let p = ConeProblem::new(Mat::identity(3, 3), vec![-2.0, -0.3, 0.4], vec![0.5]).unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        for (x, y) in r.f.iter().zip([2.0, 0.3, -0.4]) {
            assert!((x - y).abs() < 1e-9, "{:?}", r.f);
        }
        // Takes off inside the dual cone: r = 0.
        let p = ConeProblem::new(Mat::identity(3, 3), vec![1.0, 0.3, 0.4], vec![0.5]).unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!(r.f.iter().all(|v| v.abs() < 1e-9), "{:?}", r.f);
        // Frictionless: r_N = max(−q_N, 0), r_T = 0.
        let p = ConeProblem::new(Mat::identity(3, 3), vec![-1.5, 2.0, -3.0], vec![0.0]).unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert!((r.f[0] - 1.5).abs() < 1e-9 && r.f[1] == 0.0 && r.f[2] == 0.0);
    }

    /// An interior point stopped early is told apart from lift-off: the contact misses the
    /// tolerance in the relaxation itself.
    #[test]
    fn a_rough_interior_point_is_not_called_lift_off() {
        let w = Mat::from_fn(6, 6, |i, j| if i == j { 2.0 } else { 0.3 });
        let p = ConeProblem::new(w, vec![-1.0, 0.1, 0.0, -0.5, 0.0, 0.1], vec![0.8, 0.8]).unwrap();
        let mut loose = ClarabelSocp {
            ipm: InteriorPoint {
                tolerance_factor: 1e6,
                ..InteriorPoint::default()
            },
        };
        let tight = Settings {
            tolerance: 1e-12,
            ..Settings::default()
        };
        let r = ClarabelSocp::default().solve_cone(&p, &tight);
        assert_eq!(r.status, Status::Converged, "{}", r.status);
        let r = loose.solve_cone(&p, &tight);
        assert!(
            matches!(&r.status, Status::Stalled { reason }
                if reason.contains("relaxation itself") && !reason.contains("lifts off")),
            "{}",
            r.status
        );
    }

    #[test]
    fn zero_q_and_limits() {
        let p = ConeProblem::new(Mat::identity(3, 3), vec![0.0; 3], vec![0.5]).unwrap();
        let r = solve(&p);
        assert_eq!(r.status, Status::Converged);
        assert_eq!(r.f, vec![0.0; 3]);
        let p = ConeProblem::new(Mat::identity(3, 3), vec![-1.0, 0.9, 0.0], vec![0.5]).unwrap();
        let budget = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        assert_eq!(
            ClarabelSocp::default().solve_cone(&p, &budget).status,
            Status::TimeLimit
        );
        let capped = Settings {
            max_iterations: 1,
            ..Settings::default()
        };
        assert_eq!(
            ClarabelSocp::default().solve_cone(&p, &capped).status,
            Status::IterationLimit
        );
        assert_eq!(
            ClarabelSocp::default().name(),
            crate::ConeSolverKind::ClarabelSocp.name()
        );
    }

    #[test]
    fn indefinite_w_is_unsupported() {
        let w = Mat::from_fn(3, 3, |i, j| {
            [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]][i][j]
        });
        let p = ConeProblem::new(w, vec![-1.0, 0.0, 0.0], vec![0.5]).unwrap();
        let r = solve(&p);
        assert!(
            matches!(&r.status, Status::Unsupported { reason } if reason.contains("indefinite")),
            "{}",
            r.status
        );
    }
}
