//! The large scenes (more than [`LARGE_SCENE_BODIES`] dynamic bodies), where solvers differ
//! most: the best solver at each budget with its time per step and converged steps, what the
//! suite leaves out on them, and per scene the speed–accuracy figure against the worst step
//! residual (the one against the median is in the scenes section). Then, for each step that
//! no solver converged, why each failed, from the runs' `failed_steps` column
//! ([`crate::harness::step_failure`]).

use super::scenes::{converged_steps, speed_accuracy_figure};
use crate::harness::step_failure::{parse_failed_steps, FailedStep, StepFailure};
use crate::harness::{BudgetName, Case, RunRecord};
use crate::report::context::{scene_solvers_cold_and_warm, Figure, ReportContext, Section};
use crate::report::suite::{
    scene_solvers, LARGE_SCENE_BODIES, LARGE_SCENE_STEPS, LARGE_SCENE_STEP_EXCEPTIONS,
    SCENE_BUDGETS,
};
use crate::report::table::{fmt_sci, fmt_time, slug, Table};
use anyhow::Result;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// At most this many unconverged steps per scene and budget are listed; the rest are counted.
const WHY_STEPS_SHOWN: usize = 8;

pub(super) struct LargeScenes;

impl Section for LargeScenes {
    fn title(&self) -> &'static str {
        "Large scenes"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let cases = &ctx.suite.large_scene_cases;
        if cases.is_empty() {
            return Ok(Vec::new());
        }
        let exceptions: Vec<String> = LARGE_SCENE_STEP_EXCEPTIONS
            .iter()
            .map(|(name, steps)| format!("{name} {steps}"))
            .collect();
        let _ = writeln!(
            md,
            "## Large scenes\n\nThe scenes with more than {LARGE_SCENE_BODIES} dynamic bodies, \
             under every budget of the scene runs ({}), each solver cold and the iterative ones \
             warm-started. Per budget, the best solver by the rule of [Findings](#findings) \
             restricted to that budget: the fastest whose every step converged (time per step, \
             converged steps / steps); where none converged on every step, the one with the \
             most converged steps. What the suite leaves out here: the runs take \
             {LARGE_SCENE_STEPS} steps ({}; the sphere piles fall for their first 17 steps); \
             budget `tight` is not run; a run stops after three consecutive steps over the \
             per-step budget (`cut` in the tables).\n",
            SCENE_BUDGETS
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", "),
            exceptions.join(", ")
        );
        let mut header = vec![
            "scene".to_owned(),
            "rows (max)".to_owned(),
            "contacts (mean)".to_owned(),
        ];
        header.extend(SCENE_BUDGETS.iter().map(|b| format!("best at {b}")));
        let mut best = Table::with_header("large_scenes_best", header);
        let mut figures = Vec::new();
        for case in cases {
            let any = SCENE_BUDGETS
                .iter()
                .flat_map(|b| ctx.runs_of(case, &scene_solvers(), b))
                .next();
            let mut row = vec![
                case.short_name(),
                any.and_then(|r| r.n).map_or("–".into(), |n| n.to_string()),
                any.and_then(|r| r.contacts_mean)
                    .map_or("–".into(), |c| format!("{c:.0}")),
            ];
            for budget in &SCENE_BUDGETS {
                row.push(best_cell(ctx, case, budget));
            }
            best.rows.push(row);
            let name = case.short_name();
            let path = ctx
                .plots_dir
                .join(format!("large_worst_{}.svg", slug(&name)));
            speed_accuracy_figure(ctx, case, &path, &super::scenes::scene_budgets())?;
            figures.push(Figure::new(
                format!("Speed–accuracy on large scene {name} (worst step residual)"),
                path,
            ));
        }
        let _ = writeln!(md, "{}", ctx.table(&best)?);
        let mut why = Table::with_header(
            "large_scenes_why",
            [
                "scene",
                "budget",
                "step",
                "rows / contacts",
                "best residual (by)",
                "why, per solver",
            ]
            .map(String::from)
            .to_vec(),
        );
        let mut unknown = 0;
        for case in cases {
            for budget in &SCENE_BUDGETS {
                let runs: Vec<&RunRecord> = ctx
                    .runs_of(case, &scene_solvers_cold_and_warm(), budget)
                    .into_iter()
                    .filter(|r| !r.is_isolation_failure())
                    .collect();
                let found = unconverged_steps(&runs);
                unknown += found.unrecorded;
                why.rows.extend(found.rows.into_iter().map(|row| {
                    let mut cells = vec![case.short_name(), budget.to_string()];
                    cells.extend(row);
                    cells
                }));
            }
        }
        let _ = writeln!(
            md,
            "### Why it failed\n\nEach step that no solver converged (steps numbered from 0, as \
             `lcpbench export --step`), with its size, the best shared relative residual a \
             solver reached on it and why each solver failed, as its status and reason tell it: \
             `stall` (at the residual given), `iteration cap`, `time budget`, `factorisation \
             cap` (a Newton or interior-point solver declining a factor above its entry cap), \
             `unsupported`, `no solution (certificate)`, `diverged`, `breakdown`, and `not \
             reached` for a run stopped (cut or blown up) before the step. The solvers follow \
             different trajectories, so a step's size is the largest among the runs that took \
             it. At most {WHY_STEPS_SHOWN} steps per scene and budget are listed.{}\n",
            if unknown > 0 {
                format!(
                    " {unknown} runs with unconverged steps record no per-step reasons (rows \
                     written before the `failed_steps` column); a step one of them may have \
                     converged is left out."
                )
            } else {
                String::new()
            }
        );
        if why.rows.is_empty() {
            let _ = writeln!(md, "No step listed.\n");
        } else {
            let _ = writeln!(md, "{}", ctx.table(&why)?);
        }
        Ok(figures)
    }
}

/// The best run on `case` under `budget` among every solver, cold and warm.
fn best_cell(ctx: &ReportContext, case: &Case, budget: &BudgetName) -> String {
    let runs: Vec<&RunRecord> = ctx
        .runs_of(case, &scene_solvers_cold_and_warm(), budget)
        .into_iter()
        .filter(|r| !r.is_isolation_failure() && r.blow_up != Some(true))
        .collect();
    let every_step = runs
        .iter()
        .filter(|r| r.converged)
        .filter_map(|r| Some((*r, r.time_per_step_s?)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((r, t)) = every_step {
        return format!("{} {} ({})", r.solver, fmt_time(Some(t)), fraction(r));
    }
    let most = runs
        .iter()
        .filter_map(|r| Some((*r, converged_steps(r)?, r.time_per_step_s?)))
        .filter(|&(_, converged, _)| converged > 0)
        .max_by(|a, b| a.1.cmp(&b.1).then(b.2.total_cmp(&a.2)));
    match most {
        Some((r, _, t)) => format!(
            "none on every step; most: {} {} ({})",
            r.solver,
            fmt_time(Some(t)),
            fraction(r)
        ),
        None if runs.is_empty() => "–".into(),
        None => "no step converged".into(),
    }
}

/// Converged steps / planned steps.
fn fraction(r: &RunRecord) -> String {
    let planned = r.steps_planned.or(r.steps).unwrap_or(0);
    super::scenes::converged_fraction(r, planned)
}

/// The unconverged steps of one scene under one budget: table rows (step, rows / contacts,
/// best residual and by whom, why per solver), and how many runs could not say which of their
/// steps failed.
#[derive(Debug, Default, PartialEq)]
struct Unconverged {
    rows: Vec<Vec<String>>,
    unrecorded: usize,
}

/// What one run says of its steps: each failed step with why, how many steps it took, and
/// whether it can vouch for the steps it does not list (its failures are recorded and every
/// step it took was measured).
struct RunSteps<'a> {
    run: &'a RunRecord,
    failed: BTreeMap<usize, FailedStep>,
    taken: usize,
    vouches: bool,
}

impl<'a> RunSteps<'a> {
    fn of(run: &'a RunRecord) -> Self {
        let failed: BTreeMap<usize, FailedStep> = parse_failed_steps(&run.failed_steps)
            .into_iter()
            .map(|f| (f.step, f))
            .collect();
        let taken = run.steps.unwrap_or(0);
        let failures = run.nonconverged_steps.unwrap_or(0)
            + run.fallback_steps.unwrap_or(0)
            + run.time_limit_steps.unwrap_or(0);
        let all_measured = run.measured_steps().is_some_and(|m| m >= taken);
        let vouches = all_measured && (failures == 0 || !failed.is_empty());
        Self {
            run,
            failed,
            taken,
            vouches,
        }
    }

    /// True when the run converged step `k`.
    fn converged(&self, k: usize) -> bool {
        self.vouches && k < self.taken && !self.failed.contains_key(&k)
    }
}

/// The steps of `runs` (one scene, one budget) that no run converged; a step that a run
/// without recorded reasons may have converged is left out (and the run counted).
fn unconverged_steps(runs: &[&RunRecord]) -> Unconverged {
    let steps: Vec<RunSteps> = runs.iter().map(|r| RunSteps::of(r)).collect();
    let unrecorded = steps.iter().filter(|s| !s.vouches).count();
    let planned = runs
        .iter()
        .filter_map(|r| r.steps_planned.or(r.steps))
        .max()
        .unwrap_or(0);
    let mut out = Unconverged {
        unrecorded,
        ..Unconverged::default()
    };
    if steps.is_empty() {
        return out;
    }
    let mut listed = 0;
    let mut more = 0;
    for k in 0..planned {
        // Only a step that every run can speak for, and none converged.
        if steps.iter().any(|s| !s.vouches && k < s.taken) || steps.iter().any(|s| s.converged(k)) {
            continue;
        }
        // No run took it (all stopped before): nothing to say of it.
        let failures: Vec<(&RunRecord, &FailedStep)> = steps
            .iter()
            .filter_map(|s| Some((s.run, s.failed.get(&k)?)))
            .collect();
        if failures.is_empty() {
            continue;
        }
        if listed == WHY_STEPS_SHOWN {
            more += 1;
            continue;
        }
        listed += 1;
        out.rows.push(why_row(k, &failures, &steps));
    }
    if more > 0 {
        out.rows.push(vec![
            format!("+{more} more"),
            String::new(),
            String::new(),
            String::new(),
        ]);
    }
    out
}

/// One row of the table: step, rows / contacts, best residual (by), why per solver.
fn why_row(k: usize, failures: &[(&RunRecord, &FailedStep)], steps: &[RunSteps]) -> Vec<String> {
    let (rows, contacts) = failures
        .iter()
        .map(|(_, f)| (f.rows, f.contacts))
        .max()
        .unwrap_or_default();
    let best = failures
        .iter()
        .filter_map(|(r, f)| Some((*r, f.residual?)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let best = best.map_or("–".to_owned(), |(r, v)| {
        format!("{} ({})", fmt_sci(Some(v)), r.solver)
    });
    let mut by_category: BTreeMap<StepFailure, Vec<String>> = BTreeMap::new();
    for (r, f) in failures {
        let name = match (f.failure, f.residual) {
            (StepFailure::Stall, Some(v)) => format!("{} at {}", r.solver, fmt_sci(Some(v))),
            _ => r.solver.to_string(),
        };
        by_category.entry(f.failure).or_default().push(name);
    }
    let mut why: Vec<String> = by_category
        .into_iter()
        .map(|(c, names)| format!("{}: {}", c.label(), names.join(", ")))
        .collect();
    let not_reached: Vec<String> = steps
        .iter()
        .filter(|s| s.vouches && k >= s.taken)
        .map(|s| s.run.solver.to_string())
        .collect();
    if !not_reached.is_empty() {
        why.push(format!("not reached: {}", not_reached.join(", ")));
    }
    vec![
        k.to_string(),
        format!("{rows} / {contacts}"),
        best,
        why.join("; "),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::step_failure::format_failed_steps;

    fn failed(step: usize, failure: StepFailure, residual: Option<f64>) -> FailedStep {
        FailedStep {
            step,
            failure,
            residual,
            rows: 300 + step,
            contacts: 100 + step,
        }
    }

    /// A scene run of `taken` of 10 planned steps, every step measured, failing `steps`.
    fn run(solver: &str, taken: usize, steps: &[FailedStep]) -> RunRecord {
        RunRecord {
            solver: solver.parse().expect("a solver"),
            steps: Some(taken),
            steps_planned: Some(10),
            steps_measured: Some(taken),
            nonconverged_steps: Some(steps.len()),
            converged: steps.is_empty() && taken == 10,
            failed_steps: format_failed_steps(steps),
            ..RunRecord::default()
        }
    }

    #[test]
    fn steps_no_solver_converged_are_listed_with_why_each_failed() {
        use StepFailure::*;
        let a = run(
            "newton-min",
            10,
            &[failed(3, Stall, Some(3.4e-3)), failed(7, Stall, Some(2e-6))],
        );
        // Converges step 7, fails step 3 at its cap.
        let b = run("pgs", 10, &[failed(3, IterationCap, Some(1.2e-5))]);
        // Stopped after 3 steps, the last over its budget.
        let c = RunRecord {
            time_limit_steps: Some(1),
            nonconverged_steps: Some(0),
            ..run("lemke", 3, &[failed(2, TimeBudget, None)])
        };
        let found = unconverged_steps(&[&a, &b, &c]);
        assert_eq!(found.unrecorded, 0);
        assert_eq!(
            found.rows,
            vec![vec![
                "3".to_owned(),
                "303 / 103".to_owned(),
                "1.2e-5 (pgs)".to_owned(),
                "stall: newton-min at 3.4e-3; iteration cap: pgs; not reached: lemke".to_owned(),
            ]]
        );
        // Without `b`, step 7 is lost by every run that took it, and `c` never reached it;
        // step 2, which `c` lost over its budget, `a` converged.
        let found = unconverged_steps(&[&a, &c]);
        let steps: Vec<&str> = found.rows.iter().map(|r| r[0].as_str()).collect();
        assert_eq!(steps, ["3", "7"]);
        assert_eq!(
            found.rows[1][3],
            "stall: newton-min at 2.0e-6; not reached: lemke"
        );
        // A step every run fails for a different reason: each category once, in order.
        let d = run("newton-fb", 10, &[failed(3, FactorCap, None)]);
        let e = run("apgd", 10, &[failed(3, NoSolution, None)]);
        let found = unconverged_steps(&[&d, &e]);
        assert_eq!(
            found.rows[0][3],
            "factorisation cap: newton-fb; no solution (certificate): apgd"
        );
        assert_eq!(found.rows[0][2], "–");
    }

    #[test]
    fn runs_without_recorded_reasons_are_counted_and_keep_their_steps_out() {
        let a = run(
            "newton-min",
            10,
            &[failed(3, StepFailure::Stall, Some(1e-3))],
        );
        // An older row: two unconverged steps, which ones not recorded.
        let old = RunRecord {
            nonconverged_steps: Some(2),
            failed_steps: String::new(),
            ..run("pgs", 10, &[])
        };
        let found = unconverged_steps(&[&a, &old]);
        assert_eq!(found.unrecorded, 1);
        assert!(found.rows.is_empty(), "{:?}", found.rows);
        // Every step converged by some run: nothing listed.
        let clean = run("pgs", 10, &[]);
        assert_eq!(unconverged_steps(&[&a, &clean]), Unconverged::default());
    }

    #[test]
    fn long_lists_are_cut_with_a_count() {
        let many: Vec<FailedStep> = (0..10)
            .map(|k| failed(k, StepFailure::IterationCap, Some(1e-4)))
            .collect();
        let found = unconverged_steps(&[&run("pgs", 10, &many)]);
        assert_eq!(found.rows.len(), WHY_STEPS_SHOWN + 1);
        assert_eq!(found.rows[WHY_STEPS_SHOWN][0], "+2 more");
    }
}
