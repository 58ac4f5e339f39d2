//! Dantzig's active-set step on friction: the problem with its sliding friction rows eliminated.

use crate::problem::Problem;

/// The problem with the sliding friction rows `t` eliminated by `f_t = sign · mu · f_k`: column
/// `k` of `A` gains `sign · mu · A_{:,t}` (so `A` becomes non-symmetric), and row `t` is dropped.
pub(super) struct Coupled {
    pub(super) problem: Problem,
    /// Original row of each kept row.
    pub(super) kept: Vec<usize>,
    /// `(t, k, sign · mu)` per eliminated row.
    pub(super) sliding: Vec<(usize, usize, f64)>,
    pub(super) n: usize,
}

impl Coupled {
    pub(super) fn new(problem: &Problem, sliding: &[(usize, f64)]) -> Option<Self> {
        let n = problem.n();
        let mut gone = vec![false; n];
        let sliding: Vec<(usize, usize, f64)> = sliding
            .iter()
            .map(|&(t, sign)| {
                gone[t] = true;
                let (k, mu) = problem.friction_of(t).expect("a friction row");
                (t, k, sign * mu)
            })
            .collect();
        let kept: Vec<usize> = (0..n).filter(|&i| !gone[i]).collect();
        let mut new_index = vec![usize::MAX; n];
        for (r, &i) in kept.iter().enumerate() {
            new_index[i] = r;
        }
        let a = problem.dense().expect("Dantzig works on dense islands");
        let mut full = a.clone();
        for &(t, k, s) in &sliding {
            for r in 0..n {
                full[(r, k)] += s * a[(r, t)];
            }
        }
        let m = kept.len();
        let reduced = faer::Mat::from_fn(m, m, |r, c| full[(kept[r], kept[c])]);
        let pick = |v: &[f64]| kept.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let friction = problem
            .friction()
            .iter()
            .filter(|fr| !gone[fr.row])
            .map(|fr| crate::problem::FrictionRow {
                row: new_index[fr.row],
                normal: new_index[fr.normal],
                mu: fr.mu,
            })
            .collect();
        let lo: Vec<f64> = kept
            .iter()
            .map(|&i| {
                if problem.friction_of(i).is_some() {
                    0.0
                } else {
                    problem.lo()[i]
                }
            })
            .collect();
        let hi: Vec<f64> = kept
            .iter()
            .map(|&i| {
                if problem.friction_of(i).is_some() {
                    0.0
                } else {
                    problem.hi()[i]
                }
            })
            .collect();
        let problem = Problem::boxed(reduced, pick(problem.b()), lo, hi, friction).ok()?;
        Some(Self {
            problem,
            kept,
            sliding,
            n,
        })
    }

    /// The reduced problem with its friction rows given fixed bounds `±mu f_k` at the normals of
    /// the full impulse `f`.
    pub(super) fn with_fixed_bounds(&self, f: &[f64]) -> Problem {
        let p = &self.problem;
        let (mut lo, mut hi) = (p.lo().to_vec(), p.hi().to_vec());
        for fr in p.friction() {
            let c = fr.mu * f[self.kept[fr.normal]].max(0.0);
            lo[fr.row] = -c;
            hi[fr.row] = c;
        }
        Problem::boxed(p.to_dense(), p.b().to_vec(), lo, hi, Vec::new()).expect("valid bounds")
    }

    /// The full impulse from the reduced one.
    pub(super) fn expand(&self, g: &[f64]) -> Vec<f64> {
        let mut f = vec![0.0; self.n];
        for (&i, &v) in self.kept.iter().zip(g) {
            f[i] = v;
        }
        for &(t, k, s) in &self.sliding {
            f[t] = s * f[k];
        }
        f
    }
}
