//! The robustness matrix (as Siconos' expected-failure matrix): for each matrix solver and
//! problem class, converged runs out of runs under budget `default`; for the infeasible class,
//! the runs that report infeasibility. Unsupported and crashed runs are counted in the cell.
//! It shows no times, so it counts the rows of every machine.

use crate::harness::{Budget, BudgetName, ProblemClass, RunRecord};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::status;
use crate::report::suite::all_solvers;
use crate::report::table::{mark, Table};
use anyhow::{Context, Result};
use std::fmt::Write as _;

pub(super) struct Robustness;

/// The budget of the runs counted.
const BUDGET: BudgetName = BudgetName::Default;

impl Section for Robustness {
    fn title(&self) -> &'static str {
        "Robustness matrix"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let mut classes: Vec<ProblemClass> = ProblemClass::MATRIX.to_vec();
        if ctx.suite.exported_cases.is_empty() {
            classes.retain(|c| *c != ProblemClass::Friction);
        }
        let mut header = vec!["solver".to_owned()];
        header.extend(classes.iter().map(|c| c.name().to_owned()));
        let mut robust = Table::with_header("robustness", header);
        for solver in all_solvers() {
            let mut row = vec![super::findings::solver_cell(&solver)];
            for class in &classes {
                let runs: Vec<&RunRecord> = ctx
                    .lcp_cases
                    .iter()
                    .filter_map(|c| ctx.get_any_machine(c, &solver, &BUDGET))
                    .filter(|r| r.class == *class)
                    .collect();
                row.push(cell(*class, &runs));
            }
            robust.rows.push(row);
        }
        let budget = Budget::preset(&BUDGET).context("the robustness budget is a preset")?;
        let _ = writeln!(
            md,
            "## Robustness matrix\n\nWhich solver solves which class (budget `{BUDGET}`: tolerance \
             {:e}, {} iterations, {} s), as Siconos' expected-failure matrix: converged runs / \
             runs; for the infeasible class, runs that *report* infeasibility (`no_solution`). \
             ✓ all, ~ some, ✗ none. Classes: SPD (cond 1e2–1e10), rank-deficient PSD, \
             non-symmetric P-matrices and Murty's example, degenerate (duplicated rows, weakly \
             complementary solutions, `b = 0`), infeasible{}.\n\n{}",
            budget.tolerance,
            budget.max_iterations,
            budget.time_s,
            if classes.contains(&ProblemClass::Friction) {
                ", friction (boxed LCPs exported from the scenes)"
            } else {
                ""
            },
            ctx.table(&robust)?
        );
        md.push_str(&super::findings::relaxation_footnote(&all_solvers()));
        Ok(Vec::new())
    }
}

/// One solver's runs of one class.
fn cell(class: ProblemClass, runs: &[&RunRecord]) -> String {
    let total = runs.len();
    if total == 0 {
        return "–".to_owned();
    }
    if class == ProblemClass::Infeasible {
        let ok = runs
            .iter()
            .filter(|r| status::reported_no_solution(r))
            .count();
        return format!("{} {ok}/{total} detected", mark(ok, total));
    }
    let ok = runs.iter().filter(|r| r.converged).count();
    let unsupported = runs.iter().filter(|r| status::unsupported(r)).count();
    let crashed = runs.iter().filter(|r| r.is_isolation_failure()).count();
    let mut s = format!("{} {ok}/{total}", mark(ok, total));
    if unsupported > 0 {
        let _ = write!(s, " ({unsupported} unsupported)");
    }
    if crashed > 0 {
        let _ = write!(s, " ({crashed} crashed)");
    }
    s
}
