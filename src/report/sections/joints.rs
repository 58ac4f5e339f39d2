//! Report section: joints.
//!
//! The scenes of `joints/` (the suite's `joint_cases`): 20-link chains with end masses 1, 1e3
//! and 1e6 times a link, a plank bridge under a load, a ragdoll on a box pile and a pendulum
//! cradle. Their joints are equality rows of the step's mixed LCP, so they show how each solver
//! holds a path of bilateral constraints with a mass ratio along it. For the chains, one table
//! of solver × budget × end mass (joint drift, the end mass's sag, solver time per step) and the
//! two targets: the 1e3 chain held below 1 mm of drift at no more than 1 ms per step, and the
//! 1e6 chain held below 1 cm (or every solver's failure). For the other scenes, one table each
//! (drift, sag, energy change, time per step, outcome). Tables `tables/joints_chains.csv` and
//! `tables/joints_<scene>.csv`; empty when the suite has no joint scenes.

use crate::harness::{Case, NamedBudget, RunRecord, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::status;
use crate::report::table::{fmt_sci, fmt_time, Table};
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct Joints;

/// Drift the 1e3 chain must stay below, m, and the time per step it must take at most, s.
const CHAIN_1E3_TARGET: (f64, f64) = (1e-3, 1e-3);
/// Drift the 1e6 chain must stay below, m.
const CHAIN_1E6_TARGET: f64 = 1e-2;

impl Section for Joints {
    fn title(&self) -> &'static str {
        "Joints"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let suite = ctx.suite;
        if suite.joint_cases.is_empty() {
            return Ok(Vec::new());
        }
        let _ = writeln!(
            md,
            "## Joints\n\nScenes with ball, hinge, fixed and distance joints, whose rows are \
             equality rows (bounds (−∞, ∞)) of the step's mixed LCP next to the contacts \
             (`docs/scenes.md`, `[[joints]]`). Every scene solver runs them, cold and the \
             iterative ones warm-started, under the scene budgets, and the warm-started \
             iterative solvers also at 10, 20 and 50 iterations per step (tolerance 1e-6). \
             Drift: the largest joint error over the run (the anchors' separation, or a rod's \
             length error), m. Sag: the largest drop of the scene's `sag_body` (a chain's end \
             mass, the bridge's load) below its starting height, m. Time: solver time per \
             step. `body-micro`, `avg` and `penalty` resolve contacts only and are \
             `unsupported` on these scenes; the cone solvers have no place for joint rows.\n"
        );
        let (chains, others): (Vec<&Case>, Vec<&Case>) = suite
            .joint_cases
            .iter()
            .partition(|c| c.short_name().starts_with("chain_"));
        if !chains.is_empty() {
            chain_section(ctx, &chains, md)?;
        }
        for case in others {
            let name = case.short_name();
            let t = scene_table(ctx, case, &name);
            let _ = writeln!(md, "### {name}\n\n{}", ctx.table(&t)?);
        }
        Ok(Vec::new())
    }
}

/// The (solver, budget) pairs the suite ran on the joint scenes, in suite order: every solver
/// under the scene budgets, the warm-started iterative ones under the iteration budgets too.
fn runs(ctx: &ReportContext, case: &Case) -> Vec<(SolverSpec, NamedBudget)> {
    let mut out = Vec::new();
    for solver in &ctx.suite.joint_solvers {
        for b in &ctx.suite.joint_budgets {
            if ctx.get(case, solver, &b.name).is_some() {
                out.push((solver.clone(), b.clone()));
            }
        }
    }
    out
}

/// Outcome of a run in a few words: `converged`, `k of n steps short`, or the status.
fn outcome(r: &RunRecord) -> String {
    // Short of the measured steps (every step unless a residual schedule left some out).
    match (r.nonconverged_steps, r.measured_steps()) {
        _ if status::unsupported(r) => "unsupported".into(),
        _ if status::blew_up(r) => "blow-up".into(),
        (Some(nc), Some(steps)) if status::cut_short(r) => {
            format!("{nc} of {steps} short, cut short")
        }
        (Some(0), Some(_)) => "converged".into(),
        (Some(nc), Some(steps)) => format!("{nc} of {steps} short"),
        _ => r.status.to_string(),
    }
}

/// The chain table and the two targets.
fn chain_section(ctx: &ReportContext, chains: &[&Case], md: &mut String) -> Result<()> {
    let mut header = vec!["solver".to_owned(), "budget".to_owned()];
    for c in chains {
        let n = c.short_name();
        header.extend([
            format!("{n} drift (m)"),
            format!("{n} sag (m)"),
            format!("{n} time/step"),
        ]);
    }
    let mut t = Table::with_header("joints_chains", header);
    for (solver, budget) in runs(ctx, chains[0]) {
        let mut row = vec![solver.to_string(), budget.name.to_string()];
        for c in chains {
            match ctx.get(c, &solver, &budget.name) {
                Some(r) if status::unsupported(r) => {
                    row.extend(["unsupported".into(), "–".into(), "–".into()])
                }
                Some(r) => row.extend([
                    fmt_sci(r.joint_drift_max),
                    fmt_sci(r.sag_body),
                    fmt_time(r.time_per_step_s),
                ]),
                None => row.extend(std::iter::repeat_n("–".to_owned(), 3)),
            }
        }
        t.rows.push(row);
    }
    let _ = writeln!(
        md,
        "### Hanging chains\n\nA 20-link chain of 1 kg links hanging at rest from a fixed point, \
         with an end mass of 1, 1e3 and 1e6 kg, stepped at 60 Hz for 2 s (Baumgarte 0.2). At \
         rest every joint holds the weight below it; an exact solve keeps every drift at \
         round-off.\n\n{}",
        ctx.table(&t)?
    );
    for c in chains {
        let name = c.short_name();
        if name.ends_with("_1e3") {
            let (drift, time) = CHAIN_1E3_TARGET;
            let held: Vec<String> = runs(ctx, c)
                .into_iter()
                .filter_map(|(s, b)| {
                    let r = ctx.get(c, &s, &b.name)?;
                    let ok = !status::unsupported(r)
                        && r.joint_drift_max? < drift
                        && r.time_per_step_s? <= time;
                    ok.then(|| format!("{s} ({})", b.name))
                })
                .collect();
            let _ = writeln!(
                md,
                "**{name}: drift below 1 mm at ≤ 1 ms of solver time per step**: {}.\n",
                if held.is_empty() {
                    "no solver".to_owned()
                } else {
                    held.join(", ")
                }
            );
        }
        if name.ends_with("_1e6") {
            let mut held = Vec::new();
            let mut failed = Vec::new();
            for (s, b) in runs(ctx, c) {
                let Some(r) = ctx.get(c, &s, &b.name) else {
                    continue;
                };
                if status::unsupported(r) {
                    continue;
                }
                match r.joint_drift_max {
                    Some(d) if d < CHAIN_1E6_TARGET => {
                        held.push(format!("{s} ({}, {})", b.name, fmt_time(r.time_per_step_s)))
                    }
                    d => failed.push(format!(
                        "{s} ({}: drift {}, {})",
                        b.name,
                        fmt_sci(d),
                        outcome(r)
                    )),
                }
            }
            let _ = writeln!(
                md,
                "**{name}: drift below 1 cm**: held by {}. Not held: {}.\n",
                if held.is_empty() {
                    "no solver".to_owned()
                } else {
                    held.join(", ")
                },
                if failed.is_empty() {
                    "none".to_owned()
                } else {
                    failed.join("; ")
                }
            );
        }
    }
    Ok(())
}

/// One table per other joint scene: drift (max, mean), sag, energy change, time, outcome.
fn scene_table(ctx: &ReportContext, case: &Case, name: &str) -> Table {
    let header = [
        "solver",
        "budget",
        "drift max (m)",
        "drift mean (m)",
        "sag (m)",
        "energy drift",
        "penetration max (m)",
        "time/step",
        "outcome",
    ];
    let mut t = Table::new(format!("joints_{name}"), &header);
    for (solver, budget) in runs(ctx, case) {
        let Some(r) = ctx.get(case, &solver, &budget.name) else {
            continue;
        };
        t.rows.push(vec![
            solver.to_string(),
            budget.name.to_string(),
            fmt_sci(r.joint_drift_max),
            fmt_sci(r.joint_drift_mean),
            fmt_sci(r.sag_body),
            fmt_sci(r.energy_drift),
            fmt_sci(r.penetration_max),
            fmt_time(r.time_per_step_s),
            outcome(r),
        ]);
    }
    t
}
