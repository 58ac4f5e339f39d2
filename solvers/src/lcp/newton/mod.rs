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
//! otherwise the steepest-descent direction `−∇θ = −Hᵀ Φ` is used. The step length comes from Armijo
//! backtracking on `θ` (`σ = 10⁻⁴`, halving, at most 40 times), non-monotone: sufficient decrease
//! is measured against the largest `θ` of the last 10 iterates, not the current one (Grippo,
//! Lampariello, Lucidi, "A nonmonotone line search technique for Newton's method", SIAM J.
//! Numer. Anal. 23 (1986) 707–716), so that full steps that cross a kink of `Φ` (a contact or a
//! friction row changing between sticking, sliding and separating) are not cut to `2⁻⁶…2⁻¹²`.
//!
//! * **Problem class**: standard and boxed LCP with friction rows, any `A`; islands up to
//!   [`Newton::max_dense`] rows (default 3000) dense, up to [`Newton::max_sparse`] (default
//!   200 000) sparse; a larger island is `Unsupported`. Globally convergent to a stationary point of `θ`; for P-matrices (FB) every
//!   stationary point is a solution, and the measured behaviour on the generated SPD, PSD and
//!   P-matrix families is a relative residual of `1e-10` in well under 30 iterations. Friction
//!   rows are linearised *directly* (the coupling entry `γ_i`) or, with
//!   [`FrictionHandling::FixedPoint`], with their bounds frozen at the current normals in each
//!   linearisation (a fixed point on the bounds; slower, but no coupling entries).
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
//! * **Failure modes**: a line search that cannot decrease `θ` along either direction ends the
//!   solve (`Stalled`, at a stationary point of `θ` that is not a solution, possible when `A` is
//!   not a P-matrix or with the min-map merit at a kink); a non-finite iterate gives
//!   `NumericalFailure`; [`Settings::max_iterations`] counts Newton iterations.
//! * **Stopping rule**: the shared relative residual of the iterate, projected onto its bounds
//!   (PGS's projection), is at most the tolerance; the projected iterate is returned. A solve
//!   that ends short of it returns the best point it measured (projected or polished iterate),
//!   which the non-monotone line search need not have ended on.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the bounds.
//! * **Never spins**: an iterate that solves the problem while its projection does not (a
//!   normal at `−1e-20` whose friction rows sit at their bounds `±mu·max(f_k, 0) = 0`; the
//!   projection clips the normal and leaves the friction rows 100 % wrong) is returned as it
//!   is: on a 1,008-row island of `sphere_pile_200` the solve otherwise went on for 10,000
//!   iterations at a residual of `7e-15`. And when the iterate's residual has made no new low,
//!   1 % below its best, in 100 iterations ([`crate::solver`]'s stagnation rule), a
//!   warm-started solve restarts once from zero, keeping its best point, and a cold one stops
//!   `Stalled`.
//!
//! References: A. Fischer, *A special Newton-type optimization method*, Optimization 24, 1992;
//! T. De Luca, F. Facchinei, C. Kanzow, *A semismooth equation approach to the solution of
//! nonlinear complementarity problems*, Math. Prog. 75, 1996; S. C. Billups, *Algorithms for
//! complementarity problems and generalized equations*, PhD thesis, 1995; K. Erleben, *Numerical
//! methods for linear complementarity problems in physics-based animation*, SIGGRAPH course
//! 2013, §5 (min-map Newton, num4lcp); Siconos numerics, `NEWTON_MIN_FBLSA`.

use crate::lcp::pgs::sweep_assembled;
use crate::linalg::sparse_lu::SparseLu;
use crate::problem::diagonal::skipped_rows;
use crate::problem::metrics::{impulse_scale, relative_row_error};
use crate::problem::{DelassusFactors, Problem};
use crate::solver::line_search::{is_descent, Backtracking};
use crate::solver::{
    initial_impulse, solve_by_islands, solve_by_sparse_islands, Monitor, Outcome, Settings,
    SolveResult, Solver, Stagnation,
};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuSymbolicParams, NumericLu, SymbolicLu};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{Argsort, Pair, SparseColMat, SymbolicSparseColMat};
use faer::Mat;
use faer::{Conj, Par};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES_FB: &str =
    "LCP, boxed LCP, friction rows (directly); any A; LU per island: dense up to 3000 rows, sparse (Delassus or, on dense contact islands, body-space form) up to 200000; globally convergent for P-matrices";
/// Problem classes handled by the min-map variant.
pub(crate) const PROBLEM_CLASSES_MIN: &str =
    "LCP, boxed LCP, friction rows (directly); any A; LU per island: dense up to 3000 rows, sparse (Delassus or, on dense contact islands, body-space form) up to 200000; local quadratic convergence";

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
    /// How the Newton systems are factorised. Default [`LinearSystem::Auto`].
    pub linear_system: LinearSystem,
    /// Which sparse system is factorised. Default [`SparseForm::Auto`].
    pub sparse_form: SparseForm,
    /// Workspace kept between solves: the last sparse pattern's ordering and symbolic LU,
    /// reused while the pattern of the Newton system stays the same from one solve to the next
    /// (a resting stack keeps its contacts for many steps), and the numeric factors' storage.
    /// Default empty.
    pub workspace: NewtonWorkspace,
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
}

/// What the sparse reduced systems ([`reduced_direction`]) keep: the last large reduced
/// system's symbolic analysis and numeric factors' storage, and the island's ordering for the
/// small ones.
#[derive(Debug, Clone, Default)]
struct ReducedCache {
    symbolic: Option<SymbolicCache>,
    numeric: NumericLu<usize, f64>,
    /// The island's fill-reducing ordering, as each row's rank ([`island_rank`]); emptied at
    /// the start of each island solve.
    rank: Vec<usize>,
    /// The small reduced systems' LU storage.
    lu: SparseLu,
}

/// A sparse pattern with its column ordering and symbolic LU.
#[derive(Clone)]
struct SymbolicCache {
    size: usize,
    pairs: Vec<Pair<usize, usize>>,
    symbolic: SymbolicSparseColMat<usize>,
    argsort: Argsort<usize>,
    lu: SymbolicLu<usize>,
}

impl std::fmt::Debug for SymbolicCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SymbolicCache")
            .field("size", &self.size)
            .field("entries", &self.pairs.len())
            .finish()
    }
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
}

/// Which sparse system gives the Newton directions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SparseForm {
    /// The augmented body-space form when the problem carries its [`DelassusFactors`] and `A`
    /// has more than twice the augmented system's entries; the Delassus form otherwise.
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
            linear_system: LinearSystem::Auto,
            sparse_form: SparseForm::Auto,
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
}

/// `‖Φ‖∞` below this fraction of the island's impulse scale is round-off level: rows still
/// short of the tolerance there are refined on their own ([`Newton::refine`]).
const ROUND_OFF: f64 = 1e-12;
/// Nesting of refinements.
const MAX_REFINE_DEPTH: usize = 2;

/// The non-monotone line search's memory: a step is accepted on sufficient decrease against
/// the largest merit of the last this many iterates (Grippo, Lampariello and Lucidi's rule).
/// Measured at 1 (monotone), 5 and 10 (`lcpbench simulate SCENE -s S --steps 50 --tol 1e-8
/// --max-iter 10000`): pyramid_10 newton-fb 256 → 56 → 47 ms/step, newton-min 47/50 steps
/// converged at 1.8 s/step → 50/50 at 18 and 20 ms; house_of_cards newton-fb+warm 49/50 at
/// 29 ms → 50/50 at 3.2 and 0.9 ms; FCLIB spheres-in-a-box newton-fb 150 → 70 iterations,
/// newton-min stalled at 2.4e-6 → converged in 63.
const NONMONOTONE_MEMORY: usize = 10;
/// Newton iterations without a 1 % new low of the iterate's residual after which a solve has
/// stagnated ([`Stagnation`]): a warm-started solve then restarts once from zero, a cold one
/// stops `Stalled`. A cold solve of a 843-row sphere-pile island sat at `3.85e-2` for 60
/// iterations before converging in 10 more; on the 50 steps of `sphere_pile_200` at `1e-8`, a
/// window of 50 left 19 (FB) and 12 (min-map) cold steps stalled, 100 left 14 and 5, 200 no
/// fewer.
const STAGNATION_WINDOW: usize = 100;

/// `φ(a, b) = a + b − √(a² + b²)` and its partial derivatives.
#[inline]
fn fb(a: f64, b: f64) -> (f64, f64, f64) {
    let r = a.hypot(b);
    if r == 0.0 {
        let c = 1.0 - std::f64::consts::FRAC_1_SQRT_2;
        (0.0, c, c)
    } else {
        (a + b - r, 1.0 - a / r, 1.0 - b / r)
    }
}

/// One row of `Φ` and of the Jacobian: `Φ_i`, `α_i`, `β_i`, and `γ_i`, the derivative with
/// respect to the normal impulse `f_k` of a friction row (0 otherwise).
struct RowLinearisation {
    phi: f64,
    alpha: f64,
    beta: f64,
    gamma: f64,
}

impl Newton {
    /// `Φ_i` (and its derivative parts) at `f_i`, scaled velocity `fi_vel`, bounds `(lo, hi)`;
    /// `dmu` is `∂hi/∂f_k = −∂lo/∂f_k` for a friction row.
    fn row(&self, fi: f64, vel: f64, lo: f64, hi: f64, dmu: f64) -> RowLinearisation {
        match self.reformulation {
            Reformulation::MinMap => {
                let t = fi - vel;
                if t <= lo {
                    RowLinearisation {
                        phi: fi - lo,
                        alpha: 1.0,
                        beta: 0.0,
                        gamma: dmu,
                    }
                } else if t >= hi {
                    RowLinearisation {
                        phi: fi - hi,
                        alpha: 1.0,
                        beta: 0.0,
                        gamma: -dmu,
                    }
                } else {
                    RowLinearisation {
                        phi: vel,
                        alpha: 0.0,
                        beta: 1.0,
                        gamma: 0.0,
                    }
                }
            }
            Reformulation::FischerBurmeister => match (lo.is_finite(), hi.is_finite()) {
                (true, false) => {
                    let (phi, pa, pb) = fb(fi - lo, vel);
                    RowLinearisation {
                        phi,
                        alpha: pa,
                        beta: pb,
                        gamma: pa * dmu,
                    }
                }
                (false, true) => {
                    let (phi, pa, pb) = fb(hi - fi, -vel);
                    RowLinearisation {
                        phi: -phi,
                        alpha: pa,
                        beta: pb,
                        gamma: -pa * dmu,
                    }
                }
                (false, false) => RowLinearisation {
                    phi: vel,
                    alpha: 0.0,
                    beta: 1.0,
                    gamma: 0.0,
                },
                (true, true) => {
                    let (psi, qa, qb) = fb(hi - fi, -vel);
                    let (phi, pa, pb) = fb(fi - lo, -psi);
                    RowLinearisation {
                        phi,
                        alpha: pa + pb * qa,
                        beta: pb * qb,
                        gamma: dmu * (pa - pb * qa),
                    }
                }
            },
        }
    }

    /// `Φ(f)` into `phi`, given the scaled velocity `vel = D⁻¹ (A f + b)`; returns `θ = ½‖Φ‖²`.
    fn merit(&self, problem: &Problem, f: &[f64], vel: &[f64], phi: &mut [f64]) -> f64 {
        let mut theta = 0.0;
        for i in 0..f.len() {
            let (lo, hi) = problem.bounds_at(i, f);
            let r = self.row(f[i], vel[i], lo, hi, 0.0);
            phi[i] = r.phi;
            theta += 0.5 * r.phi * r.phi;
        }
        if theta.is_finite() {
            theta
        } else {
            f64::INFINITY
        }
    }

    /// The element `H = diag(α) + diag(β) D⁻¹ A + coupling` of the generalised Jacobian at
    /// `f` (`vel` the scaled velocity): `alpha`, `beta` (holding `β_i / d_i`) and `gamma`.
    #[allow(clippy::too_many_arguments)]
    fn linearise(
        &self,
        problem: &Problem,
        f: &[f64],
        vel: &[f64],
        d: &[f64],
        alpha: &mut [f64],
        beta: &mut [f64],
        gamma: &mut [f64],
    ) {
        for i in 0..f.len() {
            let (lo, hi) = problem.bounds_at(i, f);
            let dmu = match (problem.friction_of(i), self.friction) {
                (Some((k, mu)), FrictionHandling::Direct) if f[k] > 0.0 => mu,
                _ => 0.0,
            };
            let r = self.row(f[i], vel[i], lo, hi, dmu);
            alpha[i] = r.alpha;
            beta[i] = r.beta / d[i];
            gamma[i] = if dmu != 0.0 { r.gamma } else { 0.0 };
        }
    }
}

impl Solver for Newton {
    fn name(&self) -> &'static str {
        match self.reformulation {
            Reformulation::FischerBurmeister => "newton-fb",
            Reformulation::MinMap => "newton-min",
        }
    }

    fn solve(&mut self, problem: &Problem, settings: &Settings) -> SolveResult {
        if self.sparse_for(problem) {
            let limit = self.max_sparse;
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

/// Density (stored entries over `n²`) below which [`LinearSystem::Auto`] factorises sparse.
const SPARSE_BELOW_DENSITY: f64 = 0.1;
/// Largest sparse reduced system solved by [`sparse_reduced_solve`] (no ordering or symbolic
/// analysis of its own); larger ones get faer's COLAMD ordering and supernodal LU, their
/// symbolic analysis reused while the kept rows stay the same. FCLIB spheres-in-a-box's
/// 303–368 kept rows take the cheaper path. Above, measured with `lcpbench simulate
/// bench_scenes/S.toml -s newton-min+warm --steps 50 --tol 1e-8 --max-iter 10000`: with faer's
/// simplicial LU for every reduced system, pyramid_20 (reduced systems of thousands of rows)
/// took 55.5 ms per step against 27.2 with COLAMD and supernodal LU; with [`SparseLu`]
/// (diagonal preference `0.1`) for every one, pyramid_20 was within noise of this limit, and
/// sphere_pile_100 left 9 of 50 steps at the iteration limit, against 6 with this limit.
const SIMPLICIAL_UP_TO: usize = 400;
/// Fraction of an island's rows with `β_i = 0` from which the Newton system is solved through
/// their [`Elimination`]. Measured against no elimination (`lcpbench simulate SCENE -s S
/// --steps 50 --tol 1e-8 --max-iter 10000`, solver time per step): sphere_pile_100
/// newton-min+warm 3.35 s → 0.65 s (46 of 50 steps converged instead of 42), confined
/// newton-min+warm 797 → 538 ms, pyramid_10 newton-min+warm 16.0 → 9.3 ms, pyramid_20 27 ms
/// instead of 35, house_of_cards 0.79 → 0.30 ms; tower_40_60hz, arch, wall_105 and pyramid_5
/// within noise (their contacts stick: after the first iteration of a step no row is
/// eliminated); FCLIB spheres-in-a-box newton-min 70 → 46 ms in 63 iterations either way.
const REDUCE_FROM: f64 = 0.1;
/// Rows from which [`LinearSystem::Auto`] considers the sparse factorisation.
const SPARSE_FROM_ROWS: usize = 100;

/// One Newton system `H + μI` of an island, with its storage.
enum Jacobian {
    /// Dense `A`; `H` formed dense and factorised by partial-pivoting LU.
    Dense(Mat<f64>),
    /// Sparse: the fixed pattern of `H` (the pattern of `A`, the diagonal, and a coupling entry
    /// per friction row), its column ordering and symbolic LU (computed once, or taken from the workspace); each
    /// iteration refills the values and factorises numerically.
    Sparse(Box<SparseJacobian>),
}

/// What a stored entry of the sparse `H` holds.
#[derive(Clone, Copy)]
enum EntryKind {
    /// `β_i A_ij`.
    A(f64),
    /// `α_i` (plus the regularisation).
    Diagonal,
    /// `γ_i`, the friction row's coupling to its normal.
    Coupling,
    /// `β_i J_ic` (augmented form: row `i`'s Jacobian entry at body velocity `c`).
    Jacobian(f64),
    /// A fixed value (augmented form: `−1` and the entries of `M⁻¹ Jᵀ`).
    Fixed(f64),
}

struct SparseJacobian {
    /// `(row, column, kind)` per stored entry, in the order of `values`.
    entries: Vec<(usize, usize, EntryKind)>,
    /// Unknowns of the system: `n`, plus six body velocities per body of the island in the
    /// augmented form.
    size: usize,
    /// The pattern (`pairs` in the order of `entries`), its ordering and symbolic LU.
    pattern: SymbolicCache,
    values: Vec<f64>,
    /// Numeric LU factors (storage taken from the workspace and given back) and the scratch
    /// memory of factorisation and solve.
    numeric: NumericLu<usize, f64>,
    scratch: MemBuffer,
}

impl SparseJacobian {
    fn new(problem: &Problem, cache: Option<SymbolicCache>) -> Result<Self, String> {
        let n = problem.n();
        let mut entries = Vec::with_capacity(problem.nnz() + 2 * n);
        for i in 0..n {
            // Stored entries enter the pattern even when zero, so it depends on the storage only.
            for (j, v) in problem.row(i).iter() {
                entries.push((i, j, EntryKind::A(v)));
            }
            // Duplicated positions are summed when the matrix is assembled.
            entries.push((i, i, EntryKind::Diagonal));
            if let Some((k, _)) = problem.friction_of(i) {
                entries.push((i, k, EntryKind::Coupling));
            }
        }
        Self::factor_pattern(entries, n, cache)
    }

    /// The augmented (body-space) form of `H + μI` for `A = J M⁻¹ Jᵀ`, with the body
    /// velocities `u = M⁻¹ Jᵀ d` as extra unknowns:
    ///
    /// ```text
    /// [ diag(α) + μI + Γ   diag(β) J ] [d]   [−Φ]
    /// [ M⁻¹ Jᵀ             −I        ] [u] = [ 0]
    /// ```
    ///
    /// It has `O(nnz(J))` entries where `A` has one per pair of rows sharing a body, so its LU
    /// fills far less on stacks and piles (the system MuJoCo's Newton solver factorises in
    /// joint space, here kept unsymmetric for the friction coupling).
    fn augmented(
        problem: &Problem,
        factors: &DelassusFactors,
        cache: Option<SymbolicCache>,
    ) -> Result<Self, String> {
        let n = problem.n();
        let jac = factors.jacobian();
        let sym = jac.symbolic();
        let (ptr, idx, val) = (sym.row_ptr(), sym.col_idx(), jac.val());
        // Bodies the island's rows touch, numbered locally.
        let mut local = vec![usize::MAX; factors.inverse_mass().len()];
        let mut bodies = Vec::new();
        for &c in idx.iter().take(ptr[n]) {
            let body = c / 6;
            if local[body] == usize::MAX {
                local[body] = bodies.len();
                bodies.push(body);
            }
        }
        let size = n + 6 * bodies.len();
        // Every (row, body) block enters whole, zeros included, so the pattern depends only on
        // which bodies each row touches and stays the same while the contacts do (a lever arm
        // component that drifts off exactly zero does not change it, and the symbolic analysis
        // in the workspace is reused).
        let mut entries = Vec::with_capacity(24 * n + 6 * bodies.len());
        let minv = factors.inverse_mass();
        let mut m_jt = Vec::new();
        for i in 0..n {
            let mut k = ptr[i];
            while k < ptr[i + 1] {
                let body = idx[k] / 6;
                let mut jb = [0.0; 6];
                while k < ptr[i + 1] && idx[k] / 6 == body {
                    jb[idx[k] % 6] = val[k];
                    k += 1;
                }
                let first = n + 6 * local[body];
                for (c, &v) in jb.iter().enumerate() {
                    entries.push((i, first + c, EntryKind::Jacobian(v)));
                }
                // Column i of M⁻¹ Jᵀ (row i of J gives column i).
                for (r, row) in minv[body].iter().enumerate() {
                    let v: f64 = row.iter().zip(&jb).map(|(a, b)| a * b).sum();
                    m_jt.push((first + r, i, EntryKind::Fixed(v)));
                }
            }
            entries.push((i, i, EntryKind::Diagonal));
            if let Some((k, _)) = problem.friction_of(i) {
                entries.push((i, k, EntryKind::Coupling));
            }
        }
        entries.append(&mut m_jt);
        for r in n..size {
            entries.push((r, r, EntryKind::Fixed(-1.0)));
        }
        Self::factor_pattern(entries, size, cache)
    }

    /// The pattern, its column ordering and the symbolic LU; those of `cache` when its pattern
    /// is the same.
    fn factor_pattern(
        entries: Vec<(usize, usize, EntryKind)>,
        size: usize,
        cache: Option<SymbolicCache>,
    ) -> Result<Self, String> {
        let pairs: Vec<Pair<usize, usize>> = entries
            .iter()
            .map(|&(row, col, _)| Pair { row, col })
            .collect();
        let pattern = match cache {
            Some(c) if c.size == size && c.pairs == pairs => c,
            _ => {
                let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(
                    size, size, &pairs,
                )
                .map_err(|e| format!("the sparse Newton pattern could not be built: {e:?}"))?;
                // Supernodal always: the contact blocks (three rows per contact point, six
                // columns per body) make dense supernodes, and faer's flop-ratio rule chose the
                // simplicial LU on towers, where it took 2.6× the instructions.
                let params = LuSymbolicParams {
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    ..Default::default()
                };
                let lu = factorize_symbolic_lu(symbolic.as_ref(), params)
                    .map_err(|e| format!("the symbolic sparse LU failed: {e:?}"))?;
                SymbolicCache {
                    size,
                    pairs,
                    symbolic,
                    argsort,
                    lu,
                }
            }
        };
        // Fixed entries hold their values from the start; the others are set per iteration.
        let values = entries
            .iter()
            .map(|&(_, _, kind)| match kind {
                EntryKind::Fixed(v) => v,
                _ => 0.0,
            })
            .collect();
        let scratch = StackReq::any_of(&[
            pattern
                .lu
                .factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
            pattern.lu.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let scratch = MemBuffer::try_new(scratch)
            .map_err(|_| "no memory for the sparse LU's scratch space".to_string())?;
        Ok(Self {
            entries,
            size,
            pattern,
            values,
            numeric: NumericLu::new(),
            scratch,
        })
    }
}

impl Newton {
    /// Whether the Newton systems of `problem` are factorised sparse.
    fn sparse_for(&self, problem: &Problem) -> bool {
        let n = problem.n();
        match self.linear_system {
            LinearSystem::Dense => false,
            LinearSystem::Sparse => true,
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
        let limit = if sparse {
            self.max_sparse
        } else {
            self.max_dense
        };
        if n > limit {
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(format!(
                    "n = {n} rows: the {} Newton system is formed only up to n = {limit}",
                    if sparse { "sparse" } else { "dense" }
                )),
            );
        }
        // Formed at the first iteration that needs a direction: a warm start that already meets
        // the tolerance costs no factorisation analysis.
        let mut jacobian: Option<Jacobian> = None;
        let d = problem.diagonal_scale();
        let d = &d[..];
        let skip = skipped_rows(problem);
        let b = problem.b();
        let scale = impulse_scale(problem);
        // D⁻¹ A x (without b).
        let scaled_product = |x: &[f64], out: &mut [f64]| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = problem.row(i).dot(x) / d[i];
            }
        };
        let scaled_velocity = |f: &[f64], out: &mut [f64]| {
            scaled_product(f, out);
            for i in 0..n {
                out[i] += b[i] / d[i];
            }
        };
        let mut f = initial_impulse(problem, settings);
        let mut vel = vec![0.0; n];
        scaled_velocity(&f, &mut vel);
        let mut phi = vec![0.0; n];
        let mut theta = self.merit(problem, &f, &vel, &mut phi);
        // The merits of the last NONMONOTONE_MEMORY iterates; the line search's reference.
        let mut recent = std::collections::VecDeque::with_capacity(NONMONOTONE_MEMORY + 1);
        recent.push_back(theta);
        let mut trial_f = vec![0.0; n];
        let mut trial_vel = vec![0.0; n];
        let mut trial_phi = vec![0.0; n];
        let mut ad = vec![0.0; n];
        let mut alpha = vec![0.0; n];
        let mut beta = vec![0.0; n];
        let mut gamma = vec![0.0; n];
        let mut iterations = 0;
        let tol = settings.tolerance;
        let mut refined = false;
        // The best point measured (projected or polished iterate): the non-monotone line search
        // may end a failed solve on an iterate worse than an earlier one.
        let mut best: (f64, Vec<f64>) = (f64::INFINITY, Vec::new());
        let mut stagnation = Stagnation::new(STAGNATION_WINDOW);
        let mut warm = settings
            .warm_start
            .as_ref()
            .is_some_and(|ws| ws.len() == n && ws.iter().any(|v| *v != 0.0));
        let mut restarted = false;
        let line_search = Backtracking::newton();
        let outcome = loop {
            // The iterate may sit just outside its bounds (neither reformulation keeps it
            // feasible); its projection is tested too and returned when it is within tolerance.
            let progress = match finished(problem, &mut monitor, &f, &skip, d, tol) {
                Ok(done) => {
                    f = done;
                    break Outcome::Stopped;
                }
                Err(short) => {
                    if short.best < best.0 {
                        best = (short.best, short.candidate);
                    }
                    short.iterate
                }
            };
            let phi_inf = phi.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            if !refined && depth < MAX_REFINE_DEPTH && phi_inf <= ROUND_OFF * scale {
                refined = true;
                let (done, sub_iterations) =
                    self.refine(problem, &mut monitor, settings, &f, depth);
                iterations += sub_iterations;
                if let Some(done) = done {
                    f = done;
                    break Outcome::Stopped;
                }
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            if monitor.out_of_time() {
                break Outcome::TimeLimit;
            }
            // The window watches the iterates' own residual: the projected and polished
            // candidates can sit far below it early on, and after a restart the warm run's best
            // point (kept for the answer) must not cut the cold run short.
            if stagnation.stagnated(iterations, progress) {
                if !warm {
                    let mut reason = stagnation.reason("relative residual");
                    if restarted {
                        reason.push_str(", after a restart from zero");
                    }
                    break Outcome::Stalled(reason);
                }
                // A warm start that led astray: start again from zero (projected), keeping
                // the best point measured so far.
                warm = false;
                restarted = true;
                stagnation.restart(iterations);
                let cold = Settings {
                    warm_start: None,
                    ..settings.clone()
                };
                f = initial_impulse(problem, &cold);
                scaled_velocity(&f, &mut vel);
                theta = self.merit(problem, &f, &vel, &mut phi);
                recent.clear();
                recent.push_back(theta);
                continue;
            }
            self.linearise(problem, &f, &vel, d, &mut alpha, &mut beta, &mut gamma);
            let mu_reg = (phi_inf / scale).min(1e-2);
            let system = System {
                alpha: &alpha,
                beta: &beta,
                gamma: &gamma,
                phi: &phi,
                mu_reg,
            };
            let elimination = Elimination::of(problem, &system);
            if jacobian.is_none() && elimination.is_none() {
                match self.jacobian(problem, sparse) {
                    Ok(j) => jacobian = Some(j),
                    Err(e) => break Outcome::NumericalFailure(e),
                }
            }
            let grad = merit_gradient(problem, &system);
            let newton_dir = match (elimination, jacobian.as_mut()) {
                (Some(e), _) => reduced_direction(
                    problem,
                    &e,
                    &system,
                    !sparse,
                    SIMPLICIAL_UP_TO,
                    &mut self.workspace.reduced,
                ),
                (None, Some(Jacobian::Dense(a))) => dense_direction(problem, a, &system),
                (None, Some(Jacobian::Sparse(j))) => sparse_direction(j, &system),
                (None, None) => {
                    break Outcome::NumericalFailure("no Newton system was formed".into())
                }
            };
            let dnorm2: f64 = newton_dir.iter().map(|v| v * v).sum();
            let slope: f64 = (0..n).map(|i| grad[i] * newton_dir[i]).sum();
            let gnorm = grad.iter().map(|v| v * v).sum::<f64>().sqrt();
            let newton_ok = is_descent(&newton_dir, slope, gnorm, dnorm2.sqrt());
            let gradient_dir: Vec<f64> = (0..n).map(|i| -grad[i]).collect();
            let gslope = -(0..n).map(|i| grad[i] * grad[i]).sum::<f64>();
            let candidates: Vec<(&[f64], f64)> = if newton_ok {
                vec![(&newton_dir, slope), (&gradient_dir, gslope)]
            } else {
                vec![(&gradient_dir, gslope)]
            };
            // Non-monotone Armijo rule: sufficient decrease against the largest recent merit.
            let reference = recent.iter().copied().fold(theta, f64::max);
            let mut accepted = false;
            for (direction, slope) in candidates {
                if slope.is_nan() || slope >= 0.0 {
                    continue;
                }
                scaled_product(direction, &mut ad);
                let step = line_search.armijo(reference, slope, |t| {
                    for i in 0..n {
                        trial_f[i] = f[i] + t * direction[i];
                        trial_vel[i] = vel[i] + t * ad[i];
                    }
                    self.merit(problem, &trial_f, &trial_vel, &mut trial_phi)
                });
                if step.is_some() {
                    // The trial buffers hold the accepted step's iterate and `Φ`.
                    std::mem::swap(&mut f, &mut trial_f);
                    std::mem::swap(&mut phi, &mut trial_phi);
                    accepted = true;
                    break;
                }
            }
            iterations += 1;
            if !accepted {
                monitor.record(iterations, &f);
                break Outcome::Stalled(format!(
                    "the line search found no decrease of the merit function at iteration \
                     {iterations} (a stationary point that is not a solution)"
                ));
            }
            // Recompute the velocity from scratch so round-off does not accumulate.
            scaled_velocity(&f, &mut vel);
            theta = self.merit(problem, &f, &vel, &mut phi);
            recent.push_back(theta);
            if recent.len() > NONMONOTONE_MEMORY {
                recent.pop_front();
            }
            monitor.record(iterations, &f);
            if f.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite iterate at iteration {iterations}"
                ));
            }
        };
        if let Some(Jacobian::Sparse(j)) = jacobian {
            self.workspace.symbolic = Some(j.pattern);
            self.workspace.numeric = j.numeric;
        }
        // A stop within tolerance returns the finished iterate already; otherwise the better of
        // the iterate itself and `best`. Every other exit leaves `f` as [`finished`] measured
        // it at the top of the last iteration, so its projection and polish are in `best`
        // already; the one exception, a non-finite iterate, falls back on `best` too.
        if outcome != Outcome::Stopped {
            let raw = monitor.residual_of(&f);
            if raw.is_nan() || best.0 <= raw {
                f = best.1;
            }
        }
        monitor.finish(f, iterations, outcome)
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
    fn jacobian(&mut self, problem: &Problem, sparse: bool) -> Result<Jacobian, String> {
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
                SparseJacobian::augmented(problem, factors, cache)
            }
            _ => SparseJacobian::new(problem, cache),
        };
        built.map(|mut j| {
            j.numeric = std::mem::take(&mut self.workspace.numeric);
            Jacobian::Sparse(Box::new(j))
        })
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

/// What [`finished`] measured at an iterate short of the tolerance.
struct ShortOfTolerance {
    /// The smallest residual of the iterate, its projection and the polished projection.
    best: f64,
    /// The point of that residual.
    candidate: Vec<f64>,
    /// The residual of the iterate itself.
    iterate: f64,
}

/// Whether the augmented body-space system is worth its extra unknowns: when `A` has more
/// than twice its entries (about `2·nnz(J) + n + 6·bodies`). Measured: a 40-box tower (A has
/// 1.4× the augmented entries) factorises in 0.6× the time in the `A` form; the 4,800-row
/// `pyramid_20` island (3.5×) in 0.7× the time in the augmented form.
fn augmented_pays(problem: &Problem, factors: &DelassusFactors) -> bool {
    let jac = factors.jacobian();
    let augmented = 2 * jac.compute_nnz() + problem.n() + jac.ncols();
    problem.nnz() > 2 * augmented
}

/// The merit gradient `∇θ = HᵀΦ` for `H = diag(α) + diag(β) D⁻¹A + coupling` (the
/// regularisation is not part of `H`), in one pass over the stored entries of `A`, whatever its
/// storage.
fn merit_gradient(problem: &Problem, system: &System<'_>) -> Vec<f64> {
    let &System {
        alpha,
        beta,
        gamma,
        phi,
        ..
    } = system;
    let n = phi.len();
    let mut grad = vec![0.0; n];
    for i in 0..n {
        let s = beta[i] * phi[i];
        if s != 0.0 {
            for (c, a) in problem.row(i).iter() {
                grad[c] += a * s;
            }
        }
        grad[i] += alpha[i] * phi[i];
        if gamma[i] != 0.0 {
            if let Some((k, _)) = problem.friction_of(i) {
                grad[k] += gamma[i] * phi[i];
            }
        }
    }
    grad
}

/// The Newton direction `(H + μI)⁻¹(−Φ)`, dense.
fn dense_direction(problem: &Problem, a: &Mat<f64>, system: &System<'_>) -> Vec<f64> {
    let &System {
        alpha,
        beta,
        gamma,
        phi,
        mu_reg,
    } = system;
    let n = phi.len();
    let mut h = Mat::from_fn(n, n, |i, j| beta[i] * a[(i, j)]);
    for i in 0..n {
        h[(i, i)] += alpha[i] + mu_reg;
        if gamma[i] != 0.0 {
            if let Some((k, _)) = problem.friction_of(i) {
                h[(i, k)] += gamma[i];
            }
        }
    }
    let mut dir = Mat::from_fn(n, 1, |i, _| -phi[i]);
    h.partial_piv_lu().solve_in_place(&mut dir);
    (0..n).map(|i| dir[(i, 0)]).collect()
}

/// The Newton direction `(H + μI)⁻¹(−Φ)` with the sparse LU. A failed numeric factorisation
/// gives a non-finite direction (the gradient step is then taken).
fn sparse_direction(j: &mut SparseJacobian, system: &System<'_>) -> Vec<f64> {
    let &System {
        alpha,
        beta,
        gamma,
        phi,
        mu_reg,
    } = system;
    for (v, &(i, _, kind)) in j.values.iter_mut().zip(&j.entries) {
        *v = match kind {
            EntryKind::A(a) | EntryKind::Jacobian(a) => beta[i] * a,
            EntryKind::Diagonal => alpha[i] + mu_reg,
            EntryKind::Coupling => gamma[i],
            EntryKind::Fixed(v) => v,
        };
    }
    let rhs: Vec<f64> = phi.iter().map(|v| -v).collect();
    factor_and_solve(j, &rhs)
}

/// Factorises `j` with its current values and solves for `rhs` (padded with zeros up to the
/// system's size); the first `rhs.len()` unknowns. A failed factorisation gives NaN.
fn factor_and_solve(j: &mut SparseJacobian, rhs: &[f64]) -> Vec<f64> {
    let n = rhs.len();
    let failed = || vec![f64::NAN; n];
    let p = &j.pattern;
    let Ok(h) = SparseColMat::new_from_argsort(p.symbolic.clone(), &p.argsort, &j.values) else {
        return failed();
    };
    let stack = MemStack::new(&mut j.scratch);
    let Ok(lu) = p.lu.factorize_numeric_lu(
        &mut j.numeric,
        h.as_ref(),
        Par::Seq,
        stack,
        Default::default(),
    ) else {
        return failed();
    };
    let mut dir = Mat::from_fn(j.size, 1, |i, _| if i < n { rhs[i] } else { 0.0 });
    lu.solve_in_place_with_conj(
        Conj::No,
        dir.as_mut(),
        Par::Seq,
        MemStack::new(&mut j.scratch),
    );
    (0..n).map(|i| dir[(i, 0)]).collect()
}

/// One Newton system `(H + μI) d = −Φ`: `H`'s coefficients as [`Newton::linearise`] gives them
/// (`beta` holding `β_i / d_i`), `Φ` and the regularisation `μ`.
struct System<'a> {
    alpha: &'a [f64],
    beta: &'a [f64],
    gamma: &'a [f64],
    phi: &'a [f64],
    mu_reg: f64,
}

/// The rows of `H + μI` that [`reduced_direction`] eliminates, and how: a row with `β_i = 0`
/// (min-map: a row clamped at a bound; FB: a row exactly at its bound with a separating
/// velocity) reads `(α_i + μ) d_i + γ_i d_k = −Φ_i`, so `d_i = c_i + g_i d_k` with `g_i ≠ 0`
/// only for a friction row whose normal `k` is kept.
struct Elimination {
    /// Position of each kept row in the reduced system, `usize::MAX` for an eliminated one.
    position: Vec<usize>,
    /// The kept rows, increasing.
    kept: Vec<usize>,
    /// `c_i` for eliminated rows.
    offset: Vec<f64>,
    /// `(g_i, k)` for eliminated friction rows whose normal is kept.
    slope: Vec<Option<(f64, usize)>>,
}

impl Elimination {
    /// `None` when fewer than [`REDUCE_FROM`] of the rows can be eliminated (the full system
    /// is then cheaper to refactorise on its cached pattern) or a pivot `α_i + μ` is not
    /// positive.
    fn of(problem: &Problem, system: &System<'_>) -> Option<Self> {
        let &System {
            alpha,
            beta,
            gamma,
            phi,
            mu_reg,
        } = system;
        let n = phi.len();
        let eliminated = beta.iter().filter(|&&b| b == 0.0).count();
        if eliminated == 0 || (eliminated as f64) < REDUCE_FROM * n as f64 {
            return None;
        }
        let mut position = vec![usize::MAX; n];
        let mut kept = Vec::with_capacity(n - eliminated);
        for i in 0..n {
            if beta[i] != 0.0 {
                position[i] = kept.len();
                kept.push(i);
            }
        }
        let mut offset = vec![0.0; n];
        let mut slope = vec![None; n];
        // Normal rows first (they carry no coupling), then the friction rows that hang on them.
        for pass in 0..2 {
            for i in 0..n {
                if beta[i] != 0.0 || (pass == 0) == problem.friction_of(i).is_some() {
                    continue;
                }
                let pivot = alpha[i] + mu_reg;
                if !(pivot > 0.0 && pivot.is_finite()) {
                    return None;
                }
                offset[i] = -phi[i] / pivot;
                if gamma[i] != 0.0 {
                    let (k, _) = problem.friction_of(i)?;
                    let g = -gamma[i] / pivot;
                    if position[k] == usize::MAX {
                        offset[i] += g * offset[k];
                    } else {
                        slope[i] = Some((g, position[k]));
                    }
                }
            }
        }
        Some(Self {
            position,
            kept,
            offset,
            slope,
        })
    }

    /// The reduced system `R d_K = r` over the kept rows, entry by entry (duplicated positions
    /// add up), and its right-hand side: row `i` of `H + μI` with every eliminated `d_c`
    /// replaced by `c_c + g_c d_k`.
    fn reduced_system(
        &self,
        problem: &Problem,
        system: &System<'_>,
        mut entry: impl FnMut(usize, usize, f64),
    ) -> Vec<f64> {
        let System {
            beta, gamma, phi, ..
        } = system;
        let mut rhs = vec![0.0; self.kept.len()];
        let mut add = |r: usize, c: usize, v: f64, rhs: &mut [f64]| {
            let p = self.position[c];
            if p != usize::MAX {
                entry(r, p, v);
            } else {
                rhs[r] -= v * self.offset[c];
                if let Some((g, k)) = self.slope[c] {
                    entry(r, k, v * g);
                }
            }
        };
        for (r, &i) in self.kept.iter().enumerate() {
            rhs[r] -= phi[i];
            for (c, a) in problem.row(i).iter() {
                add(r, c, beta[i] * a, &mut rhs);
            }
            add(r, i, system.alpha[i] + system.mu_reg, &mut rhs);
            if gamma[i] != 0.0 {
                if let Some((k, _)) = problem.friction_of(i) {
                    add(r, k, gamma[i], &mut rhs);
                }
            }
        }
        rhs
    }

    /// The full direction from the kept rows' part `x`.
    fn expand(&self, x: &[f64]) -> Vec<f64> {
        (0..self.position.len())
            .map(|i| match self.position[i] {
                usize::MAX => self.offset[i] + self.slope[i].map_or(0.0, |(g, k)| g * x[k]),
                p => x[p],
            })
            .collect()
    }
}

/// The Newton direction `(H + μI)⁻¹(−Φ)` through the [`Elimination`] of the rows with
/// `β_i = 0`: dense LU of the reduced matrix when `dense`; else, up to `simplicial_up_to`
/// ([`SIMPLICIAL_UP_TO`]) kept rows, [`sparse_reduced_solve`], and above, faer's sparse LU on
/// the reduced pattern (the symbolic analysis in `cache` reused while the kept rows, and so the
/// pattern, stay the same). A failed factorisation gives a non-finite direction.
fn reduced_direction(
    problem: &Problem,
    elimination: &Elimination,
    system: &System<'_>,
    dense: bool,
    simplicial_up_to: usize,
    cache: &mut ReducedCache,
) -> Vec<f64> {
    let m = elimination.kept.len();
    let x = if dense {
        let mut r = Mat::<f64>::zeros(m, m);
        let rhs = elimination.reduced_system(problem, system, |i, j, v| r[(i, j)] += v);
        let mut x = Mat::from_fn(m, 1, |i, _| rhs[i]);
        r.partial_piv_lu().solve_in_place(&mut x);
        (0..m).map(|i| x[(i, 0)]).collect::<Vec<f64>>()
    } else {
        let mut rows = RowAssembly::new(m, problem.nnz());
        let rhs = elimination.reduced_system(problem, system, |i, j, v| rows.add(i, j, v));
        let rt = rows.transpose();
        if m <= simplicial_up_to {
            sparse_reduced_solve(problem, elimination, rt, &rhs, cache)
        } else {
            let mut entries = Vec::with_capacity(rt.val().len());
            for r in 0..m {
                for (c, &v) in rt.row_idx_of_col(r).zip(rt.val_of_col(r)) {
                    entries.push((r, c, EntryKind::Fixed(v)));
                }
            }
            match SparseJacobian::factor_pattern(entries, m, cache.symbolic.take()) {
                Ok(mut j) => {
                    j.numeric = std::mem::take(&mut cache.numeric);
                    let x = factor_and_solve(&mut j, &rhs);
                    cache.symbolic = Some(j.pattern);
                    cache.numeric = j.numeric;
                    x
                }
                Err(_) => vec![f64::NAN; m],
            }
        }
    };
    elimination.expand(&x)
}

/// A sparse matrix `R` assembled row by row into the compressed columns of `Rᵀ`: the entries of
/// a row arrive together and rows in increasing order, as [`Elimination::reduced_system`] gives
/// them, so no sort of the entries is needed; duplicated positions add up.
struct RowAssembly {
    size: usize,
    /// Start of each row begun so far (the column pointers of `Rᵀ`).
    start: Vec<usize>,
    col: Vec<usize>,
    val: Vec<f64>,
    /// Per column, where its entry of the current row is (an older position: none yet).
    slot: Vec<usize>,
}

impl RowAssembly {
    fn new(size: usize, capacity: usize) -> Self {
        let mut start = Vec::with_capacity(size + 1);
        start.push(0);
        Self {
            size,
            start,
            col: Vec::with_capacity(capacity),
            val: Vec::with_capacity(capacity),
            slot: vec![usize::MAX; size],
        }
    }

    fn add(&mut self, r: usize, c: usize, v: f64) {
        while self.start.len() <= r {
            self.start.push(self.col.len());
        }
        let s = self.slot[c];
        if s != usize::MAX && s >= self.start[r] {
            self.val[s] += v;
        } else {
            self.slot[c] = self.col.len();
            self.col.push(c);
            self.val.push(v);
        }
    }

    /// `Rᵀ`, each column's row indices sorted.
    fn transpose(mut self) -> SparseColMat<usize, f64> {
        while self.start.len() <= self.size {
            self.start.push(self.col.len());
        }
        let mut pairs = Vec::new();
        for r in 0..self.size {
            let (a, b) = (self.start[r], self.start[r + 1]);
            pairs.clear();
            pairs.extend((a..b).map(|k| (self.col[k], self.val[k])));
            pairs.sort_unstable_by_key(|&(c, _)| c);
            for (k, &(c, v)) in (a..b).zip(&pairs) {
                self.col[k] = c;
                self.val[k] = v;
            }
        }
        let symbolic =
            SymbolicSparseColMat::new_checked(self.size, self.size, self.start, None, self.col);
        SparseColMat::new(symbolic, self.val)
    }
}

/// The solution of the reduced system `R x = rhs`, given `Rᵀ`, by the sparse LU of `Rᵀ`
/// ([`SparseLu`]: left-looking, threshold partial pivoting, no symbolic analysis) and a
/// transposed solve. The column order is the island's fill-reducing ordering ([`island_rank`],
/// computed once per island solve) restricted to the kept rows, so an iteration does no
/// ordering or symbolic analysis of its own; the kept rows change at almost every iteration
/// where contacts separate and slide, which made the per-iteration ordering (COLAMD, 17 % of
/// the solve) the largest single cost on FCLIB spheres-in-a-box. Measured there (newton-min to
/// 1e-6, 63 iterations; fastest of 30 solves in one process): 34.1 ms per solve with COLAMD
/// and faer's supernodal LU per reduced system; with the restricted ordering, 29.0 ms with
/// faer's supernodal LU (its symbolic analysis still runs per iteration, and on the
/// symmetric ordering it assumes more fill), 25.6 ms with faer's simplicial LU, 23.1 ms with
/// [`SparseLu`]. A restricted COLAMD ordering of the island instead of AMD: 33–35 ms. `NaN`
/// when the factorisation fails.
fn sparse_reduced_solve(
    problem: &Problem,
    elimination: &Elimination,
    rt: SparseColMat<usize, f64>,
    rhs: &[f64],
    cache: &mut ReducedCache,
) -> Vec<f64> {
    let m = rhs.len();
    if cache.rank.len() != problem.n() {
        cache.rank = island_rank(problem);
    }
    let mut fwd: Vec<usize> = (0..m).collect();
    fwd.sort_unstable_by_key(|&p| cache.rank[elimination.kept[p]]);
    let (symbolic, val) = (rt.symbolic(), rt.val());
    if cache
        .lu
        .factorize(symbolic.col_ptr(), symbolic.row_idx(), val, &fwd)
        .is_err()
    {
        return vec![f64::NAN; m];
    }
    let mut x = rhs.to_vec();
    cache.lu.solve_transpose(&mut x);
    x
}

/// A fill-reducing ordering of an island, as each row's rank: approximate minimum degree
/// (faer's AMD) on the pattern of `A` and the friction coupling (symmetrised). The identity
/// when AMD fails (any order gives the same direction, only with more fill).
fn island_rank(problem: &Problem) -> Vec<usize> {
    let n = problem.n();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(problem.nnz() + n);
    col_ptr.push(0);
    let mut col = Vec::new();
    for i in 0..n {
        col.clear();
        col.extend(problem.row(i).iter().map(|(j, _)| j));
        col.push(i);
        if let Some((k, _)) = problem.friction_of(i) {
            col.push(k);
        }
        col.sort_unstable();
        col.dedup();
        row_idx.extend_from_slice(&col);
        col_ptr.push(row_idx.len());
    }
    let nnz = row_idx.len();
    let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    let mut fwd = vec![0usize; n];
    let mut inv = vec![0usize; n];
    let Ok(mut mem) = MemBuffer::try_new(amd::order_scratch::<usize>(n, nnz)) else {
        return (0..n).collect();
    };
    match amd::order(
        &mut fwd,
        &mut inv,
        pattern.as_ref(),
        Default::default(),
        MemStack::new(&mut mem),
    ) {
        Ok(_) => inv,
        Err(_) => (0..n).collect(),
    }
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
                newton.linearise(&p, &f, &vel, &d, &mut alpha, &mut beta, &mut gamma);
                let phi: Vec<f64> = (0..n)
                    .map(|i| {
                        let (lo, hi) = p.bounds_at(i, &f);
                        let dmu = p.friction_of(i).map_or(0.0, |(_, mu)| mu);
                        newton.row(f[i], vel[i], lo, hi, dmu).phi
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
                    let reduced =
                        reduced_direction(&p, &e, &system, dense, simplicial_up_to, &mut cache);
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
    /// iterate can be worse (on this infeasible instance it was, 5.0e-4 against 2.7e-4).
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
                assert_eq!(r.status, Status::IterationLimit, "{}", s.name());
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
