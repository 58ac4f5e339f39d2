//! The reduction of a boxed problem with friction rows to the standard LCP `w' = M z + q` that
//! Lemke's method pivots on, and the map back to impulses (see the module documentation of
//! [`crate::lcp::lemke`]). Free rows are eliminated first when they can be
//! ([`crate::lcp::free_rows`]); the reduction then works on the problem of the other rows.

use super::Var;
use crate::lcp::free_rows::FreeRows;
use crate::problem::Problem;

/// The standard LCP `w' = M z + q` that a boxed problem reduces to, scaled so that
/// `max|M| = max|q| = 1` (the pivot and tie tolerances are relative), and the map back
/// `f_i = c_i + Σ_v s_v z_v` over the variables `v` of row `i`.
pub(super) struct Reduction {
    /// `M / max|M|`, row-major, `m × m`.
    pub(super) m: Vec<f64>,
    /// `q / max|q|`.
    pub(super) q: Vec<f64>,
    /// `max|q|` and `max|M|` before the scaling: the LCP's `z` is the scaled one times
    /// `max|q| / max|M|`.
    pub(super) q_scale: f64,
    pub(super) m_scale: f64,
    /// Offset of each original row.
    pub(super) c: Vec<f64>,
    /// For each LCP variable: `Some((row, sign))` when it is (a signed part of) `f_row − c_row`,
    /// `None` for a box slack.
    pub(super) var_row: Vec<Option<(usize, f64)>>,
    /// The equilibration `s_i = 1/√d_i`: row `i`'s LCP variables are in units of `scale_i`.
    pub(super) scale: Vec<f64>,
    /// Friction rows reduced by sliding speeds (their `M` is never copositive-plus).
    pub(super) sliding_rows: usize,
    /// The free rows: eliminated (the rows above are then those of the reduced problem, and
    /// [`Reduction::impulse`] recovers the free impulses), split, or none.
    pub(super) free: FreeRows,
}

/// The LCP variables of a boxed problem's rows (the reductions of the module documentation),
/// before `M` and `q` are formed.
pub(super) struct Variables {
    /// Offset of each original row.
    pub(super) c: Vec<f64>,
    /// `(row, sign)` of each variable that is (a signed part of) `f_row − c_row`.
    pub(super) vars: Vec<(usize, f64)>,
    /// `(index of the variable x in vars, (hi − lo) / scale)` for every box row.
    pub(super) slacks: Vec<(usize, f64)>,
    /// `(index of x⁺ in vars, friction row, its normal row, mu)` for every friction row.
    pub(super) sliding: Vec<(usize, usize, usize, f64)>,
    /// The first variable of each row (read only by the sliding rows; empty without them).
    pub(super) first_var: Vec<usize>,
}

impl Variables {
    /// The variables of every row (a problem whose friction rows passed
    /// [`check_friction_normals`]).
    pub(super) fn of(problem: &Problem, scale: &[f64]) -> Self {
        let n = problem.n();
        let (lo, hi) = (problem.lo(), problem.hi());
        let mut out = Variables {
            c: vec![0.0; n],
            vars: Vec::with_capacity(n),
            slacks: Vec::new(),
            sliding: Vec::new(),
            first_var: if problem.friction().is_empty() {
                Vec::new()
            } else {
                vec![0; n]
            },
        };
        let Variables {
            c,
            vars,
            slacks,
            sliding,
            first_var,
        } = &mut out;
        for i in 0..n {
            if let Some(first) = first_var.get_mut(i) {
                *first = vars.len();
            }
            if let Some((k, mu)) = problem.friction_of(i) {
                sliding.push((vars.len(), i, k, mu));
                vars.push((i, 1.0));
                vars.push((i, -1.0));
                continue;
            }
            match (lo[i].is_finite(), hi[i].is_finite()) {
                (true, false) => {
                    c[i] = lo[i];
                    vars.push((i, 1.0));
                }
                (false, true) => {
                    c[i] = hi[i];
                    vars.push((i, -1.0));
                }
                (true, true) => {
                    c[i] = lo[i];
                    slacks.push((vars.len(), (hi[i] - lo[i]) / scale[i]));
                    vars.push((i, 1.0));
                }
                (false, false) => {
                    vars.push((i, 1.0));
                    vars.push((i, -1.0));
                }
            }
        }
        out
    }

    /// The number of LCP variables: the row variables, one slack per box row and one sliding
    /// speed per friction row.
    pub(super) fn len(&self) -> usize {
        self.vars.len() + self.slacks.len() + self.sliding.len()
    }

    /// `M` (row-major) and `q`, unscaled, in the equilibrated units `f_i = c_i + scale_i · x`:
    /// `M = S A S` and `q = S w(c)` up to signs on the row variables, then the slack and
    /// sliding blocks.
    pub(super) fn lcp(&self, problem: &Problem, scale: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let (vars, n) = (&self.vars, problem.n());
        let w0: std::borrow::Cow<'_, [f64]> = if self.c.iter().all(|&v| v == 0.0) {
            problem.b().into()
        } else {
            problem.velocity(&self.c).into()
        };
        let nv = vars.len();
        let m = self.len();
        let mut q = vec![0.0; m];
        // A standard LCP maps every row to one variable of its own: `M = S A S` row by row,
        // every entry written once (so not zero-filled first).
        let identity_map = m == n
            && vars
                .iter()
                .enumerate()
                .all(|(v, &(i, t))| v == i && t == 1.0);
        let mut mat = if identity_map {
            Vec::with_capacity(m * m)
        } else {
            vec![0.0; m * m]
        };
        for (v, &(i, s)) in vars.iter().enumerate() {
            q[v] = s * scale[i] * w0[i];
            let row = problem.dense_row(i);
            let si = s * scale[i];
            if identity_map {
                mat.extend(row.iter().zip(scale).map(|(a, sj)| si * a * sj));
            } else {
                let out = &mut mat[v * m..(v + 1) * m];
                for (o, &(j, t)) in out.iter_mut().zip(vars) {
                    *o = t * si * row[j] * scale[j];
                }
            }
        }
        for (k, &(v, width)) in self.slacks.iter().enumerate() {
            let y = nv + k;
            mat[v * m + y] = 1.0;
            mat[y * m + v] = -1.0;
            q[y] = width;
        }
        // Friction row `i` on normal `k`: `x⁺ ⟂ w_i + λ`, `x⁻ ⟂ −w_i + λ` and
        // `λ ⟂ mu·f_k − x⁺ − x⁻`, all in row `i`'s equilibrated units.
        for (l, &(v, i, k, mu)) in self.sliding.iter().enumerate() {
            let y = nv + self.slacks.len() + l;
            mat[v * m + y] = 1.0;
            mat[(v + 1) * m + y] = 1.0;
            mat[y * m + v] = -1.0;
            mat[y * m + v + 1] = -1.0;
            mat[y * m + self.first_var[k]] = mu * scale[k] / scale[i];
        }
        (mat, q)
    }
}

/// `Err` naming the first friction row whose normal does not have the bounds `[0, ∞)` the
/// sliding reduction needs.
fn check_friction_normals(problem: &Problem) -> Result<(), String> {
    let (lo, hi) = (problem.lo(), problem.hi());
    for fr in problem.friction() {
        let (i, k) = (fr.row, fr.normal);
        if lo[k] != 0.0 || hi[k] != f64::INFINITY {
            return Err(format!(
                "friction row {i}'s normal row {k} has bounds [{}, {}]: the friction reduction \
                 needs a normal row with bounds [0, ∞)",
                lo[k], hi[k]
            ));
        }
    }
    Ok(())
}

/// `max|v|` (1 for a zero `v`), for finite `v`.
pub(super) fn max_abs(v: &[f64]) -> f64 {
    // Four running maxima: one would be a chain of dependent comparisons.
    let mut m4 = [0.0_f64; 4];
    let mut chunks = v.chunks_exact(4);
    for c in &mut chunks {
        for l in 0..4 {
            // A plain comparison (the data are finite): `f64::max` also orders NaNs.
            let a = c[l].abs();
            if a > m4[l] {
                m4[l] = a;
            }
        }
    }
    let s = chunks
        .remainder()
        .iter()
        .fold(m4[0].max(m4[1]).max(m4[2].max(m4[3])), |m, x| {
            m.max(x.abs())
        });
    if s > 0.0 {
        s
    } else {
        1.0
    }
}

impl Reduction {
    /// The LCP of `problem`: its free rows eliminated when `A_FF` allows it, each (remaining)
    /// row equilibrated by `s_i = 1/√d_i` (so the pivots do not depend on how rows and columns
    /// are scaled: a problem scaled over many decades would otherwise mislead the ratio tests
    /// into a false ray), then reduced as the module documentation says. `Err` when a friction
    /// row's normal does not have the bounds `[0, ∞)`, or the constant term overflows.
    pub(super) fn new(problem: &Problem) -> Result<Self, String> {
        check_friction_normals(problem)?;
        let free = FreeRows::of(problem);
        let rows = free.rows(problem);
        let scale: Vec<f64> = (0..rows.n())
            .map(|i| 1.0 / rows.diagonal_scale_of(i).sqrt())
            .collect();
        let variables = Variables::of(rows, &scale);
        let (mut mat, mut q) = variables.lcp(rows, &scale);
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "the reduced LCP has a non-finite constant term q[{i}] (bounds too large)"
            ));
        }
        let (sm, sq) = (max_abs(&mat), max_abs(&q));
        mat.iter_mut().for_each(|v| *v /= sm);
        q.iter_mut().for_each(|v| *v /= sq);
        let m = variables.len();
        let Variables {
            c, vars, sliding, ..
        } = variables;
        let mut var_row: Vec<Option<(usize, f64)>> = vars.into_iter().map(Some).collect();
        var_row.resize(m, None);
        Ok(Self {
            m: mat,
            q,
            q_scale: sq,
            m_scale: sm,
            sliding_rows: sliding.len(),
            c,
            var_row,
            scale,
            free,
        })
    }

    /// `f = c + S T z`, and the free impulses recovered from it when they were eliminated.
    pub(super) fn impulse(&self, z: &[f64]) -> Vec<f64> {
        let mut f = self.c.clone();
        if z.len() == self.var_row.len() {
            for (v, &zv) in z.iter().enumerate() {
                if let Some((i, s)) = self.var_row[v] {
                    f[i] += s * self.scale[i] * zv;
                }
            }
        }
        self.free.expand(f)
    }

    /// Original rows whose variables are basic in `z` (the active set); eliminated free rows
    /// always count.
    pub(super) fn active_rows(&self, basis: &[Var]) -> Vec<usize> {
        let mut rows: Vec<usize> = basis
            .iter()
            .filter_map(|v| match v {
                Var::Z(j) => self.var_row[*j].map(|(i, _)| i),
                _ => None,
            })
            .collect();
        rows.sort_unstable();
        rows.dedup();
        self.free.original_rows(rows)
    }
}
