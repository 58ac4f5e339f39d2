//! SAP, the Semi-Analytic Primal solver: Newton's method on the body velocities of the
//! unconstrained convex approximation of contact of Castro, Permenter and Han (2022), as in
//! Drake's `multibody/contact_solvers/sap/`.
//!
//! A cone problem that came from a contact scene carries the factors of its Delassus matrix,
//! `W = J M⁻¹ Jᵀ` ([`crate::ConeProblem::factors`]): a sparse Jacobian `J` and the 6×6
//! inverse-mass block of each body. With `v` the velocity change of the dynamic bodies (six per
//! body whose inverse-mass block is not zero; static bodies have no unknowns) and the free
//! velocity folded into `q`, the contact velocity is `u = J v + q`. SAP minimises
//!
//! ```text
//! ℓ(v) = ½ vᵀ M v + Σ_c ℓ_c(u_c),     ℓ_c(u_c) = ½ γ_cᵀ R_c γ_c,
//! γ_c  = P_F(y_c),   y_c = −R_c⁻¹ u_c,
//! ```
//!
//! with `P_F` the projection onto the friction cone `F_c = { ‖γ_T‖ <= mu_c γ_N }` in the norm
//! of `R_c = diag(R_N, R_T, R_T)` (analytic: stiction `γ = y`, sliding onto the cone's surface,
//! no contact `γ = 0`). `ℓ` is convex and once continuously differentiable with
//!
//! ```text
//! ∇ℓ = M v − Jᵀ γ,     ∇²ℓ = M + Jᵀ G J,   G_c = ∂γ_c/∂y_c R_c⁻¹  (3×3, symmetric PSD),
//! ```
//!
//! so at its minimiser `v = M⁻¹ Jᵀ γ` and `u = W γ + q`: the answer `r = γ` is a contact impulse
//! of the problem as posed, with the velocities of the *regularised* model. That model is the
//! convex relaxation `γ_c = P_F(−R_c⁻¹ u_c)`, i.e. `min ½ γᵀ (W + R) γ + qᵀ γ` over the cones:
//! a sticking contact keeps a velocity `u_c = −R_c γ_c` (a normal velocity error of `R_N γ_N`,
//! a tangential creep of `R_T ‖γ_T‖`), and a sliding one separates at `u_N = mu ‖u_T‖`-like
//! rates scaled by `R_T / R_N` (Anitescu's lift-off, softened). Its regularisation follows
//! Drake's near-rigid rule, with the Delassus estimate `w_c = ‖W_cc‖_F / 3` (the root mean
//! square of the contact's diagonal block, from the factors):
//!
//! ```text
//! R_N = β² / (4π²) · w_c,     R_T = σ · w_c       (β = 1, σ = 10⁻³ by default).
//! ```
//!
//! For a single contact whose block is diagonal, the normal impulse is the rigid one divided
//! by `1 + R_N / W_NN`: with `β = 1` about 2.5 % to 5 % short of the rigid impulse. The exact
//! cone residual of [`crate::cone`] decides the status as for every cone solver, so a solve
//! that met SAP's optimality criterion on the regularised model with a cone residual above
//! the tolerance is `Stalled`, its reason saying it solved the regularised model and giving the
//! model's softness: the largest normal velocity error `R_N γ_N` and tangential creep
//! `R_T ‖γ_T‖` among the contacts.
//!
//! * **Newton direction**: `(M + Jᵀ G J) Δv = −∇ℓ`, one 6×6 block per dynamic body and one per
//!   pair of bodies in contact. The pattern of that block graph is fixed for the solve: its
//!   sparse Cholesky analysis (faer, approximate-minimum-degree ordering of the body graph) is
//!   computed once and every iteration refactorises numerically on it. The Hessian is positive
//!   definite (`M` is), so the factorisation fails only on a breakdown (`NumericalFailure`).
//! * **Line search**: exact, on `ℓ(v + α Δv)` (Drake's `PerformExactLineSearch`): `α_max = 1.5`
//!   is taken when `ℓ` still decreases there; otherwise the root of the convex one-dimensional
//!   derivative `dℓ/dα` in `(0, α_max)` is found by Newton's method from the minimiser of the
//!   local quadratic model, safeguarded by bisection on the bracket. One trial costs
//!   `O(contacts)` (the products `J Δv`, `Δvᵀ M Δv`, `Δvᵀ M v` are formed once).
//! * **Stopping rule** (Drake's): optimality `‖D ∇ℓ‖ <= ε_a + ε_r max(‖D M v‖, ‖D Jᵀγ‖)`, with
//!   `D = diag(M)^{-1/2}`, `ε_a = 10⁻¹⁴`, `ε_r = min(10⁻⁶, Settings::tolerance)`; or the cost
//!   criterion `|Δℓ| < 10⁻³⁰ + 10⁻¹⁵ ℓ` after a line search. The impulse `γ(v)` is returned.
//! * **Cost**: per iteration one numeric sparse Cholesky of the body Hessian (the fill of the
//!   body graph, 6×6 blocks: a pile of spheres factors in a small multiple of its bodies'
//!   `36 · bodies` entries), `O(nnz(J))` for `u`, `∇ℓ` and the Hessian's `Jᵀ G J` blocks. No
//!   `W` is formed or read except by the shared residual. The factorisation is not
//!   interruptible: the time budget is checked before each iteration, which is not started when
//!   the last one's length would carry the solve past the budget (`TimeLimit`).
//!   `Settings::max_iterations` caps the Newton iterations (`IterationLimit`).
//! * **Warm start**: `Settings::warm_start` (an impulse) starts Newton from the velocity it
//!   implies, `v = M⁻¹ Jᵀ r`; otherwise from `v = 0`.
//! * **Failure modes**: a problem without factors (FCLIB files give `W` only) or whose factors
//!   do not match `W`'s rows is `Unsupported`, and so is one with a non-zero inverse-mass block
//!   that is not positive definite, or a contact that touches no dynamic body (`w_c = 0`, no
//!   regularisation defined). A non-finite value or a failed factorisation is
//!   `NumericalFailure`.
//!
//! References: A. M. Castro, F. N. Permenter, X. Han, *An Unconstrained Convex Formulation of
//! Compliant Contact*, IEEE Transactions on Robotics 39(2), 2023 (arXiv:2110.10107, 2021);
//! Drake, `multibody/contact_solvers/sap/sap_solver.cc` (the Newton iteration, exact line search,
//! stopping criteria) and `sap_friction_cone_constraint.cc` (the analytic projection, its
//! derivative and the near-rigid regularisation); M. Anitescu, *Optimization-based simulation of
//! nonsmooth rigid multibody dynamics*, Math. Program. 105, 2006 (the convex relaxation).

use crate::cone::{ConeMonitor, ConeProblem, ConeSolver};
use crate::delassus::DelassusFactors;
use crate::registry::{Make, ParamSpec, SolverEntry};
use crate::solver::{Outcome, Settings, SolveResult};
use faer::linalg::solvers::SolveCore;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Mat, Side};
use std::time::{Duration, Instant};

/// Problem classes handled.
pub(crate) const PROBLEM_CLASSES: &str =
    "FC3D cone from a contact scene (needs the factors J, M⁻¹ of W: unsupported on W alone, e.g. FCLIB files); solves SAP's regularised convex model, sparse Cholesky of the body Hessian";

/// The registry's entry of `sap`.
pub static SAP: SolverEntry = SolverEntry {
    name: "sap",
    summary: "SAP: Newton on body velocities of the regularised convex contact model (Castro et al. 2022), sparse Cholesky, exact line search",
    problem_classes: PROBLEM_CLASSES,
    iteration_unit: "Newton iterations (one sparse Cholesky each)",
    iterative: true,
    relaxation: Some(
        "SAP's regularised convex model (R_N = β²/(4π²) w_c, R_T = σ w_c): sticking contacts keep \
         velocities −R γ, sliding contacts lift off",
    ),
    params: &[
        ParamSpec::real_open(
            "beta",
            1.0,
            0.0,
            100.0,
            "near-rigid parameter β: R_N = β²/(4π²) w_c (default 1, Drake's)",
        ),
        ParamSpec::real_open(
            "sigma",
            1e-3,
            0.0,
            10.0,
            "tangential regularisation σ: R_T = σ w_c (default 1e-3, Drake's)",
        ),
    ],
    make: Make::Cone(|params| {
        Box::new(Sap {
            beta: params.get("beta"),
            sigma: params.get("sigma"),
        })
    }),
};

/// SAP on the cone problem's factors. See the module documentation.
#[derive(Debug, Clone, PartialEq)]
pub struct Sap {
    /// Near-rigid parameter `β`: `R_N = β² / (4π²) · w_c`. Default 1 (Drake's).
    pub beta: f64,
    /// Tangential regularisation `σ`: `R_T = σ · w_c`. Default `10⁻³` (Drake's).
    pub sigma: f64,
}

impl Default for Sap {
    fn default() -> Self {
        Self {
            beta: 1.0,
            sigma: 1e-3,
        }
    }
}

/// Largest ratio `α_max` of the exact line search (Drake's `ls_alpha_max`).
const ALPHA_MAX: f64 = 1.5;
/// Absolute optimality tolerance `ε_a` (Drake's `abs_tolerance`).
const ABS_TOLERANCE: f64 = 1e-14;
/// Relative optimality tolerance `ε_r`, at most (Drake's `rel_tolerance`).
const REL_TOLERANCE: f64 = 1e-6;
/// The cost criterion `|Δℓ| < COST_ABS + COST_REL · ℓ` (Drake's defaults).
const COST_ABS: f64 = 1e-30;
const COST_REL: f64 = 1e-15;
/// Root-finding tolerance of the line search on `dℓ/dα`, relative to `|dℓ/dα(0)|`.
const LS_TOLERANCE: f64 = 1e-10;
/// Iterations of the line search's root finding, at most.
const LS_MAX_ITERATIONS: usize = 100;

/// One contact of the model: its dynamic bodies with their 3×6 Jacobian blocks (rows normal,
/// tangent, tangent), its friction coefficient and regularisation.
#[derive(Debug, Clone)]
struct Contact {
    bodies: Vec<(usize, [[f64; 6]; 3])>,
    mu: f64,
    /// `R_N`.
    rn: f64,
    /// `R_T`.
    rt: f64,
}

/// The regularised model of a cone problem on its factors.
#[derive(Debug, Clone)]
pub(crate) struct Model {
    /// Dynamic bodies.
    bodies: usize,
    /// `M` of each dynamic body (the inverse of its inverse-mass block).
    mass: Vec<[[f64; 6]; 6]>,
    contacts: Vec<Contact>,
    q: Vec<f64>,
}

/// The projection `γ = P_F(y)` in the `R` norm of one contact, `y = −R⁻¹ u`, with
/// `G = ∂γ/∂y R⁻¹` (rows and columns ordered normal, tangent, tangent).
fn project(mu: f64, rn: f64, rt: f64, u: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let y = [-u[0] / rn, -u[1] / rt, -u[2] / rt];
    let (yn, yr) = (y[0], y[1].hypot(y[2]));
    let rinv = [1.0 / rn, 1.0 / rt, 1.0 / rt];
    if yr <= mu * yn {
        // Stiction: γ = y.
        let g = [
            [rinv[0], 0.0, 0.0],
            [0.0, rinv[1], 0.0],
            [0.0, 0.0, rinv[2]],
        ];
        return (y, g);
    }
    let mu_hat = mu * rt / rn;
    if yn > -mu_hat * yr && mu * yn < yr {
        // Sliding: onto the cone's surface along the R-norm normal (yr > 0 here).
        let t = [y[1] / yr, y[2] / yr];
        let factor = 1.0 / (1.0 + mu * mu_hat);
        let gn = (yn + mu_hat * yr) * factor;
        let gamma = [gn, mu * gn * t[0], mu * gn * t[1]];
        let mut dp = [[0.0; 3]; 3];
        dp[0][0] = factor;
        for a in 0..2 {
            dp[0][1 + a] = mu_hat * factor * t[a];
            dp[1 + a][0] = mu * factor * t[a];
            for b in 0..2 {
                let p = t[a] * t[b];
                let perp = if a == b { 1.0 - p } else { -p };
                dp[1 + a][1 + b] = mu * (gn / yr * perp + mu_hat * factor * p);
            }
        }
        let g = std::array::from_fn(|i| std::array::from_fn(|j| dp[i][j] * rinv[j]));
        return (gamma, g);
    }
    ([0.0; 3], [[0.0; 3]; 3])
}

/// The inverse of a symmetric positive definite 6×6 block by its Cholesky factor; `None` when a
/// pivot is not positive beyond round-off of the largest diagonal entry.
fn invert_spd(a: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let big = (0..6).fold(0.0_f64, |m, i| m.max(a[i][i].abs()));
    let mut l = [[0.0; 6]; 6];
    for j in 0..6 {
        let d = a[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        // Also refuses a NaN pivot.
        if d.is_nan() || d <= 1e-13 * big {
            return None;
        }
        l[j][j] = d.sqrt();
        for i in j + 1..6 {
            l[i][j] = (a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / l[j][j];
        }
    }
    let mut inv = [[0.0; 6]; 6];
    for c in 0..6 {
        let mut x = [0.0; 6];
        x[c] = 1.0;
        for i in 0..6 {
            x[i] = (x[i] - (0..i).map(|k| l[i][k] * x[k]).sum::<f64>()) / l[i][i];
        }
        for i in (0..6).rev() {
            x[i] = (x[i] - (i + 1..6).map(|k| l[k][i] * x[k]).sum::<f64>()) / l[i][i];
        }
        for r in 0..6 {
            inv[r][c] = x[r];
        }
    }
    Some(inv)
}

impl Model {
    /// The model of `problem` on `factors` with parameters `beta`, `sigma`, or why it cannot be
    /// built.
    pub(crate) fn new(
        problem: &ConeProblem,
        factors: &DelassusFactors,
        beta: f64,
        sigma: f64,
    ) -> Result<Self, String> {
        if factors.rows() != problem.n() {
            return Err(format!(
                "the factors have {} rows, the cone problem {}",
                factors.rows(),
                problem.n()
            ));
        }
        let minv = factors.inverse_mass();
        let mut dynamic = vec![usize::MAX; minv.len()];
        let mut body_of = Vec::new();
        let mut mass = Vec::new();
        for (b, block) in minv.iter().enumerate() {
            if block.iter().flatten().all(|&v| v == 0.0) {
                continue;
            }
            let m = invert_spd(block).ok_or_else(|| {
                format!(
                    "the inverse-mass block of body {b} is neither zero (static) nor positive \
                     definite"
                )
            })?;
            dynamic[b] = mass.len();
            body_of.push(b);
            mass.push(m);
        }
        let near_rigid = beta * beta / (4.0 * std::f64::consts::PI * std::f64::consts::PI);
        let mut contacts = Vec::with_capacity(problem.contacts());
        for (c, &mu) in problem.mu().iter().enumerate() {
            let mut bodies: Vec<(usize, [[f64; 6]; 3])> = Vec::new();
            let mut w = [[0.0; 3]; 3];
            for a in 0..3 {
                for blk in factors.row_blocks(3 * c + a) {
                    if dynamic[blk.body] == usize::MAX {
                        continue;
                    }
                    let k = match bodies.iter().position(|(d, _)| *d == dynamic[blk.body]) {
                        Some(k) => k,
                        None => {
                            bodies.push((dynamic[blk.body], [[0.0; 6]; 3]));
                            bodies.len() - 1
                        }
                    };
                    for (x, v) in bodies[k].1[a].iter_mut().zip(&blk.j) {
                        *x += v;
                    }
                }
            }
            for (d, jb) in &bodies {
                let m = &minv[body_of[*d]];
                let resp: [[f64; 6]; 3] = std::array::from_fn(|a| {
                    std::array::from_fn(|r| (0..6).map(|k| m[r][k] * jb[a][k]).sum())
                });
                for a in 0..3 {
                    for e in 0..3 {
                        w[a][e] += (0..6).map(|k| jb[a][k] * resp[e][k]).sum::<f64>();
                    }
                }
            }
            let wc = w.iter().flatten().map(|v| v * v).sum::<f64>().sqrt() / 3.0;
            if !(wc > 0.0 && wc.is_finite()) {
                return Err(format!(
                    "contact {c} touches no dynamic body (its Delassus block is {wc:e}): SAP's \
                     regularisation R_c ∝ ‖W_cc‖ is undefined"
                ));
            }
            bodies.sort_by_key(|(d, _)| *d);
            contacts.push(Contact {
                bodies,
                mu,
                rn: near_rigid * wc,
                rt: sigma * wc,
            });
        }
        Ok(Self {
            bodies: mass.len(),
            mass,
            contacts,
            q: problem.q().to_vec(),
        })
    }

    /// Unknowns: six per dynamic body.
    fn nv(&self) -> usize {
        6 * self.bodies
    }

    /// `u_c = J_c v + q_c` of every contact.
    fn velocities(&self, v: &[f64]) -> Vec<[f64; 3]> {
        self.contacts
            .iter()
            .enumerate()
            .map(|(c, k)| {
                let mut u = [self.q[3 * c], self.q[3 * c + 1], self.q[3 * c + 2]];
                for (d, jb) in &k.bodies {
                    let vb = &v[6 * d..6 * d + 6];
                    for a in 0..3 {
                        u[a] += (0..6).map(|i| jb[a][i] * vb[i]).sum::<f64>();
                    }
                }
                u
            })
            .collect()
    }

    /// `J_c w` of every contact (no `q`).
    fn directions(&self, w: &[f64]) -> Vec<[f64; 3]> {
        self.contacts
            .iter()
            .map(|k| {
                let mut u = [0.0; 3];
                for (d, jb) in &k.bodies {
                    let wb = &w[6 * d..6 * d + 6];
                    for a in 0..3 {
                        u[a] += (0..6).map(|i| jb[a][i] * wb[i]).sum::<f64>();
                    }
                }
                u
            })
            .collect()
    }

    /// `M v`.
    fn momentum(&self, v: &[f64]) -> Vec<f64> {
        let mut p = vec![0.0; v.len()];
        for (d, m) in self.mass.iter().enumerate() {
            for r in 0..6 {
                p[6 * d + r] = (0..6).map(|k| m[r][k] * v[6 * d + k]).sum();
            }
        }
        p
    }

    /// `Jᵀ γ`.
    fn generalized_impulse(&self, gamma: &[[f64; 3]]) -> Vec<f64> {
        let mut out = vec![0.0; self.nv()];
        for (k, g) in self.contacts.iter().zip(gamma) {
            for (d, jb) in &k.bodies {
                for i in 0..6 {
                    out[6 * d + i] += (0..3).map(|a| jb[a][i] * g[a]).sum::<f64>();
                }
            }
        }
        out
    }

    /// The impulses `γ_c` and Hessian blocks `G_c` at contact velocities `u`.
    fn impulses(&self, u: &[[f64; 3]]) -> Vec<([f64; 3], [[f64; 3]; 3])> {
        self.contacts
            .iter()
            .zip(u)
            .map(|(k, &uc)| project(k.mu, k.rn, k.rt, uc))
            .collect()
    }

    /// `Σ_c ½ γ_cᵀ R_c γ_c`.
    fn contact_cost(&self, gamma: &[[f64; 3]]) -> f64 {
        self.contacts
            .iter()
            .zip(gamma)
            .map(|(k, g)| 0.5 * (k.rn * g[0] * g[0] + k.rt * (g[1] * g[1] + g[2] * g[2])))
            .sum()
    }

    /// `ℓ(v)` (for tests: the solve evaluates it along its line searches).
    #[cfg(test)]
    pub(crate) fn cost(&self, v: &[f64]) -> f64 {
        let u = self.velocities(v);
        let gamma: Vec<[f64; 3]> = self.impulses(&u).into_iter().map(|(g, _)| g).collect();
        let p = self.momentum(v);
        0.5 * dot(v, &p) + self.contact_cost(&gamma)
    }

    /// `∇ℓ(v) = M v − Jᵀ γ` (for tests: the solve forms it in its iteration).
    #[cfg(test)]
    pub(crate) fn gradient(&self, v: &[f64]) -> Vec<f64> {
        let u = self.velocities(v);
        let gamma: Vec<[f64; 3]> = self.impulses(&u).into_iter().map(|(g, _)| g).collect();
        let jg = self.generalized_impulse(&gamma);
        let p = self.momentum(v);
        p.iter().zip(&jg).map(|(a, b)| a - b).collect()
    }

    /// The dense Hessian `M + Jᵀ G J` at `v` (for tests).
    #[cfg(test)]
    pub(crate) fn dense_hessian(&self, v: &[f64]) -> Vec<Vec<f64>> {
        let pattern = HessianPattern::new(self);
        let mut vals = vec![0.0; pattern.row_idx.len()];
        let u = self.velocities(v);
        let g: Vec<[[f64; 3]; 3]> = self.impulses(&u).into_iter().map(|(_, g)| g).collect();
        pattern.fill(self, &g, &mut vals);
        let nv = self.nv();
        let mut h = vec![vec![0.0; nv]; nv];
        for (c, ends) in pattern.col_ptr.windows(2).enumerate() {
            for (&r, &x) in pattern.row_idx[ends[0]..ends[1]]
                .iter()
                .zip(&vals[ends[0]..ends[1]])
            {
                h[r][c] = x;
                h[c][r] = x;
            }
        }
        h
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The lower triangle of the body Hessian's block pattern in compressed columns: for body `a`'s
/// six columns, its own block on and below the diagonal, then the full blocks of the bodies
/// `b > a` it shares a contact with, increasing.
struct HessianPattern {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// The bodies `b > a` sharing a contact with body `a`, increasing.
    neighbours: Vec<Vec<usize>>,
}

impl HessianPattern {
    fn new(model: &Model) -> Self {
        let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); model.bodies];
        for k in &model.contacts {
            for (x, (a, _)) in k.bodies.iter().enumerate() {
                for (b, _) in &k.bodies[x + 1..] {
                    let (lo, hi) = ((*a).min(*b), (*a).max(*b));
                    if lo != hi {
                        neighbours[lo].push(hi);
                    }
                }
            }
        }
        for n in &mut neighbours {
            n.sort_unstable();
            n.dedup();
        }
        let nv = model.nv();
        let mut col_ptr = Vec::with_capacity(nv + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (a, nbrs) in neighbours.iter().enumerate() {
            for k in 0..6 {
                row_idx.extend(6 * a + k..6 * a + 6);
                for &b in nbrs {
                    row_idx.extend(6 * b..6 * b + 6);
                }
                col_ptr.push(row_idx.len());
            }
        }
        Self {
            col_ptr,
            row_idx,
            neighbours,
        }
    }

    /// Position in the values of entry (`6 row_body + r`, `6 col_body + k`), on or below the
    /// diagonal (`row_body > col_body`, or equal with `r >= k`).
    fn slot(&self, row_body: usize, r: usize, col_body: usize, k: usize) -> usize {
        let start = self.col_ptr[6 * col_body + k];
        if row_body == col_body {
            start + r - k
        } else {
            let pos = self.neighbours[col_body]
                .binary_search(&row_body)
                .expect("a neighbour in the pattern");
            start + (6 - k) + 6 * pos + r
        }
    }

    /// The values of `M + Jᵀ G J` with the blocks `g` of every contact.
    fn fill(&self, model: &Model, g: &[[[f64; 3]; 3]], vals: &mut [f64]) {
        vals.iter_mut().for_each(|v| *v = 0.0);
        for (d, m) in model.mass.iter().enumerate() {
            for k in 0..6 {
                for r in k..6 {
                    vals[self.slot(d, r, d, k)] += m[r][k];
                }
            }
        }
        for (contact, gc) in model.contacts.iter().zip(g) {
            if gc.iter().flatten().all(|&v| v == 0.0) {
                continue;
            }
            for (b2, j2) in &contact.bodies {
                // G J_b2: 3×6.
                let gj: [[f64; 6]; 3] = std::array::from_fn(|a| {
                    std::array::from_fn(|i| (0..3).map(|e| gc[a][e] * j2[e][i]).sum())
                });
                for (b1, j1) in &contact.bodies {
                    if b1 < b2 {
                        continue;
                    }
                    for k in 0..6 {
                        let first = if b1 == b2 { k } else { 0 };
                        for r in first..6 {
                            let h: f64 = (0..3).map(|a| j1[a][r] * gj[a][k]).sum();
                            vals[self.slot(*b1, r, *b2, k)] += h;
                        }
                    }
                }
            }
        }
    }
}

/// `ℓ(v + α Δv)` along a direction, with its first and second derivatives in `α`.
struct Line<'a> {
    model: &'a Model,
    /// `u` at `v` and `J Δv`, per contact.
    u0: Vec<[f64; 3]>,
    du: Vec<[f64; 3]>,
    /// `½ vᵀ M v`, `Δvᵀ M v`, `Δvᵀ M Δv`.
    vmv: f64,
    dmv: f64,
    dmd: f64,
}

impl Line<'_> {
    /// `(ℓ, dℓ/dα, d²ℓ/dα²)` at `α`.
    fn eval(&self, alpha: f64) -> (f64, f64, f64) {
        let mut cost = self.vmv + alpha * self.dmv + 0.5 * alpha * alpha * self.dmd;
        let mut d1 = self.dmv + alpha * self.dmd;
        let mut d2 = self.dmd;
        for ((k, u0), du) in self.model.contacts.iter().zip(&self.u0).zip(&self.du) {
            let u = [0, 1, 2].map(|a| u0[a] + alpha * du[a]);
            let (g, gg) = project(k.mu, k.rn, k.rt, u);
            cost += 0.5 * (k.rn * g[0] * g[0] + k.rt * (g[1] * g[1] + g[2] * g[2]));
            d1 -= (0..3).map(|a| du[a] * g[a]).sum::<f64>();
            d2 += (0..3)
                .map(|a| du[a] * (0..3).map(|e| gg[a][e] * du[e]).sum::<f64>())
                .sum::<f64>();
        }
        (cost, d1, d2)
    }
}

/// The exact line search (Drake's `PerformExactLineSearch`): `α_max` when `ℓ` still decreases
/// there, else the root of `dℓ/dα` in `(0, α_max)` by Newton's method safeguarded by bisection
/// on the bracket, from the minimiser of the quadratic model at `0`. Returns `(α, ℓ(α))`, or an
/// error when the direction is not one of descent.
fn exact_line_search(line: &Line) -> Result<(f64, f64, usize), String> {
    let (_, d0, dd0) = line.eval(0.0);
    if d0.is_nan() || d0 >= 0.0 {
        return Err(format!(
            "the Newton direction is not one of descent (dℓ/dα(0) = {d0:.3e})"
        ));
    }
    let (cost_max, d_max, _) = line.eval(ALPHA_MAX);
    if d_max <= 0.0 {
        return Ok((ALPHA_MAX, cost_max, 1));
    }
    let scale = -d0;
    let (mut lo, mut hi) = (0.0, ALPHA_MAX);
    let mut alpha = if dd0 > 0.0 {
        (-d0 / dd0).clamp(0.0, ALPHA_MAX)
    } else {
        0.5 * ALPHA_MAX
    };
    if !(alpha > lo && alpha < hi) {
        alpha = 0.5 * (lo + hi);
    }
    for it in 0..LS_MAX_ITERATIONS {
        let (cost, d1, d2) = line.eval(alpha);
        if d1.abs() <= LS_TOLERANCE * scale || hi - lo <= 1e-14 * ALPHA_MAX {
            return Ok((alpha, cost, it + 2));
        }
        if d1 < 0.0 {
            lo = alpha;
        } else {
            hi = alpha;
        }
        let newton = alpha - d1 / d2;
        alpha = if d2 > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    let (cost, _, _) = line.eval(alpha);
    Ok((alpha, cost, LS_MAX_ITERATIONS + 1))
}

/// `‖D x‖` with `D = diag(M)^{-1/2}`.
fn scaled_norm(model: &Model, x: &[f64]) -> f64 {
    let mut s = 0.0;
    for (d, m) in model.mass.iter().enumerate() {
        for r in 0..6 {
            s += x[6 * d + r] * x[6 * d + r] / m[r][r];
        }
    }
    s.sqrt()
}

/// What a SAP run ended with.
struct Run {
    v: Vec<f64>,
    iterations: usize,
    outcome: Outcome,
}

impl Sap {
    /// Newton's method on `ℓ` from `v`.
    fn newton(
        &self,
        model: &Model,
        mut v: Vec<f64>,
        settings: &Settings,
        monitor: &mut ConeMonitor,
    ) -> Run {
        let nv = model.nv();
        let finish = |v, iterations, outcome| Run {
            v,
            iterations,
            outcome,
        };
        if nv == 0 {
            return finish(v, 0, Outcome::Stopped);
        }
        let pattern = HessianPattern::new(model);
        let symbolic_pattern = SymbolicSparseColMat::new_checked(
            nv,
            nv,
            pattern.col_ptr.clone(),
            None,
            pattern.row_idx.clone(),
        );
        let symbolic = match SymbolicLlt::try_new(symbolic_pattern.as_ref(), Side::Lower) {
            Ok(s) => s,
            Err(e) => {
                return finish(
                    v,
                    0,
                    Outcome::NumericalFailure(format!(
                        "symbolic Cholesky of the body Hessian failed: {e:?}"
                    )),
                )
            }
        };
        let eps_rel = REL_TOLERANCE.min(settings.tolerance);
        let mut vals = vec![0.0; pattern.row_idx.len()];
        let mut cost_reached = false;
        let mut last = Duration::ZERO;
        let mut iterations = 0;
        loop {
            let t0 = Instant::now();
            let u = model.velocities(&v);
            let proj = model.impulses(&u);
            let gamma: Vec<[f64; 3]> = proj.iter().map(|(g, _)| *g).collect();
            let jg = model.generalized_impulse(&gamma);
            let p = model.momentum(&v);
            let grad: Vec<f64> = p.iter().zip(&jg).map(|(a, b)| a - b).collect();
            if grad.iter().any(|x| !x.is_finite()) {
                return finish(
                    v,
                    iterations,
                    Outcome::NumericalFailure("non-finite gradient of ℓ".into()),
                );
            }
            let optimal = scaled_norm(model, &grad)
                <= ABS_TOLERANCE + eps_rel * scaled_norm(model, &p).max(scaled_norm(model, &jg));
            if optimal || cost_reached {
                return finish(v, iterations, Outcome::Stopped);
            }
            if iterations >= settings.max_iterations {
                return finish(v, iterations, Outcome::IterationLimit);
            }
            if monitor.out_of_time() || monitor.cannot_fit(last) {
                return finish(v, iterations, Outcome::TimeLimit);
            }
            let g: Vec<[[f64; 3]; 3]> = proj.iter().map(|(_, g)| *g).collect();
            pattern.fill(model, &g, &mut vals);
            let hessian = SparseColMatRef::new(symbolic_pattern.as_ref(), &vals);
            let llt = match Llt::try_new_with_symbolic(symbolic.clone(), hessian, Side::Lower) {
                Ok(llt) => llt,
                Err(e) => {
                    return finish(
                        v,
                        iterations,
                        Outcome::NumericalFailure(format!(
                            "Cholesky of the body Hessian M + Jᵀ G J failed: {e:?}"
                        )),
                    )
                }
            };
            let mut dv = Mat::<f64>::from_fn(nv, 1, |i, _| -grad[i]);
            llt.solve_in_place_with_conj(faer::Conj::No, dv.as_mut());
            let dv: Vec<f64> = (0..nv).map(|i| dv[(i, 0)]).collect();
            let mdv = model.momentum(&dv);
            let line = Line {
                model,
                u0: u,
                du: model.directions(&dv),
                vmv: 0.5 * dot(&v, &p),
                dmv: dot(&dv, &p),
                dmd: dot(&dv, &mdv),
            };
            let cost0 = line.vmv + model.contact_cost(&gamma);
            let (alpha, cost, _) = match exact_line_search(&line) {
                Ok(step) => step,
                Err(reason) => {
                    return finish(v, iterations, Outcome::NumericalFailure(reason));
                }
            };
            for (x, d) in v.iter_mut().zip(&dv) {
                *x += alpha * d;
            }
            iterations += 1;
            cost_reached = (cost0 - cost).abs() < COST_ABS + COST_REL * cost.abs();
            if settings.record_history {
                let r = impulse(model, &v);
                monitor.record(iterations, &r);
            }
            last = t0.elapsed();
        }
    }
}

/// `r = γ(v)`, contact by contact.
fn impulse(model: &Model, v: &[f64]) -> Vec<f64> {
    let u = model.velocities(v);
    model
        .impulses(&u)
        .into_iter()
        .flat_map(|(g, _)| g)
        .collect()
}

/// The regularised model's softness at `r`: the largest normal velocity error `R_N γ_N` and
/// tangential creep `R_T ‖γ_T‖`, each with its contact.
fn softness(model: &Model, r: &[f64]) -> ((f64, usize), (f64, usize)) {
    let (mut normal, mut tangent) = ((0.0, 0), (0.0, 0));
    for (c, k) in model.contacts.iter().enumerate() {
        let n = k.rn * r[3 * c];
        let t = k.rt * r[3 * c + 1].hypot(r[3 * c + 2]);
        if n > normal.0 {
            normal = (n, c);
        }
        if t > tangent.0 {
            tangent = (t, c);
        }
    }
    (normal, tangent)
}

/// The contacts that push and separate at once (`γ_N > 0`, `u_N > 0`, `u = W r + q`): how many,
/// and the largest such normal velocity with its contact.
fn lift_off(problem: &ConeProblem, r: &[f64]) -> (usize, (f64, usize)) {
    let u = problem.velocity(r);
    let (mut count, mut largest) = (0, (0.0, 0));
    for c in 0..problem.contacts() {
        if r[3 * c] > 0.0 && u[3 * c] > 0.0 {
            count += 1;
            if u[3 * c] > largest.0 {
                largest = (u[3 * c], c);
            }
        }
    }
    (count, largest)
}

impl ConeSolver for Sap {
    fn entry(&self) -> &'static SolverEntry {
        &SAP
    }

    fn solve_cone(&mut self, problem: &ConeProblem, settings: &Settings) -> SolveResult {
        let mut monitor = ConeMonitor::new(problem, settings);
        let n = problem.n();
        let Some(factors) = problem.factors() else {
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(
                    "sap works on the bodies: it needs the factors J, M⁻¹ of W (a cone problem \
                     from a contact scene), and this problem has W only (e.g. an FCLIB file)"
                        .into(),
                ),
            );
        };
        if !(self.beta > 0.0 && self.beta.is_finite() && self.sigma > 0.0 && self.sigma.is_finite())
        {
            return monitor.finish(
                Vec::new(),
                0,
                Outcome::Unsupported(format!(
                    "beta = {} and sigma = {} must be positive and finite",
                    self.beta, self.sigma
                )),
            );
        }
        let model = match Model::new(problem, factors, self.beta, self.sigma) {
            Ok(model) => model,
            Err(reason) => return monitor.finish(Vec::new(), 0, Outcome::Unsupported(reason)),
        };
        let v0 = match &settings.warm_start {
            Some(ws) if ws.len() == n && ws.iter().all(|x| x.is_finite()) => {
                let all = factors.body_velocity(ws);
                let mut v = Vec::with_capacity(model.nv());
                for (b, block) in factors.inverse_mass().iter().enumerate() {
                    if block.iter().flatten().any(|&x| x != 0.0) {
                        v.extend_from_slice(&all[6 * b..6 * b + 6]);
                    }
                }
                v
            }
            _ => vec![0.0; model.nv()],
        };
        let run = self.newton(&model, v0, settings, &mut monitor);
        let r = impulse(&model, &run.v);
        let outcome = match run.outcome {
            Outcome::Stopped if r.iter().all(|x| x.is_finite()) => {
                let rel = monitor.residual_of(&r);
                if rel <= settings.tolerance {
                    Outcome::Stopped
                } else {
                    let ((n_err, nc), (t_err, tc)) = softness(&model, &r);
                    let (lifted, (lift, lc)) = lift_off(problem, &r);
                    Outcome::Stalled(format!(
                        "solved SAP's regularised convex model (beta = {}, sigma = {}) to its \
                         optimality criterion in {} Newton iteration(s), not the exact Coulomb \
                         cone: the model leaves normal velocity errors up to R_N γ_N = {n_err:.3e} \
                         (contact {nc}) and tangential creep up to R_T ‖γ_T‖ = {t_err:.3e} \
                         (contact {tc}); {lifted} of {} contacts push and separate at once \
                         (lift-off, largest u_N = {lift:.3e} at contact {lc}); relative residual \
                         on the exact cone {rel:.3e} > tolerance {:.1e}",
                        self.beta,
                        self.sigma,
                        run.iterations,
                        problem.contacts(),
                        settings.tolerance
                    ))
                }
            }
            other => other,
        };
        monitor.finish(r, run.iterations, outcome)
    }
}

#[cfg(test)]
mod tests;
