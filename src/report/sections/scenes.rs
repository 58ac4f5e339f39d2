//! The scenes: each scene stepped with each matrix and body-level solver, cold and (the
//! iterative ones) warm-started, under budgets `realtime`, `loose` and `default`.
//!
//! * **At a glance**: scene × solver, the solver time per step under budget `default` with the
//!   steps that converged, or what stopped the run.
//! * **One section per scene**: solver × budget, the time per step and the converged steps
//!   (all in `tables/scenes_by_budget.csv`), then, under budget `default`, status, steps,
//!   contacts, time and iterations per step, the largest residual and penetration, energy
//!   drift, failures (non-converged, no-solution and NaN steps, blow-up), lift-off and the
//!   analytic error (all rows also in `tables/scenes.csv`).
//! * **Fastest solver per scene** among the runs whose every step converged, at budgets
//!   `loose` and `default`.
//! * A speed–accuracy figure per scene: time per step against the median residual per step
//!   under budgets `realtime`, `loose` and `default`, with the Pareto front.

use crate::harness::{BudgetName, Case, RunRecord, SolverSpec};
use crate::report::context::{scene_solvers_cold_and_warm, Figure, ReportContext, Section};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::status;
use crate::report::suite::{self, scene_solvers};
use crate::report::summary::{self, ACCURACIES};
use crate::report::table::{fmt_sci, fmt_time, slug, Table};
use anyhow::Result;
use lcpbench_contact::scene::Scene;
use std::fmt::Write as _;

pub(super) struct Scenes;

/// Columns of a scene's table (the first, the scene, only in `tables/scenes.csv`).
const COLUMNS: [&str; 13] = [
    "scene",
    "solver",
    "status",
    "steps",
    "contacts",
    "time/step",
    "iters/step",
    "residual max",
    "penetration max (m)",
    "energy drift",
    "failures",
    "lift-off (m/s)",
    "analytic error",
];

impl Section for Scenes {
    fn title(&self) -> &'static str {
        "Scenes"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        if ctx.suite.scene_cases.is_empty() {
            return Ok(Vec::new());
        }
        let _ = writeln!(
            md,
            "## Scenes\n\nEach scene stepped with each solver, cold and (the iterative ones, \
             `+warm`) warm-started from the previous step's impulses, under budgets `realtime`, \
             `loose` and `default`, and the warm-started ones also under `{}` (the accuracy \
             1e-6 of [Findings](#findings); its runs appear in the solver × budget tables, the \
             figures and the best solver per scene). A budget's seconds bound each step's solve: a step that runs \
             out of them ends `time_limit` with the solver's best point and the run goes on; a \
             run stops early only at twice its steps times those seconds, or after three \
             consecutive steps over them (the solver cannot keep up). Scenes run at most {} \
             steps (except {}, whose runs take that long to settle); the large ones (more than {} dynamic bodies) {} steps, except {} (see the \
             large-scene section). Scenes with more than {} dynamic bodies run only {} (cold \
             and warm): the other solvers read rows of the assembled Delassus matrix, tens of \
             millions of entries there. Budget `tight` is not run on scenes: at 10 s per step \
             the runs of the solvers that cannot keep up would take longer than the rest of the \
             report. \
             Time/step is solver time; residual is the largest shared relative residual over the \
             steps; penetration the largest depth; drift the relative change of total energy; \
             failures count non-converged steps / of them, steps without a solution \
             (`no_solution` or `diverged`) / NaN steps / blow-up; lift-off is the largest \
             separating normal speed at a sliding contact after a solve (what a convex \
             relaxation of friction causes; Baumgarte correction of a penetrating contact shows \
             up here too).\n",
            suite::SCENE_MID_BUDGET,
            suite::SCENE_STEPS,
            suite::SMALL_SCENE_STEP_EXCEPTIONS
                .iter()
                .map(|(name, steps)| format!("{name} ({steps})"))
                .collect::<Vec<_>>()
                .join(", "),
            suite::LARGE_SCENE_BODIES,
            suite::LARGE_SCENE_STEPS,
            suite::LARGE_SCENE_STEP_EXCEPTIONS
                .iter()
                .map(|(name, steps)| format!("{name} ({steps})"))
                .collect::<Vec<_>>()
                .join(", "),
            suite::HUGE_SCENE_BODIES,
            suite::huge_scene_solvers()
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        );
        at_a_glance(ctx, md)?;
        without_solution(ctx, md)?;
        let mut by_budget = Table::new("scenes_by_budget", &BY_BUDGET_COLUMNS);
        let mut all = Table::new("scenes", &COLUMNS);
        let mut fastest = Table::new(
            "scenes_fastest",
            &[
                "scene",
                "best at 1e-4",
                "its cost",
                "best at 1e-6",
                "its cost",
                "best at 1e-8",
                "its cost",
            ],
        );
        let mut figures = Vec::new();
        for case in &ctx.suite.scene_cases {
            let name = case.short_name();
            let _ = writeln!(
                md,
                "### {name}\n\n{}\nUnder budget `default`:\n\n{}",
                budget_matrix(ctx, case, &mut by_budget),
                scene_table(ctx, case, &mut all)
            );
            fastest.rows.push(fastest_row(ctx, case));
            figures.push(pareto_figure(ctx, case)?);
        }
        all.write_csv(&ctx.tables_dir)?;
        by_budget.write_csv(&ctx.tables_dir)?;
        let _ = writeln!(
            md,
            "### Fastest solver per scene\n\nThe best solver per scene at each accuracy by the \
             rule of [Findings](#findings) ({}), cold and `+warm` runs alike; a run counts at an \
             accuracy when its budget's tolerance is that accuracy or tighter.\n\n{}\n{}",
            summary::RULE,
            ctx.table(&fastest)?,
            super::findings::relaxation_footnote(&scene_solvers())
        );
        Ok(figures)
    }
}

fn at_a_glance(ctx: &ReportContext, md: &mut String) -> Result<()> {
    let mut header = vec!["scene".to_owned()];
    header.extend(scene_solvers().iter().map(|s| s.to_string()));
    let mut glance = Table::with_header("scenes_at_a_glance", header);
    for case in &ctx.suite.scene_cases {
        let mut row = vec![case.short_name()];
        for solver in scene_solvers() {
            row.push(match ctx.get(case, &solver, &BudgetName::Default) {
                None => "–".into(),
                Some(r) => glance_cell(r),
            });
        }
        glance.rows.push(row);
    }
    let _ = writeln!(
        md,
        "### At a glance\n\nSolver time per step under budget `default`, cold start. ✓ every \
         step converged; ~ some steps did not (converged steps / steps in brackets); ✗ none \
         did or the solver declined the problem; `cut` a run stopped before its last step \
         (steps done / steps planned: three consecutive steps over the per-step budget, or the \
         run limit); `blow-up`, `timeout`, `crash` and `panic` as recorded.\n\n{}",
        ctx.table(&glance)?
    );
    Ok(())
}

/// The scenes with steps that have no solution: for each, how many of its runs met such steps
/// (`no_solution` or `diverged`), the most in one run, which solvers, its position correction
/// and its description, which say why.
fn without_solution(ctx: &ReportContext, md: &mut String) -> Result<()> {
    let mut table = Table::new(
        "scenes_without_solution",
        &[
            "scene",
            "runs with such steps / runs",
            "most such steps (of steps)",
            "solvers",
            "position correction",
            "description",
        ],
    );
    for case in &ctx.suite.scene_cases {
        let Case::Scene { path, .. } = case else {
            continue;
        };
        let runs: Vec<&RunRecord> = ctx
            .rows
            .iter()
            .filter(|r| r.case == case.to_string())
            .collect();
        let with: Vec<&&RunRecord> = runs
            .iter()
            .filter(|r| r.no_solution_steps.unwrap_or(0) > 0)
            .collect();
        let Some(most) = with.iter().max_by_key(|r| r.no_solution_steps.unwrap_or(0)) else {
            continue;
        };
        let mut solvers: Vec<String> = with.iter().map(|r| r.solver.base_name()).collect();
        solvers.sort_unstable();
        solvers.dedup();
        let (correction, description) = match Scene::load(path) {
            Ok(scene) => (
                format!("{:?}", scene.settings.builder.position_correction).to_lowercase(),
                scene
                    .description
                    .split_whitespace()
                    .collect::<Vec<_>>()
                    .join(" "),
            ),
            Err(_) => ("–".into(), "–".into()),
        };
        table.rows.push(vec![
            case.short_name(),
            format!("{} / {}", with.len(), runs.len()),
            format!(
                "{} ({})",
                most.no_solution_steps.unwrap_or(0),
                most.steps.unwrap_or(0)
            ),
            solvers.join(", "),
            correction,
            description,
        ]);
    }
    let _ = writeln!(
        md,
        "### Steps without a solution\n\nA step's LCP can have no solution: position correction \
         (Baumgarte's bias, a restitution or a removal event) can ask a body to leave two \
         contacts in opposite directions at once, and no impulse does that. Such a step ends \
         `no_solution` when a Farkas certificate read off the solver's impulse proves it, and \
         `diverged` when the residual met the tolerance only through an impulse growing along a \
         direction the Delassus matrix cancels; either way it is counted as a step without a \
         solution, not as converged. {}\n\n{}",
        if table.rows.is_empty() {
            "No scene of this report met such a step."
        } else {
            "The scenes where some run met such steps, with their position correction and \
             description:"
        },
        ctx.table(&table)?
    );
    Ok(())
}

/// Columns of `tables/scenes_by_budget.csv`.
const BY_BUDGET_COLUMNS: [&str; 12] = [
    "scene",
    "solver",
    "budget",
    "status",
    "steps",
    "steps planned",
    "converged steps",
    "time-limited steps",
    "time/step",
    "step time",
    "residual median",
    "residual max",
];

/// The budgets of the scene runs: [`suite::SCENE_BUDGETS`] and [`suite::SCENE_MID_BUDGET`].
pub(super) fn scene_budgets() -> Vec<BudgetName> {
    let mut budgets = suite::SCENE_BUDGETS.to_vec();
    budgets.push(suite::scene_mid_budget().name);
    budgets
}

/// The solver specifications with a run on `case`, in the order of the scene solvers, each
/// cold then warm.
fn solvers_of(ctx: &ReportContext, case: &Case) -> Vec<SolverSpec> {
    scene_solvers_cold_and_warm()
        .into_iter()
        .filter(|s| {
            scene_budgets()
                .iter()
                .any(|b| ctx.get(case, s, b).is_some())
        })
        .collect()
}

/// Solver × budget: the time per step and the converged steps of every run on `case` (as in
/// the glance table), as Markdown; the runs' rows are added to `by_budget`.
fn budget_matrix(ctx: &ReportContext, case: &Case, by_budget: &mut Table) -> String {
    let mut header = vec!["solver".to_owned()];
    header.extend(scene_budgets().iter().map(|b| b.to_string()));
    let mut t = Table::with_header("budgets", header);
    for solver in solvers_of(ctx, case) {
        let mut row = vec![super::findings::solver_cell(&solver)];
        for budget in &scene_budgets() {
            match ctx.get(case, &solver, budget) {
                Some(r) => {
                    row.push(glance_cell(r));
                    by_budget.rows.push(by_budget_row(case, r));
                }
                None => row.push("–".into()),
            }
        }
        t.rows.push(row);
    }
    t.markdown()
}

fn by_budget_row(case: &Case, r: &RunRecord) -> Vec<String> {
    let count = |v: Option<usize>| v.map_or("–".into(), |v| v.to_string());
    vec![
        case.to_string(),
        r.solver.to_string(),
        r.budget.to_string(),
        r.status.to_string(),
        count(r.steps),
        count(r.steps_planned),
        count(converged_steps(r)),
        count(r.time_limit_steps),
        step_time(r),
        fmt_time(r.step_time_s),
        fmt_sci(r.residual_rel_median),
        fmt_sci(r.residual_rel),
    ]
}

/// Steps of the run that converged (steps without contacts count as converged), of its
/// measured steps ([`RunRecord::converged_steps`]).
pub(super) fn converged_steps(r: &RunRecord) -> Option<usize> {
    r.converged_steps()
}

/// `c/total` converged steps, or `c of m measured (total steps)` when a residual schedule
/// left steps unmeasured (an unmeasured step is neither converged nor not).
pub(super) fn converged_fraction(r: &RunRecord, total: usize) -> String {
    let c = converged_steps(r).unwrap_or(0);
    match r.measured_steps() {
        Some(m) if Some(m) != r.steps => format!("{c} of {m} measured ({total} steps)"),
        _ => format!("{c}/{total}"),
    }
}

/// The scene's table (budget `default`) as Markdown; its rows are added to `all` too.
fn scene_table(ctx: &ReportContext, case: &Case, all: &mut Table) -> String {
    let mut t = Table::new("scene", &COLUMNS[1..]);
    for r in ctx.runs_of(case, &scene_solvers(), &BudgetName::Default) {
        let cells = scene_cells(r);
        t.rows.push(cells.clone());
        let mut full = vec![case.to_string()];
        full.extend(cells);
        all.rows.push(full);
    }
    t.markdown()
}

/// The best solver on `case` at each accuracy of [`ACCURACIES`] by the rule of
/// [`crate::report::summary`] (every solver, cold and warm), with its time per step and
/// converged steps.
fn fastest_row(ctx: &ReportContext, case: &Case) -> Vec<String> {
    let key = case.to_string();
    let runs: Vec<&RunRecord> = ctx
        .timed_rows()
        .into_iter()
        .filter(|r| r.case == key)
        .collect();
    let mut row = vec![case.short_name()];
    for level in ACCURACIES {
        let ranked = summary::rank(&runs, level);
        match ranked.first() {
            Some(best) if best.no_work => row.extend(["no contacts".into(), "—".into()]),
            Some(best) if best.solved > 0 => {
                row.push(super::findings::solver_cell(&best.solver));
                row.push(super::findings::cost_cell(best));
            }
            Some(_) => row.extend(["none converged a step".into(), "–".into()]),
            None => row.extend(["no run at this accuracy".into(), "–".into()]),
        }
    }
    row
}

/// Time per step against the worst residual of a step (the median step's beside it) of every
/// solver and budget, with the Pareto front through the runs that returned solutions.
fn pareto_figure(ctx: &ReportContext, case: &Case) -> Result<Figure> {
    let name = case.short_name();
    let path = ctx.plots_dir.join(format!("pareto_{}.svg", slug(&name)));
    speed_accuracy_figure(ctx, case, &path, &scene_budgets())?;
    Ok(Figure::new(
        format!("Speed–accuracy on scene {name} (worst step residual, median beside it)"),
        path,
    ))
}

/// True when the run returned a solution on every step it took that had work: it ran (not
/// declined, not failed in isolation, not blown up), had contacts, no step without a solution,
/// and its worst residual is below 1 (a residual of 1 or more says it did not solve).
pub(super) fn returned_solutions(r: &RunRecord) -> bool {
    let steps = r.steps.unwrap_or(0);
    let ran = !(r.is_isolation_failure() || status::blew_up(r) || status::unsupported(r));
    // A run declined on some steps but not all still returned solutions on the others.
    let ran = ran || (status::unsupported(r) && steps > 0);
    ran && steps > 0
        && !status::no_work(r)
        && r.no_solution_steps.unwrap_or(0) == 0
        && r.residual_rel.is_some_and(|v| v < 1.0)
}

/// Time per step against the worst step residual of every run of `case` under `budgets` (each
/// solver, cold and warm, one point per budget; the median step residual a small cross of the
/// same colour), with the Pareto front over the runs that returned solutions
/// ([`returned_solutions`]), drawn to `path`. Runs with no time to show (declined, failed in
/// isolation, or without contacts) are left out. Returns false (and draws nothing) when no run
/// has a point.
pub(super) fn speed_accuracy_figure(
    ctx: &ReportContext,
    case: &Case,
    path: &std::path::Path,
    budgets: &[BudgetName],
) -> Result<bool> {
    let key = case.to_string();
    let runs: Vec<&RunRecord> = ctx
        .timed_rows()
        .into_iter()
        .filter(|r| r.case == key && budgets.contains(&r.budget))
        .filter(|r| {
            let declined = status::unsupported(r) && r.steps.unwrap_or(0) == 0;
            !(r.is_isolation_failure() || declined || status::no_work(r))
        })
        .collect();
    let mut solvers: Vec<SolverSpec> = Vec::new();
    for r in &runs {
        if !solvers.contains(&r.solver) {
            solvers.push(r.solver.clone());
        }
    }
    let mut series = Vec::new();
    let mut medians = Vec::new();
    let mut solved = Vec::new();
    for solver in &solvers {
        let mine: Vec<&&RunRecord> = runs.iter().filter(|r| r.solver == *solver).collect();
        let pts: Vec<(f64, f64)> = mine
            .iter()
            .filter_map(|r| Some((r.time_per_step_s?, r.residual_rel?.max(1e-17))))
            .collect();
        if pts.is_empty() {
            continue;
        }
        solved.extend(
            mine.iter()
                .filter(|r| returned_solutions(r))
                .filter_map(|r| Some((r.time_per_step_s?, r.residual_rel?))),
        );
        medians.push(Series {
            name: String::new(),
            color_key: solver.to_string(),
            points: mine
                .iter()
                .filter_map(|r| Some((r.time_per_step_s?, r.residual_rel_median?.max(1e-17))))
                .collect(),
            mark: Mark::Secondary,
        });
        series.push(Series {
            name: super::findings::solver_cell(solver),
            color_key: solver.to_string(),
            points: pts,
            mark: if solver.warm() {
                Mark::LinePoints
            } else {
                Mark::Points
            },
        });
    }
    if series.is_empty() {
        return Ok(false);
    }
    let front = pareto_front(&solved);
    series.extend(medians);
    if front.len() > 1 {
        series.push(Series {
            name: "Pareto front (solved runs)".into(),
            color_key: "front".into(),
            points: front,
            mark: Mark::Reference,
        });
    }
    let budget_names: Vec<String> = budgets.iter().map(ToString::to_string).collect();
    plot(
        path,
        &PlotSpec {
            title: format!(
                "{}: speed against accuracy ({})",
                case.short_name(),
                budget_names.join(", ")
            ),
            x_label: "solver time per step (s)".into(),
            y_label: "worst relative residual of a step (× median)".into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::LowerLeft,
        },
        &series,
    )?;
    Ok(true)
}

/// The points no other point beats in both time and residual, by increasing time.
fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut every: Vec<(f64, f64)> = points.to_vec();
    every.retain(|(x, y)| *x > 0.0 && *y >= 0.0);
    every.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for (x, y) in every {
        if y < best {
            best = y;
            front.push((x, y.max(1e-17)));
        }
    }
    front
}

/// A scene run's time per step for the tables: `no contacts` when no step had any (there was
/// nothing to time), `—` when the solver did not run (declined, or failed in isolation).
pub(super) fn step_time(r: &RunRecord) -> String {
    if r.is_isolation_failure() || (status::unsupported(r) && r.steps.unwrap_or(0) == 0) {
        "—".into()
    } else if status::no_work(r) {
        "no contacts".into()
    } else {
        fmt_time(r.time_per_step_s)
    }
}

pub(super) fn glance_cell(r: &RunRecord) -> String {
    let t = step_time(r);
    let steps = r.steps.unwrap_or(0);
    let nc = r.nonconverged_steps.unwrap_or(0);
    // Converged or not is said of measured steps only.
    let measured = r.measured_steps().unwrap_or(steps);
    if r.is_isolation_failure() {
        r.status.to_string()
    } else if status::blew_up(r) {
        format!("blow-up ({steps} steps)")
    } else if status::cut_short(r) {
        let planned = r.steps_planned.unwrap_or(steps);
        format!("cut ({steps}/{planned} steps, {t})")
    } else if status::unsupported(r) && steps == 0 {
        "✗ unsupported".into()
    } else if nc == 0 && measured < steps {
        format!("✓ {t} ({measured} of {steps} measured)")
    } else if nc == 0 {
        format!("✓ {t}")
    } else if nc >= measured {
        format!("✗ {t} ({})", r.status)
    } else if measured < steps {
        format!("~ {t} ({} of {measured} measured)", measured - nc)
    } else {
        format!("~ {t} ({}/{steps})", steps - nc)
    }
}

fn scene_cells(r: &RunRecord) -> Vec<String> {
    let failures = format!(
        "{} / {} / {} / {}",
        r.nonconverged_steps.unwrap_or(0),
        r.no_solution_steps
            .map(|n| n.to_string())
            .unwrap_or("–".into()),
        r.nan_steps.unwrap_or(0),
        if r.blow_up == Some(true) { "yes" } else { "no" }
    );
    let analytic = match r.analytic_error {
        Some(e) => format!("{} {}", r.analytic_metric, fmt_sci(Some(e))),
        None => "–".into(),
    };
    let status = if r.reason.is_empty() {
        r.status.to_string()
    } else {
        let reason: String = r.reason.chars().take(60).collect();
        format!("{} ({reason})", r.status)
    };
    vec![
        super::findings::solver_cell(&r.solver),
        status,
        r.steps.map(|s| s.to_string()).unwrap_or("–".into()),
        r.contacts_mean
            .map(|c| format!("{c:.1}"))
            .unwrap_or("–".into()),
        step_time(r),
        r.iterations_per_step
            .map(|i| format!("{i:.1}"))
            .unwrap_or("–".into()),
        fmt_sci(r.residual_rel),
        fmt_sci(r.penetration_max),
        fmt_sci(r.energy_drift),
        failures,
        fmt_sci(r.liftoff_speed),
        analytic,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(status: &str, steps: usize, nonconverged: usize) -> RunRecord {
        RunRecord {
            status: status.parse().expect("a run status"),
            steps: Some(steps),
            steps_planned: Some(10),
            nonconverged_steps: Some(nonconverged),
            time_per_step_s: Some(2e-3),
            ..RunRecord::default()
        }
    }

    #[test]
    fn glance_cells_name_what_stopped_the_run_or_how_many_steps_converged() {
        assert_eq!(glance_cell(&run("crash", 0, 0)), "crash");
        assert_eq!(glance_cell(&run("blow_up", 7, 1)), "blow-up (7 steps)");
        assert_eq!(
            glance_cell(&run("time_limit", 9, 0)),
            "cut (9/10 steps, 2.00 ms)"
        );
        // Every step taken, some over the per-step budget: judged by the steps.
        assert_eq!(glance_cell(&run("time_limit", 10, 2)), "~ 2.00 ms (8/10)");
        assert_eq!(glance_cell(&run("unsupported", 0, 0)), "✗ unsupported");
        assert_eq!(glance_cell(&run("converged", 10, 0)), "✓ 2.00 ms");
        assert_eq!(
            glance_cell(&run("iteration_limit", 10, 3)),
            "~ 2.00 ms (7/10)"
        );
        assert_eq!(
            glance_cell(&run("iteration_limit", 10, 10)),
            "✗ 2.00 ms (iteration_limit)"
        );
        // No contacts: nothing timed.
        let idle = RunRecord {
            contacts_mean: Some(0.0),
            time_per_step_s: Some(0.0),
            ..run("converged", 10, 0)
        };
        assert_eq!(glance_cell(&idle), "✓ no contacts");
        assert_eq!(step_time(&run("unsupported", 0, 0)), "—");
        // Unsupported after some steps: judged by the steps, like any other run.
        assert_eq!(glance_cell(&run("unsupported", 4, 1)), "~ 2.00 ms (3/4)");
    }

    #[test]
    fn the_pareto_front_keeps_the_points_nothing_beats() {
        let front = pareto_front(&[
            (1.0, 1e-3),
            (3.0, 1e-4),
            (2.0, 1e-5),
            (0.5, 1e-2),
            (0.0, 1e-9),
            (4.0, 0.0),
        ]);
        assert_eq!(front, [(0.5, 1e-2), (1.0, 1e-3), (2.0, 1e-5), (4.0, 1e-17)]);
    }

    /// A run whose residual says it did not solve (penalty at 1), a declined run, a run
    /// without contacts and a run with steps without a solution are not on the front.
    #[test]
    fn only_runs_that_returned_solutions_are_on_the_front() {
        let ok = RunRecord {
            residual_rel: Some(1e-7),
            contacts_mean: Some(4.0),
            ..run("converged", 10, 0)
        };
        assert!(returned_solutions(&ok));
        let penalty = RunRecord {
            residual_rel: Some(1.0),
            ..ok.clone()
        };
        assert!(!returned_solutions(&penalty));
        assert!(!returned_solutions(&RunRecord {
            steps: Some(0),
            ..run("unsupported", 0, 0)
        }));
        let idle = RunRecord {
            contacts_mean: Some(0.0),
            ..ok.clone()
        };
        assert!(!returned_solutions(&idle));
        let no_solution = RunRecord {
            no_solution_steps: Some(2),
            ..ok
        };
        assert!(!returned_solutions(&no_solution));
    }
}
