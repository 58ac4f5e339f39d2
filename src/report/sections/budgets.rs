//! The budget presets: tolerance, iteration cap and time budget of each.

use crate::harness::Budget;
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::table::Table;
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct Budgets;

impl Section for Budgets {
    fn title(&self) -> &'static str {
        "Budgets"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let mut b = Table::new(
            "budgets",
            &["budget", "tolerance", "iteration cap", "time budget (s)"],
        );
        for (name, bud) in Budget::PRESETS.iter() {
            b.rows.push(vec![
                name.to_string(),
                format!("{:.0e}", bud.tolerance),
                bud.max_iterations.to_string(),
                format!("{}", bud.time_s),
            ]);
        }
        let _ = writeln!(md, "## Budgets\n\n{}", ctx.table(&b)?);
        Ok(Vec::new())
    }
}
