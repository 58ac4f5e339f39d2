//! The cone solvers on the FC3D collection (budget [`FC3D_BUDGET`]): the FCLIB files, the
//! exported scene LCPs and steps of the large scenes, each in its exact-cone form. Per solver
//! how many problems it brought to the cone residual 1e-4 and 1e-8 and the geometric mean of
//! those times; per problem its size and each solver's time to 1e-8 (or how it ended); and
//! Dolan–Moré profiles at both levels. Empty when the suite has no FC3D collection.

use super::findings::{relaxation_footnote, solver_cell};
use super::profiles::{performance_profile, profile_plot};
use crate::harness::{BudgetName, Case, RunRecord, RunStatus, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::suite::{cone_solvers, fc3d_budget, FC3D_BUDGET};
use crate::report::summary::{rank, Candidate};
use crate::report::table::{fmt_sci, fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct ConeProfiles;

/// The levels of the profiles and of the per-solver table.
const LEVELS: [(f64, &str); 2] = [(1e-4, "1e-4"), (1e-8, "1e-8")];

impl Section for ConeProfiles {
    fn title(&self) -> &'static str {
        "Cone solvers on the FC3D collection"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let cases: Vec<&Case> = ctx.suite.fc3d_cases.iter().collect();
        if cases.is_empty() {
            return Ok(Vec::new());
        }
        let solvers = cone_solvers();
        let budget = fc3d_budget().name;
        let summary = time_to_accuracy(ctx, &cases, &solvers, &budget);
        let problems = per_problem(ctx, &cases, &solvers, &budget);
        let _ = writeln!(
            md,
            "## Cone solvers on the FC3D collection\n\nThe exact Coulomb cone problems (FC3D) of \
             the collection, each contact's normal and two tangent rows as one cone: the FCLIB \
             files of `bench_scenes/fclib/`, the exported scene LCPs above, and steps 1 and 10 of \
             the large scenes and of the scenes of `bench_scenes/fc3d/` (a 385-box pyramid, 4,960 \
             contacts at rest; built in the run from the scene's own solver and settings; \
             `pyramid_3d_5525` is left out: its Delassus matrix has tens of millions of entries). \
             Every cone solver, cold start, budget `{FC3D_BUDGET}`; times are solver time to the \
             relative cone residual.\n\n\
             **The residual.** lcpbench's cone residual is, per contact `c`, the natural map \
             `e_c = ‖r_c − P_K(r_c − û_c / d_c)‖` (`û` De Saxcé's modified velocity, `d_c` the \
             normal row's diagonal of `W`) divided by the contact's own magnitude \
             `s_c = ‖(t_N + mu_c ‖(t_1, t_2)‖, t_1, t_2)‖ / d_c` with `t_i = |q_i| + Σ_j |W_ij r_j|`, \
             and the largest ratio over the contacts. Siconos' FC3D error (and FCLIB's) is \
             `‖(r_c − P_K(r_c − û_c))_c‖₂ / ‖q‖₂`: the same natural map with `ρ = 1`, summed over \
             all contacts and divided by one global norm. lcpbench's measure is the stricter one on \
             problems with contacts of very different loads (a light contact's error cannot hide \
             behind a heavy one's magnitude); every run also records the absolute \
             `max_c ‖r_c − P_K(r_c − û_c)‖` (`residual_abs` in `data/results.csv`), Siconos' \
             numerator, so the two can be compared.\n\nPer solver, the problems it brought to \
             each level and the shifted geometric mean (shift 10 µs) of its time over every \
             problem of the collection, a problem not reached counted at the budget's seconds \
             (the rule of [Findings](#findings): every mean over the same problems).\n\n{}\n{}\n\
             Per problem (contacts, rows), each solver's time to 1e-8, otherwise its status and \
             the cone residual it ended at:\n\n{}",
            ctx.table(&summary)?,
            relaxation_footnote(&solvers),
            ctx.table(&problems)?
        );
        let mut figures = Vec::new();
        for (level, label) in LEVELS {
            let path = ctx.plots_dir.join(format!("profile_cone_{label}.svg"));
            let series = performance_profile(ctx, &cases, &solvers, &budget, level);
            profile_plot(
                &path,
                format!("Cone solvers: performance profile, cone residual {label}"),
                &series,
            )?;
            figures.push(Figure::new(
                format!("Dolan–Moré performance profile of the cone solvers on the FC3D collection at {label}"),
                path,
            ));
        }
        Ok(figures)
    }
}

fn time_to_accuracy(
    ctx: &ReportContext,
    cases: &[&Case],
    solvers: &[SolverSpec],
    budget: &BudgetName,
) -> Table {
    let mut t = Table::new(
        "cone_time_to_accuracy",
        &[
            "solver",
            "reached 1e-4",
            "shifted geo-mean time to 1e-4",
            "reached 1e-8",
            "shifted geo-mean time to 1e-8",
            "converged",
        ],
    );
    let every: Vec<&RunRecord> = solvers
        .iter()
        .flat_map(|s| cases.iter().filter_map(|c| ctx.get(c, s, budget)))
        .collect();
    let ranked: Vec<Vec<Candidate>> = LEVELS.iter().map(|&(l, _)| rank(&every, l)).collect();
    for s in solvers {
        let runs: Vec<&&RunRecord> = every.iter().filter(|r| r.solver == *s).collect();
        let mut row = vec![solver_cell(s)];
        for level in &ranked {
            match level.iter().find(|c| c.solver == *s) {
                Some(c) => {
                    row.push(format!("{} of {}", c.solved, cases.len()));
                    row.push(fmt_time(Some(c.mean_s)));
                }
                None => row.extend(["–".to_owned(), "–".to_owned()]),
            }
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

/// One row per problem: its name, source, contacts and rows, then each solver's cell.
fn per_problem(
    ctx: &ReportContext,
    cases: &[&Case],
    solvers: &[SolverSpec],
    budget: &BudgetName,
) -> Table {
    let mut header = vec![
        "problem".to_owned(),
        "source".to_owned(),
        "contacts".to_owned(),
        "rows".to_owned(),
    ];
    header.extend(solvers.iter().map(|s| s.to_string()));
    let mut t = Table::with_header("cone_problems", header);
    for case in cases {
        let runs: Vec<Option<&RunRecord>> =
            solvers.iter().map(|s| ctx.get(case, s, budget)).collect();
        let rows = runs.iter().flatten().find_map(|r| r.n);
        let mut row = vec![
            case.short_name(),
            source(case).to_owned(),
            rows.map_or("–".to_owned(), |n| (n / 3).to_string()),
            rows.map_or("–".to_owned(), |n| n.to_string()),
        ];
        row.extend(runs.into_iter().map(cell));
        t.rows.push(row);
    }
    t
}

fn source(case: &Case) -> &'static str {
    match case {
        Case::File(p) if p.extension().is_some_and(|e| e == "hdf5") => "FCLIB",
        Case::File(_) => "exported step",
        Case::SceneStep { .. } => "large-scene step",
        _ => "other",
    }
}

fn cell(r: Option<&RunRecord>) -> String {
    match r {
        None => "–".to_owned(),
        Some(r) if r.status == RunStatus::Unsupported => r.status.to_string(),
        Some(r) => match r.tta(1e-8) {
            Some(t) => fmt_time(Some(t)),
            None => format!("{} ({})", r.status, fmt_sci(r.residual_rel)),
        },
    }
}
