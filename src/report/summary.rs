//! The one rule by which the report (and `bench`'s closing summary) compares solvers over a set
//! of problems, and the means it prints.
//!
//! **The rule.** At an accuracy `L` (a relative residual), over a group of cases:
//!
//! 1. each solver's *eligible* run on a case is the best, by this same rule, of its rows that
//!    can show `L`: an LCP or cone row whose budget tolerance is at most `L` (its residual
//!    history says when it first reached `L`); a scene row whose tolerance is at most `L` (a
//!    step converged at a tighter tolerance met `L`; its time per step is then an upper bound);
//! 2. a solver *solves* an LCP or cone case when its eligible run reached `L`, and solves the
//!    converged steps of a scene run (a scene counts its steps, an LCP case counts one);
//! 3. solvers are ranked by the most solved (problems, or steps summed over the scenes), then
//!    by the smaller **shifted geometric mean** of their times over *every* case of the group
//!    (time per step for a scene, time to `L` for an LCP or cone case), a case the solver did
//!    not solve (or did not run) counted at the budget's seconds, with shift [`SHIFT_S`]
//!    (Mittelmann's benchmarks' mean): `exp(mean(ln(t_i + s))) − s`. Every mean is so over
//!    the same cases for every solver; none is over a solver's own successes alone.
//!
//! Warm-started and cold runs are separate candidates (`pgs` and `pgs+warm`), both eligible.
//! [`rank`] applies the rule; [`Candidate`] is one solver's score on a group.

use crate::harness::{RunRecord, RunStatus, SolverSpec};
use std::collections::BTreeMap;

/// The shift of the shifted geometric mean, seconds (10 µs): a time far below it counts about
/// as much as zero, so the mean is not ruled by the fastest trivial solves.
pub const SHIFT_S: f64 = 10e-6;

/// The accuracies the Findings section and the summaries answer at.
pub const ACCURACIES: [f64; 3] = [1e-4, 1e-6, 1e-8];

/// The rule in one sentence, for captions.
pub const RULE: &str = "most problems solved (scene steps converged) at the accuracy, then the \
    smaller shifted geometric mean (shift 10 µs) of time per solve or per step over every case \
    of the group, a case not solved or not run counted at its budget's seconds; warm and cold \
    runs both eligible";

/// `exp(mean(ln(t_i + shift))) − shift` of `times` (`None` when empty).
pub fn shifted_geo_mean(times: &[f64], shift: f64) -> Option<f64> {
    if times.is_empty() {
        return None;
    }
    let mean = times.iter().map(|t| (t.max(0.0) + shift).ln()).sum::<f64>() / times.len() as f64;
    Some((mean.exp() - shift).max(0.0))
}

/// One run's contribution to its solver's score at an accuracy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// Problems solved (0 or 1) or scene steps converged.
    pub solved: usize,
    /// Problems (1) or scene steps the run had to solve.
    pub total: usize,
    /// Seconds per solve or per step counted in the mean: the time to the accuracy when
    /// solved, otherwise the budget's seconds (LCP); the time per step (scene).
    pub time_s: f64,
    /// True when no step had contacts (nothing to solve, no time worth printing).
    pub no_work: bool,
}

/// True for a scene row (it has steps).
fn is_scene(r: &RunRecord) -> bool {
    r.steps.is_some() || r.steps_planned.is_some()
}

/// A run's outcome at accuracy `level`, or `None` when the row cannot show that accuracy (its
/// tolerance is looser than `level`).
pub fn outcome(r: &RunRecord, level: f64) -> Option<Outcome> {
    if r.tolerance > level * (1.0 + 1e-9) {
        return None;
    }
    let cap = r.time_budget_s.max(SHIFT_S);
    if is_scene(r) {
        let total = r.steps_planned.or(r.steps).unwrap_or(0).max(1);
        let done = r.steps.unwrap_or(0);
        let solved = if r.is_isolation_failure() || r.blow_up == Some(true) {
            0
        } else {
            // Converged measured steps (every step before the `steps_measured` column).
            r.converged_steps().unwrap_or(0)
        };
        let no_work = crate::report::status::no_work(r);
        let time_s = match r.time_per_step_s {
            Some(t) if done > 0 && !r.is_isolation_failure() => t,
            _ => cap,
        };
        return Some(Outcome {
            solved: solved.min(total),
            total,
            time_s,
            no_work,
        });
    }
    let reached = match r.status {
        RunStatus::NoSolution | RunStatus::Diverged | RunStatus::Unsupported => None,
        _ if r.is_isolation_failure() => None,
        _ => r.tta(level).or_else(|| {
            // A row without a history: its solve time, when it converged at a tolerance at
            // least as tight as the level.
            r.converged.then_some(r.solve_time_s).flatten()
        }),
    };
    Some(Outcome {
        solved: usize::from(reached.is_some()),
        total: 1,
        time_s: reached.unwrap_or(cap),
        no_work: false,
    })
}

/// One solver's score on a group of cases at one accuracy.
#[derive(Debug, Clone)]
pub struct Candidate<'a> {
    /// The solver specification (`pgs+warm` and `pgs` are different candidates).
    pub solver: SolverSpec,
    /// Problems solved or scene steps converged, summed over the group's cases.
    pub solved: usize,
    /// Problems or scene steps of the group.
    pub total: usize,
    /// Shifted geometric mean of the times over every case of the group (see the module doc).
    pub mean_s: f64,
    /// Cases of the group the solver ran (with a row that shows the accuracy).
    pub ran: usize,
    /// Cases of the group.
    pub cases: usize,
    /// True when no case of the group had any contact to solve.
    pub no_work: bool,
    /// The eligible run of each case the solver ran, in case order.
    pub runs: Vec<&'a RunRecord>,
}

/// Rank the solvers of `rows` on the cases those rows cover, at accuracy `level`, by the rule
/// of the module doc; best first. Solvers with no eligible row are left out; a case a
/// candidate did not run counts as unsolved at the largest budget seconds of the group.
pub fn rank<'a>(rows: &[&'a RunRecord], level: f64) -> Vec<Candidate<'a>> {
    // Each (solver, case)'s eligible run: its best row at the level.
    let mut best: BTreeMap<(String, String), (&'a RunRecord, Outcome)> = BTreeMap::new();
    let mut cases: BTreeMap<String, usize> = BTreeMap::new();
    let mut cap: f64 = SHIFT_S;
    for r in rows {
        let Some(o) = outcome(r, level) else {
            continue;
        };
        cap = cap.max(r.time_budget_s);
        let total = cases.entry(r.case.clone()).or_insert(0);
        *total = (*total).max(o.total);
        let key = (r.solver.to_string(), r.case.clone());
        match best.get(&key) {
            Some((_, old)) if !better(&o, old) => {}
            _ => {
                best.insert(key, (r, o));
            }
        }
    }
    let mut by_solver: BTreeMap<String, Vec<(&'a RunRecord, Outcome)>> = BTreeMap::new();
    for ((solver, _), v) in best {
        by_solver.entry(solver).or_default().push(v);
    }
    let total: usize = cases.values().sum();
    let mut out: Vec<Candidate> = by_solver
        .into_values()
        .map(|runs| {
            let mut times: Vec<f64> = runs.iter().map(|(_, o)| o.time_s).collect();
            times.resize(cases.len(), cap);
            Candidate {
                solver: runs[0].0.solver.clone(),
                solved: runs.iter().map(|(_, o)| o.solved).sum(),
                total,
                mean_s: shifted_geo_mean(&times, SHIFT_S).unwrap_or(cap),
                ran: runs.len(),
                cases: cases.len(),
                no_work: runs.iter().all(|(_, o)| o.no_work),
                runs: runs.into_iter().map(|(r, _)| r).collect(),
            }
        })
        .collect();
    out.sort_by(|a, b| {
        b.solved
            .cmp(&a.solved)
            .then(a.mean_s.total_cmp(&b.mean_s))
            .then_with(|| a.solver.to_string().cmp(&b.solver.to_string()))
    });
    out
}

/// True when outcome `a` beats `b` by the rule (more solved, then less time).
fn better(a: &Outcome, b: &Outcome) -> bool {
    (a.solved * b.total.max(1)).cmp(&(b.solved * a.total.max(1))) == std::cmp::Ordering::Greater
        || (a.solved * b.total.max(1) == b.solved * a.total.max(1) && a.time_s < b.time_s)
}

/// The mean over the cases every one of `solvers` solved (its common set): for each solver the
/// geometric mean of its times on those cases at `level`, and the number of cases in the set.
/// A table of means over different sets is what this replaces.
pub fn common_set_means(
    rows: &[&RunRecord],
    solvers: &[SolverSpec],
    level: f64,
) -> (usize, Vec<Option<f64>>) {
    let mut cases: BTreeMap<&str, Vec<Option<f64>>> = BTreeMap::new();
    for r in rows {
        let Some(i) = solvers.iter().position(|s| *s == r.solver) else {
            continue;
        };
        let Some(o) = outcome(r, level) else {
            continue;
        };
        let slot = cases
            .entry(r.case.as_str())
            .or_insert_with(|| vec![None; solvers.len()]);
        if o.solved == o.total && o.total > 0 {
            let t = slot[i].map_or(o.time_s, |old: f64| old.min(o.time_s));
            slot[i] = Some(t);
        }
    }
    let common: Vec<Vec<f64>> = cases
        .into_values()
        .filter_map(|v| v.into_iter().collect::<Option<Vec<f64>>>())
        .collect();
    let means = (0..solvers.len())
        .map(|i| {
            let t: Vec<f64> = common.iter().map(|v| v[i]).collect();
            shifted_geo_mean(&t, 0.0)
        })
        .collect();
    (common.len(), means)
}

/// The closing summary of a sweep (`bench` prints it): per budget, and apart for scenes and
/// for problems, each solver's solved count, the cases it is best on by the rule, and its
/// shifted geometric mean, best first. Empty when there are no rows.
pub fn sweep_summary(rows: &[RunRecord]) -> String {
    use std::fmt::Write as _;
    let mut groups: Vec<(String, bool, f64, Vec<&RunRecord>)> = Vec::new();
    for r in rows {
        let scene = is_scene(r);
        let name = r.budget.to_string();
        match groups
            .iter_mut()
            .find(|(n, s, _, _)| *n == name && *s == scene)
        {
            Some(g) => g.3.push(r),
            None => groups.push((name, scene, r.tolerance, vec![r])),
        }
    }
    let mut out = String::new();
    for (budget, scene, tolerance, members) in groups {
        let ranked = rank(&members, tolerance);
        let mut cases: Vec<&str> = members.iter().map(|r| r.case.as_str()).collect();
        cases.sort_unstable();
        cases.dedup();
        let mut best_on: BTreeMap<String, usize> = BTreeMap::new();
        for case in &cases {
            let of_case: Vec<&RunRecord> = members
                .iter()
                .copied()
                .filter(|r| r.case == *case)
                .collect();
            // A case without contacts has no fastest solver: nothing was solved.
            if let Some(best) = rank(&of_case, tolerance)
                .first()
                .filter(|c| c.solved > 0 && !c.no_work)
            {
                *best_on.entry(best.solver.to_string()).or_default() += 1;
            }
        }
        let what = if scene { "scenes" } else { "problems" };
        let _ = writeln!(
            out,
            "budget {budget} (tolerance {tolerance:.0e}), {} {what}:",
            cases.len()
        );
        let _ = write!(
            out,
            "  {:<22} {:>14} {:>8} {:>22}",
            "solver",
            if scene { "steps solved" } else { "solved" },
            "fastest",
            if scene {
                "shifted geo. mean/step"
            } else {
                "shifted geo. mean"
            }
        );
        let _ = writeln!(
            out,
            "{}",
            if scene {
                format!(" {:>16}", "row updates/step")
            } else {
                String::new()
            }
        );
        for c in &ranked {
            let name = c.solver.to_string();
            let mean = if c.no_work {
                "no contacts".to_owned()
            } else {
                format_seconds(c.mean_s)
            };
            // A run whose residual was measured on a sample of its steps (`--residual
            // sample=K`) solves at most its measured steps: the cell says how many there were.
            let taken: usize = c.runs.iter().filter_map(|r| r.steps).sum();
            let measured: usize = c.runs.iter().filter_map(|r| r.measured_steps()).sum();
            let solved = if scene && measured < taken {
                format!("{}/{} ({measured} measured)", c.solved, c.total)
            } else {
                format!("{}/{}", c.solved, c.total)
            };
            let _ = write!(
                out,
                "  {:<22} {:>14} {:>8} {:>22}",
                name,
                solved,
                best_on.get(&name).copied().unwrap_or(0),
                mean
            );
            let cost = if scene {
                format!(" {:>16}", format_count(mean_row_updates(&c.runs)))
            } else {
                String::new()
            };
            let _ = writeln!(out, "{cost}");
        }
    }
    if !out.is_empty() {
        let _ = writeln!(
            out,
            "ranked by {RULE}; `fastest`: cases on which the solver is best by that rule{}",
            if rows.iter().any(is_scene) {
                "; `row updates/step`: the mean over the solver's scene runs of the constraint-row \
                 updates per step (sweeps × rows, or a substepping solver's own count)"
            } else {
                ""
            }
        );
    }
    out
}

/// Mean over `runs` of the row updates per step (`None` when no run records them).
fn mean_row_updates(runs: &[&RunRecord]) -> Option<f64> {
    let counts: Vec<f64> = runs.iter().filter_map(|r| r.row_updates_per_step).collect();
    (!counts.is_empty()).then(|| counts.iter().sum::<f64>() / counts.len() as f64)
}

/// A count with thousands written as `k` and millions as `M`; `–` for none.
fn format_count(v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(v) if v >= 1e6 => format!("{:.2} M", v / 1e6),
        Some(v) if v >= 1e4 => format!("{:.1} k", v / 1e3),
        Some(v) => format!("{v:.0}"),
    }
}

/// Seconds as `µs`, `ms` or `s`.
fn format_seconds(s: f64) -> String {
    if s < 1e-3 {
        format!("{:.1} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.2} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lcpbench_solvers::SolverKind;

    fn lcp(case: &str, solver: SolverKind, tta: Option<f64>) -> RunRecord {
        let mut r = RunRecord {
            case: case.into(),
            solver: SolverSpec::plain(solver),
            tolerance: 1e-10,
            time_budget_s: 10.0,
            status: if tta.is_some() {
                RunStatus::Converged
            } else {
                RunStatus::IterationLimit
            },
            converged: tta.is_some(),
            ..RunRecord::default()
        };
        r.set_tta([tta, tta, tta, tta]);
        r
    }

    #[test]
    fn the_shifted_geometric_mean_matches_its_formula() {
        let m = shifted_geo_mean(&[1e-3, 1e-1], 0.0).unwrap();
        assert!((m - 1e-2).abs() < 1e-15);
        let s = shifted_geo_mean(&[0.0, 0.0], SHIFT_S).unwrap();
        assert!(s.abs() < 1e-18);
        let shifted = shifted_geo_mean(&[90e-6, 990e-6], 10e-6).unwrap();
        // (100 µs · 1000 µs)^½ − 10 µs.
        assert!((shifted - (316.227_766e-6 - 10e-6)).abs() < 1e-9);
        assert_eq!(shifted_geo_mean(&[], 1.0), None);
    }

    /// A solver that solves only the easy problem fast must not look faster than one that
    /// solves both: the ranking puts the one with more solved first, and the means count the
    /// failure at the budget (shifted mean) or leave the hard case out for both (common set).
    #[test]
    fn fewer_successes_never_buy_a_smaller_mean() {
        let rows = [
            lcp("easy", SolverKind::Pgs, Some(1e-3)),
            lcp("hard", SolverKind::Pgs, Some(1.0)),
            lcp("easy", SolverKind::Lemke, Some(2e-3)),
            lcp("hard", SolverKind::Lemke, None),
        ];
        let refs: Vec<&RunRecord> = rows.iter().collect();
        let ranked = rank(&refs, 1e-6);
        assert_eq!(ranked[0].solver.to_string(), "pgs");
        assert_eq!((ranked[0].solved, ranked[1].solved), (2, 1));
        // Own-success mean of lemke would be 2 ms, below pgs' 31.6 ms: the shifted mean
        // counts its failure at the budget (10 s) and is larger.
        let pgs = ((1e-3 + SHIFT_S) * (1.0 + SHIFT_S)).sqrt() - SHIFT_S;
        let lemke = ((2e-3 + SHIFT_S) * (10.0 + SHIFT_S)).sqrt() - SHIFT_S;
        assert!((ranked[0].mean_s - pgs).abs() < 1e-12);
        assert!((ranked[1].mean_s - lemke).abs() < 1e-12);
        // The common set is `easy` alone: 1 ms against 2 ms.
        let solvers = [
            SolverSpec::plain(SolverKind::Pgs),
            SolverSpec::plain(SolverKind::Lemke),
        ];
        let (n, means) = common_set_means(&refs, &solvers, 1e-6);
        assert_eq!(n, 1);
        assert!((means[0].unwrap() - 1e-3).abs() < 1e-15);
        assert!((means[1].unwrap() - 2e-3).abs() < 1e-15);
    }

    #[test]
    fn a_case_not_run_counts_as_unsolved_at_the_budget() {
        let rows = [
            lcp("a", SolverKind::Pgs, Some(1e-3)),
            lcp("b", SolverKind::Pgs, Some(1e-3)),
            lcp("a", SolverKind::Nsgs, Some(1e-4)),
        ];
        let refs: Vec<&RunRecord> = rows.iter().collect();
        let ranked = rank(&refs, 1e-4);
        assert_eq!(ranked[0].solver.to_string(), "pgs");
        assert_eq!((ranked[1].ran, ranked[1].cases), (1, 2));
        let nsgs = ((1e-4 + SHIFT_S) * (10.0 + SHIFT_S)).sqrt() - SHIFT_S;
        assert!((ranked[1].mean_s - nsgs).abs() < 1e-12);
    }

    fn scene(solver: SpecName, tol: f64, converged: usize, t: f64) -> RunRecord {
        RunRecord {
            case: "scene:tower.toml".into(),
            solver: solver.0.parse().unwrap(),
            tolerance: tol,
            time_budget_s: 1.0,
            status: if converged == 10 {
                RunStatus::Converged
            } else {
                RunStatus::IterationLimit
            },
            steps: Some(10),
            steps_planned: Some(10),
            nonconverged_steps: Some(10 - converged),
            contacts_mean: Some(4.0),
            time_per_step_s: Some(t),
            ..RunRecord::default()
        }
    }

    struct SpecName(&'static str);

    #[test]
    fn the_sweep_summary_counts_solved_and_fastest_per_solver() {
        let rows = [
            lcp("easy", SolverKind::Pgs, Some(1e-3)),
            lcp("hard", SolverKind::Pgs, Some(1.0)),
            lcp("easy", SolverKind::Lemke, Some(2e-4)),
            lcp("hard", SolverKind::Lemke, None),
        ];
        let text = sweep_summary(&rows);
        let line = |name: &str| {
            text.lines()
                .find(|l| l.trim_start().starts_with(&format!("{name} ")))
                .unwrap()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ")
        };
        assert!(text.contains("2 problems"), "{text}");
        // pgs solved both and is best on `hard`; lemke is best on `easy` only.
        assert!(line("pgs").starts_with("pgs 2/2 1 "), "{text}");
        assert!(line("lemke").starts_with("lemke 1/2 1 "), "{text}");
        assert!(text.find("pgs").unwrap() < text.find("lemke").unwrap());
        assert_eq!(sweep_summary(&[]), "");
    }

    /// Scenes: steps converged first, then time; a row of a looser tolerance is not eligible,
    /// a tighter one is; of one solver's rows the best is taken.
    #[test]
    fn scenes_rank_by_converged_steps_then_time_per_step() {
        let rows = [
            scene(SpecName("pgs+warm"), 1e-6, 10, 3e-4),
            scene(SpecName("pgs+warm"), 1e-6, 4, 1e-5),
            scene(SpecName("lemke"), 1e-8, 10, 9e-3),
            scene(SpecName("sor"), 1e-4, 10, 1e-6),
            scene(SpecName("nsgs"), 1e-6, 9, 1e-5),
        ];
        let refs: Vec<&RunRecord> = rows.iter().collect();
        let ranked = rank(&refs, 1e-6);
        let names: Vec<String> = ranked.iter().map(|c| c.solver.to_string()).collect();
        assert_eq!(names, ["pgs+warm", "lemke", "nsgs"]);
        assert_eq!(ranked[0].solved, 10);
        assert!((ranked[0].mean_s - 3e-4).abs() < 1e-15);
    }

    /// The closing summary of scene runs gives each solver's mean row updates per step over
    /// its eligible runs; LCP groups have no such column.
    #[test]
    fn the_scene_summary_shows_row_updates_per_step() {
        let mut a = scene(SpecName("pgs+warm"), 1e-6, 10, 3e-4);
        a.row_updates_per_step = Some(1200.0);
        let mut b = scene(SpecName("si+warm"), 1e-6, 10, 2e-4);
        b.case = "scene:other.toml".into();
        b.row_updates_per_step = Some(48_000.0);
        let mut c = scene(SpecName("si+warm"), 1e-6, 10, 2e-4);
        c.row_updates_per_step = Some(2_000.0);
        let text = sweep_summary(&[a, b, c]);
        let line = |name: &str| {
            text.lines()
                .find(|l| l.trim_start().starts_with(&format!("{name} ")))
                .unwrap()
                .to_owned()
        };
        assert!(text.contains("row updates/step"), "{text}");
        assert!(line("pgs+warm").trim_end().ends_with(" 1200"), "{text}");
        // si+warm: (48,000 + 2,000) / 2 over its two scenes.
        assert!(line("si+warm").trim_end().ends_with(" 25.0 k"), "{text}");
        let lcp_only = sweep_summary(&[lcp("easy", SolverKind::Pgs, Some(1e-3))]);
        assert!(!lcp_only.contains("row updates"), "{lcp_only}");
    }

    /// A run measured on a sample of its steps shows how many were measured beside its
    /// converged steps over the steps taken; a run measured on every step shows the count alone.
    #[test]
    fn the_scene_summary_says_how_many_steps_were_measured() {
        let every = scene(SpecName("pgs+warm"), 1e-6, 10, 3e-4);
        let mut sampled = scene(SpecName("si+warm"), 1e-6, 10, 2e-4);
        sampled.steps_measured = Some(3);
        sampled.nonconverged_steps = Some(0);
        let text = sweep_summary(&[every, sampled]);
        let line = |name: &str| {
            text.lines()
                .find(|l| l.trim_start().starts_with(&format!("{name} ")))
                .unwrap()
                .to_owned()
        };
        assert!(line("si+warm").contains(" 3/10 (3 measured) "), "{text}");
        assert!(line("pgs+warm").contains(" 10/10 "), "{text}");
        assert!(!line("pgs+warm").contains("measured"), "{text}");
    }
}
