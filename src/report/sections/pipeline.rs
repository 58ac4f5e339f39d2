//! Where a step's time goes on the large scenes: the phase times of one engine-like run per
//! scene (`pgs+warm` under budget `realtime`: 20 warm-started sweeps, as real-time engines run),
//! in milliseconds per step and per 1,000 contacts, beside reference figures of engines, and
//! as stacked bars.

use crate::harness::{BudgetName, RunRecord, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::plots::stacked_bars;
use crate::report::table::Table;
use anyhow::Result;
use lcpbench_solvers::SolverKind;
use std::fmt::Write as _;

pub(super) struct Pipeline;

/// The solver of the run whose phases a large scene's row shows: warm-started PGS.
const PIPELINE_SOLVER: SolverSpec = SolverSpec::plain(SolverKind::Pgs).with_warm();

/// The budget of that run: `realtime`, 20 sweeps per step.
const PIPELINE_BUDGET: BudgetName = BudgetName::Realtime;

/// The phases, with the accessor of their mean per step in a row.
type Phase = (&'static str, fn(&RunRecord) -> Option<f64>);

const PHASES: [Phase; 6] = [
    ("collision", |r| r.phase_collision_s),
    ("assembly", |r| r.phase_assembly_s),
    ("islands", |r| r.phase_islands_s),
    ("solve", |r| r.phase_solve_s),
    ("residual", |r| r.phase_residual_s),
    ("integration", |r| r.phase_integration_s),
];

fn ms(v: Option<f64>) -> String {
    v.map_or("–".into(), |s| format!("{:.2}", 1e3 * s))
}

impl Section for Pipeline {
    fn title(&self) -> &'static str {
        "Pipeline"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let (solver, budget) = (&PIPELINE_SOLVER, &PIPELINE_BUDGET);
        let runs: Vec<(String, &RunRecord)> = ctx
            .suite
            .large_scene_cases
            .iter()
            .filter_map(|c| Some((c.short_name(), ctx.get(c, solver, budget)?)))
            .filter(|(_, r)| r.phase_solve_s.is_some())
            .collect();
        if runs.is_empty() {
            return Ok(Vec::new());
        }
        let mut header: Vec<String> = vec!["scene".into(), "contacts".into(), "step".into()];
        header.extend(PHASES.iter().map(|(name, _)| name.to_string()));
        header.extend(["broad phase".into(), "narrow phase".into()]);
        header.push("step per 1,000 contacts".into());
        let mut table = Table::with_header("pipeline", header);
        for (name, r) in &runs {
            let mut row = vec![
                name.clone(),
                r.contacts_mean.map_or("–".into(), |c| format!("{c:.0}")),
                ms(r.step_time_s),
            ];
            row.extend(PHASES.iter().map(|(_, get)| ms(get(r))));
            row.push(ms(r.phase_broad_s));
            row.push(ms(r.phase_narrow_s));
            row.push(
                match (r.step_time_s, r.contacts_mean) {
                    (Some(t), Some(c)) if c > 0.0 => Some(t * 1e3 / c),
                    _ => None,
                }
                .map_or("–".into(), |v| ms(Some(v))),
            );
            table.rows.push(row);
        }
        let _ = writeln!(
            md,
            "## Pipeline\n\nWhere a step's wall time goes on the large scenes, in ms per step \
             (mean over the steps of the `{solver}` run under budget `{budget}`: 20 warm-started \
             sweeps per step, as real-time engines run): collision detection (broad and narrow \
             phase), assembly of `J`, `b`, the bounds and the solver's `A`, the island \
             partition, the solver calls, residual measurement and the step's figures, and \
             integration; the phases add up to the step. For comparison, engines' reported \
             figures for whole steps: Box3D steps a 5,050-box 3-D pyramid in 9.6 ms, Box2D v3 \
             its 5,050-box `large_pyramid` in 3.9 ms, and Rapier 0.36 (4 iterations) the 40-box \
             tower at 60 Hz in 0.17–0.22 ms on a two-core machine of this report's kind.\n\n{}",
            ctx.table(&table)?
        );
        let categories: Vec<String> = runs.iter().map(|(name, _)| name.clone()).collect();
        let parts: Vec<(String, Vec<f64>)> = PHASES
            .iter()
            .map(|(name, get)| {
                let values = runs
                    .iter()
                    .map(|(_, r)| get(r).map_or(0.0, |s| 1e3 * s))
                    .collect();
                (name.to_string(), values)
            })
            .collect();
        let path = ctx.plots_dir.join("pipeline_phases.svg");
        stacked_bars(
            &path,
            &format!("Phases of a step ({solver}, budget {budget})"),
            "wall time per step (ms)",
            &categories,
            &parts,
        )?;
        Ok(vec![Figure::new(
            "Where a step's time goes on the large scenes",
            path,
        )])
    }
}
