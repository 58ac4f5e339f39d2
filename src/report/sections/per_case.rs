//! Results per case, for a report of any sweep (`report --from`): one table per case the rows
//! hold (and no other), each solver × budget with its status, time, warm start, iterations
//! and residuals; a speed–accuracy figure per scene; performance profiles of the LCP and cone
//! cases per budget. The default report's own sections cover its suite; this one covers
//! whatever a `bench` run wrote.

use super::findings::{relaxation_footnote, solver_cell};
use super::profiles::{performance_profile, profile_plot};
use super::scenes::{converged_steps, speed_accuracy_figure};
use crate::harness::{BudgetName, Case, RunRecord, RunStatus, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::table::{fmt_sci, fmt_time, slug, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct PerCase;

/// The section's heading (Findings links to it).
pub(crate) const HEADING: &str = "Results per case";

/// A run's time: per step for a scene (`no contacts` when no step had any), otherwise the
/// median solve time with the spread of the timed solves; `—` for a run that did not run the
/// solver (declined, or failed in isolation).
pub(crate) fn time_cell(r: &RunRecord) -> String {
    if r.status == RunStatus::Unsupported && r.steps.unwrap_or(0) == 0 || r.is_isolation_failure() {
        return "—".into();
    }
    if r.steps.is_some() {
        if crate::report::status::no_work(r) {
            return "no contacts".into();
        }
        return match r.time_per_step_s {
            Some(t) => format!("{}/step", fmt_time(Some(t))),
            None => "—".into(),
        };
    }
    let Some(t) = r.solve_time_s else {
        return "—".into();
    };
    match (r.timed_solves, r.solve_time_min_s, r.solve_time_max_s) {
        (Some(n), Some(lo), Some(hi)) if n > 1 => format!(
            "{} [{}–{}, {n} solves]",
            fmt_time(Some(t)),
            fmt_time(Some(lo)),
            fmt_time(Some(hi))
        ),
        _ => fmt_time(Some(t)),
    }
}

/// Where a warm start came from and its cost, or `cold`.
pub(crate) fn warm_cell(r: &RunRecord) -> String {
    if !r.solver.warm() {
        return "cold".into();
    }
    match (&r.warm_source[..], r.warm_time_s) {
        ("", _) => "warm".into(),
        (src, Some(t)) => format!("{src} ({})", fmt_time(Some(t))),
        (src, None) => src.to_owned(),
    }
}

impl Section for PerCase {
    fn title(&self) -> &'static str {
        HEADING
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        if !ctx.from_sweep {
            return Ok(Vec::new());
        }
        let rows = ctx.timed_rows();
        let mut cases: Vec<&str> = Vec::new();
        for r in &rows {
            if !cases.contains(&r.case.as_str()) {
                cases.push(&r.case);
            }
        }
        let _ = writeln!(
            md,
            "## {HEADING}\n\nEvery case of the sweep, each run (solver × budget) with its status; \
             its time (LCP and cone cases: the median of the timed solves, with the fastest and \
             slowest and their count; scenes: solver time per step); its warm start (where it \
             came from and what it cost, not part of the time); iterations (scenes: per step, \
             with the constraint-row updates per step and a substepping solver's substeps); the \
             largest relative residual (scenes: of a step, then the median step's; for a \
             substepping solver, of its last solve's LCP); and, for scenes, the steps that \
             converged. All rows in [`tables/per_case.csv`](tables/per_case.csv). The best \
             solver per family and accuracy is in [Findings](#{}).\n",
            super::findings::anchor(super::findings::HEADING)
        );
        let header = [
            "case",
            "solver",
            "budget",
            "status",
            "time",
            "warm start",
            "iterations",
            "residual max",
            "residual median",
            "converged steps",
        ];
        let mut all = Table::new("per_case", &header);
        let mut figures = Vec::new();
        let mut solvers: Vec<SolverSpec> = Vec::new();
        let mut lcp_cases: Vec<Case> = Vec::new();
        // File names come from case names (two cases of one name, such as a scene under two
        // friction models, get `_2`, `_3`, … after the first).
        let mut used: Vec<String> = Vec::new();
        for case in &cases {
            let runs: Vec<&RunRecord> = rows.iter().copied().filter(|r| r.case == *case).collect();
            let parsed: Option<Case> = case.parse().ok();
            let name = parsed
                .as_ref()
                .map_or_else(|| (*case).to_owned(), Case::short_name);
            let mut t = Table::new("case", &header[1..]);
            for r in &runs {
                let cells = vec![
                    solver_cell(&r.solver),
                    r.budget.to_string(),
                    r.status.to_string(),
                    time_cell(r),
                    warm_cell(r),
                    iterations_cell(r),
                    fmt_sci(r.residual_rel),
                    fmt_sci(r.residual_rel_median),
                    match (converged_steps(r), r.steps_planned.or(r.steps)) {
                        (Some(_), Some(p)) => super::scenes::converged_fraction(r, p),
                        _ => "–".into(),
                    },
                ];
                let mut full = vec![(*case).to_owned()];
                full.extend(cells.iter().cloned());
                all.rows.push(full);
                t.rows.push(cells);
                if !solvers.contains(&r.solver) {
                    solvers.push(r.solver.clone());
                }
            }
            let _ = writeln!(md, "### {name}\n\n`{case}`\n\n{}", t.markdown());
            match parsed {
                Some(c @ Case::Scene { .. }) => {
                    let budgets = budgets_of(&runs);
                    let mut file = slug(&name);
                    let same = used.iter().filter(|u| **u == file).count();
                    used.push(file.clone());
                    if same > 0 {
                        file = format!("{file}_{}", same + 1);
                    }
                    let path = ctx.plots_dir.join(format!("pareto_{file}.svg"));
                    if speed_accuracy_figure(ctx, &c, &path, &budgets)? {
                        figures.push(Figure::new(
                            format!("Speed–accuracy on scene {name} (worst step residual)"),
                            path,
                        ));
                    }
                }
                Some(c) => lcp_cases.push(c),
                None => {}
            }
        }
        all.write_csv(&ctx.tables_dir)?;
        md.push_str(&relaxation_footnote(&solvers));
        figures.extend(profiles(ctx, &rows, &lcp_cases)?);
        Ok(figures)
    }
}

/// Iterations of a run: an LCP's count; a scene's mean per step, with its row updates per
/// step and, when the solver substeps, its substeps per step.
fn iterations_cell(r: &RunRecord) -> String {
    let Some(i) = r.iterations_per_step else {
        return r.iterations.map_or("–".into(), |i| i.to_string());
    };
    let mut cell = format!("{i:.1}/step");
    if let Some(u) = r.row_updates_per_step {
        let _ = write!(cell, ", {u:.0} row updates");
    }
    if let Some(s) = r.substeps_per_step.filter(|&s| s > 1.0) {
        let _ = write!(cell, ", {s:.1} substeps");
    }
    cell
}

/// The budgets of `runs`, in order of first appearance.
fn budgets_of(runs: &[&RunRecord]) -> Vec<BudgetName> {
    let mut v: Vec<BudgetName> = Vec::new();
    for r in runs {
        if !v.contains(&r.budget) {
            v.push(r.budget.clone());
        }
    }
    v
}

/// Dolan–Moré profiles of the LCP and cone cases, per budget with at least two of them and
/// two solvers, at 1e-4 and 1e-8 (a level only when the budget's tolerance reaches it).
fn profiles(ctx: &ReportContext, rows: &[&RunRecord], cases: &[Case]) -> Result<Vec<Figure>> {
    let keys: Vec<String> = cases.iter().map(ToString::to_string).collect();
    let lcp_rows: Vec<&RunRecord> = rows
        .iter()
        .copied()
        .filter(|r| keys.contains(&r.case))
        .collect();
    let mut figures = Vec::new();
    for budget in budgets_of(&lcp_rows) {
        let of_budget: Vec<&RunRecord> = lcp_rows
            .iter()
            .copied()
            .filter(|r| r.budget == budget)
            .collect();
        let mut solvers: Vec<SolverSpec> = Vec::new();
        for r in &of_budget {
            if !solvers.contains(&r.solver) {
                solvers.push(r.solver.clone());
            }
        }
        let on: Vec<&Case> = cases
            .iter()
            .filter(|c| of_budget.iter().any(|r| r.case == c.to_string()))
            .collect();
        let tolerance = of_budget.iter().map(|r| r.tolerance).fold(0.0, f64::max);
        if on.len() < 2 || solvers.len() < 2 {
            continue;
        }
        for (level, label) in [(1e-4, "1e-4"), (1e-8, "1e-8")] {
            if tolerance > level * (1.0 + 1e-9) {
                continue;
            }
            let path = ctx
                .plots_dir
                .join(format!("profile_{}_{label}.svg", slug(budget.as_str())));
            let series = performance_profile(ctx, &on, &solvers, &budget, level);
            profile_plot(
                &path,
                format!("Performance profile, budget {budget}, residual {label}"),
                &series,
            )?;
            figures.push(Figure::new(
                format!("Dolan–Moré performance profile, budget `{budget}`, at {label}"),
                path,
            ));
        }
    }
    Ok(figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An LCP run gives its count; a scene run its mean per step with the row updates, and the
    /// substeps only when the solver substeps.
    #[test]
    fn iterations_show_the_cost_per_step_of_scenes() {
        let lcp = RunRecord {
            iterations: Some(12),
            ..RunRecord::default()
        };
        assert_eq!(iterations_cell(&lcp), "12");
        let scene = RunRecord {
            iterations: Some(200),
            iterations_per_step: Some(20.0),
            row_updates_per_step: Some(2400.0),
            substeps_per_step: Some(1.0),
            ..RunRecord::default()
        };
        assert_eq!(iterations_cell(&scene), "20.0/step, 2400 row updates");
        let substepping = RunRecord {
            substeps_per_step: Some(4.0),
            ..scene.clone()
        };
        assert_eq!(
            iterations_cell(&substepping),
            "20.0/step, 2400 row updates, 4.0 substeps"
        );
        assert_eq!(iterations_cell(&RunRecord::default()), "–");
    }

    #[test]
    fn times_show_their_spread_and_nothing_for_runs_that_did_not_run() {
        let timed = RunRecord {
            status: RunStatus::Converged,
            solve_time_s: Some(2e-4),
            timed_solves: Some(7),
            solve_time_min_s: Some(1.9e-4),
            solve_time_max_s: Some(3e-4),
            ..RunRecord::default()
        };
        assert_eq!(time_cell(&timed), "200.0 µs [190.0 µs–300.0 µs, 7 solves]");
        let declined = RunRecord {
            status: RunStatus::Unsupported,
            solve_time_s: Some(2e-7),
            ..RunRecord::default()
        };
        assert_eq!(time_cell(&declined), "—");
        let idle = RunRecord {
            status: RunStatus::Converged,
            steps: Some(5),
            contacts_mean: Some(0.0),
            time_per_step_s: Some(0.0),
            ..RunRecord::default()
        };
        assert_eq!(time_cell(&idle), "no contacts");
        let warm = RunRecord {
            solver: "pgs+warm".parse().unwrap(),
            warm_source: "20 PGS sweeps".into(),
            warm_time_s: Some(5e-6),
            ..RunRecord::default()
        };
        assert_eq!(warm_cell(&warm), "20 PGS sweeps (5.0 µs)");
        assert_eq!(warm_cell(&RunRecord::default()), "cold");
    }
}
