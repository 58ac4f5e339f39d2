//! The SOR relaxation sweep: sweeps to the relative residual 1e-8 (budget `default`) against
//! the relaxation factor `omega` on the suite's omega cases (`omega = 1` is PGS), as a table
//! and a figure of the converged runs.

use crate::harness::{BudgetName, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::table::Table;
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct SorOmega;

/// The budget of the SOR runs.
const BUDGET: BudgetName = BudgetName::Default;

impl Section for SorOmega {
    fn title(&self) -> &'static str {
        "SOR relaxation sweep"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let suite = ctx.suite;
        let mut header = vec!["omega".to_owned()];
        header.extend(
            suite
                .omega_cases
                .iter()
                .map(|c| format!("`{c}` iterations")),
        );
        let mut table = Table::with_header("sor_omega", header);
        let mut series: Vec<Series> = suite
            .omega_cases
            .iter()
            .map(|c| Series {
                name: c.to_string(),
                color_key: c.to_string(),
                points: Vec::new(),
                mark: Mark::LinePoints,
            })
            .collect();
        for &w in &suite.omegas {
            let mut row = vec![format!("{w}")];
            for (case, series) in suite.omega_cases.iter().zip(&mut series) {
                let spec = SolverSpec::sor(w);
                let cell = match spec.as_ref().ok().and_then(|s| ctx.get(case, s, &BUDGET)) {
                    Some(r) if r.converged => {
                        let it = r.iterations.unwrap_or(0);
                        series.points.push((w, it as f64));
                        it.to_string()
                    }
                    Some(r) => format!("{} ({})", r.iterations.unwrap_or(0), r.status),
                    None => "–".into(),
                };
                row.push(cell);
            }
            table.rows.push(row);
        }
        let _ = writeln!(
            md,
            "## SOR relaxation sweep\n\nSweeps to relative residual 1e-8 (budget `{BUDGET}`) \
             against the relaxation factor `omega` (`omega = 1` is PGS).\n\n{}",
            ctx.table(&table)?
        );
        let path = ctx.plots_dir.join("sor_omega.svg");
        plot(
            &path,
            &PlotSpec {
                title: "SOR: sweeps to 1e-8 against omega".into(),
                x_label: "omega".into(),
                y_label: "sweeps".into(),
                log_x: false,
                log_y: true,
                y_range: None,
                legend: LegendAt::UpperRight,
            },
            &series,
        )?;
        Ok(vec![Figure::new("SOR sweeps against omega", path)])
    }
}
