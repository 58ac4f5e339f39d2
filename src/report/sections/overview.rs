//! The report's opening: the title, how to regenerate it, the header table (date, commit,
//! machine, command, and the sweep: rows, isolation failures, seconds, and the number of
//! worker processes it actually ran on), and how residuals and times are measured. The machine
//! is the one the rows record; rows from several kinds of machine are listed with their counts,
//! and a note says which kind's rows the timing tables use (or, for one kind on several hosts,
//! that their times are compared as one machine's).

use crate::report::context::{Figure, ReportContext, Section};
use crate::report::table::Table;
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct Overview;

/// How times are measured, as the header states it.
const TIMING: &str = "**Timing.** LCP and cone cases: median of repeated solves from the same \
    start after one untimed warm-up solve, until ≥ 20 ms total and ≥ 3 solves (a first solve \
    of ≥ 20 ms counts alone); spread (min, max, count) in the tables' data \
    (`timed_solves`, `solve_time_min_s`, `solve_time_max_s`). A warm start's source and the \
    time to compute it (`warm_source`, `warm_time_s`) are recorded beside the solve time and \
    are not part of it. Scene steps timed in-process per step (solver time per step). Means \
    over several problems are shifted geometric means (shift 10 µs) over every problem of the \
    set, a failure counted at the budget's seconds, or geometric means over the problems every \
    compared solver solved, as each caption says; never a mean over a solver's own successes.";

impl Section for Overview {
    fn title(&self) -> &'static str {
        "lcpbench report"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let _ = writeln!(md, "{}\n", crate::report::README_TITLE);
        if ctx.from_sweep {
            let _ = writeln!(
                md,
                "The report of one `lcpbench bench` sweep; regenerate it with `lcpbench report \
                 --from DIR` on the sweep's directory.\n"
            );
        } else {
            let _ = writeln!(
                md,
                "Regenerate with `cargo run --release -- report` (about 45 minutes on two cores; \
                 `--quick` for a small version); run the tests with `cargo test --workspace`.\n"
            );
        }
        md.push_str(&ctx.table(&header_table(ctx))?);
        if let Some(timing) = ctx.machines.timing() {
            let _ = writeln!(
                md,
                "\n**Timings from {} kinds of machine.** Times measured on different CPU models \
                 or core counts do not compare: every table and figure that shows times uses \
                 only the {} rows of the kind with the most rows, {}; the robustness matrix, \
                 which counts statuses, uses every row.",
                ctx.machines.groups.len(),
                timing.rows,
                timing.describe(),
            );
        } else if let Some(group) = ctx.machines.groups.first().filter(|g| g.hosts.len() > 1) {
            let _ = writeln!(
                md,
                "\n**Timings from {} hosts** of one kind of machine ({}); the tables compare \
                 their times as those of one machine.",
                group.hosts.len(),
                group.describe(),
            );
        }
        let _ = writeln!(
            md,
            "\nEvery run is one child process (a panic, abort or hang is recorded, not fatal). \
             Residuals are the shared relative natural-map residual of the returned impulse, \
             `max_i |f_i − mid(lo_i, hi_i, f_i − w_i/A_ii)| / ((|b_i| + Σ_j |A_ij f_j|) / A_ii)`: \
             each row measured against the magnitudes its own velocity is made of, so no row, bound \
             or scale can hide another row's error (see the README); times are solver wall time \
             with residual measurement excluded. {} Every table below is also in `tables/`, \
             every figure's points next to it in `plots/`.\n\n{TIMING}\n",
            if ctx.from_sweep {
                "Raw rows: the sweep's `results.csv` and `histories.csv`."
            } else {
                "Raw rows: [`data/results.csv`](data/results.csv); convergence histories: \
                 [`data/histories.csv`](data/histories.csv)."
            }
        );
        Ok(Vec::new())
    }
}

fn header_table(ctx: &ReportContext) -> Table {
    let header = ctx.header;
    let failures = ctx.rows.iter().filter(|r| r.is_isolation_failure()).count();
    let mut h = Table::new("header", &["field", "value"]);
    for (k, v) in [
        ("date (UTC)", header.date.clone()),
        ("commit", header.commit.clone()),
        ("machine", machine_cell(ctx)),
        ("command", format!("`{}`", header.command)),
        (
            "runs",
            if ctx.sweep_seconds > 0.0 {
                format!(
                    "{} rows ({} isolation failures: panic, crash, timeout or error), sweep \
                     {:.0} s on {} worker processes",
                    ctx.rows.len(),
                    failures,
                    ctx.sweep_seconds,
                    header.workers
                )
            } else {
                format!(
                    "{} rows ({} isolation failures: panic, crash, timeout or error) of an \
                     earlier sweep; tables and figures rewritten from them without runs",
                    ctx.rows.len(),
                    failures,
                )
            },
        ),
    ] {
        h.rows.push(vec![k.to_owned(), v]);
    }
    h
}

/// Where the runs ran: the rows' kind of machine and hosts, each kind with its row count when
/// there are several, or (rows that record none) the machine writing the report.
fn machine_cell(ctx: &ReportContext) -> String {
    let header = ctx.header;
    match &ctx.machines.groups[..] {
        [one] if one.kind.is_some() => format!("{}, {}", one.describe(), header.os),
        [] | [_] => format!("{}, {} cores, {}", header.cpu, header.cores, header.os),
        several => several
            .iter()
            .map(|g| format!("{}: {} rows", g.describe(), g.rows))
            .collect::<Vec<_>>()
            .join("; "),
    }
}
