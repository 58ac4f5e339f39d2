//! Global semismooth Newton on the exact Coulomb cone: one driver for three per-contact
//! reformulations of Coulomb's law, the Alart–Curnier function ([`crate::cone`]'s
//! `alart_curnier`, Siconos' `FC3D_NSN_AC`), the Fischer–Burmeister function on the
//! second-order cone (`fischer_burmeister`, `FC3D_NSN_FB`) and the natural map
//! (`natural_map`, `FC3D_NSN_NM`).
//!
//! Each reformulation gives, contact by contact, `Φ_c(r_c, u_c)` with `Φ_c = 0` exactly where
//! contact `c` meets Coulomb's law, and an element of its generalised Jacobian
//! `dΦ_c = P_c dr_c + Q_c du_c`, with `ρ_c = 1 / d_c` (`d_c` the diagonal scale of the normal
//! row). With `u = W r + q`, one iteration solves
//!
//! ```text
//! (P + Q W + λ I) d = −Φ,     λ = min(10⁻², ‖Φ‖∞ / s)   (s the largest ρ_c ‖q_c‖; 1 if zero)
//! ```
//!
//! — the Levenberg term keeps the system regular where contacts are degenerate and vanishes at
//! the solution — and takes a non-monotone Armijo step on the merit `θ = ½‖Φ‖²` (`σ = 10⁻⁴`,
//! halving, at most 40 times; sufficient decrease against the largest `θ` of the last
//! [`NONMONOTONE_MEMORY`] iterates, Grippo, Lampariello, Lucidi 1986), falling back to the
//! steepest-descent direction `−(P + Q W)ᵀ Φ` when the Newton direction is not a descent
//! direction or no step along it passes.
//!
//! `P + Q W` has the 3×3 block pattern of `W` (block `(c, e)` is `Q_c W_ce`, plus `P_c` on the
//! diagonal), fixed for the whole solve. Up to [`ConeNewton::dense_up_to`] rows it is formed
//! dense and factorised by a partial-pivoting LU; above, it is assembled in compressed columns
//! on the block pattern of `W` and factorised by faer's sparse LU (COLAMD ordering,
//! supernodal), the ordering and symbolic analysis computed once per solve and reused by every
//! iteration. Contacts that `W` does not couple give independent diagonal blocks of the
//! factorisation, so the sparse LU works island by island without a partition of its own.
//!
//! * **Problem class**: FC3D ([`crate::ConeProblem`]), dense or sparse `W`, up to
//!   [`ConeNewton::max_rows`] rows (default 300,000; above it the solve is `Unsupported`).
//!   Locally quadratically convergent near a non-degenerate solution; the line search on `θ`
//!   is not globally convergent for Coulomb friction (Acary, Brémond, Huber 2018 measure these
//!   methods as fast and less robust than NSGS), so a solve may end `Stalled` at a stationary
//!   point of `θ`.
//! * **Cost**: per iteration one LU (dense: `⅔ n³`; sparse: the fill of the block pattern of
//!   `W`), `O(nnz(W))` for `Q W` and `∇θ`, and `O(n)` per line-search trial. The LU is not
//!   interruptible, so the solve never starts one it cannot finish: the sparse LU's size is
//!   estimated by a symbolic Cholesky analysis of `W`'s block pattern before any numerical
//!   work, and a system above [`ConeNewton::max_factor_entries`] (default
//!   [`MAX_FACTOR_ENTRIES`]) makes the solve `Unsupported`; the time budget is checked before
//!   each iteration, which is not started when the last one's length would carry it past the
//!   budget (`TimeLimit`).
//! * **Stopping rule**: the cone residual ([`crate::cone`]) of the iterate with each contact
//!   projected onto its cone is at most the tolerance; that point is returned. A solve that
//!   ends short of it returns the best such point it measured.
//! * **Warm start**: uses [`Settings::warm_start`], projected onto the cones.
//!
//! **Newton–Krylov** ([`ConeNewton::krylov`], `newton-krylov-ac`, `newton-krylov-fb-cone`): no
//! matrix is formed and nothing is factorised, so there is no row or fill cap. Each direction
//! comes from restarted GMRES ([`crate::linalg::krylov`]) on the same system, applied as
//! `P_c x_c + Q_c (W x)_c + λ x_c` contact by contact with the products `W x` on the stored
//! blocks of `W`, right-preconditioned by the inverse of each contact's 3×3 diagonal block
//! `P_c + Q_c W_cc + λI` (block Jacobi), to the relative tolerance of the Eisenstat–Walker
//! forcing sequence (choice 2; S. C. Eisenstat, H. F. Walker, SIAM J. Sci. Comput. 17, 1996).
//! The time budget is checked between GMRES iterations (`TimeLimit` when it runs out there);
//! a GMRES solve that stops short (iteration cap, breakdown, stagnation) gives its best iterate
//! to the line search, which falls back on the gradient direction when it is not a descent
//! direction.
//!
//! References: P. Alart, A. Curnier, CMAME 92, 1991; M. Fukushima, Z.-Q. Luo, P. Tseng, SIAM J.
//! Optim. 12, 2002; V. Acary, M. Brémond, O. Huber, *On solving contact problems with Coulomb
//! friction: formulations and numerical comparisons*, 2018; Siconos numerics,
//! `fc3d_nonsmooth_Newton_solvers.c` (`FC3D_NSN_AC`, `FC3D_NSN_FB`, `FC3D_NSN_NM`).

use crate::cone::{initial_reaction, project_onto_cone, ConeMonitor, ConeProblem, ConeSolver};
use crate::lcp::newton::{KrylovSettings, MAX_REGULARISATION};
use crate::linalg::krylov::{gmres, BlockJacobi, Forcing, GmresParams, KrylovStatus};
use crate::linalg::newton_system::KRYLOV_ETA_MIN;
use crate::linalg::newton_system::{factor_and_solve, EntryKind, PatternRefusal, SparseJacobian};
use crate::linalg::symmetric_fill;
use crate::solver::line_search::{is_descent, Backtracking};
use crate::solver::{Outcome, Settings, SolveResult};
use faer::linalg::solvers::Solve;
use faer::Mat;
use std::collections::VecDeque;

/// Problem classes handled by the Alart–Curnier variant.
pub(crate) const PROBLEM_CLASSES_AC: &str =
    "FC3D cone (exact Coulomb); global Alart–Curnier Newton, LU dense up to 300 rows, sparse on W's block pattern above (up to 300000 rows and an LU estimated at 20 million entries)";
/// Problem classes handled by the Fischer–Burmeister variant.
pub(crate) const PROBLEM_CLASSES_FB: &str =
    "FC3D cone (exact Coulomb); global Newton on the second-order-cone Fischer–Burmeister function, LU dense up to 300 rows, sparse above (up to an LU estimated at 20 million entries)";
/// Problem classes handled by the natural-map variant.
pub(crate) const PROBLEM_CLASSES_NM: &str =
    "FC3D cone (exact Coulomb); global Newton on the natural map r − P_K(r − ρû), LU dense up to 300 rows, sparse above (up to an LU estimated at 20 million entries)";

/// The registry's entry of `newton-ac`.
pub static NEWTON_AC: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-ac",
    summary: "global Alart-Curnier semismooth Newton",
    problem_classes: PROBLEM_CLASSES_AC,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(ConeNewton::alart_curnier())),
};

/// The registry's entry of `newton-fb-cone`.
pub static NEWTON_FB_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-fb-cone",
    summary: "global semismooth Newton on the second-order-cone Fischer-Burmeister function",
    problem_classes: PROBLEM_CLASSES_FB,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(ConeNewton::fischer_burmeister())),
};

/// The registry's entry of `newton-nm-cone`.
pub static NEWTON_NM_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-nm-cone",
    summary: "global semismooth Newton on the natural map",
    problem_classes: PROBLEM_CLASSES_NM,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: &[],
    make: crate::registry::Make::Cone(|_params| Box::new(ConeNewton::natural_map())),
};

/// Problem classes handled by the Newton–Krylov variants.
pub(crate) const PROBLEM_CLASSES_KRYLOV: &str =
    "FC3D cone (exact Coulomb); global semismooth Newton with GMRES directions (products with the stored W, per-contact block-Jacobi preconditioner, Eisenstat-Walker forcing); no factorisation, no size or fill cap";

/// Parameters of the cone Newton–Krylov entries.
const CONE_KRYLOV_PARAMS: &[crate::registry::ParamSpec] = &[
    crate::registry::ParamSpec::count(
        "restart",
        crate::lcp::newton::DEFAULT_RESTART,
        1,
        1000,
        "GMRES basis vectors per cycle before a restart",
    ),
    crate::registry::ParamSpec::count(
        "max_krylov",
        crate::lcp::newton::DEFAULT_MAX_KRYLOV,
        1,
        1_000_000,
        "GMRES iterations per Newton step",
    ),
    crate::registry::ParamSpec::real(
        "forcing",
        crate::lcp::newton::DEFAULT_ETA_MAX,
        1e-10,
        0.99,
        "largest relative GMRES tolerance (Eisenstat-Walker eta_max)",
    ),
];

/// `newton` with GMRES directions and the settings of `params`.
fn krylov_from(newton: ConeNewton, params: &crate::registry::Params) -> Box<ConeNewton> {
    Box::new(ConeNewton {
        krylov: Some(KrylovSettings {
            restart: params.count("restart"),
            max_krylov: params.count("max_krylov"),
            eta_max: params.get("forcing"),
        }),
        ..newton
    })
}

/// The registry's entry of `newton-krylov-ac`.
pub static NEWTON_KRYLOV_AC: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-krylov-ac",
    summary:
        "global Alart-Curnier semismooth Newton with matrix-free GMRES directions (Newton-Krylov)",
    problem_classes: PROBLEM_CLASSES_KRYLOV,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: CONE_KRYLOV_PARAMS,
    make: crate::registry::Make::Cone(|params| krylov_from(ConeNewton::alart_curnier(), params)),
};

/// The registry's entry of `newton-krylov-fb-cone`.
pub static NEWTON_KRYLOV_FB_CONE: crate::registry::SolverEntry = crate::registry::SolverEntry {
    name: "newton-krylov-fb-cone",
    summary: "global second-order-cone Fischer-Burmeister semismooth Newton with matrix-free GMRES directions (Newton-Krylov)",
    problem_classes: PROBLEM_CLASSES_KRYLOV,
    iteration_unit: "Newton steps",
    iterative: true,
    relaxation: None,
    params: CONE_KRYLOV_PARAMS,
    make: crate::registry::Make::Cone(|params| {
        krylov_from(ConeNewton::fischer_burmeister(), params)
    }),
};

/// Rows up to which the Newton system is formed dense by default: below it a dense LU costs
/// less than the sparse ordering and symbolic analysis.
pub const DENSE_UP_TO: usize = 300;
/// Largest problem, in rows, the Newton system is formed for by default.
pub const MAX_ROWS: usize = 300_000;
/// Largest sparse LU a solve factorises, in entries of `L` and `U` estimated before any
/// numerical work ([`crate::linalg::cholesky_fill`]): a factorisation cannot be interrupted,
/// so one that would take longer than a budget of seconds is refused instead of started. On a
/// 2-core x86-64 machine faer's supernodal LU of the Newton system took 19 ms at an estimate
/// of 0.4 million entries (a 105-box wall), 0.5 s at 6 million (a 3,500-contact sphere pile),
/// 15 s at 100 million (a 13,900-contact box pyramid) and 88 s at 330 million (a 30,000-contact
/// pile): the limit stands at about 2 s there.
pub const MAX_FACTOR_ENTRIES: usize = 20_000_000;
/// The non-monotone line search's memory: a step is accepted on sufficient decrease against
/// the largest merit of the last this many iterates, as in [`crate::Newton`].
pub const NONMONOTONE_MEMORY: usize = 10;

/// `Φ`, `P = ∂Φ/∂r` and `Q = ∂Φ/∂u` of one contact (3×3, row-major).
pub(crate) struct Linearisation {
    pub(crate) phi: [f64; 3],
    pub(crate) p: [[f64; 3]; 3],
    pub(crate) q: [[f64; 3]; 3],
}

/// The per-contact reformulation of Coulomb's law a [`ConeNewton`] works on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConeFunction {
    /// Alart and Curnier's augmented-Lagrangian function.
    AlartCurnier,
    /// The Fischer–Burmeister function on the second-order cone.
    FischerBurmeister,
    /// The natural map `r − P_K(r − ρ û)`.
    NaturalMap,
}

impl ConeFunction {
    /// `Φ_c` and an element of its generalised Jacobian at `(r, u)`.
    pub(crate) fn linearise(self, mu: f64, rho: f64, r: [f64; 3], u: [f64; 3]) -> Linearisation {
        match self {
            ConeFunction::AlartCurnier => crate::cone::alart_curnier::linearise(mu, rho, r, u),
            ConeFunction::FischerBurmeister => {
                crate::cone::fischer_burmeister::linearise(mu, rho, r, u)
            }
            ConeFunction::NaturalMap => crate::cone::natural_map::linearise(mu, rho, r, u),
        }
    }
}

/// Global semismooth Newton on the cone. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeNewton {
    /// The reformulation. Default [`ConeFunction::AlartCurnier`].
    pub function: ConeFunction,
    /// Rows up to which the Newton system is dense; sparse above. Default [`DENSE_UP_TO`].
    pub dense_up_to: usize,
    /// Largest number of rows solved. Default [`MAX_ROWS`].
    pub max_rows: usize,
    /// Largest LU of the sparse Newton system, in entries of `L` and `U` as estimated before
    /// any numerical work; a larger one makes the solve `Unsupported`. Default
    /// [`MAX_FACTOR_ENTRIES`].
    pub max_factor_entries: usize,
    /// GMRES directions with these settings instead of a factorisation (the module
    /// documentation's Newton–Krylov paragraph); `max_rows` and `max_factor_entries` then do
    /// not apply. Default `None`.
    pub krylov: Option<KrylovSettings>,
}

/// The Alart–Curnier Newton method (`newton-ac`), the name it had before its variants.
pub type NewtonAc = ConeNewton;

impl Default for ConeNewton {
    fn default() -> Self {
        Self::alart_curnier()
    }
}

impl ConeNewton {
    /// The Alart–Curnier variant (`newton-ac`) with default settings.
    pub fn alart_curnier() -> Self {
        Self::with(ConeFunction::AlartCurnier)
    }

    /// The Fischer–Burmeister variant (`newton-fb-cone`) with default settings.
    pub fn fischer_burmeister() -> Self {
        Self::with(ConeFunction::FischerBurmeister)
    }

    /// The natural-map variant (`newton-nm-cone`) with default settings.
    pub fn natural_map() -> Self {
        Self::with(ConeFunction::NaturalMap)
    }

    fn with(function: ConeFunction) -> Self {
        Self {
            function,
            dense_up_to: DENSE_UP_TO,
            max_rows: MAX_ROWS,
            max_factor_entries: MAX_FACTOR_ENTRIES,
            krylov: None,
        }
    }
}

#[inline]
fn take(x: &[f64]) -> [f64; 3] {
    [x[0], x[1], x[2]]
}

/// `W` by 3×3 blocks: block row `c` holds `(e, W_ce)` for each contact `e` it couples to
/// (a block with a nonzero entry, and always the diagonal one), `e` increasing.
struct BlockRows(Vec<Vec<(usize, [[f64; 3]; 3])>>);

impl BlockRows {
    fn of(problem: &ConeProblem) -> Self {
        let w = problem.delassus();
        let nc = problem.contacts();
        let mut slot = vec![usize::MAX; nc];
        let rows = (0..nc)
            .map(|c| {
                let mut blocks: Vec<(usize, [[f64; 3]; 3])> = vec![(c, [[0.0; 3]; 3])];
                slot[c] = 0;
                for a in 0..3 {
                    for (j, v) in w.row(3 * c + a).iter() {
                        if v == 0.0 {
                            continue;
                        }
                        let e = j / 3;
                        if slot[e] == usize::MAX {
                            slot[e] = blocks.len();
                            blocks.push((e, [[0.0; 3]; 3]));
                        }
                        blocks[slot[e]].1[a][j % 3] = v;
                    }
                }
                for (e, _) in &blocks {
                    slot[*e] = usize::MAX;
                }
                blocks.sort_unstable_by_key(|b| b.0);
                blocks
            })
            .collect();
        Self(rows)
    }

    /// `out = W x`.
    fn apply(&self, x: &[f64], out: &mut [f64]) {
        for (c, blocks) in self.0.iter().enumerate() {
            let mut acc = [0.0; 3];
            for (e, b) in blocks {
                let xe = take(&x[3 * e..]);
                for (a, s) in acc.iter_mut().enumerate() {
                    *s += b[a][0] * xe[0] + b[a][1] * xe[1] + b[a][2] * xe[2];
                }
            }
            out[3 * c..3 * c + 3].copy_from_slice(&acc);
        }
    }

    /// Stored 3×3 blocks.
    fn blocks(&self) -> usize {
        self.0.iter().map(Vec::len).sum()
    }
}

/// The storage of the Newton matrix.
enum NewtonMatrix {
    Dense(Mat<f64>),
    Sparse(Box<SparseJacobian>),
    /// Nothing formed: each contact's `P_c`, `Q_c` and diagonal block for GMRES.
    Krylov(Box<KrylovMatrix>),
}

/// What GMRES needs of the cone Newton system `P + Q W + λI`.
struct KrylovMatrix {
    p: Vec<[[f64; 3]; 3]>,
    q: Vec<[[f64; 3]; 3]>,
    lambda: f64,
    diagonal: Vec<[[f64; 3]; 3]>,
    preconditioner: BlockJacobi,
    forcing: Forcing,
    params: GmresParams,
    /// How the last GMRES solve ended.
    status: KrylovStatus,
}

impl KrylovMatrix {
    fn new(contacts: usize, settings: KrylovSettings) -> Self {
        Self {
            p: vec![[[0.0; 3]; 3]; contacts],
            q: vec![[[0.0; 3]; 3]; contacts],
            lambda: 0.0,
            diagonal: vec![[[0.0; 3]; 3]; contacts],
            preconditioner: BlockJacobi::new(
                (0..3 * contacts).collect(),
                (0..=contacts).map(|c| 3 * c).collect(),
            ),
            forcing: Forcing::new(settings.eta_max, KRYLOV_ETA_MIN),
            params: GmresParams {
                restart: settings.restart,
                max_iterations: settings.max_krylov,
                tolerance: settings.eta_max,
            },
            status: KrylovStatus::Converged,
        }
    }

    /// GMRES on `(P + Q W + λI) x = rhs`, `stop` asked between iterations; the best iterate
    /// (how GMRES ended is kept in `status`).
    fn solve(&mut self, rhs: &[f64], blocks: &BlockRows, stop: impl FnMut() -> bool) -> Vec<f64> {
        let norm = rhs.iter().map(|v| v * v).sum::<f64>().sqrt();
        self.params.tolerance = self.forcing.next(norm);
        let diagonal = &self.diagonal;
        self.preconditioner
            .update(|_, i, j| diagonal[i / 3][i % 3][j % 3]);
        let (p, q, lambda) = (&self.p, &self.q, self.lambda);
        let mut wx = vec![0.0; rhs.len()];
        let apply = |x: &[f64], out: &mut [f64]| {
            blocks.apply(x, &mut wx);
            for (c, (pc, qc)) in p.iter().zip(q).enumerate() {
                let (xc, wc) = (take(&x[3 * c..]), take(&wx[3 * c..]));
                for a in 0..3 {
                    out[3 * c + a] = (0..3)
                        .map(|m| pc[a][m] * xc[m] + qc[a][m] * wc[m])
                        .sum::<f64>()
                        + lambda * xc[a];
                }
            }
        };
        let preconditioner = &self.preconditioner;
        let r = gmres(
            apply,
            |x, out| preconditioner.apply(x, out),
            rhs,
            &self.params,
            stop,
        );
        self.status = r.status;
        r.x
    }
}

impl NewtonMatrix {
    /// Dense `n × n`, or the compressed block pattern of `W` with its ordering and symbolic LU,
    /// refused when its LU is estimated to hold more than `max_entries` entries.
    fn new(
        blocks: &BlockRows,
        n: usize,
        sparse: bool,
        max_entries: usize,
    ) -> Result<Self, PatternRefusal> {
        if !sparse {
            return Ok(Self::Dense(Mat::zeros(n, n)));
        }
        let estimate = lu_estimate(blocks);
        if estimate > max_entries {
            return Err(PatternRefusal::TooMuchFill(format!(
                "the LU of the sparse Newton system ({n} rows) would hold about {estimate} \
                 entries (symbolic analysis of W's block pattern, AMD ordering), above the \
                 {max_entries} a Newton iteration is allowed to factorise: a factorisation \
                 cannot be interrupted, so the solve would overrun its time budget"
            )));
        }
        let mut entries = Vec::with_capacity(9 * blocks.blocks());
        for (c, row) in blocks.0.iter().enumerate() {
            for (e, _) in row {
                for a in 0..3 {
                    for b in 0..3 {
                        entries.push((3 * c + a, 3 * e + b, EntryKind::Fixed(0.0)));
                    }
                }
            }
        }
        // The estimate above stands for the pattern's own (on W's block pattern, finer).
        SparseJacobian::factor_pattern(entries, n, None, usize::MAX)
            .map(|j| Self::Sparse(Box::new(j)))
    }

    /// Set block `(c, e)` (the `k`-th stored block in block-row order).
    #[inline]
    fn set(&mut self, k: usize, c: usize, e: usize, block: &[[f64; 3]; 3]) {
        match self {
            Self::Krylov(m) => {
                if c == e {
                    m.diagonal[c] = *block;
                }
            }
            Self::Dense(h) => {
                for (a, row) in block.iter().enumerate() {
                    for (b, v) in row.iter().enumerate() {
                        h[(3 * c + a, 3 * e + b)] = *v;
                    }
                }
            }
            Self::Sparse(j) => {
                for (a, row) in block.iter().enumerate() {
                    j.values[9 * k + 3 * a..9 * k + 3 * a + 3].copy_from_slice(row);
                }
            }
        }
    }

    /// Contact `c`'s `P_c` and `Q_c`, and the regularisation `λ` (kept by the Krylov form
    /// only, which applies the system from them).
    #[inline]
    fn set_linearisation(&mut self, c: usize, l: &Linearisation, lambda: f64) {
        if let Self::Krylov(m) = self {
            m.p[c] = l.p;
            m.q[c] = l.q;
            m.lambda = lambda;
        }
    }

    /// The solution of `H x = rhs`; non-finite when the factorisation fails. The Krylov form
    /// applies `W` through `blocks` and asks `stop` between GMRES iterations.
    fn solve(&mut self, rhs: &[f64], blocks: &BlockRows, stop: impl FnMut() -> bool) -> Vec<f64> {
        match self {
            Self::Krylov(m) => m.solve(rhs, blocks, stop),
            Self::Dense(h) => {
                let n = rhs.len();
                let mut x = Mat::from_fn(n, 1, |i, _| rhs[i]);
                h.partial_piv_lu().solve_in_place(&mut x);
                (0..n).map(|i| x[(i, 0)]).collect()
            }
            Self::Sparse(j) => factor_and_solve(j, rhs),
        }
    }
}

/// Entries of `L` and `U` for the Newton matrix on `W`'s block pattern, estimated from the
/// symbolic Cholesky factor of the contacts' coupling graph ([`symmetric_fill`]): each block of
/// that factor is nine scalar entries (six for a diagonal block's lower triangle), and an LU
/// holds about twice a Cholesky factor's entries less the diagonal. `usize::MAX` when the
/// analysis fails.
fn lu_estimate(blocks: &BlockRows) -> usize {
    let nc = blocks.0.len();
    let pairs: Vec<(usize, usize)> = blocks
        .0
        .iter()
        .enumerate()
        .flat_map(|(c, row)| {
            row.iter()
                .filter(move |(e, _)| *e < c)
                .map(move |(e, _)| (c, *e))
        })
        .collect();
    symmetric_fill(nc, &pairs).map_or(usize::MAX, |f| {
        (2 * (6 * nc + 9 * (f - nc))).saturating_sub(3 * nc)
    })
}

/// The solve's fixed data and buffers.
struct Work<'a> {
    problem: &'a ConeProblem,
    function: ConeFunction,
    blocks: BlockRows,
    rho: Vec<f64>,
}

impl Work<'_> {
    /// `Φ(r, u)` into `phi`; returns `θ = ½‖Φ‖²` (infinite when not finite).
    fn merit(&self, r: &[f64], u: &[f64], phi: &mut [f64]) -> f64 {
        let mut theta = 0.0;
        for (c, &mu) in self.problem.mu().iter().enumerate() {
            let s = 3 * c..3 * c + 3;
            let l =
                self.function
                    .linearise(mu, self.rho[c], take(&r[s.clone()]), take(&u[s.clone()]));
            phi[s].copy_from_slice(&l.phi);
            theta += 0.5 * l.phi.iter().map(|v| v * v).sum::<f64>();
        }
        if theta.is_finite() {
            theta
        } else {
            f64::INFINITY
        }
    }

    /// `u = W r + q`.
    fn velocity(&self, r: &[f64], u: &mut [f64]) {
        self.blocks.apply(r, u);
        for (ui, qi) in u.iter_mut().zip(self.problem.q()) {
            *ui += qi;
        }
    }

    /// Forms `P + Q W + λI` in `h` at `(r, u)` and returns `∇θ = (P + Q W)ᵀ Φ`.
    fn assemble(&self, r: &[f64], u: &[f64], lambda: f64, h: &mut NewtonMatrix) -> Vec<f64> {
        let mut grad = vec![0.0; r.len()];
        let mut k = 0;
        for (c, (&mu, row)) in self.problem.mu().iter().zip(&self.blocks.0).enumerate() {
            let s = 3 * c;
            let l = self
                .function
                .linearise(mu, self.rho[c], take(&r[s..]), take(&u[s..]));
            h.set_linearisation(c, &l, lambda);
            for (e, w) in row {
                let mut block = [[0.0; 3]; 3];
                for (a, brow) in block.iter_mut().enumerate() {
                    for (b, v) in brow.iter_mut().enumerate() {
                        *v = (0..3).map(|m| l.q[a][m] * w[m][b]).sum::<f64>();
                        if *e == c {
                            *v += l.p[a][b];
                        }
                    }
                }
                for b in 0..3 {
                    grad[3 * e + b] += (0..3).map(|a| block[a][b] * l.phi[a]).sum::<f64>();
                }
                if *e == c {
                    for (a, brow) in block.iter_mut().enumerate() {
                        brow[a] += lambda;
                    }
                }
                h.set(k, c, *e, &block);
                k += 1;
            }
        }
        grad
    }

    /// Each contact of `r` projected onto its cone.
    fn projected(&self, r: &[f64]) -> Vec<f64> {
        let mut p = r.to_vec();
        for (c, &mu) in self.problem.mu().iter().enumerate() {
            let v = project_onto_cone(mu, take(&r[3 * c..]));
            p[3 * c..3 * c + 3].copy_from_slice(&v);
        }
        p
    }
}

/// The iterate, its velocity, `Φ`, merit and the merits of the last iterates.
struct Iterate {
    r: Vec<f64>,
    u: Vec<f64>,
    phi: Vec<f64>,
    theta: f64,
    recent: VecDeque<f64>,
}

impl ConeSolver for ConeNewton {
    fn entry(&self) -> &'static crate::registry::SolverEntry {
        match self.function {
            ConeFunction::AlartCurnier if self.krylov.is_some() => &NEWTON_KRYLOV_AC,
            ConeFunction::FischerBurmeister if self.krylov.is_some() => &NEWTON_KRYLOV_FB_CONE,
            ConeFunction::AlartCurnier => &NEWTON_AC,
            ConeFunction::FischerBurmeister => &NEWTON_FB_CONE,
            ConeFunction::NaturalMap => &NEWTON_NM_CONE,
        }
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let n = problem.n();
        if n > self.max_rows && self.krylov.is_none() {
            let reason = format!(
                "n = {n} rows: the Newton system is formed only up to n = {}",
                self.max_rows
            );
            return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason));
        }
        let nc = problem.contacts();
        let q = problem.q();
        let work = Work {
            problem,
            function: self.function,
            blocks: BlockRows::of(problem),
            rho: (0..nc).map(|c| 1.0 / problem.scale_of(c)).collect(),
        };
        let scale = (0..nc)
            .map(|c| work.rho[c] * take(&q[3 * c..]).iter().map(|v| v * v).sum::<f64>().sqrt())
            .fold(0.0f64, f64::max);
        let scale = if scale > 0.0 { scale } else { 1.0 };
        let r = initial_reaction(problem, settings);
        let mut u = vec![0.0; n];
        work.velocity(&r, &mut u);
        let mut phi = vec![0.0; n];
        let theta = work.merit(&r, &u, &mut phi);
        let mut it = Iterate {
            r,
            u,
            phi,
            theta,
            recent: VecDeque::from([theta]),
        };
        // Formed at the first iteration that needs a direction.
        let mut matrix: Option<NewtonMatrix> = None;
        let (mut trial_r, mut trial_u, mut trial_phi, mut wd) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut best: (f64, Vec<f64>) = (f64::INFINITY, Vec::new());
        let mut iterations = 0;
        // The length of the last iteration: one is not started when it would overrun the
        // budget (its factorisation cannot be interrupted).
        let mut last_iteration = std::time::Duration::ZERO;
        let line_search = Backtracking::newton();
        let outcome = loop {
            let rp = work.projected(&it.r);
            let rel = monitor.residual_of(&rp);
            if rel <= settings.tolerance {
                best = (rel, rp);
                break Outcome::Stopped;
            }
            if rel < best.0 {
                best = (rel, rp);
            }
            if iterations >= settings.max_iterations {
                break Outcome::IterationLimit;
            }
            // A GMRES solve is interrupted by the budget itself; a factorisation cannot be.
            let interruptible = self.krylov.is_some();
            if monitor.out_of_time() || (!interruptible && monitor.cannot_fit(last_iteration)) {
                break Outcome::TimeLimit;
            }
            let iteration_start = monitor.elapsed();
            let h = match (&mut matrix, self.krylov) {
                (Some(h), _) => h,
                (None, Some(k)) => {
                    matrix.insert(NewtonMatrix::Krylov(Box::new(KrylovMatrix::new(nc, k))))
                }
                (None, None) => match NewtonMatrix::new(
                    &work.blocks,
                    n,
                    n > self.dense_up_to,
                    self.max_factor_entries,
                ) {
                    Ok(h) => matrix.insert(h),
                    Err(refusal) => break refusal.outcome(),
                },
            };
            let phi_inf = it.phi.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let lambda = (phi_inf / scale).min(MAX_REGULARISATION);
            let grad = work.assemble(&it.r, &it.u, lambda, h);
            let rhs: Vec<f64> = it.phi.iter().map(|v| -v).collect();
            let newton_dir = h.solve(&rhs, &work.blocks, || monitor.out_of_time());
            if let NewtonMatrix::Krylov(m) = h {
                if m.status == KrylovStatus::TimeLimit {
                    break Outcome::TimeLimit;
                }
            }
            iterations += 1;
            let dnorm = newton_dir.iter().map(|v| v * v).sum::<f64>().sqrt();
            let slope: f64 = grad.iter().zip(&newton_dir).map(|(g, d)| g * d).sum();
            let gnorm = grad.iter().map(|v| v * v).sum::<f64>().sqrt();
            let gradient_dir: Vec<f64> = grad.iter().map(|g| -g).collect();
            let mut candidates: Vec<(&[f64], f64)> = Vec::with_capacity(2);
            if is_descent(&newton_dir, slope, gnorm, dnorm) {
                candidates.push((&newton_dir, slope));
            }
            candidates.push((&gradient_dir, -gnorm * gnorm));
            let reference = it.recent.iter().copied().fold(it.theta, f64::max);
            let mut accepted = false;
            for (direction, slope) in candidates {
                if slope.is_nan() || slope >= 0.0 {
                    continue;
                }
                work.blocks.apply(direction, &mut wd);
                let step = line_search.armijo(reference, slope, |t| {
                    for i in 0..n {
                        trial_r[i] = it.r[i] + t * direction[i];
                        trial_u[i] = it.u[i] + t * wd[i];
                    }
                    work.merit(&trial_r, &trial_u, &mut trial_phi)
                });
                if step.is_some() {
                    std::mem::swap(&mut it.r, &mut trial_r);
                    accepted = true;
                    break;
                }
            }
            if !accepted {
                monitor.record(iterations, &it.r);
                break Outcome::Stalled(format!(
                    "the line search found no decrease of the merit at iteration {iterations} \
                     (a stationary point that is not a solution)"
                ));
            }
            work.velocity(&it.r, &mut it.u);
            it.theta = work.merit(&it.r, &it.u, &mut it.phi);
            it.recent.push_back(it.theta);
            if it.recent.len() > NONMONOTONE_MEMORY {
                it.recent.pop_front();
            }
            last_iteration = monitor.elapsed().saturating_sub(iteration_start);
            monitor.record(iterations, &it.r);
            if it.r.iter().any(|v| !v.is_finite()) {
                break Outcome::NumericalFailure(format!(
                    "non-finite iterate at iteration {iterations}"
                ));
            }
        };
        let r = if best.1.is_empty() { it.r } else { best.1 };
        monitor.finish(r, iterations, outcome)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn apply3(w: &[[f64; 3]; 3], r: [f64; 3], q: [f64; 3]) -> [f64; 3] {
        let mut u = q;
        for (a, ua) in u.iter_mut().enumerate() {
            *ua += w[a][0] * r[0] + w[a][1] * r[1] + w[a][2] * r[2];
        }
        u
    }

    /// `P + Q W` of `linearise` matches central finite differences of `Φ(r, W r + q)` at points
    /// where `Φ` is differentiable (taking off, sticking, sliding, in the polar cone), and its
    /// `P` and `Q` separately match differences in `r` and in `u`.
    pub(crate) fn assert_jacobian_matches_finite_differences(
        linearise: fn(f64, f64, [f64; 3], [f64; 3]) -> Linearisation,
    ) {
        let w = [[2.0, 0.3, -0.1], [0.3, 1.5, 0.2], [-0.1, 0.2, 1.2]];
        let (mu, rho) = (0.4, 0.5);
        let points = [
            ([0.7, -0.1, 0.05], [-1.0, 0.8, -0.6]),
            ([0.7, 0.2, -0.1], [-1.4, -0.5, 0.3]),
            ([0.3, 0.05, 0.02], [-0.5, 0.1, 0.0]),
            ([0.2, 0.6, 0.3], [0.4, -0.3, 0.2]),
            ([-0.5, 0.1, 0.2], [1.0, 0.2, -0.1]),
        ];
        let h = 1e-7;
        for (r, q) in points {
            let u = apply3(&w, r, q);
            let l = linearise(mu, rho, r, u);
            for b in 0..3 {
                let (mut rp, mut rm, mut up, mut um) = (r, r, u, u);
                rp[b] += h;
                rm[b] -= h;
                up[b] += h;
                um[b] -= h;
                let (lp, lm) = (linearise(mu, rho, rp, u), linearise(mu, rho, rm, u));
                let (vp, vm) = (linearise(mu, rho, r, up), linearise(mu, rho, r, um));
                for a in 0..3 {
                    let dr = (lp.phi[a] - lm.phi[a]) / (2.0 * h);
                    let du = (vp.phi[a] - vm.phi[a]) / (2.0 * h);
                    assert!(
                        (dr - l.p[a][b]).abs() < 1e-6,
                        "P ({a},{b}) at r {r:?}: {dr} vs {}",
                        l.p[a][b]
                    );
                    assert!(
                        (du - l.q[a][b]).abs() < 1e-6,
                        "Q ({a},{b}) at r {r:?}: {du} vs {}",
                        l.q[a][b]
                    );
                }
            }
        }
    }

    /// Random coupled contacts `W = J Jᵀ + 10⁻³ I` (a block band), stored sparse.
    fn banded(contacts: usize, seed: u64) -> ConeProblem {
        use rand::{Rng, SeedableRng};
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
        let w = &j * j.transpose();
        let mut triplets = Vec::new();
        for r in 0..n {
            for c in 0..n {
                let v = w[(r, c)] + if r == c { 1e-3 } else { 0.0 };
                if v != 0.0 {
                    triplets.push((r, c, v));
                }
            }
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
        ConeProblem::new_sparse(
            crate::problem::sparse_from_triplets(n, &triplets).unwrap(),
            q,
            mu,
        )
        .unwrap()
    }

    /// The dense and the sparse Newton systems give the same iterates: each path forced by the
    /// size switch, the same reactions to 1e-10 for every reformulation.
    #[test]
    fn dense_and_sparse_systems_agree() {
        let settings = Settings {
            tolerance: 1e-12,
            max_iterations: 200,
            ..Settings::default()
        };
        let mut compared = 0;
        for seed in 0..4 {
            let p = banded(12, seed);
            for function in [
                ConeFunction::AlartCurnier,
                ConeFunction::FischerBurmeister,
                ConeFunction::NaturalMap,
            ] {
                let solve = |dense_up_to| {
                    ConeNewton {
                        function,
                        dense_up_to,
                        ..ConeNewton::default()
                    }
                    .solve_cone(&p, &settings)
                };
                let (dense, sparse) = (solve(usize::MAX), solve(0));
                assert_eq!(dense.status, sparse.status, "{function:?} seed {seed}");
                if !dense.status.is_converged() {
                    continue;
                }
                compared += 1;
                for (x, y) in dense.f.iter().zip(&sparse.f) {
                    assert!(
                        (x - y).abs() <= 1e-10,
                        "{function:?} seed {seed}: {x} vs {y}"
                    );
                }
            }
        }
        assert!(compared >= 8, "only {compared} converged pairs");
    }

    /// The LU estimate is exact at the two ends: uncoupled contacts (3×3 diagonal blocks, nine
    /// entries each) and contacts all coupled (a full `3nc × 3nc` LU, `(3nc)²` entries).
    #[test]
    fn lu_estimate_is_exact_for_uncoupled_and_fully_coupled_contacts() {
        let nc = 7;
        let block = [[1.0; 3]; 3];
        let uncoupled = BlockRows((0..nc).map(|c| vec![(c, block)]).collect());
        assert_eq!(lu_estimate(&uncoupled), 9 * nc);
        let coupled = BlockRows(
            (0..nc)
                .map(|c| {
                    let mut row = vec![(c, block)];
                    row.extend((0..nc).filter(|&e| e != c).map(|e| (e, block)));
                    row
                })
                .collect(),
        );
        assert_eq!(lu_estimate(&coupled), 9 * nc * nc);
    }

    /// A sparse system whose LU is estimated above the cap is refused before any factorisation,
    /// as `unsupported` with the estimate in the reason; the dense system is not capped.
    #[test]
    fn a_factorisation_above_the_fill_cap_is_unsupported() {
        let p = banded(16, 7);
        let mut s = ConeNewton {
            dense_up_to: 0,
            max_factor_entries: 100,
            ..ConeNewton::default()
        };
        let r = s.solve_cone(&p, &Settings::default());
        assert_eq!(r.status.name(), "unsupported");
        let reason = format!("{:?}", r.status);
        assert!(
            reason.contains("above the 100 a Newton iteration"),
            "{reason}"
        );
        s.dense_up_to = usize::MAX;
        let settings = Settings {
            tolerance: 1e-10,
            max_iterations: 200,
            ..Settings::default()
        };
        let r = s.solve_cone(&p, &settings);
        assert_ne!(r.status.name(), "unsupported", "{:?}", r.status);
        assert!(r.iterations > 0);
    }

    #[test]
    fn a_zero_time_budget_ends_time_limit() {
        let p = banded(10, 1);
        let settings = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        for mut s in [
            ConeNewton::alart_curnier(),
            ConeNewton::fischer_burmeister(),
            ConeNewton::natural_map(),
        ] {
            for dense_up_to in [0, usize::MAX] {
                s.dense_up_to = dense_up_to;
                let r = s.solve_cone(&p, &settings);
                assert_eq!(r.status.name(), "time_limit", "{}", s.name());
            }
        }
    }

    /// De Saxcé's natural map `r − P_K(r − (u + μ‖u_t‖ e_n))` with `u = W r + q` from the dense
    /// `W` and the projection onto the cone `‖r_t‖ <= μ r_n` written out here, over
    /// `max(‖q‖∞, 1)`, in the infinity norm.
    fn independent_cone_residual(p: &ConeProblem, r: &[f64]) -> f64 {
        let w = p.delassus().to_dense();
        let n = p.n();
        let u: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| w[(i, j)] * r[j]).sum::<f64>() + p.q()[i])
            .collect();
        let mut worst = 0.0_f64;
        for (c, &mu) in p.mu().iter().enumerate() {
            let s = 3 * c;
            let ut = u[s + 1].hypot(u[s + 2]);
            let z = [
                r[s] - u[s] - mu * ut,
                r[s + 1] - u[s + 1],
                r[s + 2] - u[s + 2],
            ];
            let zt = z[1].hypot(z[2]);
            let proj = if zt <= mu * z[0] {
                z
            } else if mu * zt <= -z[0] {
                [0.0; 3]
            } else {
                let a = (mu * zt + z[0]) / (mu * mu + 1.0);
                [a, mu * a * z[1] / zt, mu * a * z[2] / zt]
            };
            for k in 0..3 {
                worst = worst.max((r[s + k] - proj[k]).abs());
            }
        }
        worst / p.q().iter().fold(1.0_f64, |m, v| m.max(v.abs()))
    }

    fn with_krylov(function: ConeFunction) -> ConeNewton {
        ConeNewton {
            function,
            krylov: Some(KrylovSettings::default()),
            ..ConeNewton::default()
        }
    }

    /// GMRES directions against the LU ones (Alart–Curnier and FB): the same statuses, the
    /// same reactions to `1e-8`, every `converged` answer checked by the independent natural
    /// map; with `max_rows` below the problem's rows (no cap for Krylov) and the registry names.
    #[test]
    fn krylov_and_lu_directions_agree() {
        let settings = Settings {
            tolerance: 1e-10,
            max_iterations: 100,
            ..Settings::default()
        };
        let mut compared = 0;
        for seed in 0..4 {
            let p = banded(40, seed);
            for function in [ConeFunction::AlartCurnier, ConeFunction::FischerBurmeister] {
                let lu = ConeNewton {
                    function,
                    ..ConeNewton::default()
                }
                .solve_cone(&p, &settings);
                let mut s = ConeNewton {
                    max_rows: 6,
                    ..with_krylov(function)
                };
                let r = s.solve_cone(&p, &settings);
                assert!(s.name().starts_with("newton-krylov-"), "{}", s.name());
                assert_eq!(r.status, lu.status, "{function:?} seed {seed}");
                if !r.status.is_converged() {
                    continue;
                }
                compared += 1;
                let scale = 1.0 + lu.f.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                for (x, y) in r.f.iter().zip(&lu.f) {
                    assert!(
                        (x - y).abs() <= 1e-8 * scale,
                        "{function:?} seed {seed}: {x} vs {y}"
                    );
                }
                let res = independent_cone_residual(&p, &r.f);
                assert!(res <= 1e-8, "{function:?} seed {seed}: {res:.2e}");
            }
        }
        assert!(compared >= 6, "only {compared} converged pairs");
    }

    /// A spent budget: the GMRES loop asks first and the solve ends `time_limit` (the Krylov
    /// form skips the rule for uninterruptible factorisations, so this is the GMRES check or
    /// the one before the iteration).
    #[test]
    fn a_zero_time_budget_ends_a_krylov_solve_time_limit() {
        let p = banded(10, 1);
        let settings = Settings {
            time_budget: Some(std::time::Duration::ZERO),
            ..Settings::default()
        };
        let mut m = KrylovMatrix::new(10, KrylovSettings::default());
        let blocks = BlockRows::of(&p);
        let x = m.solve(&vec![1.0; 30], &blocks, || true);
        assert_eq!(m.status, KrylovStatus::TimeLimit);
        assert!(x.iter().all(|&v| v == 0.0));
        let r = with_krylov(ConeFunction::AlartCurnier).solve_cone(&p, &settings);
        assert_eq!(r.status.name(), "time_limit");
    }

    #[test]
    fn too_large_is_unsupported() {
        let p = banded(4, 2);
        let mut s = ConeNewton {
            max_rows: 6,
            ..ConeNewton::default()
        };
        let r = s.solve_cone(&p, &Settings::default());
        assert_eq!(r.status.name(), "unsupported");
    }
}
