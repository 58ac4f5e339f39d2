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
            &[
                "budget",
                "tolerance",
                "iteration cap (per solve or step)",
                "time budget (s, per solve or step)",
            ],
        );
        for (name, bud) in Budget::PRESETS.iter() {
            b.rows.push(vec![
                name.to_string(),
                format!("{:.0e}", bud.tolerance),
                bud.max_iterations.to_string(),
                format!("{}", bud.time_s),
            ]);
        }
        let _ = writeln!(
            md,
            "## Budgets\n\nA budget's iteration cap and seconds bound each solve of an LCP case and \
             each step's solve of a scene (a step that runs out of time ends `time_limit` with the \
             solver's best point, and the run goes on; a scene run stops at twice its steps times \
             the seconds, or after three consecutive steps over them). Budgets written \
             `TOL:ITER:SECONDS` are custom ones.\n\n{}",
            ctx.table(&b)?
        );
        Ok(Vec::new())
    }
}
