//! How a solve of one problem is timed: the one method behind the `solve_time_s`,
//! `timed_solves`, `solve_time_min_s`, `solve_time_max_s`, `tta_*` and `warm_time_s` columns of
//! LCP and cone cases (file, scene-step and generated), and behind `lcpbench solve`.
//!
//! One cold solve of a small problem measures page faults, cold caches and branch predictors
//! rather than the solver, and does so unevenly from solver to solver. So [`measure`] runs:
//!
//! 1. one **untimed first solve**, which warms the caches. If its solver time alone is at least
//!    the minimum total ([`MIN_TOTAL_S`]), it is the single measurement: a slow solve (one that
//!    runs to its time budget, say) is not multiplied. It is also the single measurement when a
//!    second solve taking as long would overrun the wall-time cap.
//! 2. otherwise **repeated solves from the same start**, each timed, until their times add up
//!    to [`MIN_TOTAL_S`] and at least [`MIN_SOLVES`] are done, at most [`MAX_SOLVES`] of them,
//!    and a repeat starts only while the longest solve seen so far would still end within
//!    [`MAX_WALL_S`] of wall time from the start of the first solve.
//!
//! The time of a solve is the solver's own clock (its [`SolveResult::time`], which leaves out
//! the residual measurements of a convergence history); the caps count wall time, history
//! measurement included. The **median** of the timed solves is the recorded time, with their
//! fastest and slowest beside it. The impulse, status and residuals recorded are those of the
//! last timed solve. The caller makes every solve the same computation: the same problem, the
//! same settings and warm start, and a fresh copy of the solver each time.
//!
//! A warm start the harness computes (the PGS sweeps of a `+warm` run) is timed by the same
//! method, separately; its cost is not part of the solve's time.

use lcpbench_solvers::SolveResult;
use std::time::Instant;

/// Smallest total of the timed solves, seconds, and the solver time from which a first solve
/// alone is the measurement: 20 ms.
pub const MIN_TOTAL_S: f64 = 0.02;

/// Fewest timed solves when the first solve is not the measurement: 3.
pub const MIN_SOLVES: usize = 3;

/// Most timed solves: 1000 (a 1 µs solve stops here, at 1 ms of timed total).
pub const MAX_SOLVES: usize = 1000;

/// Wall time, seconds, within which the whole measurement (the first solve included) keeps
/// its repeats: 1 s. A case's child process is killed only after three times its time budget
/// plus five seconds, so the measurement stays well inside that.
pub const MAX_WALL_S: f64 = 1.0;

/// The timing method and the warm-start rule in a few lines, as `lcpbench bench --help` prints
/// them (the module documentation above gives the whole rule).
pub const HELP: &str = "\
Timing (LCP, scene-step and generated cases): one untimed first solve warms the caches; a \
first solve of at least 20 ms is the single measurement. Otherwise solves from the same start \
are repeated, each timed, until they add up to 20 ms and at least 3 are done (at most 1000, \
within 1 s of wall time). solve_time_s is their median, solve_time_min_s and solve_time_max_s \
their spread, timed_solves their count. Only the untimed first solve records a convergence \
history; the time-to-accuracy columns are its times scaled by the median over its own time. Scene steps are timed once each, in the stepping loop.

Warm starts (NAME+warm): a scene starts each step from the previous step's impulses; a problem \
file from its `warm_start` (as `lcpbench export` writes it) when it has one; a generated case \
from its planted solution perturbed by 1% of its largest entry; any other (a file without one, \
a scene step) from 20 cold PGS sweeps. warm_source names the start; warm_time_s is the cost of \
the PGS sweeps, timed as solves are, and is not part of solve_time_s.";

/// A clock reading seconds from some fixed origin; abstract so the method can be tested on a
/// clock that only moves when told.
pub trait Clock {
    /// Seconds since the clock's origin; never decreases.
    fn now_s(&self) -> f64;
}

/// The monotonic wall clock.
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    origin: Instant,
}

impl WallClock {
    /// A wall clock whose origin is now.
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
        }
    }
}

impl Default for WallClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for WallClock {
    fn now_s(&self) -> f64 {
        self.origin.elapsed().as_secs_f64()
    }
}

/// What a solve reports as its own time.
pub trait SolverTime {
    /// Seconds the solver measured for itself.
    fn solver_time_s(&self) -> f64;
}

impl SolverTime for SolveResult {
    fn solver_time_s(&self) -> f64 {
        self.time.as_secs_f64()
    }
}

/// When to stop repeating a solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimingRule {
    /// Total of the timed solves to reach, seconds \[[`MIN_TOTAL_S`]\].
    pub min_total_s: f64,
    /// Fewest timed solves \[[`MIN_SOLVES`]\].
    pub min_solves: usize,
    /// Most timed solves (at least one is always made) \[[`MAX_SOLVES`]\].
    pub max_solves: usize,
    /// Wall time from the start of the first solve within which a repeat must be expected to
    /// end, judged by the longest solve so far, seconds \[[`MAX_WALL_S`]\].
    pub max_wall_s: f64,
    /// A first solve whose solver time is at least `min_total_s` is the single measurement
    /// \[`true`\].
    pub slow_first_counts: bool,
}

impl Default for TimingRule {
    fn default() -> Self {
        Self {
            min_total_s: MIN_TOTAL_S,
            min_solves: MIN_SOLVES,
            max_solves: MAX_SOLVES,
            max_wall_s: MAX_WALL_S,
            slow_first_counts: true,
        }
    }
}

impl TimingRule {
    /// Exactly `n` timed solves after the untimed first, however long they take (`lcpbench
    /// solve --repeat N`).
    pub fn exactly(n: usize) -> Self {
        Self {
            min_total_s: 0.0,
            min_solves: n.max(1),
            max_solves: n.max(1),
            max_wall_s: f64::INFINITY,
            slow_first_counts: false,
        }
    }
}

/// The outcome of [`measure`].
#[derive(Debug, Clone)]
pub struct Timed<T, K = ()> {
    /// The last timed solve (the first solve when it was the measurement).
    pub result: T,
    /// The solver time of each timed solve, in order, seconds.
    pub times_s: Vec<f64>,
    /// What the caller kept of each timed solve, aligned with `times_s`.
    pub kept: Vec<K>,
    /// True when the untimed first solve became the single measurement (it was long enough
    /// alone, or a repeat would not have fitted in the wall-time cap).
    pub first_counted: bool,
}

impl<T, K> Timed<T, K> {
    /// Number of timed solves (at least 1 from [`measure`]).
    pub fn count(&self) -> usize {
        self.times_s.len()
    }

    /// Median of the timed solves, seconds (0 when there is none).
    pub fn median_s(&self) -> f64 {
        median(&self.times_s).unwrap_or(0.0)
    }

    /// Fastest timed solve, seconds (0 when there is none).
    pub fn min_s(&self) -> f64 {
        if self.times_s.is_empty() {
            return 0.0;
        }
        self.times_s.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Slowest timed solve, seconds (0 when there is none).
    pub fn max_s(&self) -> f64 {
        self.times_s.iter().copied().fold(0.0, f64::max)
    }
}

/// The median of `values` (the mean of the two middle values for an even count); `None` for
/// an empty list.
pub fn median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    Some(if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        0.5 * (sorted[mid - 1] + sorted[mid])
    })
}

/// Expected solver seconds the default rule spends on a solve taking `solve_s` seconds: the
/// first solve alone from [`MIN_TOTAL_S`] on, else the first plus repeats up to the larger of
/// [`MIN_TOTAL_S`] and [`MIN_SOLVES`] solves (at most [`MAX_SOLVES`] solves, at most
/// [`MAX_WALL_S`]). The cost model of sharded sweeps uses it.
pub fn expected_seconds(solve_s: f64) -> f64 {
    if solve_s >= MIN_TOTAL_S {
        return solve_s;
    }
    let repeats = MIN_TOTAL_S
        .max(MIN_SOLVES as f64 * solve_s)
        .min(MAX_SOLVES as f64 * solve_s);
    (solve_s + repeats).min(MAX_WALL_S)
}

/// Time `solve` by the rule (see the module documentation): an untimed first solve, then timed
/// repeats. `keep` picks what to keep of each timed solve (time-to-accuracy figures, say).
/// `solve` must perform the same computation each call.
pub fn measure<T: SolverTime, K>(
    rule: &TimingRule,
    clock: &impl Clock,
    mut solve: impl FnMut() -> T,
    mut keep: impl FnMut(&T) -> K,
) -> Timed<T, K> {
    let start = clock.now_s();
    let first = solve();
    let first_wall = clock.now_s() - start;
    let fits = |elapsed: f64, longest: f64| elapsed + longest <= rule.max_wall_s;
    let slow_first = rule.slow_first_counts && first.solver_time_s() >= rule.min_total_s;
    if slow_first || !fits(first_wall, first_wall) {
        return Timed {
            times_s: vec![first.solver_time_s()],
            kept: vec![keep(&first)],
            result: first,
            first_counted: true,
        };
    }
    let max_solves = rule.max_solves.max(1);
    let mut longest = first_wall;
    let mut times_s = Vec::new();
    let mut kept = Vec::new();
    let mut last = first;
    while times_s.len() < max_solves {
        let total: f64 = times_s.iter().sum();
        if times_s.len() >= rule.min_solves && total >= rule.min_total_s {
            break;
        }
        let before = clock.now_s();
        if !times_s.is_empty() && !fits(before - start, longest) {
            break;
        }
        let r = solve();
        longest = longest.max(clock.now_s() - before);
        times_s.push(r.solver_time_s());
        kept.push(keep(&r));
        last = r;
    }
    Timed {
        result: last,
        times_s,
        kept,
        first_counted: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// A clock that moves only when a fake solve advances it.
    struct FakeClock(Cell<f64>);

    impl Clock for FakeClock {
        fn now_s(&self) -> f64 {
            self.0.get()
        }
    }

    /// A fake solve: its number (0 for the first call) and the solver time it reports.
    #[derive(Debug)]
    struct Fake {
        call: usize,
        time_s: f64,
    }

    impl SolverTime for Fake {
        fn solver_time_s(&self) -> f64 {
            self.time_s
        }
    }

    /// Run `measure` with solves whose (solver time, wall time) the `plan` gives per call.
    fn run(rule: &TimingRule, plan: impl Fn(usize) -> (f64, f64)) -> (Timed<Fake, usize>, usize) {
        let clock = FakeClock(Cell::new(100.0));
        let mut calls = 0;
        let timed = measure(
            rule,
            &clock,
            || {
                let (time_s, wall_s) = plan(calls);
                clock.0.set(clock.0.get() + wall_s);
                calls += 1;
                Fake {
                    call: calls - 1,
                    time_s,
                }
            },
            |r| r.call,
        );
        (timed, calls)
    }

    #[test]
    fn a_fast_solve_is_repeated_until_the_timed_total_reaches_the_minimum() {
        // Solves of 2⁻¹⁰ s (about 1 ms, exact in binary): 20 make 19.5 ms, 21 make 20.5 ms.
        let dt = 2f64.powi(-10);
        let (t, calls) = run(&TimingRule::default(), |_| (dt, dt));
        assert_eq!(calls, 22);
        assert_eq!(t.count(), 21);
        assert!(!t.first_counted);
        assert_eq!(
            t.kept,
            (1..=21).collect::<Vec<_>>(),
            "the first is not kept"
        );
        assert_eq!(t.result.call, 21, "the answer is the last timed solve's");
        assert_eq!(t.times_s.iter().sum::<f64>(), 21.0 * dt);
    }

    #[test]
    fn at_least_three_solves_are_timed() {
        // 12 ms solves: two make 24 ms, but three are needed.
        let (t, calls) = run(&TimingRule::default(), |_| (0.012, 0.012));
        assert_eq!((t.count(), calls), (3, 4));
        assert!(!t.first_counted);
    }

    #[test]
    fn a_first_solve_of_at_least_the_minimum_total_is_the_single_measurement() {
        // A solve that runs to a 1 s time budget is made once, not four times.
        for time_s in [0.02, 1.0] {
            let (t, calls) = run(&TimingRule::default(), |_| (time_s, time_s));
            assert_eq!((t.count(), calls), (1, 1));
            assert!(t.first_counted);
            assert_eq!(t.result.call, 0);
            assert_eq!(t.kept, vec![0]);
            assert_eq!(
                (t.median_s(), t.min_s(), t.max_s()),
                (time_s, time_s, time_s)
            );
        }
        // Just under the minimum: repeated.
        let (t, _) = run(&TimingRule::default(), |_| (0.0199, 0.0199));
        assert!(!t.first_counted);
        assert_eq!(t.count(), 3);
    }

    #[test]
    fn the_count_is_capped() {
        // 1 µs solves would need 20,000 repeats to make 20 ms.
        let (t, calls) = run(&TimingRule::default(), |_| (1e-6, 1e-6));
        assert_eq!((t.count(), calls), (MAX_SOLVES, MAX_SOLVES + 1));
    }

    #[test]
    fn the_wall_time_is_capped() {
        // 1 ms of solver time but 300 ms of wall time each (say, a long convergence history):
        // first at 0.3 s, timed ones end at 0.6 and 0.9 s; a third would end at 1.2 s > 1 s.
        let (t, calls) = run(&TimingRule::default(), |_| (1e-3, 0.3));
        assert_eq!((t.count(), calls), (2, 3));
        assert!(!t.first_counted);
        // A first solve longer than half the cap leaves no room for a repeat: it counts alone.
        let (t, calls) = run(&TimingRule::default(), |_| (1e-3, 0.6));
        assert_eq!((t.count(), calls), (1, 1));
        assert!(t.first_counted);
        // A repeat that takes longer than the first ones stops the rest.
        let (t, calls) = run(&TimingRule::default(), |k| {
            (1e-3, if k == 2 { 0.5 } else { 0.1 })
        });
        assert_eq!((t.count(), calls), (2, 3));
    }

    #[test]
    fn median_min_and_max_of_the_timed_solves() {
        let times = [9.0, 5.0, 1.0, 3.0, 2.0, 4.0];
        // The first (9 s, untimed) is not among them, and `exactly` does not stop on it.
        let (t, calls) = run(&TimingRule::exactly(5), |k| (times[k], 0.0));
        assert_eq!((t.count(), calls), (5, 6));
        assert_eq!(t.times_s, vec![5.0, 1.0, 3.0, 2.0, 4.0]);
        assert_eq!((t.median_s(), t.min_s(), t.max_s()), (3.0, 1.0, 5.0));
        let (t, _) = run(&TimingRule::exactly(4), |k| (times[k], 0.0));
        assert_eq!(t.median_s(), 2.5, "even count: mean of the middle two");
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[7.0]), Some(7.0));
    }

    #[test]
    fn the_expected_cost_follows_the_rule() {
        assert_eq!(expected_seconds(0.5), 0.5, "a slow solve is made once");
        assert_eq!(expected_seconds(0.02), 0.02);
        assert_eq!(expected_seconds(0.01), 0.04, "first and three repeats");
        assert_eq!(expected_seconds(0.001), 0.021, "first and 20 ms of repeats");
        assert_eq!(expected_seconds(1e-6), 1e-6 + 1e-3, "the count cap");
    }

    /// The help text states the constants the method uses.
    #[test]
    fn the_help_states_the_rule_in_force() {
        let ms = |s: f64| format!("{} ms", s * 1e3);
        assert!(HELP.contains(&format!("at least {}", ms(MIN_TOTAL_S))));
        assert!(HELP.contains(&format!("add up to {}", ms(MIN_TOTAL_S))));
        assert!(HELP.contains(&format!("at least {MIN_SOLVES} are done")));
        assert!(HELP.contains(&format!("at most {MAX_SOLVES}")));
        assert!(HELP.contains(&format!("within {MAX_WALL_S} s of wall time")));
        let sweeps = crate::harness::record::WARM_PGS_SWEEPS;
        assert!(HELP.contains(&format!("{sweeps} cold PGS sweeps")));
    }

    #[test]
    fn exactly_n_ignores_the_total_and_the_wall_time() {
        let (t, calls) = run(&TimingRule::exactly(3), |_| (5.0, 5.0));
        assert_eq!((t.count(), calls), (3, 4));
        let (t, calls) = run(&TimingRule::exactly(0), |_| (1e-6, 1e-6));
        assert_eq!((t.count(), calls), (1, 2), "at least one timed solve");
    }
}
