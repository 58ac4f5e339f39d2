//! Report section: time of impact.
//!
//! The scenes of `impact/` (the suite's `impact_cases`) under each stepping mode: fixed steps at
//! 60, 240 and 1,000 Hz, fixed 60 Hz steps cut at the first time of impact (bisection,
//! conservative advancement), and Timewarp with 60 Hz frames. One table of accuracy (impact-time
//! error, energy error at impacts, penetration, tunnelling) against cost (queries, rolled-back
//! body-steps, wall time) per run, and one of the cost per impact of the bouncing-ball family
//! as the number of balls grows, with its plot. Read from `data/impact.csv`
//! ([`crate::harness::impact`]); tables `tables/time_of_impact.csv` and
//! `tables/time_of_impact_scaling.csv`; empty when the suite has no impact runs.

use crate::harness::impact::{read_rows, ImpactMode, ImpactRow};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::plots::{plot, LegendAt, Mark, PlotSpec, Series};
use crate::report::table::{fmt_sci, fmt_time, Table};
use crate::report::IMPACT_TABLE;
use anyhow::Result;
use std::fmt::Write as _;

pub(super) struct TimeOfImpact;

impl Section for TimeOfImpact {
    fn title(&self) -> &'static str {
        "Time of impact"
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        if ctx.suite.impact_cases.is_empty() {
            return Ok(Vec::new());
        }
        let data = ctx
            .tables_dir
            .parent()
            .map(|d| d.join("data").join(IMPACT_TABLE));
        let rows = match data.filter(|p| p.exists()) {
            Some(p) => read_rows(&p)?,
            None => Vec::new(),
        };
        let _ = writeln!(
            md,
            "## Time of impact\n\nLocating the instant of a collision. The scenes of \
             `bench_scenes/impact/` run 2 s (the fast sphere 0.1 s, the cradle 0.5 s, the \
             dominoes 3 s) under each stepping mode: fixed steps at 60, 240 and 1,000 Hz \
             with speculative contacts; 60 Hz steps whose motion is cut at the first time of \
             impact of the step (`ccd = \"bisection\"`, `\"conservative\"`); and Timewarp \
             (`stepping = \"timewarp\"`, docs/scenes.md), 60 Hz frames between which free \
             bodies advance from impact to impact on their own clocks and roll back when an \
             impact reaches them late. Budget: Timewarp and the 60 Hz step run every scene; \
             240 Hz and the backtracking steps up to 1,000 balls; 1 kHz up to 100 balls (the \
             quick suite stops at 100). Impact-time error: each ball's k-th impact against \
             the k-th analytic one (from its drop height, g, e = 0.9 and the restitution \
             threshold; a fixed step's impact is the start of the step that reverses the \
             ball); `missed` counts analytic impacts without a counterpart. Energy error: \
             the ball's energy after its k-th impact against e^2k of its start, relative. \
             Tunnelling: body-steps in which a centre crossed another body. Queries: \
             narrow-phase pairs plus time-of-impact pair searches (for the fixed-step modes \
             the broad phase's pairs at each step's start). Wall time is the steps' own, on \
             a shared machine.\n"
        );
        if rows.is_empty() {
            let _ = writeln!(
                md,
                "No time-of-impact runs were recorded (`data/{IMPACT_TABLE}`).\n"
            );
            return Ok(Vec::new());
        }
        let t = accuracy_table(&rows);
        let _ = writeln!(md, "{}", ctx.table(&t)?);
        let (t, series) = scaling(&rows);
        let _ = writeln!(
            md,
            "### Cost per impact against the number of balls\n\nThe `bouncing_N` scenes: \
             queries per analytic impact (and wall time per impact) for each mode that ran \
             them. Timewarp's work per impact is a few distance queries against the ground, \
             whatever N; a fixed step's is every pair near contact at every step.\n\n{}",
            ctx.table(&t)?
        );
        if series.iter().all(|s| s.points.is_empty()) {
            return Ok(Vec::new());
        }
        let path = ctx.plots_dir.join("time_of_impact_cost.svg");
        plot(
            &path,
            &PlotSpec {
                title: "Queries per impact against the number of balls".into(),
                x_label: "balls".into(),
                y_label: "queries per impact".into(),
                log_x: true,
                log_y: true,
                y_range: None,
                legend: LegendAt::UpperRight,
            },
            &series,
        )?;
        Ok(vec![Figure::new(
            "Time of impact: queries per impact against the number of bouncing balls",
            path,
        )])
    }
}

/// Accuracy against cost, one row per run.
fn accuracy_table(rows: &[ImpactRow]) -> Table {
    let mut t = Table::new(
        "time_of_impact",
        &[
            "scene",
            "mode",
            "impacts (analytic / found / missed)",
            "time error max (s)",
            "energy error max",
            "penetration (m)",
            "tunnelling",
            "queries",
            "rolled back",
            "wall time",
            "outcome",
        ],
    );
    for r in rows {
        let impacts = if r.analytic_impacts > 0 {
            format!(
                "{} / {} / {}",
                r.analytic_impacts, r.detected_impacts, r.missed_impacts
            )
        } else {
            r.recorded_impacts
                .map_or("–".into(), |n| format!("{n} resolved"))
        };
        let outcome = match (&r.error, r.nonconverged_steps) {
            (Some(e), _) => e.clone(),
            (None, 0) => "converged".into(),
            (None, k) => format!("{k} of {} steps short", r.steps),
        };
        t.rows.push(vec![
            r.scene.clone(),
            r.mode.clone(),
            impacts,
            fmt_sci(r.impact_time_error_max),
            fmt_sci(r.energy_error_max),
            fmt_sci(Some(r.max_penetration)),
            r.tunnelling.to_string(),
            (r.collision_queries + r.toi_queries).to_string(),
            r.rolled_back_steps.to_string(),
            fmt_time(Some(r.wall_time_s)),
            outcome,
        ]);
    }
    t
}

/// The ball count of a `bouncing_N` row.
fn balls(r: &ImpactRow) -> Option<usize> {
    r.scene.strip_prefix("bouncing_")?.parse().ok()
}

/// Cost per impact by mode (rows) and ball count (columns), and the plot's series.
fn scaling(rows: &[ImpactRow]) -> (Table, Vec<Series>) {
    let mut ns: Vec<usize> = rows.iter().filter_map(balls).collect();
    ns.sort_unstable();
    ns.dedup();
    let mut header = vec!["mode".to_owned()];
    for n in &ns {
        header.push(format!("N = {n}: queries / impact"));
        header.push(format!("N = {n}: time / impact"));
    }
    let mut t = Table::with_header("time_of_impact_scaling", header);
    let mut series = Vec::new();
    for mode in ImpactMode::ALL {
        let name = mode.name();
        let mut row = vec![name.clone()];
        let mut points = Vec::new();
        for &n in &ns {
            match rows.iter().find(|r| r.mode == name && balls(r) == Some(n)) {
                Some(r) => {
                    row.push(fmt_sci(r.queries_per_impact));
                    row.push(fmt_time(r.wall_time_per_impact_s));
                    if let Some(q) = r.queries_per_impact.filter(|q| *q > 0.0) {
                        points.push((n as f64, q));
                    }
                }
                None => row.extend(["–".to_owned(), "–".to_owned()]),
            }
        }
        t.rows.push(row);
        series.push(Series {
            name: name.clone(),
            color_key: name,
            points,
            mark: Mark::LinePoints,
        });
    }
    (t, series)
}
