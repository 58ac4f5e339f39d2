//! Semismooth Newton methods for the LCP and the boxed LCP: the Fischer–Burmeister and the
//! min-map (natural map) reformulations, with an Armijo line search on the merit function and a
//! gradient step when the Newton direction fails.
//!
//! The problem is rewritten as a system of nonsmooth equations `Φ(f) = 0` with the scaled velocity
//! `F = D⁻¹ w = D⁻¹ (A f + b)` (`D` the [diagonal scale](crate::Problem::diagonal_scale), so `Φ`
//! is in impulse units like the shared residual), row by row:
//!
//! ```text
//! min-map:   Φ_i = f_i − mid(lo_i, hi_i, f_i − F_i)
//! FB:        φ(a, b) = a + b − √(a² + b²)
//!            lo finite, hi = ∞:   Φ_i = φ(f_i − lo_i, F_i)
//!            lo = −∞, hi finite:  Φ_i = −φ(hi_i − f_i, −F_i)
//!            both finite:         Φ_i = φ(f_i − lo_i, −φ(hi_i − f_i, −F_i))   (Billups 1995)
//!            both infinite:       Φ_i = F_i
//! ```
//!
//! Each row of an element `H` of the generalised Jacobian is `α_i e_iᵀ + β_i D⁻¹A_i` (plus a
//! coupling entry `γ_i` in the column of the normal row for a friction row, whose bounds
//! `±mu f_k` move with `f_k`). One iteration solves `(H + μ I) d = −Φ` with `μ = min(10⁻², ‖Φ‖∞ /
//! s)` (`s` the residual scale; a Levenberg-type regularisation that keeps the system regular on
//! PSD, rank-deficient `A` and vanishes at the solution, so the local convergence stays
//! quadratic), by an LU factorisation (faer, partial pivoting): dense for small or dense
//! islands, sparse (COLAMD ordering, supernodal; the symbolic analysis and the storage of the
//! numeric factors are kept in [`Newton::workspace`] and reused while the pattern stays the same,
//! as it does on a resting stack from step to step) for sparse ones, and for contact problems
//! that carry their factors `A = J M⁻¹ Jᵀ`, when `A` is the denser of the two, in the
//! *augmented body-space form* `[diag(α)+μI+Γ, diag(β)J; M⁻¹Jᵀ, −I] [d; u] = [−Φ; 0]`, whose
//! `O(nnz(J))` entries fill far less than `A`'s on piles and pyramids (the body-space system of
//! MuJoCo's Newton solver, kept unsymmetric for the friction coupling; [`SparseForm`]).
//! When at least a tenth of the rows have `β_i = 0` (in the min-map every row clamped at a
//! bound: separated contacts, sliding friction rows, and the friction rows of a cold start;
//! in FB a row exactly at its bound with a separating velocity), those rows are eliminated
//! first: such a row reads `(α_i + μ) d_i + γ_i d_k = −Φ_i`, so `d_i` is known up to its
//! normal's `d_k`, and substituting it leaves the system of the kept rows alone, whose pattern
//! lies within `A`'s (a kept normal's column gains the entries of its eliminated friction rows,
//! which touch the same bodies). That is the primal-dual active-set step (Hintermüller, Ito,
//! Kunisch, SIAM J. Optim. 13, 2002) with the friction coupling kept; its LU (dense, or sparse:
//! up to 400 rows on the island's ordering restricted to the kept rows, above with its own
//! ordering, reused while the kept rows stay the same) replaces the full one and gives the same
//! direction. The direction is accepted when it makes
//! an angle with `−∇θ` below 90° by a margin, `∇θᵀd <= −10⁻⁸ ‖∇θ‖ ‖d‖`, for the merit
//! `θ = ½‖Φ‖²` (a scale-free form of De Luca, Facchinei, Kanzow's test `∇θᵀd <= −ρ‖d‖ᵖ`, which
//! rejects the long steps along the null space of a rank-deficient `A` once `θ` is small);
//! otherwise the steepest-descent direction `−∇θ = −Hᵀ Φ`, scaled to the length `‖Φ‖`, is used.
//! The step length comes from Armijo backtracking on `θ` (`σ = 10⁻⁴`, halving, down to the
//! shortest step `2⁻¹⁴`: rule 3 below), non-monotone: sufficient decrease
//! is measured against the largest `θ` of the last 10 iterates, not the current one (Grippo,
//! Lampariello, Lucidi, "A nonmonotone line search technique for Newton's method", SIAM J.
//! Numer. Anal. 23 (1986) 707–716), so that full steps that cross a kink of `Φ` (a contact or a
//! friction row changing between sticking, sliding and separating) are not cut to `2⁻⁶…2⁻¹²`.
//!
//! **Newton–Krylov** ([`LinearSystem::Krylov`]; `newton-krylov-fb`, `newton-krylov-min`): an
//! inexact Newton method that forms and factorises nothing, so no island is too large. Each
//! direction comes from restarted GMRES ([`crate::linalg::krylov`], right-preconditioned,
//! [`KrylovSettings`]) on `(H + μI) d = −Φ`, applied as `(α + μ) ∘ x + β ∘ (A x) + γ ∘ x_k`
//! with `A x = J (M⁻¹ (Jᵀ x))` through the problem's [`DelassusFactors`](crate::DelassusFactors)
//! when it carries them (a problem of one island; the islands of a split problem are stored
//! sparse) and through the stored rows otherwise; the preconditioner inverts each contact's
//! diagonal block of `H + μI` (its normal and friction rows; 1×1 for any other row). GMRES stops
//! at the relative residual `η_k` of Eisenstat and Walker's choice 2 (`η_k = 0.9 (‖Φ_k‖ /
//! ‖Φ_{k−1}‖)²`, safeguarded, between `10⁻¹¹` and [`KrylovSettings::eta_max`]; S. C. Eisenstat,
//! H. F. Walker, SIAM J. Sci. Comput. 17, 1996), so the steps are loose far from the solution
//! and as accurate as a factorisation's near it, where the local convergence stays superlinear.
//! The time budget is checked between GMRES iterations (the solve ends `TimeLimit` there); a
//! GMRES solve that ends short of `η_k` (its iteration cap [`KrylovSettings::max_krylov`], a
//! breakdown, stagnation; counted in [`Newton::krylov_stats`]) gives its best iterate to the
//! line search, which falls back on the gradient direction when it is no descent direction, and
//! a line search that fails is a stall for the globalisation below. The rest of the method
//! (merits, line search, globalisation, the polish and the refinement) is the same; those read
//! the rows of `A`, so a factored problem's `A` is still assembled once (never factorised).
//!
//! * **Problem class**: standard and boxed LCP with friction rows, any `A`; islands up to
//!   [`Newton::max_dense`] rows (default 3000) dense, up to [`Newton::max_sparse`] (default
//!   200 000) sparse; a larger island is `Unsupported`. Globally convergent to a stationary point of `θ`; for P-matrices (FB) every
//!   stationary point is a solution, and the measured behaviour on the generated SPD, PSD and
//!   P-matrix families is a relative residual of `1e-10` in well under 30 iterations. Friction
//!   rows are linearised *directly* (the coupling entry `γ_i`) or, with
//!   [`FrictionHandling::FixedPoint`], with their bounds frozen at the current normals in each
//!   linearisation (a fixed point on the bounds; slower, but no coupling entries). Free
//!   (equality) rows of joints (`lo = −∞`, `hi = +∞`) have `Φ_i = F_i` in both reformulations,
//!   a row of `D⁻¹A` in `H` that is never eliminated; redundant joints (singular `A_FF`) leave
//!   `H` singular, which the regularisation `μ I` covers as it does for redundant contacts.
//! * **Cost**: one LU per iteration (dense: `⅔ n³`; sparse: the fill of the ordering, about
//!   40 ms for the 4,800-row island of `pyramid_20` in body-space form, 1 ms for a 40-box
//!   tower's 480 rows in the Delassus form; on the kept rows only when rows are eliminated:
//!   201 kept rows of FCLIB spheres-in-a-box's 735-row island factorise, symbolic analysis
//!   included, in 0.15 ms, where the full system's numeric LU takes about 0.45 ms; the kept
//!   rows change at almost every iteration there, so a reduced system of up to 400 rows takes
//!   its ordering from the island's AMD ordering, computed once per solve, and a left-looking
//!   LU that needs no symbolic analysis (`sparse_lu`); a larger one gets its own COLAMD
//!   ordering), plus `O(nnz)` for `H`, `∇θ` and the products with `A`; line-search trials
//!   cost `O(n)` each.
//! * **Failure modes**: a stall (below) that every remedy of the globalisation meets again ends
//!   the solve `Stalled`, its reason naming the last stall and the remedies taken (at a point
//!   that is stationary for both merits and a fixed point of the sweeps: possible when `A` is
//!   not a P-matrix or the problem has no solution); a non-finite iterate gives
//!   `NumericalFailure`; [`Settings::max_iterations`] counts Newton iterations (the sweeps of
//!   rules 2 and 4 are bounded on their own, and count against the time budget).
//! * **Stopping rule**: the shared relative residual of the iterate, projected onto its bounds
//!   (PGS's projection), is at most the tolerance; the projected iterate is returned. A solve
//!   that ends short of it returns the best point it measured (projected or polished iterate),
//!   which the non-monotone line search need not have ended on.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the bounds; without one (or
//!   with an all-zero one), zero (projected). NSGS sweeps from zero are a remedy (rule 4),
//!   not the start.
//! * **Never spins**: an iterate that solves the problem while its projection does not (a
//!   normal at `−1e-20` whose friction rows sit at their bounds `±mu·max(f_k, 0) = 0`; the
//!   projection clips the normal and leaves the friction rows 100 % wrong) is returned as it
//!   is, instead of iterating to the cap at a round-off residual (a 1,008-row island of
//!   `sphere_pile_200` sits at `7e-15` there). Every stall is met by the next remedy below; the
//!   tenth stall of a contact-island solve that began from zero ends it (the eighth without
//!   friction rows, the twelfth from a warm start), and each stall comes at most 100 Newton
//!   iterations after the remedy before it.
//!
//! # Globalisation
//!
//! A solve *stalls* when the line search finds no step (rule 3), or when the iterate's residual
//! has made no new low, 1 % below its best, in 100 Newton iterations ([`crate::solver`]'s
//! stagnation rule). A stall is not the end of the solve: the remedies below are taken in turn
//! (a stall after a remedy calls the next one), and the best point measured is kept
//! throughout and returned when the solve ends short of the tolerance. The status is decided
//! by the shared residual of the returned impulse as for every solver: a remedy changes the
//! path, never the verdict. [`Newton::remedies`] counts what the last solve did, and
//! [`Newton::globalisation`] turns each rule off ([`Globalisation::off`]: the plain method).
//!
//! 1. **Merit switch.** At a stall, the solve switches to the other reformulation (min-map ↔
//!    Fischer–Burmeister, direction and merit together) from the current iterate, with a fresh
//!    line-search memory, and continues. The two merits have different stationary points: the
//!    min-map merit is nonsmooth where a row changes state, and its line search stalls at such
//!    kinks, where the FB merit is smooth (away from degenerate rows) and, for a P-matrix, has
//!    no stationary point that is not a solution (Facchinei and Pang, *Finite-Dimensional
//!    Variational Inequalities and Complementarity Problems*, 2003, §9.1); the FB merit flattens
//!    where the min-map merit still gives full steps. Siconos pairs the two in one solver
//!    (`NEWTON_MIN_FBLSA`: min-map directions, FB merit); switching keeps each direction with
//!    its own merit. Measured on step 26 of `sphere_pile_100` (warm-started min-map Newton
//!    stalled at `3.4e-3` after a restart, where FB Newton from zero converges): see
//!    `tests/globalisation.rs`.
//! 2. **Sweeps and return.** When the switched merit stalls too, fifty NSGS
//!    sweeps ([`Nsgs`]) run from the best point measured since the last restart (rule 4 and
//!    below: the run before a restart led astray), and Newton resumes on the solver's own
//!    merit from where they end; at most three such phases, each preceded by a
//!    switch, before the solve gives up. This is Siconos' hybrid nonsmooth Newton (numerics,
//!    `fc3d_onecontact_nonsmooth_Newton_solvers_solve_hybrid`, strategy
//!    `NSN_AND_PLI_NSN_LOOP`: Newton first, then rounds of projected fixed-point iterations
//!    and Newton again, keeping the better point after each), with NSGS as the projected
//!    iteration and the whole island instead of one contact. Before the first phase a
//!    warm-started solve restarts once from zero on its own merit (a warm start that led
//!    astray: the 1,155-row island of `sphere_pile_200`'s step 33, where FB Newton stagnates
//!    from its warm start and from ten sweeps, and converges from zero), and then rule 4
//!    applies.
//! 3. **Shortest step.** The line search tries steps `1, ½, …, 2⁻¹⁴` and no shorter
//!    ([`Globalisation::min_step`]), along the Newton direction and then
//!    along `−∇θ` scaled to `‖Φ‖`. A hundred steps of `2⁻¹⁴` along a Newton direction lower
//!    `‖Φ‖` by at most 0.6 %, less than the stagnation rule asks for in its window, so a search
//!    whose every step down to `2⁻¹⁴` is rejected is a stall at once (rule 1 takes over),
//!    not a creep through the whole window.
//! 4. **Restart from sweeps.** On an island with friction rows (a contact problem), a solve
//!    whose run from zero stalled on both merits restarts once, on its own merit, from
//!    [`Globalisation::start_sweeps`] NSGS sweeps from zero (default [`START_SWEEPS`], the
//!    `start_sweeps` parameter): the first sweep solves each contact exactly with its
//!    neighbours fixed, and the next ones settle which contacts are closed and which friction
//!    rows slide, the active set Newton has to find from zero otherwise (Siconos' hybrid
//!    strategy `VI_EG_NSN` likewise runs a first-order method before Newton). Measured on step
//!    26 of `sphere_pile_100` (`tests/globalisation.rs`): min-map Newton from zero stalls on
//!    both merits and through every phase of sweeps, and converges from the sweeps. A remedy,
//!    not the start: on problems with many solutions (redundant face contacts, PSD `A`) a start
//!    from sweeps leads Newton to another solution than the one it reaches from zero, and as
//!    the warm start of the next steps that one is worse — with the sweeps as every cold
//!    solve's start, `wall_105` under `newton-min+warm` took 25.2 Newton iterations per step
//!    over 6 steps instead of 2.3, `pyramid_20`'s cold first step took `newton-fb` 17
//!    iterations (0.99 s) instead of 10 (0.69 s), and its warm-started run at a 0.5 s budget
//!    ended 5 of 5 steps at the time limit instead of 1. Problems without friction rows (the
//!    generated SPD, PSD and P-matrix families, joints) do without it: sweeps carry no
//!    guarantee on a non-symmetric `A`; a refinement's sub-problem too.
//!
//! References: A. Fischer, *A special Newton-type optimization method*, Optimization 24, 1992;
//! T. De Luca, F. Facchinei, C. Kanzow, *A semismooth equation approach to the solution of
//! nonlinear complementarity problems*, Math. Prog. 75, 1996; S. C. Billups, *Algorithms for
//! complementarity problems and generalized equations*, PhD thesis, 1995; K. Erleben, *Numerical
//! methods for linear complementarity problems in physics-based animation*, SIGGRAPH course
//! 2013, §5 (min-map Newton, num4lcp); Siconos numerics, `NEWTON_MIN_FBLSA` and the hybrid
//! nonsmooth Newton strategies of `fc3d_onecontact_nonsmooth_Newton_solvers.c`; F. Facchinei,
//! J.-S. Pang, *Finite-Dimensional Variational Inequalities and Complementarity Problems*,
//! vol. II, Springer 2003, ch. 9.

mod merit;

use crate::lcp::nsgs::Nsgs;
use crate::lcp::pgs::sweep_assembled;
use crate::linalg::krylov::KrylovStatus;
use crate::linalg::newton_system::{
    augmented_pays, dense_direction, reduced_direction, sparse_direction, Elimination, Jacobian,
    KrylovSystem, PatternRefusal, ReducedCache, SparseJacobian, SymbolicCache, System,
    SIMPLICIAL_UP_TO, SPARSE_BELOW_DENSITY, SPARSE_FROM_ROWS,
};
use crate::problem::diagonal::skipped_rows;
use crate::problem::metrics::{impulse_scale, relative_row_error};
use crate::problem::Problem;
use crate::solver::line_search::{
    is_descent, Backtracking, ARMIJO_SIGMA, HALVING, MIN_NEWTON_STEP, NEWTON_BACKTRACKS,
};
use crate::solver::{
    initial_impulse, solve_by_islands, solve_by_sparse_islands, zero_impulse, Monitor, Outcome,
    Settings, SolveResult, Solver, Stagnation, Status,
};
use faer::sparse::linalg::lu::NumericLu;
use merit::{merit_gradient, Formulation};
use std::collections::VecDeque;

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES_FB: &str =
    "LCP, boxed LCP, friction rows (directly), free (equality) rows as Phi_i = w_i / d_i; any A; LU per island: dense up to 3000 rows, sparse (Delassus or, on dense contact islands, body-space form) up to 200000; globally convergent for P-matrices";
/// Problem classes handled by the min-map variant.
pub(crate) const PROBLEM_CLASSES_MIN: &str =
    "LCP, boxed LCP, friction rows (directly), free (equality) rows as Phi_i = w_i / d_i; any A; LU per island: dense up to 3000 rows, sparse (Delassus or, on dense contact islands, body-space form) up to 200000; local quadratic convergence";

/// The `start_sweeps` parameter of every Newton entry (rule 4 of the module documentation).
const START_SWEEPS_PARAM: crate::registry::ParamSpec = crate::registry::ParamSpec::count(
    "start_sweeps",
    START_SWEEPS,
    0,
    100_000,
    "NSGS sweeps from zero a stalled start from zero restarts from, once, on a contact island (rule 4; 0: off)",
);

/// Parameters of the factorising Newton entries.
const NEWTON_PARAMS: &[crate::registry::ParamSpec] = &[
    START_SWEEPS_PARAM,
    crate::registry::ParamSpec::count(
        "max_factor_entries",
        crate::cone::newton::MAX_FACTOR_ENTRIES,
        1,
        1_000_000_000_000,
        "largest sparse LU factorised, in entries of L and U estimated before any numerical work (a larger one: unsupported)",
    ),
];

/// `newton` with the restart from sweeps (rule 4) of `params`.
fn with_start(mut newton: Newton, params: &crate::registry::Params) -> Newton {
    newton.globalisation.start_sweeps = params.count("start_sweeps");
    newton
}

/// `newton` with the restart from sweeps and the factorisation cap of `params`.
fn factorising(mut newton: Newton, params: &crate::registry::Params) -> Newton {
    newton.max_factor_entries = params.count("max_factor_entries");
    with_start(newton, params)
}

/// The registry's entry of `newton-fb`.
pub static NEWTON_FB: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-fb",
    summary: "semismooth Newton on the Fischer-Burmeister reformulation",
    problem_classes: PROBLEM_CLASSES_FB,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: NEWTON_PARAMS,
    make: crate::registry::Make::Matrix(|params| {
        Box::new(factorising(Newton::fischer_burmeister(), params))
    }),
};

/// The registry's entry of `newton-min`.
pub static NEWTON_MIN: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-min",
    summary: "semismooth Newton on the min-map reformulation",
    problem_classes: PROBLEM_CLASSES_MIN,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: NEWTON_PARAMS,
    make: crate::registry::Make::Matrix(|params| Box::new(factorising(Newton::min_map(), params))),
};

/// Problem classes handled by the Newton–Krylov variants.
pub(crate) const PROBLEM_CLASSES_KRYLOV: &str =
    "LCP, boxed LCP, friction rows (directly), free (equality) rows; any A; no factorisation and no size cap: GMRES per Newton step, products with A through its factors J M^-1 J^T when the problem carries them (one island), per-contact block-Jacobi preconditioner, Eisenstat-Walker forcing";

/// Parameters of the Newton–Krylov entries.
const KRYLOV_PARAMS: &[crate::registry::ParamSpec] = &[
    crate::registry::ParamSpec::count(
        "restart",
        DEFAULT_RESTART,
        1,
        1000,
        "GMRES basis vectors per cycle before a restart",
    ),
    crate::registry::ParamSpec::count(
        "max_krylov",
        DEFAULT_MAX_KRYLOV,
        1,
        1_000_000,
        "GMRES iterations per Newton step",
    ),
    crate::registry::ParamSpec::real(
        "forcing",
        DEFAULT_ETA_MAX,
        1e-10,
        0.99,
        "largest relative GMRES tolerance (Eisenstat-Walker eta_max)",
    ),
    START_SWEEPS_PARAM,
];

/// `Newton` with [`LinearSystem::Krylov`] and the settings of `params`.
fn krylov_from(newton: Newton, params: &crate::registry::Params) -> Box<Newton> {
    let mut newton = with_start(newton, params);
    newton.linear_system = LinearSystem::Krylov;
    newton.krylov = KrylovSettings {
        restart: params.count("restart"),
        max_krylov: params.count("max_krylov"),
        eta_max: params.get("forcing"),
    };
    Box::new(newton)
}

/// The registry's entry of `newton-krylov-fb`.
pub static NEWTON_KRYLOV_FB: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-krylov-fb",
    summary: "matrix-free inexact (Newton-Krylov, GMRES) semismooth Newton on the Fischer-Burmeister reformulation",
    problem_classes: PROBLEM_CLASSES_KRYLOV,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: KRYLOV_PARAMS,
    make: crate::registry::Make::Matrix(|params| {
        krylov_from(Newton::fischer_burmeister(), params)
    }),
};

/// The registry's entry of `newton-krylov-min`.
pub static NEWTON_KRYLOV_MIN: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-krylov-min",
    summary:
        "matrix-free inexact (Newton-Krylov, GMRES) semismooth Newton on the min-map reformulation",
    problem_classes: PROBLEM_CLASSES_KRYLOV,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: KRYLOV_PARAMS,
    make: crate::registry::Make::Matrix(|params| krylov_from(Newton::min_map(), params)),
};

/// GMRES basis vectors per cycle by default.
pub const DEFAULT_RESTART: usize = 30;
/// GMRES iterations per Newton step by default.
pub const DEFAULT_MAX_KRYLOV: usize = 300;
/// The largest forcing term by default: a first Newton step solved to half of `‖Φ‖`.
pub const DEFAULT_ETA_MAX: f64 = 0.5;

/// The settings of [`LinearSystem::Krylov`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KrylovSettings {
    /// GMRES basis vectors per cycle. Default [`DEFAULT_RESTART`].
    pub restart: usize,
    /// GMRES iterations per Newton step. Default [`DEFAULT_MAX_KRYLOV`].
    pub max_krylov: usize,
    /// Largest Eisenstat–Walker forcing term `η_max` (the relative GMRES tolerance of the first
    /// step and the cap of every later one). Default [`DEFAULT_ETA_MAX`].
    pub eta_max: f64,
}

impl Default for KrylovSettings {
    fn default() -> Self {
        Self {
            restart: DEFAULT_RESTART,
            max_krylov: DEFAULT_MAX_KRYLOV,
            eta_max: DEFAULT_ETA_MAX,
        }
    }
}

/// What the Krylov solves of the last solve of a [`Newton`] with [`LinearSystem::Krylov`] did,
/// summed over its islands; read with [`Newton::krylov_stats`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KrylovStats {
    /// Newton directions computed by GMRES.
    pub directions: usize,
    /// GMRES iterations (products with the Newton matrix) over all of them.
    pub iterations: usize,
    /// Directions whose GMRES solve stopped at its iteration cap short of the forcing term.
    pub iteration_limits: usize,
    /// Directions whose GMRES solve broke down (an invariant Krylov space short of the
    /// tolerance, or a non-finite product).
    pub breakdowns: usize,
    /// Directions whose GMRES solve stagnated over a restart cycle.
    pub stagnations: usize,
    /// The largest relative residual `‖(H + μI) d + Φ‖ / ‖Φ‖` a direction was returned with.
    pub worst_relative_residual: f64,
}

/// Which nonsmooth equation the solver works on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reformulation {
    /// The Fischer–Burmeister function (smooth merit away from degenerate rows).
    FischerBurmeister,
    /// The min-map (natural map) `f − mid(lo, hi, f − F)`.
    MinMap,
}

/// How friction rows (bounds `±mu f_k`) enter the linearisation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionHandling {
    /// The bounds' dependence on `f_k` is linearised (coupling entries in the Jacobian).
    Direct,
    /// The bounds are frozen at the current normal impulses in each linearisation.
    FixedPoint,
}

/// Semismooth Newton. See the module documentation.
#[derive(Debug, Clone)]
pub struct Newton {
    /// The reformulation. Default Fischer–Burmeister.
    pub reformulation: Reformulation,
    /// Friction rows. Default [`FrictionHandling::Direct`].
    pub friction: FrictionHandling,
    /// Largest island for which the dense Jacobian is formed. Default `3000`.
    pub max_dense: usize,
    /// Largest island for which the sparse Jacobian is formed. Default `200 000`.
    pub max_sparse: usize,
    /// Largest sparse LU a solve factorises, in entries of `L` and `U` estimated before any
    /// numerical work (the column counts of the Cholesky factor of `AᵀA` under the LU's
    /// COLAMD ordering, [`crate::linalg::newton_system::lu_entries_estimate`]): a larger
    /// one is refused, the solve ending `Unsupported` with the estimate in its reason, since a
    /// factorisation cannot be interrupted at the time budget. Default
    /// [`crate::cone::newton::MAX_FACTOR_ENTRIES`] (20 million, about 2 s of factorisation on
    /// two cores).
    pub max_factor_entries: usize,
    /// How the Newton systems are factorised. Default [`LinearSystem::Auto`].
    pub linear_system: LinearSystem,
    /// The GMRES settings of [`LinearSystem::Krylov`]. Default [`KrylovSettings::default`].
    pub krylov: KrylovSettings,
    /// Which sparse system is factorised. Default [`SparseForm::Auto`].
    pub sparse_form: SparseForm,
    /// What a solve does when it stalls, and how it starts without a warm start (the module
    /// documentation's globalisation). Default [`Globalisation::default`].
    pub globalisation: Globalisation,
    /// Workspace kept between solves: the last sparse pattern's ordering and symbolic LU,
    /// reused while the pattern of the Newton system stays the same from one solve to the next
    /// (a resting stack keeps its contacts for many steps), and the numeric factors' storage.
    /// Default empty.
    pub workspace: NewtonWorkspace,
}

/// The globalisation of [`Newton`]: the rules of the module documentation, each of which can
/// be turned off (to compare, or to see the plain method's stalls).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Globalisation {
    /// Rule 1: at a stall, switch to the other merit from the current iterate. Default `true`.
    pub merit_switch: bool,
    /// Rule 2: phases of NSGS sweeps from the best point after a switch that stalled too,
    /// before the solve gives up. Default `3`; `0` gives up at the first stall no other
    /// remedy covers.
    pub fallback_phases: usize,
    /// Sweeps per fallback phase (rule 2). Default `50`.
    pub fallback_sweeps: usize,
    /// Rule 3: the shortest step the line search takes, in `(0, 1]`. Default `2⁻¹⁴`; `2⁻³⁹` is
    /// the search without the rule (steps shorter than that move a unit-scaled iterate by less
    /// than its rounding). A value outside `(0, 1]` makes the solve `Unsupported` with the reason.
    pub min_step: f64,
    /// Rule 4: NSGS sweeps from zero that a solve on an island with friction rows restarts
    /// from, once, when a start from zero has stalled on both merits. Default
    /// [`START_SWEEPS`] (the `start_sweeps` parameter of the registry's Newton entries); `0`
    /// turns the rule off.
    pub start_sweeps: usize,
}

impl Default for Globalisation {
    fn default() -> Self {
        Self {
            merit_switch: true,
            fallback_phases: MAX_FALLBACKS,
            fallback_sweeps: FALLBACK_SWEEPS,
            min_step: MIN_NEWTON_STEP,
            start_sweeps: START_SWEEPS,
        }
    }
}

impl Globalisation {
    /// Every rule off: a stall ends the solve (after one restart of a warm start from zero),
    /// the line search goes down to `2⁻³⁹`, and a solve without a warm start starts from zero.
    pub fn off() -> Self {
        Self {
            merit_switch: false,
            fallback_phases: 0,
            fallback_sweeps: FALLBACK_SWEEPS,
            min_step: 0.5_f64.powi(NEWTON_BACKTRACKS as i32 - 1),
            start_sweeps: 0,
        }
    }
}

/// What [`Newton`] keeps between solves (opaque): the symbolic analysis of the last sparse
/// pattern, and the storage of the numeric LU factors, which keeps its capacity from one
/// factorisation to the next (the factors' size is known only once pivoting has run, so fresh
/// storage would grow column by column every iteration).
#[derive(Debug, Clone, Default)]
pub struct NewtonWorkspace {
    symbolic: Option<SymbolicCache>,
    numeric: NumericLu<usize, f64>,
    reduced: ReducedCache,
    remedies: Remedies,
    krylov: KrylovStats,
}

/// What the globalisation of the last solve of a [`Newton`] did (rules 1, 2 and 4 of the module
/// documentation), summed over its islands and the sub-solves of their refinement; read with
/// [`Newton::remedies`]. A solve that ends `stalled` also lists its remedies in its reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Remedies {
    /// Switches of the merit function (min-map ↔ Fischer–Burmeister) at a stall.
    pub merit_switches: usize,
    /// Phases of NSGS sweeps run from the best point after a switch that stalled too.
    pub sweep_phases: usize,
    /// Restarts from zero of a solve that began from a warm start, after a switch that
    /// stalled too.
    pub restarts: usize,
    /// Restarts from NSGS sweeps from zero of a solve that stalled from zero on both merits
    /// (rule 4).
    pub sweep_starts: usize,
}

/// How the Newton systems `(H + μI) d = −Φ` are factorised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearSystem {
    /// Sparse when the island is stored sparse with fewer than a tenth of its entries nonzero
    /// (and at least 100 rows), or larger than [`Newton::max_dense`]; dense otherwise.
    Auto,
    /// Dense partial-pivoting LU (faer), up to [`Newton::max_dense`] rows per island.
    Dense,
    /// Sparse LU (faer: COLAMD ordering, partial pivoting), up to [`Newton::max_sparse`] rows.
    Sparse,
    /// No factorisation and no size cap: restarted GMRES, matrix-free, with the settings of
    /// [`Newton::krylov`] (the module documentation's Newton–Krylov paragraph).
    Krylov,
}

/// Which sparse system gives the Newton directions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SparseForm {
    /// The augmented body-space form when the problem carries its
    /// [`DelassusFactors`](crate::DelassusFactors) and `A` has more than twice the augmented
    /// system's entries; the Delassus form otherwise.
    Auto,
    /// `H` itself, on the stored pattern of `A`.
    Delassus,
    /// The augmented body-space form (see `SparseJacobian::augmented`) when the problem carries
    /// its factors; the Delassus form otherwise.
    BodySpace,
}

impl Default for Newton {
    fn default() -> Self {
        Self::fischer_burmeister()
    }
}

impl Newton {
    /// Fischer–Burmeister Newton with default settings.
    pub fn fischer_burmeister() -> Self {
        Self {
            reformulation: Reformulation::FischerBurmeister,
            friction: FrictionHandling::Direct,
            max_dense: 3000,
            max_sparse: 200_000,
            max_factor_entries: crate::cone::newton::MAX_FACTOR_ENTRIES,
            linear_system: LinearSystem::Auto,
            krylov: KrylovSettings::default(),
            sparse_form: SparseForm::Auto,
            globalisation: Globalisation::default(),
            workspace: NewtonWorkspace::default(),
        }
    }

    /// Min-map Newton with default settings.
    pub fn min_map() -> Self {
        Self {
            reformulation: Reformulation::MinMap,
            ..Self::fischer_burmeister()
        }
    }

    /// What the globalisation of the last solve did: merit switches, phases of fallback
    /// sweeps, restarts and sweep starts, summed over its islands. Zero before any solve.
    pub fn remedies(&self) -> Remedies {
        self.workspace.remedies
    }

    /// What the GMRES solves of the last solve did (zero unless
    /// [`Newton::linear_system`] is [`LinearSystem::Krylov`]).
    pub fn krylov_stats(&self) -> KrylovStats {
        self.workspace.krylov
    }

    /// The nonsmooth equation a solve starts on.
    fn formulation(&self) -> Formulation {
        Formulation {
            reformulation: self.reformulation,
            friction: self.friction,
        }
    }
}

/// `‖Φ‖∞` below this fraction of the island's impulse scale is round-off level: rows still
/// short of the tolerance there are refined on their own ([`Newton::refine`]).
const ROUND_OFF: f64 = 1e-12;
/// Largest Levenberg regularisation `μ` of the Newton system (`μ = min(10⁻², ‖Φ‖∞ / s)`): large
/// enough to keep `H + μI` regular on a rank-deficient PSD `A` far from the solution, small
/// enough that the step stays close to Newton's; it vanishes with `Φ`, so the local
/// convergence stays quadratic.
pub(crate) const MAX_REGULARISATION: f64 = 1e-2;
/// Nesting of refinements.
const MAX_REFINE_DEPTH: usize = 2;

/// The non-monotone line search's memory: a step is accepted on sufficient decrease against
/// the largest merit of the last this many iterates (Grippo, Lampariello and Lucidi's rule).
/// Ten iterates let full Newton steps cross the kinks of `Φ` (contacts switching between
/// sticking, sliding and separating) that a monotone search cuts to `2⁻⁶…2⁻¹²`; on the pyramid,
/// house-of-cards and FCLIB scenes (`lcpbench simulate SCENE -s newton-fb --steps 50`) it
/// converges every step, where a monotone search leaves steps stalled and takes several times
/// the iterations.
const NONMONOTONE_MEMORY: usize = 10;
/// Newton iterations without a 1 % new low of the iterate's residual after which a solve has
/// stagnated ([`Stagnation`]): a warm-started solve then restarts once from zero, a cold one
/// stops `Stalled`. Long enough for the plateaus a semismooth Newton method crosses on large
/// sphere piles (a cold 843-row island sits at `3.85e-2` for 60 iterations before converging in
/// 10 more); a longer window stalls no fewer steps of `sphere_pile_200` and only wastes work.
const STAGNATION_WINDOW: usize = 100;
/// Sweeps of one fallback phase (rule 2): each costs one pass over the stored entries of `A`,
/// so fifty cost about what a few Newton iterations do on the large islands (a sparse
/// factorisation each), and they settle each contact's normal and friction rows together,
/// which moves the iterate off the point where both merits stalled.
const FALLBACK_SWEEPS: usize = 50;
/// Phases of fallback sweeps before a solve gives up (rule 2): with a switch of merit before
/// each and after the last, the `2 · MAX_FALLBACKS + 2`-th stall ends a solve without friction
/// rows from zero (two later on a contact island, which restarts from sweeps once, and two
/// more from a warm start, which restarts from zero once).
const MAX_FALLBACKS: usize = 3;
/// NSGS sweeps from zero that a stalled solve restarts from (rule 4): Siconos' hybrid
/// solvers take ten projected iterations per round (`SICONOS_FRICTION_3D_NSN_HYBRID_MAX_ITER`
/// defaults to 10); on contact problems the first sweep already solves each decoupled contact
/// exactly, and the following ones settle which contacts are closed and which friction rows
/// slide, the active set Newton from zero has to find otherwise.
pub const START_SWEEPS: usize = 10;

impl Solver for Newton {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        match (self.reformulation, self.linear_system) {
            (Reformulation::FischerBurmeister, LinearSystem::Krylov) => &NEWTON_KRYLOV_FB,
            (Reformulation::MinMap, LinearSystem::Krylov) => &NEWTON_KRYLOV_MIN,
            (Reformulation::FischerBurmeister, _) => &NEWTON_FB,
            (Reformulation::MinMap, _) => &NEWTON_MIN,
        }
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        self.workspace.remedies = Remedies::default();
        self.workspace.krylov = KrylovStats::default();
        if self.sparse_for(problem) {
            let limit = if self.linear_system == LinearSystem::Krylov {
                usize::MAX
            } else {
                self.max_sparse
            };
            solve_by_sparse_islands(problem, settings, limit, |island, settings| {
                let sparse = self.sparse_for(island);
                self.solve_island(island, settings, sparse, 0)
            })
        } else {
            let limit = self.max_dense;
            solve_by_islands(problem, settings, limit, |island, settings| {
                self.solve_island(island, settings, false, 0)
            })
        }
    }
}

impl Newton {
    /// Whether the Newton systems of `problem` are factorised sparse.
    fn sparse_for(&self, problem: &Problem) -> bool {
        let n = problem.n();
        match self.linear_system {
            LinearSystem::Dense => false,
            LinearSystem::Sparse | LinearSystem::Krylov => true,
            LinearSystem::Auto => {
                n > self.max_dense
                    || (problem.is_sparse()
                        && n >= SPARSE_FROM_ROWS
                        && (problem.nnz() as f64) < SPARSE_BELOW_DENSITY * (n * n) as f64)
            }
        }
    }

    /// One island; `sparse` chooses the factorisation of its Newton systems.
    fn solve_island(
        &mut self,
        problem: &Problem,
        settings: &Settings,
        sparse: bool,
        depth: usize,
    ) -> SolveResult {
        let mut monitor = Monitor::new(problem, settings);
        let n = problem.n();
        self.workspace.reduced.rank.clear();
        if let Some(reason) = self.too_large(n, sparse) {
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        let rules = self.globalisation;
        let line_search = match Backtracking::down_to(ARMIJO_SIGMA, HALVING, rules.min_step) {
            Ok(search) => search,
            Err(e) => {
                let reason = format!("Newton::globalisation.min_step: {e}");
                return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
            }
        };
        // Formed at the first iteration that needs a direction: a warm start that already meets
        // the tolerance costs no factorisation analysis.
        let mut jacobian: Option<Jacobian> = None;
        let mut krylov: Option<KrylovSystem> = None;
        let d = problem.diagonal_scale();
        let ops = Scaled { problem, d: &d };
        let skip = skipped_rows(problem);
        let scale = impulse_scale(problem);
        let warm = settings
            .warm_start
            .as_ref()
            .is_some_and(|ws| ws.len() == n && ws.iter().any(|v| *v != 0.0));
        // The formulation the solve starts on (the solver's own) and the one it works on now.
        let own = self.formulation();
        let mut form = own;
        let start = if warm {
            initial_impulse(problem, settings)
        } else {
            zero_impulse(problem)
        };
        let mut it = Iterate::new(form, &ops, start);
        let mut lin = Linearisation::new(n);
        let mut iterations = 0;
        let tol = settings.tolerance;
        let mut refined = false;
        // The best point measured (projected or polished iterate): the non-monotone line search
        // may end a failed solve on an iterate worse than an earlier one. `run_best` is the best
        // since the last restart (from zero or from sweeps), where a phase of sweeps (rule 2)
        // starts, since a restart means the run before it led astray; a restart hands it on to
        // `best`, the best of the earlier runs.
        let mut best: (f64, Vec<f64>) = (f64::INFINITY, Vec::new());
        let mut run_best: (f64, Vec<f64>) = (f64::INFINITY, Vec::new());
        let mut stagnation = Stagnation::new(STAGNATION_WINDOW);
        // Rule 4 is for contact islands at the top level (a refinement's sub-problem keeps its
        // warm start).
        let sweep_start = depth == 0 && !problem.friction().is_empty();
        let mut ladder = Ladder::new(own, warm, sweep_start, rules);
        let outcome = loop {
            // The iterate may sit just outside its bounds (neither reformulation keeps it
            // feasible); its projection is tested too and returned when it is within tolerance.
            let progress = match finished(problem, &mut monitor, &it.f, &skip, &d, tol) {
                Ok(done) => {
                    it.f = done;
                    break Outcome::Stopped;
                }
                Err(short) => {
                    if short.best < run_best.0 {
                        run_best = (short.best, short.candidate);
                    }
                    short.iterate
                }
            };
            let phi_inf = it.phi.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            if !refined && depth < MAX_REFINE_DEPTH && phi_inf <= ROUND_OFF * scale {
                refined = true;
                let (done, sub_iterations) =
                    self.refine(problem, &mut monitor, settings, &it.f, depth);
                iterations += sub_iterations;
                if let Some(done) = done {
                    it.f = done;
                    break Outcome::Stopped;
                }
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            // A stall is either the stagnation rule (the window watches the iterates' own
            // residual: the projected and polished candidates can sit far below it early on,
            // and after a remedy the best point kept for the answer must not cut the new run
            // short) or a line search that finds no step of the minimum length.
            let stall = if stagnation.stagnated(iterations, progress) {
                stagnation.reason("relative residual")
            } else {
                form.linearise(
                    problem,
                    &it.f,
                    &it.vel,
                    &d,
                    &mut lin.alpha,
                    &mut lin.beta,
                    &mut lin.gamma,
                );
                let system = System {
                    alpha: &lin.alpha,
                    beta: &lin.beta,
                    gamma: &lin.gamma,
                    phi: &it.phi,
                    mu_reg: (phi_inf / scale).min(MAX_REGULARISATION),
                };
                let grad = merit_gradient(problem, &system);
                let newton_dir = if self.linear_system == LinearSystem::Krylov {
                    let k = krylov.get_or_insert_with(|| {
                        let s = self.krylov;
                        KrylovSystem::new(problem, s.restart, s.max_krylov, s.eta_max)
                    });
                    match self.krylov_direction(problem, &system, k, &monitor) {
                        Ok(dir) => dir,
                        Err(outcome) => break outcome,
                    }
                } else {
                    match self.direction(problem, &system, sparse, &mut jacobian) {
                        Ok(dir) => dir,
                        Err(outcome) => break outcome,
                    }
                };
                iterations += 1;
                let stepped =
                    line_search_step(form, &ops, &mut it, &grad, &newton_dir, &line_search);
                monitor.record(iterations, &it.f);
                if stepped {
                    if it.f.iter().any(|v| !v.is_finite()) {
                        break Outcome::NumericalFailure(format!(
                            "non-finite iterate at iteration {iterations}"
                        ));
                    }
                    continue;
                }
                format!(
                    "the line search found no step of at least {:.1e} of the Newton or the \
                     gradient direction decreasing the {} merit function at iteration \
                     {iterations} (a stationary point of that merit that is not a solution, or \
                     steps too short to make progress)",
                    line_search.min_step(),
                    form.short_name()
                )
            };
            match ladder.remedy() {
                Remedy::Switch => {
                    // Rule 1: the other merit, from the current iterate.
                    form = form.switched();
                    ladder.took_switch(form);
                    self.workspace.remedies.merit_switches += 1;
                    let f = std::mem::take(&mut it.f);
                    it = Iterate::new(form, &ops, f);
                }
                Remedy::Restart => {
                    // A warm start that led astray: the solver's own merit from zero
                    // (projected), keeping the best point measured so far.
                    form = own;
                    ladder.took_restart();
                    self.workspace.remedies.restarts += 1;
                    it = Iterate::new(form, &ops, zero_impulse(problem));
                    keep_better(&mut best, &mut run_best);
                }
                Remedy::SweepStart => {
                    // Rule 4: zero led astray on both merits; the solver's own merit from NSGS
                    // sweeps from zero, keeping the best point measured so far.
                    form = own;
                    ladder.took_sweep_start();
                    self.workspace.remedies.sweep_starts += 1;
                    let zero = zero_impulse(problem);
                    let (f, _) = sweep_phase(problem, settings, &monitor, zero, rules.start_sweeps);
                    it = Iterate::new(form, &ops, f);
                    keep_better(&mut best, &mut run_best);
                }
                Remedy::Sweeps => {
                    // Rule 2: sweeps from the best point, then Newton on the solver's own merit
                    // from where they end.
                    form = own;
                    ladder.took_sweeps();
                    self.workspace.remedies.sweep_phases += 1;
                    let from = if run_best.1.is_empty() {
                        std::mem::take(&mut it.f)
                    } else {
                        run_best.1.clone()
                    };
                    let (f, _) =
                        sweep_phase(problem, settings, &monitor, from, rules.fallback_sweeps);
                    it = Iterate::new(form, &ops, f);
                }
                Remedy::GiveUp => {
                    break Outcome::Stalled(format!("{stall}; {}", ladder.summary()));
                }
            }
            stagnation.restart(iterations);
        };
        if let Some(Jacobian::Sparse(j)) = jacobian {
            self.workspace.symbolic = Some(j.pattern);
            self.workspace.numeric = j.numeric;
        }
        // A stop within tolerance returns the finished iterate already; otherwise the better of
        // the iterate itself and `best`. Every other exit leaves `f` as [`finished`] measured
        // it at the top of the last iteration (a failed line search does not move it), so its
        // projection and polish are in `best` already; the one exception, a non-finite
        // iterate, falls back on `best` too.
        let mut f = it.f;
        if outcome != Outcome::Stopped {
            keep_better(&mut best, &mut run_best);
            let raw = monitor.residual_of(&f);
            // `best` is empty when no point was measured finite (a warm start at which the
            // velocity overflows): the iterate stays, and its non-finite residual says so.
            if !best.1.is_empty() && (raw.is_nan() || best.0 <= raw) {
                f = best.1;
            }
        }
        monitor.finish(f, iterations, outcome)
    }

    /// Why an island of `n` rows is beyond the size up to which the (sparse or dense) Newton
    /// system is formed, if it is.
    fn too_large(&self, n: usize, sparse: bool) -> Option<String> {
        if self.linear_system == LinearSystem::Krylov {
            return None;
        }
        let limit = if sparse {
            self.max_sparse
        } else {
            self.max_dense
        };
        (n > limit).then(|| {
            format!(
                "n = {n} rows: the {} Newton system is formed only up to n = {limit}",
                if sparse { "sparse" } else { "dense" }
            )
        })
    }

    /// The Newton direction `(H + μI)⁻¹(−Φ)` of `system`: through the [`Elimination`] of the
    /// rows with `β_i = 0` when it pays, otherwise from the island's full system, formed on
    /// first use. `Err` with the outcome when the system cannot be formed.
    fn direction(
        &mut self,
        problem: &Problem,
        system: &System<'_>,
        sparse: bool,
        jacobian: &mut Option<Jacobian>,
    ) -> Result<Vec<f64>, Outcome> {
        let elimination = Elimination::of(problem, system);
        if jacobian.is_none() && elimination.is_none() {
            *jacobian = Some(
                self.jacobian(problem, sparse)
                    .map_err(PatternRefusal::outcome)?,
            );
        }
        match (elimination, jacobian.as_mut()) {
            (Some(e), _) => reduced_direction(
                problem,
                &e,
                system,
                !sparse,
                SIMPLICIAL_UP_TO,
                &mut self.workspace.reduced,
                self.max_factor_entries,
            )
            .map_err(Outcome::Unsupported),
            (None, Some(Jacobian::Dense(a))) => Ok(dense_direction(problem, a, system)),
            (None, Some(Jacobian::Sparse(j))) => Ok(sparse_direction(j, system)),
            (None, None) => Err(Outcome::NumericalFailure(
                "no Newton system was formed".into(),
            )),
        }
    }

    /// The inexact Newton direction from GMRES ([`KrylovSystem`]), the time budget checked
    /// between Krylov iterations. A GMRES solve that stops short of its forcing term (its
    /// iteration cap, a breakdown, stagnation) still gives its best iterate, which the line
    /// search takes if it is a descent direction and replaces by the gradient step otherwise;
    /// the globalisation then treats a failed line search as any stall. `Err(TimeLimit)` when
    /// the budget ran out inside GMRES.
    fn krylov_direction(
        &mut self,
        problem: &Problem,
        system: &System<'_>,
        krylov: &mut KrylovSystem,
        monitor: &Monitor<'_>,
    ) -> Result<Vec<f64>, Outcome> {
        let r = krylov.direction(problem, system, || monitor.out_of_time());
        let stats = &mut self.workspace.krylov;
        stats.directions += 1;
        stats.iterations += r.iterations;
        stats.worst_relative_residual = stats.worst_relative_residual.max(r.rel_residual);
        match r.status {
            KrylovStatus::TimeLimit => return Err(Outcome::TimeLimit),
            KrylovStatus::IterationLimit => stats.iteration_limits += 1,
            KrylovStatus::Breakdown(_) => stats.breakdowns += 1,
            KrylovStatus::Stagnation => stats.stagnations += 1,
            KrylovStatus::Converged => {}
        }
        Ok(r.x)
    }

    /// The rows still short of the tolerance when the whole island is at round-off level of
    /// its own scale, solved again as the sub-problem with every other row held at `f`
    /// ([`Problem::restrict_at`], plus the normal of each such friction row): a sub-problem
    /// has its own, much smaller, scale, so its Newton steps are accurate where the island's
    /// were not (the friction rows among resting spheres: all their data near `1e-18` next to
    /// normals near 1, coupled to each other, so one Gauss–Seidel sweep does not settle them).
    /// The refined impulse is returned only when the whole island then meets the tolerance,
    /// with the sub-problem's iterations (which count as the island's).
    fn refine(
        &mut self,
        problem: &Problem,
        monitor: &mut Monitor<'_>,
        settings: &Settings,
        f: &[f64],
        depth: usize,
    ) -> (Option<Vec<f64>>, usize) {
        let tol = settings.tolerance;
        let n = problem.n();
        let b = problem.b();
        let mut short = vec![false; n];
        for i in 0..n {
            let (af, magnitude) = problem.row(i).dot_and_magnitude(f);
            if relative_row_error(problem, i, f, af + b[i], magnitude + b[i].abs()) > tol {
                short[i] = true;
                if let Some((k, _)) = problem.friction_of(i) {
                    short[k] = true;
                }
            }
        }
        let rows: Vec<usize> = (0..n).filter(|&i| short[i]).collect();
        if rows.is_empty() || rows.len() == n {
            return (None, 0);
        }
        let Ok(sub) = problem.restrict_at(&rows, f) else {
            return (None, 0);
        };
        let sub_settings = Settings {
            warm_start: Some(rows.iter().map(|&i| f[i]).collect()),
            record_history: false,
            ..settings.clone()
        };
        let sparse = self.sparse_for(&sub);
        let r = self.solve_island(&sub, &sub_settings, sparse, depth + 1);
        if !r.status.is_converged() {
            return (None, r.iterations);
        }
        let mut g = f.to_vec();
        for (k, &i) in rows.iter().enumerate() {
            g[i] = r.f[k];
        }
        let done = monitor.residual_of(&g) <= tol;
        (done.then_some(g), r.iterations)
    }

    /// The Newton system's storage for `problem`: dense, or the sparse pattern in the form
    /// [`Newton::sparse_form`] chooses, reusing the cached symbolic analysis and the numeric
    /// factors' storage.
    fn jacobian(&mut self, problem: &Problem, sparse: bool) -> Result<Jacobian, PatternRefusal> {
        if !sparse {
            return Ok(Jacobian::Dense(problem.to_dense()));
        }
        let cache = self.workspace.symbolic.take();
        let built = match problem.factors() {
            Some(factors)
                if self.sparse_form == SparseForm::BodySpace
                    || (self.sparse_form == SparseForm::Auto
                        && augmented_pays(problem, factors)) =>
            {
                SparseJacobian::augmented(problem, factors, cache, self.max_factor_entries)
            }
            _ => SparseJacobian::new(problem, cache, self.max_factor_entries),
        };
        built.map(|mut j| {
            j.numeric = std::mem::take(&mut self.workspace.numeric);
            Jacobian::Sparse(Box::new(j))
        })
    }
}

/// One step from `it` on the merit of `form`: along the Newton direction when it is a descent
/// direction for the merit, else (or when no step along it passes) along the steepest-descent
/// direction `−∇θ` scaled to the length `‖Φ‖` (the length of a Newton step where `H` is near
/// the identity, so that the shortest step the line search takes means the same along both
/// directions), its length from the non-monotone Armijo rule (sufficient decrease against the
/// largest recent merit), no shorter than the line search's minimum step (rule 3 of the module
/// documentation). On success `it` moves to the new iterate, whose velocity is recomputed from
/// scratch so that round-off does not accumulate. False when neither direction gives a
/// decrease with a step of at least the minimum length; `it` has not moved then.
fn line_search_step(
    form: Formulation,
    ops: &Scaled<'_>,
    it: &mut Iterate,
    grad: &[f64],
    newton_dir: &[f64],
    line_search: &Backtracking,
) -> bool {
    let n = grad.len();
    let dnorm2: f64 = newton_dir.iter().map(|v| v * v).sum();
    let slope: f64 = (0..n).map(|i| grad[i] * newton_dir[i]).sum();
    let gnorm = grad.iter().map(|v| v * v).sum::<f64>().sqrt();
    let phinorm = it.phi.iter().map(|v| v * v).sum::<f64>().sqrt();
    let newton_ok = is_descent(newton_dir, slope, gnorm, dnorm2.sqrt());
    // `−∇θ · ‖Φ‖ / ‖∇θ‖`, of slope `∇θᵀd = −‖∇θ‖ ‖Φ‖`; no direction when `∇θ = 0`.
    let gscale = if gnorm > 0.0 { phinorm / gnorm } else { 0.0 };
    let gradient_dir: Vec<f64> = grad.iter().map(|g| -g * gscale).collect();
    let gslope = -gnorm * phinorm;
    let candidates: Vec<(&[f64], f64)> = if newton_ok {
        vec![(newton_dir, slope), (&gradient_dir, gslope)]
    } else {
        vec![(&gradient_dir, gslope)]
    };
    let reference = it.recent.iter().copied().fold(it.theta, f64::max);
    let accepted = candidates.into_iter().any(|(direction, slope)| {
        if slope.is_nan() || slope >= 0.0 || direction.iter().any(|v| !v.is_finite()) {
            return false;
        }
        ops.product(direction, &mut it.ad);
        let Iterate {
            f,
            vel,
            trial_f,
            trial_vel,
            trial_phi,
            ad,
            ..
        } = &mut *it;
        let step = line_search.armijo(reference, slope, |t| {
            for i in 0..n {
                trial_f[i] = f[i] + t * direction[i];
                trial_vel[i] = vel[i] + t * ad[i];
            }
            form.merit(ops.problem, trial_f, trial_vel, trial_phi)
        });
        if step.is_some() {
            // The trial buffers hold the accepted step's iterate and `Φ`.
            std::mem::swap(&mut it.f, &mut it.trial_f);
            std::mem::swap(&mut it.phi, &mut it.trial_phi);
        }
        step.is_some()
    });
    if accepted {
        ops.velocity(&it.f, &mut it.vel);
        it.theta = form.merit(ops.problem, &it.f, &it.vel, &mut it.phi);
        it.recent.push_back(it.theta);
        if it.recent.len() > NONMONOTONE_MEMORY {
            it.recent.pop_front();
        }
    }
    accepted
}

/// Ends a run of a solve (a restart, or the solve's end): `run` becomes `best` when it is
/// strictly better (the earlier point wins a tie), and is emptied for the next run.
fn keep_better(best: &mut (f64, Vec<f64>), run: &mut (f64, Vec<f64>)) {
    let run = std::mem::replace(run, (f64::INFINITY, Vec::new()));
    if run.0 < best.0 {
        *best = run;
    }
}

/// `sweeps` NSGS sweeps ([`Nsgs`]) from `f`, within what is left of the solve's time budget
/// (rules 2 and 4 of the module documentation): the impulse they end on and its shared
/// relative residual, or `f` itself and an infinite residual when no sweep was run (none
/// asked for, or NSGS refused the problem) or they end on a non-finite impulse.
fn sweep_phase(
    problem: &Problem,
    settings: &Settings,
    monitor: &Monitor<'_>,
    f: Vec<f64>,
    sweeps: usize,
) -> (Vec<f64>, f64) {
    if sweeps == 0 {
        return (f, f64::INFINITY);
    }
    let sub = Settings {
        tolerance: settings.tolerance,
        max_iterations: sweeps,
        time_budget: settings
            .time_budget
            .map(|budget| budget.saturating_sub(monitor.elapsed())),
        warm_start: Some(f.clone()),
        record_history: false,
        // The result's status and residual decide what follows.
        measure_result: true,
    };
    let r = Nsgs.solve(problem, &sub);
    let residual = r.residuals.natural_map_rel;
    let usable = !matches!(r.status, Status::Unsupported { .. })
        && r.f.len() == f.len()
        && r.f.iter().all(|v| v.is_finite())
        && residual.is_finite();
    if usable {
        (r.f, residual)
    } else {
        (f, f64::INFINITY)
    }
}

/// What a stalled solve does next (rules 1 and 2 of the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Remedy {
    /// Switch to the other merit, from the current iterate.
    Switch,
    /// Start a solve that began from a warm start again from zero, on its own merit.
    Restart,
    /// Start a solve that stalled from zero again from NSGS sweeps from zero, on its own merit
    /// (rule 4).
    SweepStart,
    /// Sweeps from the best point, then Newton on its own merit from where they end.
    Sweeps,
    /// Stop `Stalled`.
    GiveUp,
}

/// Where a solve stands on its ladder of remedies: after a stall, the other merit; when that
/// stalls too, a restart from zero (a solve that began from a warm start, once), a restart
/// from sweeps (rule 4, once, after a start from zero stalled on both merits) or a phase of
/// sweeps (at most [`Globalisation::fallback_phases`]), each followed by the solver's own merit
/// again; then it gives up. A rule turned off is skipped.
struct Ladder {
    /// The rules in force.
    rules: Globalisation,
    /// The solver's own formulation, which a restart and the sweeps return to.
    own: Formulation,
    /// Whether the merit was switched since the solve started, restarted or swept.
    switched: bool,
    /// Whether the solve started from a warm start and has not restarted from zero.
    can_restart: bool,
    /// Whether the restart from sweeps (rule 4) is still to come.
    can_sweep_start: bool,
    /// The remedies taken, in order, for the reason of a solve that gives up.
    taken: Vec<String>,
    /// Phases of sweeps taken.
    fallbacks: usize,
}

impl Ladder {
    /// `sweep_start`: whether the problem is one rule 4 is for (a contact island at the top
    /// level); the rule also needs [`Globalisation::start_sweeps`] above zero.
    fn new(own: Formulation, warm: bool, sweep_start: bool, rules: Globalisation) -> Self {
        Self {
            rules,
            own,
            switched: false,
            can_restart: warm,
            can_sweep_start: sweep_start && rules.start_sweeps > 0,
            taken: vec![format!("{} merit", own.short_name())],
            fallbacks: 0,
        }
    }

    /// The remedy for the next stall.
    fn remedy(&self) -> Remedy {
        if self.rules.merit_switch && !self.switched {
            Remedy::Switch
        } else if self.can_restart {
            Remedy::Restart
        } else if self.can_sweep_start {
            Remedy::SweepStart
        } else if self.fallbacks < self.rules.fallback_phases {
            Remedy::Sweeps
        } else {
            Remedy::GiveUp
        }
    }

    /// The merit was switched to `to`.
    fn took_switch(&mut self, to: Formulation) {
        self.switched = true;
        self.taken.push(format!("{} merit", to.short_name()));
    }

    /// The solve restarted from sweeps from zero (rule 4).
    fn took_sweep_start(&mut self) {
        self.switched = false;
        self.can_sweep_start = false;
        self.taken.push(format!(
            "restart from {} NSGS sweeps from zero, {} merit",
            self.rules.start_sweeps,
            self.own.short_name()
        ));
    }

    /// The solve restarted from zero.
    fn took_restart(&mut self) {
        self.switched = false;
        self.can_restart = false;
        self.taken.push(format!(
            "restart from zero, {} merit",
            self.own.short_name()
        ));
    }

    /// A phase of sweeps was run.
    fn took_sweeps(&mut self) {
        self.switched = false;
        self.fallbacks += 1;
        self.taken.push(format!(
            "{} NSGS sweeps, {} merit",
            self.rules.fallback_sweeps,
            self.own.short_name()
        ));
    }

    /// The remedies taken, for the reason of a solve that gives up.
    fn summary(&self) -> String {
        format!("every remedy stalled in turn: {}", self.taken.join(" -> "))
    }
}

/// The iterate to return when `f` is done: its projection onto the bounds when that meets the
/// tolerance, else the projection after one projected Gauss–Seidel sweep when that does, else
/// the iterate itself when it does.
///
/// The sweep is the polish for rows whose data are all at round-off level next to the rest
/// (the friction rows of a resting sphere: `b_t` and every `A_tj f_j` near `1e-18` where the
/// normals are near 1). The relative residual measures such a row against its own scale, but
/// the Newton step carries the linear solve's error, `ε` times the whole system's scale, into
/// it; one sweep solves each such row to its own scale, and leaves converged rows converged.
///
/// Otherwise `Err` with the best of the three (residual and impulse, the candidate for the best
/// point of a solve that ends short of the tolerance) and the iterate's own residual.
fn finished(
    problem: &Problem,
    monitor: &mut Monitor<'_>,
    f: &[f64],
    skip: &[bool],
    d: &[f64],
    tol: f64,
) -> Result<Vec<f64>, ShortOfTolerance> {
    let mut fp = f.to_vec();
    problem.project_onto_bounds(&mut fp);
    let projected = monitor.residual_of(&fp);
    if projected <= tol {
        return Ok(fp);
    }
    let before = fp.clone();
    sweep_assembled(problem, &mut fp, skip, d, 1.0);
    let polished = monitor.residual_of(&fp);
    if polished <= tol {
        return Ok(fp);
    }
    // The iterate itself, when its projection is worse: a normal at `−1e-20` whose friction
    // rows sit at their bounds `±mu·max(f_k, 0) = 0` solves the problem to round-off, but
    // clipping it to zero leaves a friction row's own error at 100 % of its scale.
    let raw = monitor.residual_of(f);
    if raw <= tol {
        return Ok(f.to_vec());
    }
    let (best, candidate) = if polished <= projected && polished <= raw {
        (polished, fp)
    } else if projected <= raw {
        (projected, before)
    } else {
        (raw, f.to_vec())
    };
    Err(ShortOfTolerance {
        best,
        candidate,
        iterate: raw,
    })
}

/// The scaled products of an island: `D⁻¹ A x` and the scaled velocity `D⁻¹ (A f + b)`.
struct Scaled<'a> {
    problem: &'a Problem,
    /// The diagonal scale `D`.
    d: &'a [f64],
}

impl Scaled<'_> {
    /// `out = D⁻¹ A x` (without `b`).
    fn product(&self, x: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.problem.row(i).dot(x) / self.d[i];
        }
    }

    /// `out = D⁻¹ (A f + b)`.
    fn velocity(&self, f: &[f64], out: &mut [f64]) {
        self.product(f, out);
        let b = self.problem.b();
        for (i, o) in out.iter_mut().enumerate() {
            *o += b[i] / self.d[i];
        }
    }
}

/// The Newton iterate with its scaled velocity, `Φ`, merit `θ`, the merits of the last
/// [`NONMONOTONE_MEMORY`] iterates (the line search's reference), and the line search's trial
/// buffers.
struct Iterate {
    f: Vec<f64>,
    vel: Vec<f64>,
    phi: Vec<f64>,
    theta: f64,
    recent: VecDeque<f64>,
    trial_f: Vec<f64>,
    trial_vel: Vec<f64>,
    trial_phi: Vec<f64>,
    /// `D⁻¹ A d` along the direction being searched.
    ad: Vec<f64>,
}

impl Iterate {
    /// The iterate at `f` on the merit of `form`: its scaled velocity, `Φ` and merit, with a
    /// fresh line-search memory.
    fn new(form: Formulation, ops: &Scaled<'_>, f: Vec<f64>) -> Self {
        let n = f.len();
        let mut vel = vec![0.0; n];
        ops.velocity(&f, &mut vel);
        let mut phi = vec![0.0; n];
        let theta = form.merit(ops.problem, &f, &vel, &mut phi);
        let mut recent = VecDeque::with_capacity(NONMONOTONE_MEMORY + 1);
        recent.push_back(theta);
        Self {
            f,
            vel,
            phi,
            theta,
            recent,
            trial_f: vec![0.0; n],
            trial_vel: vec![0.0; n],
            trial_phi: vec![0.0; n],
            ad: vec![0.0; n],
        }
    }
}

/// The rows of the generalised Jacobian at the iterate: `α`, `β` (holding `β_i / d_i`) and the
/// friction couplings `γ`.
struct Linearisation {
    alpha: Vec<f64>,
    beta: Vec<f64>,
    gamma: Vec<f64>,
}

impl Linearisation {
    fn new(n: usize) -> Self {
        Self {
            alpha: vec![0.0; n],
            beta: vec![0.0; n],
            gamma: vec![0.0; n],
        }
    }
}

/// What [`finished`] measured at an iterate short of the tolerance.
struct ShortOfTolerance {
    /// The smallest residual of the iterate, its projection and the polished projection.
    best: f64,
    /// The point of that residual.
    candidate: Vec<f64>,
    /// The residual of the iterate itself.
    iterate: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::generate::{generate, Family};
    use crate::problem::FrictionRow;
    use crate::test_util::lcp;
    use crate::{Dantzig, Status};
    use faer::sparse::{SparseRowMat, Triplet};

    fn tight() -> Settings {
        Settings {
            tolerance: 1e-10,
            max_iterations: 30,
            ..Settings::default()
        }
    }

    /// The order of the remedies: the other merit first; then, for a warm start, the cold
    /// start once; then, on a contact island, the start from sweeps once; then phases of
    /// sweeps, each followed by a switch; then the solve gives up. A rule turned off is
    /// skipped.
    #[test]
    fn remedies_come_in_the_documented_order() {
        use Remedy::{GiveUp, Restart, SweepStart, Sweeps, Switch};
        let own = Newton::min_map().formulation();
        let walk = |warm: bool, rules: Globalisation| {
            let mut ladder = Ladder::new(own, warm, true, rules);
            let mut form = own;
            let mut taken = Vec::new();
            loop {
                let remedy = ladder.remedy();
                taken.push(remedy);
                match remedy {
                    Remedy::Switch => {
                        form = form.switched();
                        ladder.took_switch(form);
                    }
                    Remedy::Restart => {
                        form = own;
                        ladder.took_restart();
                    }
                    Remedy::SweepStart => {
                        form = own;
                        ladder.took_sweep_start();
                    }
                    Remedy::Sweeps => {
                        form = own;
                        ladder.took_sweeps();
                    }
                    Remedy::GiveUp => break,
                }
                assert!(taken.len() < 20, "{taken:?}");
            }
            (taken, ladder.summary())
        };
        let (cold, summary) = walk(false, Globalisation::default());
        assert_eq!(
            cold,
            [Switch, SweepStart, Switch, Sweeps, Switch, Sweeps, Switch, Sweeps, Switch, GiveUp]
        );
        assert_eq!(
            summary,
            "every remedy stalled in turn: min-map merit -> FB merit -> restart from 10 NSGS \
             sweeps from zero, min-map merit -> FB merit -> 50 NSGS sweeps, min-map merit -> FB \
             merit -> 50 NSGS sweeps, min-map merit -> FB merit -> 50 NSGS sweeps, min-map \
             merit -> FB merit"
        );
        let (warm, _) = walk(true, Globalisation::default());
        assert_eq!(
            warm,
            [
                Switch, Restart, Switch, SweepStart, Switch, Sweeps, Switch, Sweeps, Switch,
                Sweeps, Switch, GiveUp
            ]
        );
        // Without the rules: a cold solve gives up at its first stall, a warm one restarts once.
        assert_eq!(walk(false, Globalisation::off()).0, [GiveUp]);
        assert_eq!(walk(true, Globalisation::off()).0, [Restart, GiveUp]);
        let sweeps_only = Globalisation {
            merit_switch: false,
            start_sweeps: 0,
            ..Globalisation::default()
        };
        assert_eq!(walk(false, sweeps_only).0, [Sweeps, Sweeps, Sweeps, GiveUp]);
        // Off a contact island (or in a refinement's sub-problem) rule 4 does not apply.
        let mut ladder = Ladder::new(own, false, false, Globalisation::default());
        ladder.took_switch(own.switched());
        assert_eq!(ladder.remedy(), Sweeps);
    }

    /// Contacts of a normal and two friction rows each, `A = J Jᵀ + εI` from a random
    /// Jacobian with fewer columns than rows for most seeds (rank-deficient, as on piles),
    /// normals pushed together: the family on which the rules below were found to matter.
    fn rank_deficient_contacts(seed: u64) -> Problem {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let nc = rng.random_range(2..7usize);
        let n = 3 * nc;
        let dofs = rng.random_range(nc..(2 * n));
        let j = faer::Mat::from_fn(n, dofs, |_, _| rng.random_range(-1.0..1.0));
        let eps = [0.0, 1e-8, 1e-4][rng.random_range(0..3usize)];
        let a = faer::Mat::from_fn(n, n, |r, c| {
            (0..dofs).map(|k| j[(r, k)] * j[(c, k)]).sum::<f64>() + if r == c { eps } else { 0.0 }
        });
        let b: Vec<f64> = (0..n)
            .map(|i| {
                if i % 3 == 0 {
                    rng.random_range(-1.5..0.3)
                } else {
                    rng.random_range(-1.0..1.0)
                }
            })
            .collect();
        let mu = rng.random_range(0.1..1.5);
        let friction = (0..nc)
            .flat_map(|c| {
                (1..3).map(move |t| FrictionRow {
                    row: 3 * c + t,
                    normal: 3 * c,
                    mu,
                })
            })
            .collect();
        Problem::boxed(a, b, vec![0.0; n], vec![f64::INFINITY; n], friction).unwrap()
    }

    /// Min-map Newton with the rules `rules` on `p` from zero, at `1e-10`.
    fn min_map_with(rules: Globalisation, p: &Problem) -> (SolveResult, Remedies) {
        let mut s = Newton {
            globalisation: rules,
            ..Newton::min_map()
        };
        let settings = Settings {
            tolerance: 1e-10,
            max_iterations: 2000,
            ..Settings::default()
        };
        let r = s.solve(p, &settings);
        (r, s.remedies())
    }

    /// Each rule on its own turns a stall of the plain method into a solution, on small
    /// contact problems (seeds 10 and 82 of [`rank_deficient_contacts`]) where plain min-map
    /// Newton from zero makes no progress for its window and stops `stalled`.
    #[test]
    fn each_rule_alone_solves_a_contact_problem_the_plain_method_stalls_on() {
        let off = Globalisation::off();
        for seed in [10, 82] {
            let p = rank_deficient_contacts(seed);
            let (plain, remedies) = min_map_with(off, &p);
            match &plain.status {
                Status::Stalled { reason } => {
                    assert!(reason.contains("no progress"), "seed {seed}: {reason}")
                }
                other => panic!("seed {seed}: the plain method {other}"),
            }
            assert_eq!(remedies, Remedies::default());
            // Rule 1: the other merit from where min-map stalled.
            let switch = Globalisation {
                merit_switch: true,
                ..off
            };
            let (r, remedies) = min_map_with(switch, &p);
            assert!(r.status.is_converged(), "seed {seed}, switch: {}", r.status);
            assert!(remedies.merit_switches >= 1, "{remedies:?}");
            assert_eq!((remedies.sweep_phases, remedies.sweep_starts), (0, 0));
            // Rule 2: sweeps from the best point, then min-map again.
            let sweeps = Globalisation {
                fallback_phases: MAX_FALLBACKS,
                ..off
            };
            let (r, remedies) = min_map_with(sweeps, &p);
            assert!(r.status.is_converged(), "seed {seed}, sweeps: {}", r.status);
            assert!(remedies.sweep_phases >= 1, "{remedies:?}");
            assert_eq!((remedies.merit_switches, remedies.sweep_starts), (0, 0));
            // Rule 4: after the stall from zero, a restart from ten NSGS sweeps from zero.
            let start = Globalisation {
                start_sweeps: START_SWEEPS,
                ..off
            };
            let (r, remedies) = min_map_with(start, &p);
            assert!(r.status.is_converged(), "seed {seed}, start: {}", r.status);
            assert_eq!(remedies.sweep_starts, 1, "{remedies:?}");
            assert_eq!((remedies.merit_switches, remedies.sweep_phases), (0, 0));
            // All of them.
            let (r, _) = min_map_with(Globalisation::default(), &p);
            assert!(r.status.is_converged(), "seed {seed}: {}", r.status);
        }
    }

    /// Problems without friction rows start from zero, rule 4 on or off (it is for contact
    /// problems).
    #[test]
    fn a_problem_without_friction_rows_starts_from_zero() {
        let g = generate(Family::Spd { cond: 1e2 }, 20, 1);
        let mut s = Newton::fischer_burmeister();
        s.globalisation.start_sweeps = START_SWEEPS;
        let r = s.solve(&g.problem, &tight());
        assert!(r.status.is_converged());
        assert_eq!(s.remedies(), Remedies::default());
    }

    /// A shortest step outside `(0, 1]` is refused with the setting's name, before any work.
    #[test]
    fn an_invalid_shortest_step_is_unsupported() {
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[-1.0, 1.0]);
        for min_step in [0.0, 2.0, f64::NAN] {
            let mut s = Newton::min_map();
            s.globalisation.min_step = min_step;
            let r = s.solve(&p, &Settings::default());
            match r.status {
                Status::Unsupported { reason } => {
                    assert!(reason.contains("min_step"), "{reason}")
                }
                other => panic!("{min_step}: {other}"),
            }
        }
    }

    #[test]
    fn solves_a_two_by_two_lcp() {
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[-1.0, 1.0]);
        for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
            let r = s.solve(&p, &Settings::default());
            assert_eq!(r.status, Status::Converged, "{}", s.name());
            assert!((r.f[0] - 0.5).abs() < 1e-8 && r.f[1].abs() < 1e-8);
        }
    }

    #[test]
    fn planted_families_reach_1e_10_in_30_iterations() {
        for (family, n) in [
            (Family::Spd { cond: 1e3 }, 60),
            (Family::Spd { cond: 1e6 }, 40),
            (Family::PsdRankDeficient { rank: 15 }, 30),
            (Family::PMatrix, 50),
        ] {
            for seed in 0..3 {
                let g = generate(family, n, seed);
                for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
                    let r = s.solve(&g.problem, &tight());
                    assert_eq!(
                        r.status,
                        Status::Converged,
                        "{} on {family:?} seed {seed}: {} after {} iterations",
                        s.name(),
                        r.residuals.natural_map_rel,
                        r.iterations
                    );
                    assert!(r.residuals.natural_map_rel <= 1e-10);
                    assert!(r.iterations <= 30);
                }
            }
        }
    }

    #[test]
    fn rank_deficient_psd_at_n_100_converges() {
        // Half the rank: the Jacobian is singular at the solution, and the Newton direction is
        // long along its null space while the merit is tiny; the angle test must still take it.
        let g = generate(Family::PsdRankDeficient { rank: 50 }, 100, 0);
        for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
            let r = s.solve(&g.problem, &tight());
            assert_eq!(r.status, Status::Converged, "{}: {}", s.name(), r.status);
        }
    }

    #[test]
    fn convergence_is_quadratic_at_the_end() {
        // On an SPD problem the residual history ends with r_{k+1} <= C r_k², which a linear
        // rate cannot do: the last steps' exponents log r_{k+1} / log r_k approach 2.
        let g = generate(Family::Spd { cond: 1e2 }, 80, 7);
        let settings = Settings {
            tolerance: 1e-14,
            max_iterations: 50,
            record_history: true,
            ..Settings::default()
        };
        let r = Newton::fischer_burmeister().solve(&g.problem, &settings);
        let hist: Vec<f64> = r.history.iter().map(|h| h.residual).collect();
        // The last step from a residual below 1e-3 to the next one (or to 0).
        let k = hist
            .iter()
            .position(|&x| x < 1e-3)
            .expect("residual falls below 1e-3");
        assert!(k + 1 < hist.len(), "{hist:?}");
        let (r0, r1) = (hist[k], hist[k + 1]);
        assert!(
            r1 <= 10.0 * r0 * r0 || r1 <= 1e-14,
            "not quadratic: {r0:e} -> {r1:e}; history {hist:?}"
        );
        assert!(r.residuals.natural_map_rel <= 1e-13, "{hist:?}");
    }

    #[test]
    fn boxed_and_friction_problems_match_dantzig() {
        let n = 12;
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
        let a = crate::problem::generate::spd_matrix(n, 10.0, &mut rng);
        let b: Vec<f64> = (0..n).map(|i| ((i * 7 % 5) as f64 - 2.0) * 0.3).collect();
        let inf = f64::INFINITY;
        let lo = vec![
            0.0, -inf, -0.2, -inf, 0.1, 0.0, -inf, -0.2, -inf, 0.0, 0.0, 0.0,
        ];
        let hi = vec![inf, 0.3, 0.4, inf, 0.1, inf, 0.3, 0.4, inf, inf, 0.0, 0.0];
        let friction = vec![
            FrictionRow {
                row: 10,
                normal: 0,
                mu: 0.5,
            },
            FrictionRow {
                row: 11,
                normal: 9,
                mu: 0.3,
            },
        ];
        let p = Problem::boxed(a, b, lo, hi, friction).unwrap();
        let reference = Dantzig::default().solve(&p, &Settings::default());
        assert_eq!(reference.status, Status::Converged);
        for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
            for handling in [FrictionHandling::Direct, FrictionHandling::FixedPoint] {
                s.friction = handling;
                let r = s.solve(&p, &Settings::default());
                assert_eq!(r.status, Status::Converged, "{} {handling:?}", s.name());
                for (x, y) in r.f.iter().zip(&reference.f) {
                    assert!((x - y).abs() < 1e-6, "{:?} vs {:?}", r.f, reference.f);
                }
            }
        }
    }

    /// A contact-like problem: `bodies` point-and-rotation bodies in a chain, each link a
    /// contact with a normal row and two friction rows, `A = J M⁻¹ Jᵀ` assembled sparse and
    /// its factors attached.
    fn chain_with_factors(bodies: usize, seed: u64) -> Problem {
        use crate::problem::{sparse_from_triplets, DelassusFactors};
        use rand::Rng;
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(seed);
        let contacts = bodies; // contact k between body k−1 (ground for k = 0) and body k
        let n = 3 * contacts;
        let mut jt = Vec::new();
        for k in 0..contacts {
            for r in 0..3 {
                let row = 3 * k + r;
                for (body, sign) in [(k, 1.0), (k.wrapping_sub(1), -1.0)] {
                    if body >= bodies {
                        continue;
                    }
                    for c in 0..6 {
                        let v: f64 = if c == r {
                            sign
                        } else {
                            rng.random_range(-0.3..0.3)
                        };
                        jt.push(Triplet::new(row, 6 * body + c, v));
                    }
                }
            }
        }
        let jac = SparseRowMat::try_new_from_triplets(n, 6 * bodies, &jt).unwrap();
        let minv: Vec<[[f64; 6]; 6]> = (0..bodies)
            .map(|_| {
                let mut m = [[0.0; 6]; 6];
                for (r, row) in m.iter_mut().enumerate() {
                    row[r] = rng.random_range(0.1..10.0);
                }
                m
            })
            .collect();
        let factors = DelassusFactors::new(jac, minv).unwrap();
        // Assemble A column by column from the factors.
        let mut triplets = Vec::new();
        for j in 0..n {
            let mut e = vec![0.0; n];
            e[j] = 1.0;
            for (i, v) in factors.apply(&e).into_iter().enumerate() {
                if v != 0.0 {
                    triplets.push((i, j, v));
                }
            }
        }
        let a = sparse_from_triplets(n, &triplets).unwrap();
        let inf = f64::INFINITY;
        let mut lo = vec![0.0; n];
        let mut hi = vec![inf; n];
        let mut friction = Vec::new();
        let mut b = vec![0.0; n];
        for k in 0..contacts {
            b[3 * k] = -rng.random_range(0.5..2.0);
            for r in 1..3 {
                b[3 * k + r] = rng.random_range(-1.0..1.0);
                lo[3 * k + r] = 0.0;
                hi[3 * k + r] = 0.0;
                friction.push(FrictionRow {
                    row: 3 * k + r,
                    normal: 3 * k,
                    mu: 0.4,
                });
            }
        }
        Problem::boxed_sparse(a, b, lo, hi, friction)
            .unwrap()
            .with_factors(factors)
            .unwrap()
    }

    /// The direction through the elimination of the rows with `β_i = 0` is the full system's,
    /// dense and sparse, at iterates where normals and friction rows sit at their bounds, so
    /// that clamped friction rows hang on both kept and eliminated normals.
    #[test]
    fn eliminating_clamped_rows_gives_the_full_direction() {
        use rand::{Rng, SeedableRng};
        let (mut checked, mut coupled) = (0, 0);
        for seed in 0..6 {
            let p = chain_with_factors(20, seed);
            let n = p.n();
            let a = p.to_dense();
            let d = p.diagonal_scale();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(100 + seed);
            let mut f = vec![0.0; n];
            for k in 0..n / 3 {
                f[3 * k] = if rng.random_bool(0.3) {
                    0.0
                } else {
                    rng.random_range(0.1..1.0)
                };
            }
            for k in 0..n / 3 {
                let bound = 0.4 * f[3 * k];
                for r in 1..3 {
                    f[3 * k + r] = match rng.random_range(0..3) {
                        0 => bound,
                        1 => -bound,
                        _ => rng.random_range(-1.0..1.0) * bound,
                    };
                }
            }
            let vel: Vec<f64> = (0..n)
                .map(|i| (p.row(i).dot(&f) + p.b()[i]) / d[i])
                .collect();
            for newton in [Newton::min_map(), Newton::fischer_burmeister()] {
                let (mut alpha, mut beta, mut gamma) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                newton
                    .formulation()
                    .linearise(&p, &f, &vel, &d, &mut alpha, &mut beta, &mut gamma);
                let phi: Vec<f64> = (0..n)
                    .map(|i| {
                        let (lo, hi) = p.bounds_at(i, &f);
                        let dmu = p.friction_of(i).map_or(0.0, |(_, mu)| mu);
                        newton.formulation().row(f[i], vel[i], lo, hi, dmu).phi
                    })
                    .collect();
                let mu_reg = 1e-3;
                let system = System {
                    alpha: &alpha,
                    beta: &beta,
                    gamma: &gamma,
                    phi: &phi,
                    mu_reg,
                };
                let Some(e) = Elimination::of(&p, &system) else {
                    continue;
                };
                assert!(e.kept.len() < n);
                coupled += e.slope.iter().filter(|g| g.is_some()).count();
                let full = dense_direction(&p, &a, &system);
                let scale = full.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                let mut cache = ReducedCache::default();
                // Dense; sparse on the island's ordering (simplicial); sparse with its own.
                for (dense, simplicial_up_to) in [(true, 0), (false, usize::MAX), (false, 0)] {
                    let reduced = reduced_direction(
                        &p,
                        &e,
                        &system,
                        dense,
                        simplicial_up_to,
                        &mut cache,
                        usize::MAX,
                    )
                    .unwrap();
                    for i in 0..n {
                        assert!(
                            (reduced[i] - full[i]).abs() <= 1e-10 * scale,
                            "{} seed {seed} row {i}: {} against {}",
                            newton.name(),
                            reduced[i],
                            full[i]
                        );
                    }
                }
                checked += 1;
            }
        }
        assert!(checked >= 6, "only {checked} eliminations checked");
        assert!(
            coupled > 0,
            "no eliminated friction row hangs on a kept normal"
        );
    }

    /// The natural map `f − mid(lo, hi, f − w)` with `w = A f + b` and the friction bounds
    /// `±mu f_k`, from the dense `A` (independent of the solver crate's residual code), in the
    /// infinity norm, over the scale `max(‖b‖∞, ‖f‖∞ · max A_ii)`.
    fn independent_natural_map(p: &Problem, f: &[f64]) -> f64 {
        let a = p.to_dense();
        let n = p.n();
        let mut worst = 0.0_f64;
        let mut scale = p.b().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let amax = (0..n).fold(0.0_f64, |m, i| m.max(a[(i, i)]));
        scale = scale.max(f.iter().fold(0.0_f64, |m, v| m.max(v.abs())) * amax);
        for i in 0..n {
            let w: f64 = (0..n).map(|j| a[(i, j)] * f[j]).sum::<f64>() + p.b()[i];
            let (lo, hi) = match p.friction_of(i) {
                Some((k, mu)) => (-mu * f[k].max(0.0), mu * f[k].max(0.0)),
                None => (p.lo()[i], p.hi()[i]),
            };
            worst = worst.max((f[i] - (f[i] - w).max(lo).min(hi)).abs());
        }
        worst / scale.max(f64::MIN_POSITIVE)
    }

    fn krylov(reformulation: Reformulation) -> Newton {
        Newton {
            reformulation,
            linear_system: LinearSystem::Krylov,
            ..Newton::default()
        }
    }

    /// Newton–Krylov against the LU Newton on random boxed LCPs with friction rows (dense,
    /// rank-deficient `A`) and on factored contact chains (products through `J M⁻¹ Jᵀ`): the
    /// same statuses, impulses within `1e-8`, and every `converged` answer checked by an
    /// independent natural map.
    #[test]
    fn krylov_newton_agrees_with_the_lu_newton() {
        let settings = Settings {
            tolerance: 1e-11,
            max_iterations: 200,
            ..Settings::default()
        };
        let mut problems: Vec<Problem> = (0..8).map(rank_deficient_contacts).collect();
        problems.extend((0..3).map(|seed| chain_with_factors(30, seed)));
        let (mut converged, mut directions) = (0, 0);
        for (k, p) in problems.iter().enumerate() {
            for reformulation in [Reformulation::FischerBurmeister, Reformulation::MinMap] {
                let direct = Newton {
                    reformulation,
                    ..Newton::default()
                }
                .solve(p, &settings);
                let mut s = krylov(reformulation);
                let r = s.solve(p, &settings);
                assert_eq!(
                    r.status, direct.status,
                    "problem {k} {reformulation:?}: {r:?}"
                );
                if r.status != Status::Converged {
                    continue;
                }
                converged += 1;
                directions += s.krylov_stats().directions;
                let scale = 1.0 + direct.f.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                for (x, y) in r.f.iter().zip(&direct.f) {
                    assert!(
                        (x - y).abs() <= 1e-8 * scale,
                        "problem {k} {reformulation:?}: {x} vs {y}"
                    );
                }
                let nm = independent_natural_map(p, &r.f);
                assert!(nm <= 1e-9, "problem {k} {reformulation:?}: {nm:.2e}");
            }
        }
        assert!(converged >= 16, "only {converged} converged");
        assert!(directions >= 20, "only {directions} GMRES directions");
    }

    /// An island whose sparse LU is estimated above `max_factor_entries`: the LU Newton ends
    /// `Unsupported` before any factorisation, naming the cap (the report's `factor_cap`); with
    /// the default cap it solves the island, checked by the independent natural map.
    #[test]
    fn an_island_above_the_factorisation_cap_is_refused() {
        let p = chain_with_factors(40, 5);
        let settings = Settings {
            tolerance: 1e-10,
            max_iterations: 100,
            ..Settings::default()
        };
        let capped = Newton {
            linear_system: LinearSystem::Sparse,
            max_factor_entries: 10,
            ..Newton::default()
        }
        .solve(&p, &settings);
        match &capped.status {
            Status::Unsupported { reason } => {
                assert!(reason.contains("max_factor_entries = 10"), "{reason}")
            }
            other => panic!("{other}"),
        }
        let r = Newton {
            linear_system: LinearSystem::Sparse,
            ..Newton::default()
        }
        .solve(&p, &settings);
        assert_eq!(r.status, Status::Converged, "{r:?}");
        assert!(independent_natural_map(&p, &r.f) <= 1e-8);
    }

    /// An island above `max_sparse` rows: the LU Newton refuses it, the Krylov Newton (no
    /// factorisation cap) solves it, checked by the independent natural map.
    #[test]
    fn krylov_newton_has_no_size_cap() {
        let p = chain_with_factors(40, 5);
        let settings = Settings {
            tolerance: 1e-10,
            max_iterations: 100,
            ..Settings::default()
        };
        let lu = Newton {
            linear_system: LinearSystem::Sparse,
            max_sparse: 50,
            ..Newton::default()
        }
        .solve(&p, &settings);
        assert!(
            matches!(lu.status, Status::Unsupported { .. }),
            "{:?}",
            lu.status
        );
        let mut s = Newton {
            max_sparse: 50,
            max_dense: 50,
            ..krylov(Reformulation::FischerBurmeister)
        };
        let r = s.solve(&p, &settings);
        assert_eq!(r.status, Status::Converged, "{r:?}");
        assert!(independent_natural_map(&p, &r.f) <= 1e-8);
        assert_eq!(s.name(), "newton-krylov-fb");
    }

    /// A spent time budget ends the GMRES loop before its first product with the time-limit
    /// outcome, and a whole solve with it ends `TimeLimit`.
    #[test]
    fn a_spent_budget_ends_the_krylov_loop_with_time_limit() {
        let p = chain_with_factors(20, 1);
        let n = p.n();
        let settings = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        let monitor = Monitor::new(&p, &settings);
        let (alpha, beta, gamma, phi) = (vec![1.0; n], vec![0.5; n], vec![0.0; n], vec![1.0; n]);
        let system = System {
            alpha: &alpha,
            beta: &beta,
            gamma: &gamma,
            phi: &phi,
            mu_reg: 0.0,
        };
        let mut s = krylov(Reformulation::MinMap);
        let mut k = KrylovSystem::new(&p, 30, 100, 0.5);
        let out = s.krylov_direction(&p, &system, &mut k, &monitor);
        assert_eq!(out, Err(Outcome::TimeLimit));
        assert_eq!(s.krylov_stats().iterations, 0);
        let r = s.solve(&p, &settings);
        assert_eq!(r.status, Status::TimeLimit);
    }

    /// A warm start whose every row is clamped (impulses on separating contacts): the reduced
    /// system is empty and the direction comes from the eliminated rows alone.
    #[test]
    fn a_system_with_every_row_eliminated_is_solved() {
        let p = lcp(&[&[2.0, 1.0], &[1.0, 2.0]], &[10.0, 10.0]);
        for linear_system in [LinearSystem::Dense, LinearSystem::Sparse] {
            let mut s = Newton {
                linear_system,
                ..Newton::min_map()
            };
            let settings = Settings {
                warm_start: Some(vec![1.0, 1.0]),
                ..tight()
            };
            let r = s.solve(&p, &settings);
            assert_eq!(r.status, Status::Converged, "{linear_system:?}");
            assert!(
                r.f.iter().all(|&v| v == 0.0),
                "{linear_system:?}: {:?}",
                r.f
            );
        }
    }

    #[test]
    fn dense_sparse_and_body_space_systems_give_the_same_answer() {
        for seed in 0..4 {
            let p = chain_with_factors(40, seed);
            let settings = Settings {
                tolerance: 1e-11,
                max_iterations: 60,
                ..Settings::default()
            };
            for reformulation in [Reformulation::FischerBurmeister, Reformulation::MinMap] {
                let mut answers = Vec::new();
                for (linear_system, sparse_form) in [
                    (LinearSystem::Dense, SparseForm::Auto),
                    (LinearSystem::Sparse, SparseForm::Delassus),
                    (LinearSystem::Sparse, SparseForm::BodySpace),
                ] {
                    let mut s = Newton {
                        reformulation,
                        linear_system,
                        sparse_form,
                        ..Newton::default()
                    };
                    let r = s.solve(&p, &settings);
                    assert_eq!(
                        r.status,
                        Status::Converged,
                        "{reformulation:?} {linear_system:?} {sparse_form:?}, seed {seed}: {}",
                        r.residuals.natural_map_rel
                    );
                    answers.push(r.f);
                }
                let reference = Dantzig::default().solve(&p, &settings);
                for f in &answers {
                    for (x, y) in f.iter().zip(&answers[0]) {
                        assert!((x - y).abs() < 1e-8, "{x} vs {y} (seed {seed})");
                    }
                    if reference.status == Status::Converged {
                        for (x, y) in f.iter().zip(&reference.f) {
                            assert!((x - y).abs() < 1e-6, "newton {x} vs dantzig {y}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_cached_symbolic_analysis_gives_the_answers_of_a_fresh_solver() {
        let settings = Settings {
            tolerance: 1e-11,
            max_iterations: 60,
            ..Settings::default()
        };
        let mut reused = Newton {
            linear_system: LinearSystem::Sparse,
            ..Newton::default()
        };
        // Same pattern with other data (the cache is reused), then another pattern (rebuilt),
        // then the first pattern again.
        for (bodies, seed) in [(40, 0), (40, 1), (30, 2), (40, 3)] {
            let p = chain_with_factors(bodies, seed);
            let r = reused.solve(&p, &settings);
            let fresh = Newton {
                linear_system: LinearSystem::Sparse,
                ..Newton::default()
            }
            .solve(&p, &settings);
            assert!(r.status.is_converged(), "seed {seed}: {:?}", r.status);
            assert_eq!(r.iterations, fresh.iterations, "seed {seed}");
            for (x, y) in r.f.iter().zip(&fresh.f) {
                assert_eq!(x, y, "seed {seed}: the cached pattern changed the answer");
            }
        }
        assert!(reused.workspace.symbolic.is_some());
    }

    #[test]
    fn too_large_is_unsupported_and_no_solution_stalls() {
        let g = generate(Family::Spd { cond: 10.0 }, 12, 0);
        for linear_system in [LinearSystem::Dense, LinearSystem::Sparse] {
            let mut s = Newton {
                max_dense: 10,
                max_sparse: 10,
                linear_system,
                ..Newton::default()
            };
            assert_eq!(
                s.solve(&g.problem, &Settings::default()).status.name(),
                "unsupported"
            );
        }
        // Auto factorises sparse above the dense limit.
        let mut s = Newton {
            max_dense: 10,
            ..Newton::default()
        };
        assert!(s
            .solve(&g.problem, &Settings::default())
            .status
            .is_converged());
        let g = generate(Family::Infeasible, 10, 1);
        let r = Newton::default().solve(&g.problem, &Settings::default());
        assert!(!r.status.is_converged());
    }

    /// A solve that ends short of the tolerance returns the best point it measured, not its
    /// last iterate: the non-monotone line search accepts increases of the merit, so the last
    /// iterate can be worse (on this infeasible instance it was, 5.0e-4 against 2.7e-4), and
    /// the remedies of a stall move the iterate away from the best point.
    #[test]
    fn a_failed_solve_returns_its_best_point() {
        for seed in [9, 14] {
            let g = generate(Family::Infeasible, 10, seed);
            let settings = Settings {
                tolerance: 1e-10,
                max_iterations: 30,
                record_history: true,
                ..Settings::default()
            };
            for mut s in [Newton::fischer_burmeister(), Newton::min_map()] {
                let r = s.solve(&g.problem, &settings);
                assert!(
                    matches!(r.status, Status::IterationLimit | Status::Stalled { .. }),
                    "{}: {}",
                    s.name(),
                    r.status
                );
                let best_seen = r
                    .history
                    .iter()
                    .map(|h| h.residual)
                    .fold(f64::INFINITY, f64::min);
                let returned = r.residuals.natural_map_rel;
                assert!(
                    returned <= best_seen * (1.0 + 1e-9),
                    "{} seed {seed}: returned {returned:.3e}, best iterate {best_seen:.3e}",
                    s.name()
                );
            }
        }
    }
}
