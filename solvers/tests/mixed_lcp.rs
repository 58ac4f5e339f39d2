//! Mixed LCPs: the equality (free) rows of joints, `lo = −∞`, `hi = +∞` with `w_i = 0`, in the
//! same problem as contact rows (normals on `[0, ∞)`, box friction `±mu f_k`).
//!
//! Every problem but the hand-solved pendulum is built around a planted solution on a Delassus
//! matrix `A = J M⁻¹ Jᵀ` of rigid bodies (random Jacobians with fixed seeds, planar link chains
//! with mass ratios of `1e6`, redundant joints), and every answer is checked against a residual
//! computed here from `A`, `b` and the returned `f`, not against the solver's own. The pivoting
//! methods (`lemke`, `dantzig`, `enum`) must solve every problem; every other solver may stop
//! short, but a `converged` must meet the residual here, and none may claim that a problem with
//! a (planted) solution has none.

use faer::Mat;
use lcpbench_solvers::{
    sparse_from_triplets, FrictionRow, Problem, Settings, SolveResult, SolverKind, Status,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What a row of a problem is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// A joint's equality row: `f` free, `w = 0`.
    Free,
    /// A contact normal: `0 <= f ⟂ w >= 0`.
    Normal,
    /// A box-friction row bounded by `±mu f_normal`.
    Friction { normal: usize, mu: f64 },
}

/// A mixed problem with the data the independent check reads.
struct Mixed {
    name: String,
    a: Mat<f64>,
    b: Vec<f64>,
    kinds: Vec<Kind>,
    /// A solution.
    f: Vec<f64>,
    /// `f` is the only solution (positive definite `A`, no friction rows). Otherwise a
    /// frictionless problem's solutions share their `w` (semidefinite `A`), and a problem with
    /// friction rows may have several.
    unique: bool,
}

impl Mixed {
    /// The problem, `A` dense or sparse.
    fn problem(&self, sparse: bool) -> Problem {
        let n = self.b.len();
        let inf = f64::INFINITY;
        let lo = self
            .kinds
            .iter()
            .map(|k| if *k == Kind::Free { -inf } else { 0.0 })
            .collect();
        let friction = self
            .kinds
            .iter()
            .enumerate()
            .filter_map(|(row, k)| match *k {
                Kind::Friction { normal, mu } => Some(FrictionRow { row, normal, mu }),
                _ => None,
            })
            .collect();
        let (b, hi) = (self.b.clone(), vec![inf; n]);
        let p = if sparse {
            let triplets: Vec<(usize, usize, f64)> = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .map(|(i, j)| (i, j, self.a[(i, j)]))
                .filter(|&(i, j, v)| v != 0.0 || i == j)
                .collect();
            let a = sparse_from_triplets(n, &triplets).unwrap();
            Problem::boxed_sparse(a, b, lo, hi, friction)
        } else {
            Problem::boxed(self.a.clone(), b, lo, hi, friction)
        };
        p.unwrap().with_name(self.name.clone())
    }

    /// The same problem with its rows in the order `perm` (new row `k` is old row `perm[k]`).
    fn permuted(self, perm: &[usize]) -> Self {
        let n = perm.len();
        let mut inv = vec![0; n];
        perm.iter().enumerate().for_each(|(k, &p)| inv[p] = k);
        let kinds = perm
            .iter()
            .map(|&p| match self.kinds[p] {
                Kind::Friction { normal, mu } => Kind::Friction {
                    normal: inv[normal],
                    mu,
                },
                k => k,
            })
            .collect();
        Self {
            name: format!("{}, rows reordered", self.name),
            a: Mat::from_fn(n, n, |i, j| self.a[(perm[i], perm[j])]),
            b: perm.iter().map(|&p| self.b[p]).collect(),
            kinds,
            f: perm.iter().map(|&p| self.f[p]).collect(),
            unique: self.unique,
        }
    }

    /// `w = A f + b`, computed here.
    fn velocity(&self, f: &[f64]) -> Vec<f64> {
        let n = self.b.len();
        (0..n)
            .map(|i| self.b[i] + (0..n).map(|j| self.a[(i, j)] * f[j]).sum::<f64>())
            .collect()
    }

    /// Row `i`'s scale at `f`: the magnitude of the terms of its velocity,
    /// `|b_i| + Σ_j |A_ij f_j|`.
    fn row_scale(&self, i: usize, f: &[f64]) -> f64 {
        let n = self.b.len();
        self.b[i].abs() + (0..n).map(|j| (self.a[(i, j)] * f[j]).abs()).sum::<f64>()
    }

    /// The largest error of `f` over the rows, each relative to its own row's scale: a free
    /// row's `|w_i|`, a bounded row's natural-map step `|f_i − mid(lo_i, hi_i, f_i − w_i / A_ii)|`
    /// times `A_ii` (which also measures a bound violation). `0/0` counts as 0.
    fn error(&self, f: &[f64]) -> f64 {
        let n = self.b.len();
        if f.len() != n || f.iter().any(|v| !v.is_finite()) {
            return f64::INFINITY;
        }
        let w = self.velocity(f);
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let d = self.a[(i, i)];
            let err = match self.kinds[i] {
                Kind::Free => w[i].abs(),
                Kind::Normal => (f[i] - (f[i] - w[i] / d).max(0.0)).abs() * d,
                Kind::Friction { normal, mu } => {
                    let c = mu * f[normal].max(0.0);
                    (f[i] - (f[i] - w[i] / d).clamp(-c, c)).abs() * d
                }
            };
            if err != 0.0 {
                worst = worst.max(err / self.row_scale(i, f));
            }
        }
        worst
    }

    fn has_friction(&self) -> bool {
        self.kinds
            .iter()
            .any(|k| matches!(k, Kind::Friction { .. }))
    }
}

/// `A = J M⁻¹ Jᵀ` for a diagonal `M⁻¹`, exactly symmetric.
fn delassus(j: &Mat<f64>, inv_mass: &[f64]) -> Mat<f64> {
    let n = j.nrows();
    let mut a = Mat::zeros(n, n);
    for r in 0..n {
        for c in r..n {
            let v: f64 = (0..j.ncols())
                .map(|k| j[(r, k)] * inv_mass[k] * j[(c, k)])
                .sum();
            a[(r, c)] = v;
            a[(c, r)] = v;
        }
    }
    a
}

/// A solution planted on `a` for rows of `kinds`: free rows get impulses of alternating signs
/// (every problem has a pulling and a pushing joint row) and `w = 0`; normals are pressed
/// (`f > 0`, `w = 0`) or separate (`f = 0`, `w > 0`); friction rows of a pressed normal stick
/// inside their box (`w = 0`) or slide at a bound with a velocity of the sliding sign. Returns
/// `(f, b)` with `b = w − A f`.
fn plant(a: &Mat<f64>, kinds: &[Kind], rng: &mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>) {
    let n = kinds.len();
    let (mut f, mut w) = (vec![0.0; n], vec![0.0; n]);
    let mut free_rows = 0;
    for i in 0..n {
        match kinds[i] {
            Kind::Free => {
                let sign = if free_rows % 2 == 0 { -1.0 } else { 1.0 };
                f[i] = sign * rng.random_range(0.5..2.0);
                free_rows += 1;
            }
            Kind::Normal => {
                if rng.random_bool(0.7) {
                    f[i] = rng.random_range(0.5..2.0);
                } else {
                    w[i] = rng.random_range(0.2..1.0);
                }
            }
            Kind::Friction { .. } => {}
        }
    }
    for i in 0..n {
        if let Kind::Friction { normal, mu } = kinds[i] {
            let c = mu * f[normal];
            if c == 0.0 {
                w[i] = rng.random_range(-1.0..1.0);
            } else if rng.random_bool(0.5) {
                f[i] = c * rng.random_range(-0.8..0.8);
            } else {
                let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                f[i] = sign * c;
                w[i] = -sign * rng.random_range(0.2..1.0);
            }
        }
    }
    let b = (0..n)
        .map(|i| w[i] - (0..n).map(|j| a[(i, j)] * f[j]).sum::<f64>())
        .collect();
    (f, b)
}

/// The row of a planar rigid body (`x`, `y`, `θ`) for the velocity along `e` of the point at
/// offset `r` from its centre: `e · v + (r × e) ω`.
fn planar_row(e: [f64; 2], r: [f64; 2]) -> [f64; 3] {
    [e[0], e[1], r[0] * e[1] - r[1] * e[0]]
}

/// How the masses of a chain's links go.
#[derive(Debug, Clone, Copy)]
enum Masses {
    /// Log-spaced from 1 to the ratio along the chain.
    Graded(f64),
    /// 1 and the ratio, alternately (a light link between two heavy ones).
    Alternating(f64),
}

/// A chain of `links` planar links of unit length (seeded random angles, hanging), the first
/// pinned to the world, each pinned to the next (two joint rows per pin, so `A` is block
/// tridiagonal along the chain), with a contact at the far end of every other link (a normal
/// and, with `friction`, a friction row, `mu = 0.5`). With `weld` the first link is also welded
/// to the world at its pin (three more joint rows: the pin's two rows come twice, a redundant
/// joint that makes `A_FF` singular, and the link's contact is redundant too).
fn chain(links: usize, masses: Masses, weld: bool, friction: bool, seed: u64) -> Mixed {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dofs = 3 * links;
    let mut inv_mass = Vec::with_capacity(dofs);
    for k in 0..links {
        let m = match masses {
            Masses::Graded(ratio) => ratio.powf(k as f64 / (links - 1).max(1) as f64),
            Masses::Alternating(ratio) => [1.0, ratio][k % 2],
        };
        let inertia = m / 12.0;
        inv_mass.extend([1.0 / m, 1.0 / m, 1.0 / inertia]);
    }
    // Each link's half-vector from its centre to its far end.
    let half: Vec<[f64; 2]> = (0..links)
        .map(|_| {
            let phi: f64 = rng.random_range(-1.2..1.2) - std::f64::consts::FRAC_PI_2;
            [0.5 * phi.cos(), 0.5 * phi.sin()]
        })
        .collect();
    let near = |k: usize| [-half[k][0], -half[k][1]];
    let axes = [[1.0, 0.0], [0.0, 1.0]];
    let mut rows: Vec<Vec<(usize, [f64; 3])>> = Vec::new();
    let mut kinds = Vec::new();
    let pins_to_world = if weld { 2 } else { 1 };
    for _ in 0..pins_to_world {
        for e in axes {
            rows.push(vec![(0, planar_row(e, near(0)))]);
            kinds.push(Kind::Free);
        }
    }
    if weld {
        rows.push(vec![(0, [0.0, 0.0, 1.0])]);
        kinds.push(Kind::Free);
    }
    for (k, &far) in half.iter().enumerate().take(links - 1) {
        for e in axes {
            let theirs = planar_row(e, near(k + 1)).map(|v| -v);
            rows.push(vec![(k, planar_row(e, far)), (k + 1, theirs)]);
            kinds.push(Kind::Free);
        }
    }
    for k in (0..links).step_by(2) {
        let normal = rows.len();
        rows.push(vec![(k, planar_row([0.0, 1.0], half[k]))]);
        kinds.push(Kind::Normal);
        if friction {
            rows.push(vec![(k, planar_row([1.0, 0.0], half[k]))]);
            kinds.push(Kind::Friction { normal, mu: 0.5 });
        }
    }
    let n = rows.len();
    let mut j = Mat::zeros(n, dofs);
    for (r, blocks) in rows.iter().enumerate() {
        for &(body, entries) in blocks {
            for (c, v) in entries.iter().enumerate() {
                j[(r, 3 * body + c)] = *v;
            }
        }
    }
    let a = delassus(&j, &inv_mass);
    let (f, b) = plant(&a, &kinds, &mut rng);
    Mixed {
        name: format!(
            "chain of {links} links, masses {masses:?}{}{}, seed {seed}",
            if weld { ", welded" } else { "" },
            if friction { ", friction" } else { "" }
        ),
        a,
        b,
        kinds,
        f,
        unique: !weld && !friction && n <= dofs,
    }
}

/// What [`random_bodies`] builds.
#[derive(Debug, Clone, Copy)]
struct Bodies {
    bodies: usize,
    joints: usize,
    rows_per_joint: usize,
    /// Extra joint rows, each a combination of two others (a closed loop's dependent
    /// constraints: `A_FF` singular).
    redundant: usize,
    contacts: usize,
    friction: bool,
    /// Masses log-uniform over `[1, mass_ratio]`.
    mass_ratio: f64,
}

/// Random Jacobians on spatial bodies (6 DoF): joints of several rows between random pairs of
/// bodies, and contacts (a normal and, with friction, two friction rows, `mu = 0.6`) on one
/// body each.
fn random_bodies(c: Bodies, seed: u64) -> Mixed {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dofs = 6 * c.bodies;
    let inv_mass: Vec<f64> = (0..c.bodies)
        .flat_map(|_| {
            let m = c.mass_ratio.powf(rng.random_range(0.0..1.0));
            let i = m * rng.random_range(0.1..0.5);
            [1.0 / m, 1.0 / m, 1.0 / m, 1.0 / i, 1.0 / i, 1.0 / i]
        })
        .collect();
    let random_row = |on: &[usize], rng: &mut ChaCha8Rng| {
        let mut row = vec![0.0; dofs];
        for (s, &body) in on.iter().enumerate() {
            let sign = if s == 0 { 1.0 } else { -1.0 };
            for k in 0..6 {
                row[6 * body + k] = sign * rng.random_range(-1.0..1.0);
            }
        }
        row
    };
    let mut j_rows: Vec<Vec<f64>> = Vec::new();
    let mut kinds = Vec::new();
    for _ in 0..c.joints {
        let p = rng.random_range(0..c.bodies);
        let q = (p + rng.random_range(1..c.bodies)) % c.bodies;
        for _ in 0..c.rows_per_joint {
            j_rows.push(random_row(&[p, q], &mut rng));
            kinds.push(Kind::Free);
        }
    }
    let joint_rows = j_rows.len();
    for _ in 0..c.redundant {
        let (x, y) = (
            rng.random_range(0..joint_rows),
            rng.random_range(0..joint_rows),
        );
        let (cx, cy) = (rng.random_range(0.5..1.5), rng.random_range(-1.5..-0.5));
        let row = (0..dofs)
            .map(|k| cx * j_rows[x][k] + cy * j_rows[y][k])
            .collect();
        j_rows.push(row);
        kinds.push(Kind::Free);
    }
    for _ in 0..c.contacts {
        let body = rng.random_range(0..c.bodies);
        let normal = j_rows.len();
        j_rows.push(random_row(&[body], &mut rng));
        kinds.push(Kind::Normal);
        if c.friction {
            for _ in 0..2 {
                j_rows.push(random_row(&[body], &mut rng));
                kinds.push(Kind::Friction { normal, mu: 0.6 });
            }
        }
    }
    let n = j_rows.len();
    let j = Mat::from_fn(n, dofs, |r, k| j_rows[r][k]);
    let a = delassus(&j, &inv_mass);
    let (f, b) = plant(&a, &kinds, &mut rng);
    Mixed {
        name: format!("{c:?}, seed {seed}"),
        a,
        b,
        kinds,
        f,
        unique: c.redundant == 0 && !c.friction && n <= dofs,
    }
}

/// One spatial body welded to the world (six joint rows of a random regular Jacobian) with
/// `contacts` contacts on it (a normal and two friction rows each): `A` is singular, `A_FF` is
/// not, and every contact is redundant (the weld holds the body whatever they do).
fn welded_body(contacts: usize, seed: u64) -> Mixed {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let inv_mass = [1.0, 1.0, 1.0, 4.0, 4.0, 4.0];
    let mut j_rows: Vec<[f64; 6]> = Vec::new();
    let mut kinds = Vec::new();
    for k in 0..6 {
        let mut row: [f64; 6] = std::array::from_fn(|_| 0.3 * rng.random_range(-1.0..1.0));
        row[k] += 1.0;
        j_rows.push(row);
        kinds.push(Kind::Free);
    }
    for _ in 0..contacts {
        let normal = j_rows.len();
        for t in 0..3 {
            j_rows.push(std::array::from_fn(|_| rng.random_range(-1.0..1.0)));
            kinds.push(if t == 0 {
                Kind::Normal
            } else {
                Kind::Friction { normal, mu: 0.4 }
            });
        }
    }
    let n = j_rows.len();
    let j = Mat::from_fn(n, 6, |r, k| j_rows[r][k]);
    let a = delassus(&j, &inv_mass);
    let (f, b) = plant(&a, &kinds, &mut rng);
    Mixed {
        name: format!("a body welded to the world with {contacts} contacts, seed {seed}"),
        a,
        b,
        kinds,
        f,
        unique: false,
    }
}

/// The default tolerance of the shared residual; a `converged` result must meet it here too,
/// up to a factor 2 for the different order of the sums.
const TOL: f64 = 1e-8;

fn is_pivoting(kind: SolverKind) -> bool {
    [
        SolverKind::Lemke,
        SolverKind::Dantzig,
        SolverKind::Enumeration,
    ]
    .contains(&kind)
}

fn solve(kind: SolverKind, p: &Problem) -> SolveResult {
    kind.create().solve(p, &Settings::default())
}

/// Every solver accepts the free rows; a `converged` meets the residual computed here, and no
/// solver says a problem with a solution has none.
fn assert_honest(kind: SolverKind, m: &Mixed, r: &SolveResult) {
    let (name, err) = (kind.name(), m.error(&r.f));
    assert!(
        !matches!(
            r.status,
            Status::Unsupported { .. } | Status::NoSolution { .. }
        ),
        "{name} on {}: {}",
        m.name,
        r.status
    );
    if r.status.is_converged() {
        assert!(
            err <= 2.0 * TOL,
            "{name} on {}: converged, but the residual here is {err:.3e}",
            m.name
        );
    }
}

/// A pivoting method's answer: converged, the residual here at round-off level (`1e-10`), and
/// the planted solution's `f` (when it is the only one) or `w` (frictionless problems: every
/// solution has the same `w`) to `1e-6` of the problem's size.
fn assert_exact(kind: SolverKind, m: &Mixed, r: &SolveResult) {
    let (name, err) = (kind.name(), m.error(&r.f));
    assert_eq!(r.status, Status::Converged, "{name} on {}", m.name);
    assert!(err <= 1e-10, "{name} on {}: residual {err:.3e}", m.name);
    let size = m.f.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
    if m.unique {
        for (x, y) in r.f.iter().zip(&m.f) {
            assert!((x - y).abs() <= 1e-6 * size, "{name} on {}: f", m.name);
        }
    } else if !m.has_friction() {
        let (w, planted) = (m.velocity(&r.f), m.velocity(&m.f));
        for i in 0..w.len() {
            let scale = m.row_scale(i, &m.f);
            assert!(
                (w[i] - planted[i]).abs() <= 1e-6 * scale,
                "{name} on {}: w[{i}] = {} against {}",
                m.name,
                w[i],
                planted[i]
            );
        }
    }
}

/// Run every solver on `m` (stored dense, or sparse with `sparse`): the pivoting methods must
/// solve it, the others be honest.
fn check_all(m: &Mixed, sparse: bool) {
    assert!(m.error(&m.f) <= 1e-14, "{}: planted solution", m.name);
    let p = m.problem(sparse);
    for kind in SolverKind::all() {
        let r = solve(kind, &p);
        assert_honest(kind, m, &r);
        if is_pivoting(kind) {
            assert_exact(kind, m, &r);
        }
    }
}

/// A pendulum bob of mass 2 hanging on a rod from a pivot up and to the left (rod direction
/// `(3/5, −4/5)` from the pivot), pressed against a wall on its right (normal `(−1, 0)`), moving
/// at `v = (2, −1)`. Row 0 is the rod (the bob's stretch rate `u · v`, free), row 1 the wall
/// contact. `A = J M⁻¹ Jᵀ = [[1/2, −3/10], [−3/10, 1/2]]`, `b = J v = (2, −2)`; with both rows
/// at `w = 0`: `5 f₀ − 3 f₁ = −20`, `−3 f₀ + 5 f₁ = 20`, so `f = (−5/2, 5/2)`: the rod pulls
/// (a negative free impulse), the wall pushes, and the bob stops (`v + M⁻¹ Jᵀ f = 0`). The
/// wall's other state (`f₁ = 0`) gives `f₀ = −4` and `w₁ = −4/5 < 0`, so the answer is unique.
#[test]
fn pendulum_against_a_wall_by_hand() {
    let a = Mat::from_fn(2, 2, |i, j| [[0.5, -0.3], [-0.3, 0.5]][i][j]);
    let inf = f64::INFINITY;
    let p = Problem::boxed(
        a.clone(),
        vec![2.0, -2.0],
        vec![-inf, 0.0],
        vec![inf, inf],
        vec![],
    )
    .unwrap();
    let m = Mixed {
        name: "pendulum against a wall".into(),
        a,
        b: vec![2.0, -2.0],
        kinds: vec![Kind::Free, Kind::Normal],
        f: vec![-2.5, 2.5],
        unique: true,
    };
    assert_eq!(m.error(&m.f), 0.0);
    for kind in SolverKind::all() {
        let r = solve(kind, &p);
        assert_honest(kind, &m, &r);
        if is_pivoting(kind) {
            assert_exact(kind, &m, &r);
            for (x, y) in r.f.iter().zip([-2.5, 2.5]) {
                assert!((x - y).abs() <= 1e-14, "{}: {:?}", kind.name(), r.f);
            }
        }
        if r.status.is_converged() {
            // Whoever converges pulls on the rod.
            assert!(r.f[0] < -2.49, "{}: {:?}", kind.name(), r.f);
        }
    }
    // Micro-impulses pull on the rod too: a free row takes impulses of either sign.
    let r = solve(SolverKind::MicroImpulse, &p);
    assert_eq!(r.status, Status::Converged, "{}", r.status);
}

/// Joints between random bodies with contacts, with and without friction, stored dense and
/// sparse, and with the rows reordered so that contacts come before joints.
#[test]
fn planted_joints_and_contacts() {
    for seed in 0..6 {
        let friction = seed % 2 == 1;
        let m = random_bodies(
            Bodies {
                bodies: 4,
                joints: 3,
                rows_per_joint: 2,
                redundant: 0,
                contacts: 3,
                friction,
                mass_ratio: 1e3,
            },
            seed,
        );
        let m = if seed >= 3 {
            let n = m.b.len();
            let perm: Vec<usize> = (0..n).rev().collect();
            m.permuted(&perm)
        } else {
            m
        };
        check_all(&m, seed % 3 == 2);
    }
    // Joints alone: the pivoting methods solve the linear system.
    let m = random_bodies(
        Bodies {
            bodies: 3,
            joints: 3,
            rows_per_joint: 3,
            redundant: 0,
            contacts: 0,
            friction: false,
            mass_ratio: 1e4,
        },
        10,
    );
    check_all(&m, false);
}

/// Chains of links with a mass ratio of `1e6`, graded along the chain or alternating (a light
/// link between heavy ones, the worse conditioned).
#[test]
fn chains_with_a_mass_ratio_of_1e6() {
    check_all(&chain(6, Masses::Graded(1e6), false, true, 4), false);
    check_all(&chain(6, Masses::Graded(1e6), false, false, 7), true);
    check_all(&chain(7, Masses::Alternating(1e6), false, false, 15), false);
    // The same chain with its rows shuffled (joints among the contacts).
    let m = chain(7, Masses::Alternating(1e6), false, false, 15);
    let n = m.b.len();
    let perm: Vec<usize> = (0..n).map(|k| (5 * k + 3) % n).collect();
    check_all(&m.permuted(&perm), false);
}

/// With friction on the alternating chain, Lemke and enumeration still solve every seed
/// exactly, and every solver stays honest. Dantzig's friction-bound fixed point stalls on some
/// seeds (measured: 14, and 3, 6 and 10 of 0..12): it pivots on the contacts' Schur complement,
/// where the joints are already eliminated, so the stall is its friction heuristic's (its module
/// documentation says that fixed point need not converge), and it is held to honesty here.
#[test]
fn alternating_chain_with_friction() {
    for seed in [0, 1, 3, 11, 14] {
        let m = chain(7, Masses::Alternating(1e6), false, true, seed);
        let p = m.problem(false);
        for kind in SolverKind::all() {
            let r = solve(kind, &p);
            assert_honest(kind, &m, &r);
            if [SolverKind::Lemke, SolverKind::Enumeration].contains(&kind) {
                assert_exact(kind, &m, &r);
            }
        }
    }
}

/// Redundant joints: a chain welded to the world beside its pin (the pin's rows twice),
/// closed-loop rows that combine other joint rows, and contacts on a welded body (`A` singular,
/// `A_FF` regular, every contact redundant).
#[test]
fn redundant_joints() {
    check_all(&chain(6, Masses::Graded(1e6), true, true, 5), false);
    check_all(&chain(6, Masses::Graded(1e6), true, false, 8), false);
    check_all(&chain(7, Masses::Alternating(1e6), true, true, 16), false);
    check_all(&chain(7, Masses::Alternating(1e6), true, false, 17), false);
    for (seed, friction) in [(6, true), (9, false)] {
        let c = Bodies {
            bodies: 4,
            joints: 3,
            rows_per_joint: 2,
            redundant: 2,
            contacts: 3,
            friction,
            mass_ratio: 1e2,
        };
        check_all(&random_bodies(c, seed), seed == 9);
    }
    let joints_only = Bodies {
        bodies: 3,
        joints: 3,
        rows_per_joint: 3,
        redundant: 2,
        contacts: 0,
        friction: false,
        mass_ratio: 1e4,
    };
    check_all(&random_bodies(joints_only, 11), false);
    check_all(&welded_body(2, 12), false);
    check_all(&welded_body(3, 13), false);
}

/// Redundant joints whose velocities disagree (a closed loop's dependent row off by 0.5) have
/// no solution: nobody converges, and without friction Lemke, Dantzig and Clarabel prove it.
/// Lemke's reason says how the free rows were treated.
#[test]
fn inconsistent_redundant_joints_have_no_solution() {
    for (seed, friction) in [(21, false), (22, true)] {
        let mut m = random_bodies(
            Bodies {
                bodies: 4,
                joints: 3,
                rows_per_joint: 2,
                redundant: 2,
                contacts: 3,
                friction,
                mass_ratio: 1e2,
            },
            seed,
        );
        assert_eq!(m.kinds[6], Kind::Free, "row 6 is the first redundant row");
        m.b[6] += 0.5;
        let p = m.problem(false);
        for kind in SolverKind::all() {
            let r = solve(kind, &p);
            assert!(!r.status.is_converged(), "{}: {}", kind.name(), r.status);
            let proves =
                [SolverKind::Lemke, SolverKind::Dantzig, SolverKind::Clarabel].contains(&kind);
            if proves && !friction {
                assert_eq!(r.status.name(), "no_solution", "{}", kind.name());
            }
            if kind == SolverKind::Lemke {
                let reason = r.status.reason().unwrap_or_default();
                assert!(
                    reason.contains("free rows eliminated") && reason.contains("kept free"),
                    "{reason}"
                );
            }
        }
    }
}

/// Mass ratios past `1e6` (up to `1e10`, alternating along the chain, with and without
/// friction): every solver stays honest, and Lemke and enumeration still solve every one.
#[test]
fn extreme_mass_ratios_stay_honest() {
    for ratio in [1e8, 1e10] {
        for seed in 2..5 {
            for friction in [false, true] {
                let m = chain(7, Masses::Alternating(ratio), false, friction, seed);
                let p = m.problem(false);
                for kind in SolverKind::all() {
                    let r = solve(kind, &p);
                    assert_honest(kind, &m, &r);
                    if [SolverKind::Lemke, SolverKind::Enumeration].contains(&kind) {
                        assert_eq!(r.status, Status::Converged, "{} on {}", kind.name(), m.name);
                    }
                }
            }
        }
    }
}
