//! What every section reads and the interface each implements.
//!
//! [`ReportContext`] holds the suite, the header, the result rows indexed once by run key
//! (case, solver, budget) (those of one kind of machine for the tables that show times, when
//! the rows come from several: see [`Machines`]), the convergence histories and the output directories; a
//! [`Section`] renders its Markdown into the README, writes its tables and figures, and
//! returns the figures for the gallery at the end.

use super::machine::Header;
use super::machines::Machines;
use super::suite::{scene_solvers, Suite};
use super::table::Table;
use crate::harness::{BudgetName, Case, HistoryRow, ProblemClass, RunKey, RunRecord, SolverSpec};
use anyhow::Result;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// One part of the report: a heading (or none), text, tables and figures.
pub(super) trait Section: Sync {
    /// What the section is about (its heading, or a short description when it has none).
    fn title(&self) -> &'static str;

    /// Append the section's Markdown to `md` (nothing when the suite has no runs for it),
    /// write its tables under `ctx.tables_dir` and figures under `ctx.plots_dir`, and return
    /// the figures in the order they are shown.
    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>>;
}

/// A figure of the gallery: its caption and SVG (with the CSV of its points next to it).
pub(super) struct Figure {
    pub(super) caption: String,
    pub(super) path: PathBuf,
}

impl Figure {
    pub(super) fn new(caption: impl Into<String>, path: PathBuf) -> Self {
        Self {
            caption: caption.into(),
            path,
        }
    }
}

/// The data of one report.
pub(super) struct ReportContext<'a> {
    pub(super) suite: &'a Suite,
    pub(super) header: &'a Header,
    /// Seconds the sweep took (0 when the report is redrawn from existing data).
    pub(super) sweep_seconds: f64,
    /// Every result row.
    pub(super) rows: &'a [RunRecord],
    /// Every convergence-history row.
    pub(super) histories: &'a [HistoryRow],
    /// The generated problems of the matrix and the exported scene LCPs.
    pub(super) lcp_cases: Vec<&'a Case>,
    /// The same without the infeasible class.
    pub(super) feasible_cases: Vec<&'a Case>,
    pub(super) tables_dir: PathBuf,
    pub(super) plots_dir: PathBuf,
    /// The machines the rows ran on, and which kind's rows the timing tables use.
    pub(super) machines: Machines,
    /// True for a report of a sweep of the user's (`report --from`): its sections are those
    /// that apply to whatever the rows hold, and Findings links to the per-case tables.
    pub(super) from_sweep: bool,
    /// The rows the timing tables use (every row when they come from one kind of machine).
    by_key: HashMap<RunKey, &'a RunRecord>,
    /// Every row.
    all_by_key: HashMap<RunKey, &'a RunRecord>,
}

impl<'a> ReportContext<'a> {
    pub(super) fn new(
        suite: &'a Suite,
        header: &'a Header,
        sweep_seconds: f64,
        rows: &'a [RunRecord],
        histories: &'a [HistoryRow],
        out_dir: &Path,
    ) -> Self {
        let lcp_cases: Vec<&Case> = suite
            .matrix_cases
            .iter()
            .chain(&suite.exported_cases)
            .collect();
        let feasible_cases = lcp_cases
            .iter()
            .copied()
            .filter(|c| c.class() != ProblemClass::Infeasible)
            .collect();
        let machines = Machines::of(rows);
        Self {
            suite,
            header,
            sweep_seconds,
            rows,
            histories,
            lcp_cases,
            feasible_cases,
            tables_dir: out_dir.join("tables"),
            plots_dir: out_dir.join("plots"),
            by_key: rows
                .iter()
                .filter(|r| machines.timed(r))
                .map(|r| (r.key(), r))
                .collect(),
            all_by_key: rows.iter().map(|r| (r.key(), r)).collect(),
            machines,
            from_sweep: false,
        }
    }

    /// The rows the timing tables use, in the order of the results table.
    pub(super) fn timed_rows(&self) -> Vec<&'a RunRecord> {
        self.rows
            .iter()
            .filter(|r| self.machines.timed(r))
            .collect()
    }

    /// The run of `case` by `solver` under `budget`, if there is one among the rows the timing
    /// tables use (see [`Machines`]).
    pub(super) fn get(
        &self,
        case: &Case,
        solver: &SolverSpec,
        budget: &BudgetName,
    ) -> Option<&'a RunRecord> {
        self.by_key.get(&RunKey::of(case, solver, budget)).copied()
    }

    /// The run of `case` by `solver` under `budget` on whichever machine ran it, for tables
    /// that show no times.
    pub(super) fn get_any_machine(
        &self,
        case: &Case,
        solver: &SolverSpec,
        budget: &BudgetName,
    ) -> Option<&'a RunRecord> {
        self.all_by_key
            .get(&RunKey::of(case, solver, budget))
            .copied()
    }

    /// The runs of `case` under `budget`, one per solver of `solvers` that has one, in that
    /// order.
    pub(super) fn runs_of(
        &self,
        case: &Case,
        solvers: &[SolverSpec],
        budget: &BudgetName,
    ) -> Vec<&'a RunRecord> {
        solvers
            .iter()
            .filter_map(|s| self.get(case, s, budget))
            .collect()
    }

    /// Write the table's CSV under `tables/` and return its Markdown.
    pub(super) fn table(&self, table: &Table) -> Result<String> {
        table.write_csv(&self.tables_dir)?;
        Ok(table.markdown())
    }
}

/// Every scene solver (matrix, then body-level), each cold then warm-started; the warm form of
/// a solver that does not iterate names no run.
pub(super) fn scene_solvers_cold_and_warm() -> Vec<SolverSpec> {
    scene_solvers()
        .into_iter()
        .flat_map(|s| [s.clone(), s.with_warm()])
        .collect()
}
