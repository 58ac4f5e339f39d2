//! The cone solvers on the cone form of the exported scene steps (budget `tight`): how many
//! each brought to the cone residual 1e-4 and 1e-8 and the geometric mean of the time, how
//! many converged at the budget's tolerance, and Dolan–Moré profiles at both levels. Empty
//! when the suite has no exported LCPs.

use super::profiles::{performance_profile, profile_plot};
use crate::harness::{BudgetName, Case, RunRecord, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::suite::cone_solvers;
use crate::report::table::{fmt_time, geo_mean, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct ConeProfiles;

/// The budget of the cone solvers' runs.
const BUDGET: BudgetName = BudgetName::Tight;

impl Section for ConeProfiles {
    fn title(&self) -> &'static str {
        "Cone solvers on the exported scene steps"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let cases: Vec<&Case> = ctx.suite.exported_cases.iter().collect();
        if cases.is_empty() {
            return Ok(Vec::new());
        }
        let solvers = cone_solvers();
        let t = time_to_accuracy(ctx, &cases, &solvers);
        let _ = writeln!(
            md,
            "## Cone solvers on the exported scene steps\n\nThe exported scene LCPs above in their \
             exact Coulomb cone form (each contact's normal and two tangent rows as one cone), solved \
             by every cone solver under budget `{BUDGET}`; times to the relative cone residual (the \
             natural map with the cone projection, measured contact by contact). `clarabel-socp` \
             solves Anitescu's convex relaxation, so a sliding contact keeps it from converging \
             (its lift-off is in the run's reason). Profiles at 1e-4 and 1e-8 are in the figures.\n\n{}",
            ctx.table(&t)?
        );
        let mut figures = Vec::new();
        for (level, label) in [(1e-4, "1e-4"), (1e-8, "1e-8")] {
            let path = ctx.plots_dir.join(format!("profile_cone_{label}.svg"));
            let series = performance_profile(ctx, &cases, &solvers, level);
            profile_plot(
                &path,
                format!("Cone solvers: performance profile, cone residual {label}"),
                &series,
            )?;
            figures.push(Figure::new(
                format!("Dolan–Moré performance profile of the cone solvers at {label}"),
                path,
            ));
        }
        Ok(figures)
    }
}

fn time_to_accuracy(ctx: &ReportContext, cases: &[&Case], solvers: &[SolverSpec]) -> Table {
    let mut t = Table::new(
        "cone_time_to_accuracy",
        &[
            "solver",
            "reached 1e-4",
            "geo-mean time to 1e-4",
            "reached 1e-8",
            "geo-mean time to 1e-8",
            "converged at 1e-10",
        ],
    );
    for s in solvers {
        let runs: Vec<&RunRecord> = cases
            .iter()
            .filter_map(|c| ctx.get(c, s, &BUDGET))
            .collect();
        let mut row = vec![s.to_string()];
        for level in [1e-4, 1e-8] {
            let times: Vec<f64> = runs.iter().filter_map(|r| r.tta(level)).collect();
            row.push(format!("{} of {}", times.len(), cases.len()));
            row.push(fmt_time(geo_mean(&times)));
        }
        row.push(format!(
            "{} of {}",
            runs.iter().filter(|r| r.converged).count(),
            cases.len()
        ));
        t.rows.push(row);
    }
    t
}
