//! Newton's globalisation (the module documentation of `lcpbench_solvers::Newton`: merit switch,
//! sweeps and return, shortest step, restart from sweeps) on exported steps of the sphere piles where
//! the plain method stalled. The files are in `tests/data/stall/` (its README says how each was
//! made); every answer is checked by a residual written here from its definition, not taken
//! from the library.

use lcpbench_solvers::{Globalisation, Newton, Problem, Settings, SolveResult, Solver};
use std::path::PathBuf;

/// The relative natural-map residual of `f`, written from its definition (the module
/// documentation of `lcpbench_solvers::metrics`):
/// `max_i |f_i − mid(lo_i, hi_i, f_i − w_i / d_i)| / s_i` with
/// `s_i = (|b_i| + Σ_j |A_ij f_j|) / d_i`, `d_i = A_ii` when positive (else the row's largest
/// magnitude, or 1), `0/0 = 0`, `x/0 = ∞`; friction bounds `±mu · max(f_k, 0)`; infinite for a
/// non-finite `f`. `A` is read entry by entry and `w_i` summed with Neumaier's compensation.
fn independent_residual(p: &Problem, f: &[f64]) -> f64 {
    let n = p.n();
    if f.len() != n || f.iter().any(|v| !v.is_finite()) {
        return f64::INFINITY;
    }
    let mut worst = 0.0f64;
    for i in 0..n {
        let row: Vec<f64> = (0..n).map(|j| p.entry(i, j)).collect();
        let d = if row[i] > 0.0 {
            row[i]
        } else {
            let m = row.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if m > 0.0 {
                m
            } else {
                1.0
            }
        };
        let (mut w, mut c) = (0.0f64, 0.0f64);
        for t in row.iter().zip(f).map(|(a, x)| a * x).chain([p.b()[i]]) {
            let u = w + t;
            c += if w.abs() >= t.abs() {
                (w - u) + t
            } else {
                (t - u) + w
            };
            w = u;
        }
        let w = w + c;
        let (lo, hi) = match p.friction_of(i) {
            Some((k, mu)) => (-mu * f[k].max(0.0), mu * f[k].max(0.0)),
            None => (p.lo()[i], p.hi()[i]),
        };
        let step = (f[i] - (f[i] - w / d).max(lo).min(hi)).abs();
        let scale =
            (p.b()[i].abs() + row.iter().zip(f).map(|(a, x)| (a * x).abs()).sum::<f64>()) / d;
        let rel = if step == 0.0 {
            0.0
        } else if scale == 0.0 {
            f64::INFINITY
        } else {
            step / scale
        };
        worst = worst.max(rel);
    }
    worst
}

/// A problem file of `tests/data/stall/` with its `warm_start`.
fn stall_case(name: &str) -> (Problem, Vec<f64>) {
    let path = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/stall")).join(name);
    let problem = lcpbench_solvers::read_problem(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let warm: Vec<f64> = value["warm_start"]
        .as_array()
        .map(|a| a.iter().map(|v| v.as_f64().unwrap()).collect())
        .unwrap_or_default();
    assert_eq!(warm.len(), problem.n(), "{name}: warm start");
    (problem, warm)
}

/// The report's `default` budget without its clock: tolerance `1e-8`, 10,000 iterations.
fn default_budget(warm_start: Option<Vec<f64>>) -> Settings {
    Settings {
        tolerance: 1e-8,
        max_iterations: 10_000,
        warm_start,
        ..Settings::default()
    }
}

/// Solve with `newton`, and check the status against the independent residual of the
/// returned impulse: converged if and only if it is within the tolerance.
fn solve(newton: &mut Newton, p: &Problem, settings: &Settings) -> SolveResult {
    let r = newton.solve(p, settings);
    let rel = independent_residual(p, &r.f);
    assert_eq!(
        r.status.is_converged(),
        rel <= settings.tolerance,
        "{}: {} with an independent residual of {rel:e}",
        newton.name(),
        r.status
    );
    r
}

/// Step 26 of `sphere_pile_100` (exported with `newton-min+warm` at `1e-8`, warm start
/// included): warm-started min-map Newton stagnated, restarted from zero and stagnated again at
/// `3.4e-3`, where Fischer–Burmeister Newton from zero converges. With the globalisation both
/// reformulations reach `1e-8`, warm and cold, and the plain method still stalls there (so the
/// file keeps testing what it was exported for).
#[test]
fn newton_reaches_1e_8_on_the_sphere_pile_100_step_where_min_map_stalled() {
    let (p, warm) = stall_case("sphere_pile_100_step26.json");
    for make in [Newton::min_map, Newton::fischer_burmeister] {
        for warm_start in [Some(warm.clone()), None] {
            let mut newton = make();
            let r = solve(&mut newton, &p, &default_budget(warm_start.clone()));
            assert!(
                r.status.is_converged(),
                "{} (warm: {}): {}; {:?}",
                newton.name(),
                warm_start.is_some(),
                r.status,
                newton.remedies()
            );
        }
    }
    let mut plain = Newton {
        globalisation: Globalisation::off(),
        ..Newton::min_map()
    };
    let r = solve(&mut plain, &p, &default_budget(Some(warm)));
    assert!(!r.status.is_converged(), "{}", r.status);
    assert!(plain.remedies().restarts >= 1, "{:?}", plain.remedies());
}
