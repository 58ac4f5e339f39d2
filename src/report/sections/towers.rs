//! Report section: towers at 60 Hz under low iteration budgets.
//!
//! The stacks engines must hold at game budgets: every warm-started iterative solver on the
//! 60 Hz towers of the scene library (their full ten seconds), at a few warm-started iterations
//! per step ([`TOWER_BUDGETS`](crate::report::suite::TOWER_BUDGETS)). For each solver and
//! budget: the top box's sag and lateral drift after the run, the solver time per step, and how
//! many steps ended short of the tolerance. One table per tower (`tables/towers_<tower>.csv`);
//! empty when the suite has no scenes or no tower runs.

use crate::harness::{Case, RunRecord};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::status;
use crate::report::table::{fmt_sci, fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct Towers;

impl Section for Towers {
    fn title(&self) -> &'static str {
        "Towers at 60 Hz, low budgets"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let suite = ctx.suite;
        if suite.scene_cases.is_empty() || suite.tower_cases.is_empty() {
            return Ok(Vec::new());
        }
        let _ = writeln!(
            md,
            "## Towers at 60 Hz, low budgets\n\nEach tower stepped for its whole run (10 s at \
             dt = 1/60) by every warm-started iterative solver, at tolerance 1e-6 with the iteration \
             cap per step of each budget. Sag: how far the top box's centre ended below its resting \
             height; drift: its horizontal distance from where it started; time: solver time per \
             step; steps short: steps that ended short of the tolerance (of the steps taken). A run \
             that collapses shows a sag of metres. These runs answer what a capped iteration \
             count per step buys; which solver is best on the towers at each accuracy (with a \
             real iteration cap) is in [Findings](#findings), by its one rule.\n"
        );
        for case in &suite.tower_cases {
            let name = case.short_name();
            let t = tower_table(ctx, case, &name);
            let _ = writeln!(md, "### {name}\n\n{}", ctx.table(&t)?);
        }
        Ok(Vec::new())
    }
}

/// Four columns per budget: sag, drift, time per step, steps short.
fn header(ctx: &ReportContext) -> Vec<String> {
    let mut header = vec!["solver".to_owned()];
    for b in &ctx.suite.tower_budgets {
        let cap = b.budget.max_iterations;
        header.extend([
            format!("sag ({cap} it, m)"),
            format!("drift ({cap} it, m)"),
            format!("time/step ({cap} it)"),
            format!("steps short ({cap} it)"),
        ]);
    }
    header
}

fn tower_table(ctx: &ReportContext, case: &Case, name: &str) -> Table {
    let mut t = Table::with_header(format!("towers_{name}"), header(ctx));
    for solver in &ctx.suite.tower_solvers {
        let mut row = vec![solver.to_string()];
        for b in &ctx.suite.tower_budgets {
            match ctx.get(case, solver, &b.name) {
                Some(r) => row.extend(cells(r)),
                None => row.extend(std::iter::repeat_n("–".to_owned(), 4)),
            }
        }
        t.rows.push(row);
    }
    t
}

fn cells(r: &RunRecord) -> [String; 4] {
    // Short of the measured steps (every step unless a residual schedule left some out).
    let short = match (r.nonconverged_steps, r.measured_steps()) {
        (Some(nc), Some(steps)) if status::cut_short(r) => {
            format!("{nc} of {steps} (cut short: {})", r.reason)
        }
        (Some(nc), Some(steps)) => format!("{nc} of {steps}"),
        _ => r.status.to_string(),
    };
    [
        fmt_sci(r.sag),
        fmt_sci(r.lateral_drift),
        fmt_time(r.time_per_step_s),
        short,
    ]
}
