//! Report section: the averaged-impulse baseline on its failure cases.
//!
//! `avg` applies one impulse per body pair at the averaged contact point along the averaged
//! normal: exact for a convex contact region with one normal, wrong where the region is not
//! convex or the normals differ. The two scenes built to show it (`avg_two_supports`: a plank on
//! two separated supports under an off-centre load; `avg_nonconvex`: a ball in the notch of an
//! L-shaped mesh) must not move; the table gives, for `avg` next to micro-impulses, sequential
//! impulses and the LCP (Lemke), the first body's displacement, the deepest penetration and the
//! median relative residual of the step's LCP, under budget `default`. Table
//! `tables/averaged_impulse.csv`; empty when the suite has neither scene.

use crate::harness::{BudgetName, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::table::{fmt_sci, fmt_time, Table};
use anyhow::Result;
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_solvers::SolverKind;
use std::fmt::Write as _;

pub(super) struct AveragedImpulse;

/// The scenes of the section (file stems).
const SCENES: [&str; 2] = ["avg_two_supports", "avg_nonconvex"];

impl Section for AveragedImpulse {
    fn title(&self) -> &'static str {
        "Averaged impulses"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let cases: Vec<_> = ctx
            .suite
            .scene_cases
            .iter()
            .filter(|c| SCENES.contains(&c.short_name().as_str()))
            .collect();
        if cases.is_empty() {
            return Ok(Vec::new());
        }
        let solvers = [
            SolverSpec::body(BodySolverKind::AveragedImpulse),
            SolverSpec::body(BodySolverKind::MicroImpulses),
            SolverSpec::body(BodySolverKind::SequentialImpulses),
            SolverSpec::plain(SolverKind::Lemke),
        ];
        let mut t = Table::new(
            "averaged_impulse",
            &[
                "scene",
                "solver",
                "displacement (m)",
                "penetration max (m)",
                "residual (median)",
                "time/step",
                "status",
            ],
        );
        for case in &cases {
            for solver in &solvers {
                let Some(r) = ctx.get(case, solver, &BudgetName::Default) else {
                    continue;
                };
                t.rows.push(vec![
                    case.short_name(),
                    solver.to_string(),
                    fmt_sci(r.analytic_error),
                    fmt_sci(r.penetration_max),
                    fmt_sci(r.residual_rel_median),
                    fmt_time(r.time_per_step_s),
                    r.status.to_string(),
                ]);
            }
        }
        let _ = writeln!(
            md,
            "## Averaged impulses\n\nThe averaged-impulse baseline (`avg`) applies one impulse per \
             body pair, at the mean of the pair's contact points along the mean of their \
             normals: exact for a convex contact region with one normal. `avg_two_supports` \
             rests a plank on two separated supports under an off-centre load (the mean point \
             of each support's contacts carries the load the LCP spreads over the face, and the \
             plank tilts and sinks); `avg_nonconvex` rests a ball in the right-angled notch of \
             an L-shaped mesh (one pair, two normals 90° apart: the mean normal pushes the ball \
             into one face). Both must not move. Displacement: the first dynamic body's, over \
             the run; residual: the median over steps of the relative residual of the step's \
             LCP. Budget `default`.\n\n{}",
            ctx.table(&t)?
        );
        Ok(Vec::new())
    }
}
