//! The report's sections, in the order the README shows them, and the driver that renders them.
//!
//! Each module is one [`Section`]: it writes its Markdown, its tables (`tables/*.csv`) and
//! figures (`plots/*.svg` with their points in `plots/*.csv`). A new table is a new module and
//! one line in [`SECTIONS`]. After the sections comes the gallery of every figure they
//! returned, in their order.

mod averaged_impulse;
mod budgets;
mod cone_profiles;
mod convergence;
mod engine_scaling;
mod engine_solvers;
mod fastest;
mod fclib;
mod findings;
mod friction;
mod joints;
mod large_scenes;
mod overview;
mod per_case;
mod pipeline;
mod profiles;
mod robustness;
mod scaling;
mod scenes;
mod sor_omega;
mod time_of_impact;
mod time_to_accuracy;
mod towers;
mod warm_start;

use super::context::{Figure, ReportContext, Section};
use super::machine::Header;
use super::machines::Machines;
use super::rel;
use super::suite::Suite;
use crate::harness::sweep::{read_histories, read_results};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The sections of the README, in order.
const SECTIONS: &[&dyn Section] = &[
    &overview::Overview,
    &findings::Findings,
    &budgets::Budgets,
    &scenes::Scenes,
    &large_scenes::LargeScenes,
    &pipeline::Pipeline,
    &towers::Towers,
    &joints::Joints,
    &engine_solvers::EngineSolvers,
    &time_of_impact::TimeOfImpact,
    &averaged_impulse::AveragedImpulse,
    &friction::FrictionModels,
    &robustness::Robustness,
    &fastest::Fastest,
    &time_to_accuracy::TimeToAccuracy,
    &profiles::Profiles,
    &cone_profiles::ConeProfiles,
    &convergence::Convergence,
    &warm_start::WarmStart,
    &sor_omega::SorOmega,
    &scaling::Scaling,
    &engine_scaling::EngineScaling,
    &fclib::Fclib,
];

/// The sections of a report of any sweep (`report --from`): the header, Findings, and the
/// results per case with their figures and profiles.
const FROM_SECTIONS: &[&dyn Section] =
    &[&overview::Overview, &findings::Findings, &per_case::PerCase];

/// Write README.md, tables/ and plots/ from `out_dir/data`. Returns the README path.
pub fn write_report(
    out_dir: &Path,
    suite: &Suite,
    header: &Header,
    sweep_seconds: f64,
) -> Result<PathBuf> {
    render(
        &out_dir.join("data"),
        out_dir,
        suite,
        header,
        sweep_seconds,
        false,
    )
}

/// Write the report of a sweep `bench` wrote into `from` (its `results.csv`, and
/// `histories.csv` when there is one) into `out_dir`: Findings, the results per case, their
/// figures and profiles, about the cases of those rows and no others. Returns the README path.
pub fn write_report_from(from: &Path, out_dir: &Path, header: &Header) -> Result<PathBuf> {
    render(from, out_dir, &Suite::default(), header, 0.0, true)
}

fn render(
    data_dir: &Path,
    out_dir: &Path,
    suite: &Suite,
    header: &Header,
    sweep_seconds: f64,
    from_sweep: bool,
) -> Result<PathBuf> {
    let results = data_dir.join("results.csv");
    let rows = read_results(&results).with_context(|| format!("reading {}", results.display()))?;
    let hist_path = data_dir.join("histories.csv");
    let histories = if hist_path.exists() {
        read_histories(&hist_path)?
    } else {
        Vec::new()
    };
    // Histories plot residuals against time: only those of the runs the timing tables use.
    let histories = Machines::of(&rows).timed_histories(&rows, histories);
    let mut ctx = ReportContext::new(suite, header, sweep_seconds, &rows, &histories, out_dir);
    ctx.from_sweep = from_sweep;
    std::fs::create_dir_all(&ctx.tables_dir)?;
    std::fs::create_dir_all(&ctx.plots_dir)?;
    let mut md = String::new();
    let mut figures = Vec::new();
    let sections = if from_sweep { FROM_SECTIONS } else { SECTIONS };
    for section in sections {
        let shown = section
            .render(&ctx, &mut md)
            .with_context(|| format!("report section `{}`", section.title()))?;
        figures.extend(shown);
    }
    gallery(&mut md, &figures, out_dir);
    let readme = out_dir.join("README.md");
    std::fs::write(&readme, md)?;
    Ok(readme)
}

/// The closing section: every figure with its caption and a link to its data.
fn gallery(md: &mut String, figures: &[Figure], out_dir: &Path) {
    let _ = writeln!(md, "## Figures\n");
    for Figure { caption, path } in figures {
        let r = rel(path, out_dir);
        let _ = writeln!(
            md,
            "**{caption}** ([data]({}))\n\n![{caption}]({r})\n",
            rel(&path.with_extension("csv"), out_dir)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::{write_report, SECTIONS};
    use crate::harness::{BudgetName, Case, CaseFamily, ProblemClass, RunRecord, SolverSpec};
    use crate::report::machine::Header;
    use crate::report::suite::Suite;
    use crate::report::write_results_for_tests;
    use lcpbench_solvers::SolverKind;

    #[test]
    fn section_titles_are_distinct() {
        let mut titles: Vec<&str> = SECTIONS.iter().map(|s| s.title()).collect();
        titles.sort();
        titles.dedup();
        assert_eq!(titles.len(), SECTIONS.len());
    }

    fn record(case: &Case, solver: SolverSpec, status: &str, converged: bool) -> RunRecord {
        RunRecord {
            case: case.to_string(),
            class: case.class(),
            solver_base: solver.base_name(),
            solver,
            budget: BudgetName::Default,
            status: status.parse().expect("a run status"),
            converged,
            iterations: Some(3),
            solve_time_s: Some(1e-4),
            n: Some(8),
            ..RunRecord::default()
        }
    }

    /// A README from two hand-made rows: the sections in their order, the scene sections left
    /// out (no scenes), the robustness cells counting what the rows say, the figures in the
    /// order their sections come.
    #[test]
    fn the_report_is_its_sections_in_order_then_the_figures() {
        let dir = tempfile::tempdir().unwrap();
        let spd: Case = "spd:n=8:cond=1e2:seed=1".parse().unwrap();
        let infeasible: Case = "infeasible:n=8:seed=1".parse().unwrap();
        let rows = [
            record(&spd, SolverSpec::plain(SolverKind::Pgs), "converged", true),
            record(
                &infeasible,
                SolverSpec::plain(SolverKind::Lemke),
                "no_solution",
                false,
            ),
            record(
                &infeasible,
                SolverSpec::plain(SolverKind::Pgs),
                "iteration_limit",
                false,
            ),
        ];
        write_results_for_tests(dir.path(), &rows);
        let suite = Suite {
            matrix_cases: vec![spd, infeasible],
            ..Suite::default()
        };
        let header = Header::for_tests("lcpbench report", 3);
        let readme = write_report(dir.path(), &suite, &header, 12.0).unwrap();
        let md = std::fs::read_to_string(readme).unwrap();
        let headings: Vec<&str> = md.lines().filter(|l| l.starts_with('#')).collect();
        assert_eq!(
            headings,
            [
                "# lcpbench report",
                "## Findings",
                "## Budgets",
                "## Robustness matrix",
                "## Fastest solver per problem",
                "## Time to accuracy",
                "## Warm start versus cold start",
                "## SOR relaxation sweep",
                "## Scaling",
                "## Figures",
            ]
        );
        assert!(md.contains("3 rows (0 isolation failures"));
        // Findings: the generated family (the infeasible case left out), pgs the only solver
        // that solved it, at each accuracy.
        let findings = std::fs::read_to_string(dir.path().join("tables/findings.csv")).unwrap();
        for level in ["1e-4", "1e-6", "1e-8"] {
            assert!(
                findings.contains(&format!(
                    "generated LCPs,1,{level},pgs,100.0 µs (1/1 problems)"
                )),
                "{findings}"
            );
        }
        assert!(md.contains("sweep 12 s on 3 worker processes"));
        let robust = std::fs::read_to_string(dir.path().join("tables/robustness.csv")).unwrap();
        let line = |solver: &str| {
            robust
                .lines()
                .find(|l| l.starts_with(&format!("{solver},")))
                .unwrap()
                .to_owned()
        };
        assert!(line("pgs").contains("✓ 1/1"), "{robust}");
        assert!(line("pgs").contains("✗ 0/1 detected"), "{robust}");
        assert!(line("lemke").contains("✓ 1/1 detected"), "{robust}");
        let figures: Vec<&str> = md
            .lines()
            .filter_map(|l| l.strip_prefix("![").and_then(|l| l.split_once("](")))
            .map(|(_, path)| path.trim_end_matches(')'))
            .collect();
        assert_eq!(
            figures,
            [
                "plots/profile_1e-4.svg",
                "plots/profile_1e-8.svg",
                "plots/sor_omega.svg",
                "plots/scaling_lcp.svg",
            ]
        );
    }

    fn scene_record(
        case: &Case,
        solver: SolverSpec,
        budget: BudgetName,
        converged_steps: usize,
        time_per_step_s: f64,
    ) -> RunRecord {
        let steps = 10;
        RunRecord {
            case: case.to_string(),
            class: ProblemClass::Scene,
            family: CaseFamily::Scene,
            solver_base: solver.base_name(),
            warm: solver.warm(),
            solver,
            budget,
            status: if converged_steps == steps {
                "converged"
            } else {
                "iteration_limit"
            }
            .parse()
            .unwrap(),
            converged: converged_steps == steps,
            n: Some(480),
            steps: Some(steps),
            steps_planned: Some(steps),
            nonconverged_steps: Some(steps - converged_steps),
            contacts_mean: Some(160.0),
            time_per_step_s: Some(time_per_step_s),
            step_time_s: Some(3e-3),
            residual_rel: Some(1e-7),
            residual_rel_median: Some(1e-9),
            residual_rel_mean: Some(2e-9),
            phase_collision_s: Some(2e-4),
            phase_broad_s: Some(5e-5),
            phase_narrow_s: Some(1.5e-4),
            phase_assembly_s: Some(4e-4),
            phase_islands_s: Some(1e-5),
            phase_solve_s: Some(2e-3),
            phase_residual_s: Some(3e-4),
            phase_integration_s: Some(9e-5),
            ..RunRecord::default()
        }
    }

    /// The scene sections from hand-made rows of one large scene: the scenes section with its
    /// solver × budget table, the large-scene section with the best solver per budget, and the
    /// pipeline section with the phases (their CSV and the stacked bars).
    #[test]
    fn scene_sections_render_budgets_best_solvers_and_phases() {
        let dir = tempfile::tempdir().unwrap();
        let tower: Case = "scene:bench_scenes/tower_40.toml?steps=10".parse().unwrap();
        let pgs_warm = SolverSpec::plain(SolverKind::Pgs).with_warm();
        let newton = SolverSpec::plain(SolverKind::NewtonFb);
        let rows = [
            scene_record(&tower, pgs_warm.clone(), BudgetName::Realtime, 4, 2e-3),
            scene_record(&tower, pgs_warm, BudgetName::Default, 10, 2e-3),
            scene_record(&tower, newton.clone(), BudgetName::Default, 10, 1e-3),
            scene_record(&tower, newton, BudgetName::Loose, 7, 1e-3),
        ];
        write_results_for_tests(dir.path(), &rows);
        let suite = Suite {
            scene_cases: vec![tower.clone()],
            large_scene_cases: vec![tower],
            ..Suite::default()
        };
        let header = Header::for_tests("lcpbench report", 2);
        let readme = write_report(dir.path(), &suite, &header, 1.0).unwrap();
        let md = std::fs::read_to_string(readme).unwrap();
        for heading in [
            "## Scenes",
            "### tower_40",
            "## Large scenes",
            "## Pipeline",
        ] {
            assert!(md.contains(heading), "missing {heading}");
        }
        // Solver × budget cells: converged steps over steps where some did not converge.
        assert!(
            md.contains("| pgs+warm | ~ 2.00 ms (4/10) | – | ✓ 2.00 ms | – |"),
            "{md}"
        );
        // Findings and the fastest-per-scene table agree: newton-fb converged every step, at
        // 1.00 ms per step; pgs+warm (2.00 ms, every step under `default`) is the runner-up.
        let findings = std::fs::read_to_string(dir.path().join("tables/findings.csv")).unwrap();
        assert!(
            findings.contains(
                "towers,1,1e-6,newton-fb,1.00 ms/step (10/10 steps),pgs+warm,2.00 ms/step (10/10 steps)"
            ),
            "{findings}"
        );
        let fastest =
            std::fs::read_to_string(dir.path().join("tables/scenes_fastest.csv")).unwrap();
        assert!(
            fastest.contains("tower_40,newton-fb,1.00 ms/step (10/10 steps)"),
            "{fastest}"
        );
        let best =
            std::fs::read_to_string(dir.path().join("tables/large_scenes_best.csv")).unwrap();
        assert!(
            best.contains("none on every step; most: pgs+warm 2.00 ms (4/10)"),
            "{best}"
        );
        assert!(best.contains("most: newton-fb 1.00 ms (7/10)"), "{best}");
        assert!(best.contains(",newton-fb 1.00 ms (10/10)"), "{best}");
        let pipeline = std::fs::read_to_string(dir.path().join("tables/pipeline.csv")).unwrap();
        let line = pipeline.lines().nth(1).unwrap();
        assert!(
            line.starts_with("tower_40,160,3.00,0.20,0.40,0.01,2.00,0.30,0.09"),
            "{line}"
        );
        let by_budget =
            std::fs::read_to_string(dir.path().join("tables/scenes_by_budget.csv")).unwrap();
        assert_eq!(by_budget.lines().count(), 5, "{by_budget}");
        assert!(dir.path().join("plots/pipeline_phases.svg").exists());
        assert!(dir.path().join("plots/large_worst_tower_40.svg").exists());
    }
}

#[cfg(test)]
mod impact_tests {
    use super::write_report;
    use crate::harness::impact::{run_cases, ImpactCase, ImpactMode};
    use crate::report::machine::Header;
    use crate::report::suite::Suite;
    use crate::report::write_results_for_tests;
    use std::path::PathBuf;

    /// The time-of-impact runs of a small scene under two modes, through their CSV, into the
    /// section: Timewarp finds every analytic impact to round-off, the 60 Hz step does not.
    #[test]
    fn the_time_of_impact_section_reads_the_impact_runs() {
        let dir = tempfile::tempdir().unwrap();
        write_results_for_tests(dir.path(), &[]);
        let scene: PathBuf = [env!("CARGO_MANIFEST_DIR"), "bench_scenes", "impact"]
            .iter()
            .collect::<PathBuf>()
            .join("bouncing_10.toml");
        let cases: Vec<ImpactCase> = [ImpactMode::Fixed { hz: 60 }, ImpactMode::Timewarp]
            .into_iter()
            .map(|mode| ImpactCase {
                scene: scene.clone(),
                mode,
            })
            .collect();
        let rows = run_cases(&cases, &dir.path().join("data/impact.csv"), false).unwrap();
        assert_eq!(rows.len(), 2);
        let (fixed, tw) = (&rows[0], &rows[1]);
        assert_eq!(tw.analytic_impacts, fixed.analytic_impacts);
        assert!(tw.analytic_impacts >= 10);
        assert_eq!(tw.missed_impacts, 0);
        assert!(tw.impact_time_error_max.unwrap() < 1e-9, "{tw:?}");
        assert!(fixed.impact_time_error_max.unwrap() > 1e-3, "{fixed:?}");
        // Resumed: nothing runs again, the rows read back equal.
        let again = run_cases(&cases, &dir.path().join("data/impact.csv"), true).unwrap();
        assert_eq!(again, rows);
        let suite = Suite {
            impact_cases: cases,
            ..Suite::default()
        };
        let header = Header::for_tests("lcpbench report", 1);
        let readme = write_report(dir.path(), &suite, &header, 1.0).unwrap();
        let md = std::fs::read_to_string(readme).unwrap();
        assert!(md.contains("## Time of impact"));
        assert!(md.contains("| bouncing_10 | timewarp |"), "{md}");
        assert!(dir
            .path()
            .join("tables/time_of_impact_scaling.csv")
            .exists());
    }
}
