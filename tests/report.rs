//! Every section of the report rendered from a handful of hand-made rows (no sweep): each
//! section's heading is in the README and a cell the rows determine is in its table.

use lcpbench::harness::record::base_record;
use lcpbench::harness::{
    BudgetName, Case, HistoryRow, NamedBudget, RunRecord, RunStatus, SolverSpec,
};
use lcpbench::report::replays::{replay_section, ReplayLink, REPLAY_SOLVERS};
use lcpbench::report::suite::{self, Suite};
use lcpbench::report::{write_report, Header};
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::{ConeSolverKind, SolverKind};
use std::path::Path;

fn preset(name: BudgetName) -> NamedBudget {
    name.named().unwrap()
}

fn pgs() -> SolverSpec {
    SolverSpec::plain(SolverKind::Pgs)
}

/// A converged LCP run that reached every accuracy level in `time_s`.
fn lcp_run(case: &Case, solver: &SolverSpec, budget: &NamedBudget, time_s: f64) -> RunRecord {
    let mut r = base_record(case, solver, budget);
    r.status = RunStatus::Converged;
    r.converged = true;
    r.n = Some(8);
    r.iterations = Some(12);
    r.solve_time_s = Some(time_s);
    r.residual_rel = Some(1e-11);
    r.set_tta([Some(time_s / 4.0), Some(time_s / 2.0), Some(time_s), None]);
    r
}

/// A scene run of 10 steps of which `converged` converged, `time_s` of solver time per step.
fn scene_run(
    case: &Case,
    solver: &SolverSpec,
    budget: &NamedBudget,
    converged: usize,
    time_s: f64,
) -> RunRecord {
    let mut r = base_record(case, solver, budget);
    let steps = 10;
    r.status = if converged == steps {
        RunStatus::Converged
    } else {
        RunStatus::IterationLimit
    };
    r.converged = converged == steps;
    r.n = Some(120);
    r.steps = Some(steps);
    r.steps_planned = Some(steps);
    r.nonconverged_steps = Some(steps - converged);
    r.no_solution_steps = Some(0);
    r.nan_steps = Some(0);
    r.fallback_steps = Some(0);
    r.blow_up = Some(false);
    r.contacts_mean = Some(40.0);
    r.time_per_step_s = Some(time_s);
    r.step_time_s = Some(3e-3);
    r.iterations_per_step = Some(20.0);
    r.residual_rel = Some(1e-7);
    r.residual_rel_median = Some(1e-9);
    r
}

fn write_csv<T: serde::Serialize>(path: &Path, rows: &[T]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let mut w = csv::Writer::from_path(path).unwrap();
    for r in rows {
        w.serialize(r).unwrap();
    }
    w.flush().unwrap();
}

fn read(dir: &Path, table: &str) -> String {
    std::fs::read_to_string(dir.join(format!("tables/{table}.csv")))
        .unwrap_or_else(|e| panic!("tables/{table}.csv: {e}"))
}

/// Assert that `tables/{table}.csv` holds `cell`.
fn has(dir: &Path, table: &str, cell: &str) {
    let text = read(dir, table);
    assert!(
        text.contains(cell),
        "tables/{table}.csv lacks `{cell}`:\n{text}"
    );
}

/// The suite of the fixture: one or two cases per section, with the rows below.
fn fixture_suite() -> Suite {
    let spd: Case = "spd:n=8:cond=1e2:seed=1".parse().unwrap();
    let infeasible: Case = "infeasible:n=8:seed=1".parse().unwrap();
    let exported = Case::File("lcps/tower_10_step3.json".into());
    let fclib = Case::File("bench_scenes/fclib/Box_Stacks-i0122-82-5.hdf5".into());
    let wedged = Case::scene("bench_scenes/wedged.toml", Some(10));
    let large = Case::scene("bench_scenes/tower_40.toml", Some(10));
    let step: Case = "step:bench_scenes/tower_40.toml?step=1".parse().unwrap();
    let tower = Case::scene("bench_scenes/tower_10_60hz.toml", Some(10));
    let supports = Case::scene("bench_scenes/avg_two_supports.toml", Some(10));
    let chain = Case::scene("bench_scenes/joints/chain_20_1e3.toml", Some(10));
    let heavy_chain = Case::scene("bench_scenes/joints/chain_20_1e6.toml", Some(10));
    let cradle = Case::scene("bench_scenes/joints/pendulum_cradle.toml", Some(10));
    let incline = Case::scene_with_friction(
        "bench_scenes/incline_slide.toml",
        Some(10),
        FrictionModel::Box,
    );
    Suite {
        jobs: Vec::new(),
        matrix_cases: vec![spd.clone(), infeasible],
        scaling_cases: vec![spd.clone()],
        omega_cases: vec![spd.clone()],
        omegas: vec![1.3],
        warm_cases: vec![spd.clone()],
        scene_cases: vec![wedged, large.clone(), tower.clone(), supports],
        large_scene_cases: vec![large],
        scene_scaling_cases: Vec::new(),
        friction_cases: vec![incline],
        exported_cases: vec![exported.clone()],
        history_cases: vec![spd],
        tower_cases: vec![tower],
        tower_solvers: vec![pgs().with_warm()],
        tower_budgets: vec!["1e-6:20:1".parse().unwrap()],
        fclib_cases: vec![fclib],
        fc3d_cases: vec![exported, step],
        joint_cases: vec![chain, heavy_chain, cradle],
        joint_solvers: vec![SolverSpec::plain(SolverKind::Lemke), pgs().with_warm()],
        joint_budgets: vec![preset(BudgetName::Realtime), "1e-6:20:1".parse().unwrap()],
        engine_cases: Vec::new(),
        engine_runs: Vec::new(),
        engine_scaling_cases: Vec::new(),
        engine_scaling_runs: Vec::new(),
        impact_cases: Vec::new(),
    }
}

/// The rows of the fixture, for the cases of [`fixture_suite`] in its order.
fn fixture_rows(suite: &Suite) -> (Vec<RunRecord>, Vec<HistoryRow>) {
    let (default, tight) = (preset(BudgetName::Default), preset(BudgetName::Tight));
    let (spd, infeasible) = (&suite.matrix_cases[0], &suite.matrix_cases[1]);
    let lemke = SolverSpec::plain(SolverKind::Lemke);
    let mut rows = vec![
        lcp_run(spd, &pgs(), &default, 2e-4),
        lcp_run(spd, &pgs(), &tight, 3e-4),
        lcp_run(spd, &lemke, &tight, 1e-4),
        lcp_run(spd, &pgs().with_warm(), &default, 1e-4),
        lcp_run(spd, &SolverSpec::sor(1.3).unwrap(), &default, 1e-4),
        lcp_run(&suite.exported_cases[0], &pgs(), &tight, 5e-4),
        lcp_run(
            &suite.exported_cases[0],
            &SolverSpec::cone(ConeSolverKind::NsgsCone),
            &suite::fc3d_budget(),
            6e-4,
        ),
        lcp_run(&suite.fclib_cases[0], &pgs(), &suite::fclib_budget(), 7e-3),
    ];
    // A large scene's step: 162 contacts; newton-ac stops short of 1e-8.
    let step = &suite.fc3d_cases[1];
    let mut nsgs = lcp_run(
        step,
        &SolverSpec::cone(ConeSolverKind::NsgsCone),
        &suite::fc3d_budget(),
        2e-3,
    );
    nsgs.n = Some(486);
    let mut newton = lcp_run(
        step,
        &SolverSpec::cone(ConeSolverKind::NewtonAc),
        &suite::fc3d_budget(),
        5.0,
    );
    newton.n = Some(486);
    newton.status = RunStatus::TimeLimit;
    newton.converged = false;
    newton.residual_rel = Some(3e-5);
    newton.set_tta([Some(1.0), None, None, None]);
    rows.extend([nsgs, newton]);
    let mut no_solution = base_record(infeasible, &lemke, &default);
    no_solution.status = RunStatus::NoSolution;
    rows.push(no_solution);
    rows[3].iterations = Some(5);

    let (wedged, large, tower) = (
        &suite.scene_cases[0],
        &suite.scene_cases[1],
        &suite.scene_cases[2],
    );
    let si = SolverSpec::body(BodySolverKind::SequentialImpulses);
    let mut stuck = scene_run(wedged, &pgs(), &default, 6, 1e-3);
    stuck.no_solution_steps = Some(4);
    rows.push(stuck);
    rows.push(scene_run(wedged, &si, &default, 10, 2e-3));
    let realtime = preset(BudgetName::Realtime);
    let mut pipeline = scene_run(large, &pgs().with_warm(), &realtime, 4, 2e-3);
    pipeline.phase_collision_s = Some(2e-4);
    pipeline.phase_broad_s = Some(5e-5);
    pipeline.phase_narrow_s = Some(1.5e-4);
    pipeline.phase_assembly_s = Some(4e-4);
    pipeline.phase_islands_s = Some(1e-5);
    pipeline.phase_solve_s = Some(2e-3);
    pipeline.phase_residual_s = Some(3e-4);
    pipeline.phase_integration_s = Some(9e-5);
    rows.push(pipeline);
    rows.push(scene_run(large, &pgs(), &default, 10, 4e-3));
    let mut sagging = scene_run(tower, &pgs().with_warm(), &suite.tower_budgets[0], 8, 1e-3);
    sagging.sag = Some(0.25);
    sagging.lateral_drift = Some(0.5);
    rows.push(sagging);
    rows.push(scene_run(tower, &pgs(), &default, 10, 1e-3));
    let mut sliding = scene_run(
        &suite.friction_cases[0],
        &pgs().with_warm(),
        &suite::friction_budget(),
        10,
        1e-3,
    );
    sliding.analytic_metric = "acceleration".into();
    sliding.analytic_error = Some(0.25);
    rows.push(sliding);
    // The averaged-impulse baseline tilts the plank on two supports; the LCP holds it.
    let supports = &suite.scene_cases[3];
    let mut tilted = scene_run(
        supports,
        &SolverSpec::body(BodySolverKind::AveragedImpulse),
        &default,
        2,
        1e-4,
    );
    tilted.analytic_error = Some(0.014);
    tilted.penetration_max = Some(0.038);
    rows.push(tilted);
    let mut level = scene_run(
        supports,
        &SolverSpec::plain(SolverKind::Lemke),
        &default,
        10,
        1e-4,
    );
    level.analytic_error = Some(1e-12);
    rows.push(level);
    // Joints: lemke holds both chains at round-off in 0.1 ms per step; warm PGS at 20
    // iterations stretches them.
    let lemke_joint = SolverSpec::plain(SolverKind::Lemke);
    let realtime = preset(BudgetName::Realtime);
    let twenty = &suite.joint_budgets[1];
    for (k, case) in suite.joint_cases.iter().enumerate() {
        let mut exact = scene_run(case, &lemke_joint, &realtime, 10, 1e-4);
        exact.joint_drift_max = Some(2e-15);
        exact.joint_drift_mean = Some(1e-16);
        exact.sag_body = Some(0.0);
        rows.push(exact);
        let mut stretched = scene_run(case, &pgs().with_warm(), twenty, 2, 3e-4);
        stretched.joint_drift_max = Some(0.02 * (k + 1) as f64);
        stretched.joint_drift_mean = Some(0.01);
        stretched.sag_body = Some(0.3);
        rows.push(stretched);
    }

    let history = (1..=4)
        .map(|i| HistoryRow {
            case: spd.to_string(),
            solver: pgs(),
            budget: BudgetName::Tight,
            iteration: i,
            time_s: 1e-5 * i as f64,
            residual: 10f64.powi(-2 * i as i32),
        })
        .collect();
    (rows, history)
}

#[test]
fn every_section_renders_from_a_fixture_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let suite = fixture_suite();
    let (rows, histories) = fixture_rows(&suite);
    write_csv(&out.join("data/results.csv"), &rows);
    write_csv(&out.join("data/histories.csv"), &histories);
    let header = Header {
        cpu: "cpu".into(),
        cores: 2,
        os: "os".into(),
        commit: "abc".into(),
        date: "today".into(),
        command: "lcpbench report".into(),
        workers: 2,
    };
    let readme = write_report(out, &suite, &header, 3.0).unwrap();
    let md = std::fs::read_to_string(readme).unwrap();
    for heading in [
        "# lcpbench",
        "## Budgets",
        "## Scenes",
        "### At a glance",
        "### Steps without a solution",
        "### wedged",
        "### Fastest solver per scene",
        "## Large scenes",
        "## Pipeline",
        "## Towers at 60 Hz, low budgets",
        "### tower_10_60hz",
        "## Joints",
        "## Averaged impulses",
        "### Hanging chains",
        "### pendulum_cradle",
        "## Friction models",
        "## Robustness matrix",
        "## Fastest solver per problem",
        "## Time to accuracy",
        "## Cone solvers on the FC3D collection",
        "## Warm start versus cold start",
        "## SOR relaxation sweep",
        "## Scaling",
        "## FCLIB problems",
        "## Figures",
    ] {
        assert!(
            md.lines().any(|l| l.starts_with(heading)),
            "missing {heading}"
        );
    }

    // One known cell per table.
    has(out, "budgets", "tight,1e-10,100000,10");
    has(out, "scenes_at_a_glance", "wedged,~ 1.00 ms (6/10)");
    let without = read(out, "scenes_without_solution");
    assert!(without.contains("wedged,1 / 2,4 (10),pgs,"), "{without}");
    has(
        out,
        "scenes_by_budget",
        ",pgs+warm,realtime,iteration_limit,10,",
    );
    has(
        out,
        "large_scenes_best",
        "none on every step; most: pgs+warm",
    );
    has(
        out,
        "pipeline",
        "tower_40,40,3.00,0.20,0.40,0.01,2.00,0.30,0.09",
    );
    let towers = read(out, "towers_tower_10_60hz");
    assert!(
        towers.contains("pgs+warm,2.5e-1,5.0e-1,1.00 ms,2 of 10"),
        "{towers}"
    );
    let chains = read(out, "joints_chains");
    assert!(
        chains.contains("lemke,realtime,2.0e-15,0,100.0 µs,2.0e-15,0,100.0 µs"),
        "{chains}"
    );
    assert!(
        chains.contains("pgs+warm,1e-6:20:1,2.0e-2,3.0e-1"),
        "{chains}"
    );
    let md_joints = md.split("## Joints").nth(1).unwrap_or_default();
    assert!(
        md_joints.contains(
            "chain_20_1e3: drift below 1 mm at ≤ 1 ms of solver time per step**: lemke (realtime)"
        ),
        "{md_joints}"
    );
    assert!(
        md_joints.contains("chain_20_1e6: drift below 1 cm**: held by lemke (realtime"),
        "{md_joints}"
    );
    has(
        out,
        "joints_pendulum_cradle",
        "pgs+warm,1e-6:20:1,6.0e-2,1.0e-2,3.0e-1",
    );
    has(
        out,
        "averaged_impulse",
        "avg_two_supports,avg,1.4e-2,3.8e-2",
    );
    has(out, "averaged_impulse", "avg_two_supports,lemke,1.0e-12");
    let friction = read(out, "friction_models");
    assert!(friction.contains("box,pgs+warm,2.5e-1"), "{friction}");
    let robust = read(out, "robustness");
    assert!(robust.contains("pgs,✓ 1/1"), "{robust}");
    assert!(robust.contains("lemke,–,–,–,–,✓ 1/1 detected"), "{robust}");
    has(out, "fastest", "lemke,25.0 µs,lemke,100.0 µs");
    has(out, "time_to_accuracy", "spd:n=8:cond=1e2:seed=1,lemke,");
    has(out, "cone_time_to_accuracy", "nsgs-cone,2 of 2");
    has(
        out,
        "cone_time_to_accuracy",
        // Over both problems: newton-ac's unsolved one counted at the budget's 5 s, so
        // `((1 s + 10 µs)(5 s + 10 µs))^½ − 10 µs`, not the 1 s of its one success.
        "newton-ac,1 of 2,2.24 s,0 of 2,5.00 s,0 of 2",
    );
    // Findings comes first after the header, and answers per family and accuracy with a link
    // to its evidence.
    let first_section = md.lines().find(|l| l.starts_with("## ")).unwrap();
    assert_eq!(first_section, "## Findings");
    // Relaxed solvers are marked where they are tabled, and the mark explained.
    let robust_md = md.split("## Robustness matrix").nth(1).unwrap_or_default();
    assert!(robust_md.contains("| clarabel † |"), "{robust_md}");
    assert!(
        robust_md.contains(
            "† solves a relaxed problem, not the one posed (`clarabel`: on friction rows, Anitescu"
        ),
        "{robust_md}"
    );
    let findings = read(out, "findings");
    assert!(
        findings.contains("FC3D (cone solvers),2,1e-8,nsgs-cone,1.10 ms (2/2 problems),newton-ac,"),
        "{findings}"
    );
    assert!(
        findings.contains("[Fastest solver per scene](#fastest-solver-per-scene)"),
        "{findings}"
    );
    for family in ["towers,", "generated LCPs,", "FCLIB (box-friction LCPs),"] {
        assert!(findings.contains(family), "{family} in {findings}");
    }
    has(
        out,
        "cone_problems",
        "tower_40 step1,large-scene step,162,486,2.00 ms,time_limit (3.0e-5)",
    );
    has(out, "warm_vs_cold", ",pgs,12,5,");
    has(out, "sor_omega", "1.3,12");
    has(out, "scaling_slopes", "pgs,");
    has(out, "fclib", "**pgs**, 7.00 ms");

    // The replay section, appended after a run's replays are written.
    let links = [ReplayLink {
        scene: "wedged".into(),
        page: Some(out.join("replays/wedged.html")),
        solvers: REPLAY_SOLVERS.iter().map(ToString::to_string).collect(),
        error: None,
    }];
    let replays = replay_section(&links, out);
    assert!(replays.starts_with("## Replays"), "{replays}");
    assert!(
        replays.contains("| wedged | [dantzig vs si](replays/wedged.html) |"),
        "{replays}"
    );

    // The sections that are figures only.
    for plot in [
        "profile_1e-4",
        "profile_cone_1e-8",
        "convergence_spd_n_8_cond_1e2_seed_1_iter",
        "pareto_wedged",
        "large_worst_tower_40",
        "pipeline_phases",
    ] {
        assert!(
            out.join(format!("plots/{plot}.svg")).exists(),
            "missing plots/{plot}.svg"
        );
    }
}

/// `bench` on a scene and a problem file of the user's, run from a directory outside the
/// checkout, prints its per-solver summary; `report --from` on its output, from there too,
/// writes Findings and the tables of those two cases only, figures named after the cases,
/// and refuses to overwrite a README it did not write.
#[test]
fn report_from_a_users_sweep_covers_its_cases_only() {
    use std::process::Command;
    let exe = env!("CARGO_BIN_EXE_lcpbench");
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(
        root.join("bench_scenes/box_on_ground.toml"),
        dir.path().join("my_scene.toml"),
    )
    .unwrap();
    std::fs::copy(
        root.join("tests/data/siconos/lcp_deudeu_block.dat"),
        dir.path().join("my_problem.dat"),
    )
    .unwrap();
    let bench = Command::new(exe)
        .current_dir(dir.path())
        .args(["bench", "--no-progress", "--jobs", "1", "--out", "sweep"])
        .args(["--lcps", "scene:my_scene.toml?steps=5,file:my_problem.dat"])
        .args([
            "--solvers",
            "pgs,pgs+warm,lemke",
            "--budgets",
            "loose,default",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&bench.stdout);
    assert!(
        bench.status.success(),
        "{}",
        String::from_utf8_lossy(&bench.stderr)
    );
    assert!(
        stdout.contains("budget default (tolerance 1e-8), 1 problems:"),
        "{stdout}"
    );
    assert!(
        stdout.contains("budget loose (tolerance 1e-4), 1 scenes:"),
        "{stdout}"
    );
    assert!(
        stdout.contains("report: lcpbench report --from sweep"),
        "{stdout}"
    );

    let report = Command::new(exe)
        .current_dir(dir.path())
        .args(["report", "--from", "sweep"])
        .output()
        .unwrap();
    assert!(
        report.status.success(),
        "{}",
        String::from_utf8_lossy(&report.stderr)
    );
    let out = dir.path().join("sweep/report");
    let md = std::fs::read_to_string(out.join("README.md")).unwrap();
    let sections: Vec<&str> = md.lines().filter(|l| l.starts_with("## ")).collect();
    assert_eq!(
        sections,
        ["## Findings", "## Results per case", "## Figures"],
        "{md}"
    );
    let cases: Vec<&str> = md.lines().filter(|l| l.starts_with("### ")).collect();
    assert_eq!(cases, ["### my_scene", "### my_problem"], "{md}");
    let per_case = read(&out, "per_case");
    assert_eq!(per_case.lines().count(), 1 + 2 * 3 * 2, "{per_case}");
    assert!(per_case
        .lines()
        .skip(1)
        .all(|l| l.starts_with("scene:my_scene.toml") || l.starts_with("file:my_problem.dat")));
    let findings = read(&out, "findings");
    let families: Vec<&str> = findings
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert!(
        families
            .iter()
            .all(|f| *f == "other scenes" || *f == "problem files"),
        "{findings}"
    );
    assert!(
        findings.contains("[per case](#results-per-case)"),
        "{findings}"
    );
    // Figures are named after the cases, never after a path.
    let plots: Vec<String> = std::fs::read_dir(out.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        plots.contains(&"pareto_my_scene.svg".to_owned()),
        "{plots:?}"
    );
    let tmp = dir.path().to_string_lossy().replace('/', "_");
    assert!(
        plots
            .iter()
            .all(|p| !p.contains("tmp") && !p.contains(&tmp)),
        "{plots:?}"
    );

    // A README lcpbench did not write is never overwritten.
    let foreign = dir.path().join("elsewhere");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("README.md"), "# my notes\n").unwrap();
    let refused = Command::new(exe)
        .current_dir(dir.path())
        .args(["report", "--from", "sweep", "--out", "elsewhere"])
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("is not a report lcpbench wrote"), "{err}");
    assert_eq!(
        std::fs::read_to_string(foreign.join("README.md")).unwrap(),
        "# my notes\n"
    );
    // A directory without a sweep's rows is named in the error.
    let empty = Command::new(exe)
        .current_dir(dir.path())
        .args(["report", "--from", "elsewhere"])
        .output()
        .unwrap();
    assert!(!empty.status.success());
    assert!(String::from_utf8_lossy(&empty.stderr).contains("no results.csv"));
}

/// An engine run of 10 steps: `updates` row updates per step, `time_s` of step time without
/// the residual phase, `sag` (or joint drift, on a chain) as its error.
fn engine_run(
    case: &Case,
    solver: &SolverSpec,
    budget: &NamedBudget,
    updates: f64,
    time_s: f64,
    error: f64,
) -> RunRecord {
    let mut r = scene_run(case, solver, budget, 7, time_s);
    r.substeps_per_step = Some(1.0);
    r.row_updates_per_step = Some(updates);
    r.body_passes_per_step = Some(1.0);
    r.step_time_no_residual_s = Some(time_s);
    r.time_limit_steps = Some(0);
    if case.short_name().starts_with("chain") {
        r.joint_drift_max = Some(error);
    } else {
        r.sag = Some(error);
        r.lateral_drift = Some(error / 10.0);
    }
    r
}

/// The engine section from hand-made rows: one table per scene with the runs by increasing
/// row updates per step (the cost over the cheapest beside), the residual's LCP, the steps'
/// statuses, Rapier's quoted rows with their date on the scenes it was measured on, and the
/// figures of sag and joint drift against time per step.
#[test]
fn the_engine_section_lists_runs_at_equal_cost_beside_the_peer() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let tower = Case::scene("bench_scenes/tower_40_60hz.toml", None);
    let chain = Case::scene("bench_scenes/joints/chain_20_1e3.toml", None);
    let stack = Case::scene("bench_scenes/sphere_stack.toml", None);
    let pgs_warm = pgs().with_warm();
    let si_warm = SolverSpec::body(BodySolverKind::SequentialImpulses).with_warm();
    let cap = |n: usize| -> NamedBudget { format!("1e-6:{n}:1").parse().unwrap() };
    let runs = vec![
        (pgs_warm.clone(), cap(8)),
        (pgs_warm.clone(), cap(40)),
        (si_warm.clone(), cap(16)),
    ];
    let suite = Suite {
        engine_cases: vec![tower.clone(), chain.clone(), stack.clone()],
        engine_runs: runs,
        ..Suite::default()
    };
    let mut rows = Vec::new();
    for case in [&tower, &chain, &stack] {
        // Listed out of cost order: the table sorts them.
        rows.push(engine_run(case, &pgs_warm, &cap(40), 19_200.0, 4e-4, 1e-3));
        rows.push(engine_run(case, &pgs_warm, &cap(8), 3_840.0, 1e-4, 0.2));
        rows.push(engine_run(case, &si_warm, &cap(16), 7_680.0, 2e-4, 0.05));
    }
    // A run outside the section's list is not shown.
    rows.push(engine_run(&tower, &pgs(), &cap(8), 3_000.0, 1e-4, 0.3));
    write_csv(&out.join("data/results.csv"), &rows);
    let header = Header {
        cpu: "cpu".into(),
        cores: 2,
        os: "os".into(),
        commit: "abc".into(),
        date: "today".into(),
        command: "lcpbench report".into(),
        workers: 2,
    };
    let readme = write_report(out, &suite, &header, 3.0).unwrap();
    let md = std::fs::read_to_string(readme).unwrap();
    for heading in [
        "## Engine solvers",
        "### tower_40_60hz",
        "### chain_20_1e3",
        "### sphere_stack",
    ] {
        assert!(md.lines().any(|l| l == heading), "missing {heading}");
    }
    assert!(md.contains("These 9 runs took"), "{md}");
    let table = read(out, "engine_tower_40_60hz");
    let lines: Vec<&str> = table.lines().collect();
    assert!(
        lines[0].starts_with("solver,budget,substeps,row updates/step,× cheapest,"),
        "{table}"
    );
    // By cost: 3,840, then 7,680, then 19.2 k row updates per step; each 10 steps, 7
    // converged; residual of the step's LCP.
    assert!(
        lines[1].starts_with("pgs+warm,1e-6:8:1,1,3840,1.0×,1,100.0 µs,2.0e-1,2.0e-2,"),
        "{table}"
    );
    assert!(
        lines[2].starts_with("si+warm,1e-6:16:1,1,7680,2.0×,"),
        "{table}"
    );
    assert!(
        lines[3].starts_with("pgs+warm,1e-6:40:1,1,19.2 k,5.0×,"),
        "{table}"
    );
    for line in &lines[1..4] {
        assert!(line.contains(",step,7/10 converged,"), "{line}");
    }
    assert!(!table.contains("\npgs,"), "{table}");
    // Rapier's quoted row on the tower (docs/peers/rapier.csv): 79.9 µs per step, sag 0.434 m, dated.
    let rapier = lines
        .iter()
        .find(|l| l.starts_with("Rapier 0.36,"))
        .unwrap_or_else(|| panic!("{table}"));
    assert!(rapier.contains(",79.9 µs,4.3e-1,"), "{rapier}");
    assert!(rapier.contains("measured 2026-12-06"), "{rapier}");
    // The chain: Rapier's two rows (20 and 4 substeps); the sphere stack: none.
    let chain_table = read(out, "engine_chain_20_1e3");
    let peer_rows = chain_table
        .lines()
        .filter(|l| l.starts_with("Rapier 0.36,"))
        .count();
    assert_eq!(peer_rows, 2, "{chain_table}");
    assert!(chain_table.contains(",2.7e-2,"), "{chain_table}");
    assert!(!read(out, "engine_sphere_stack").contains("Rapier"));
    assert!(md.contains("rapier_scenes.rs"), "{md}");
    // The figures: sag on the tower, joint drift on the chain, with their points.
    let points = std::fs::read_to_string(out.join("plots/engine_tower_40_60hz.csv")).unwrap();
    assert!(points.contains("pgs+warm,1e-4,2e-1"), "{points}");
    assert!(
        points.contains("\"Rapier 0.36 (quoted, see table)\",7.99e-5,4.34e-1"),
        "{points}"
    );
    assert!(out.join("plots/engine_chain_20_1e3.svg").exists());
    assert!(!out.join("plots/engine_sphere_stack.svg").exists());
}

/// An engine scaling run of 10 steps of which `measured` were measured and `converged` of
/// those converged: `without_s` per step without the residual phase, `with_s` per measured
/// step, `contacts` per step.
fn scaling_run(
    case: &Case,
    solver: &SolverSpec,
    budget: &NamedBudget,
    (measured, converged): (usize, usize),
    (without_s, with_s): (f64, f64),
    contacts: f64,
) -> RunRecord {
    let mut r = scene_run(case, solver, budget, 10, without_s);
    r.steps_measured = Some(measured);
    r.nonconverged_steps = Some(measured - converged);
    r.status = if measured == converged {
        RunStatus::Converged
    } else {
        RunStatus::IterationLimit
    };
    r.converged = measured == converged;
    r.contacts_mean = Some(contacts);
    r.step_time_no_residual_s = Some(without_s);
    r.measured_step_time_s = Some(with_s);
    r.time_limit_steps = Some(0);
    r
}

/// The engine scaling section from a small synthetic data set: one row per run with the time
/// per step and per 1,000 contacts without and with the residual, converged steps counted of
/// the measured ones, a refused run named so, Rapier's dated row on the pyramid it measured,
/// and the log–log figure with its points.
#[test]
fn the_engine_scaling_section_tabulates_time_against_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path();
    let schedule = suite::ENGINE_SCALING_RESIDUAL;
    let small =
        Case::scene("bench_scenes/scaling/pyramid_3d_1015.toml", Some(10)).with_residual(schedule);
    let huge =
        Case::scene("bench_scenes/scaling/pyramid_3d_14910.toml", Some(10)).with_residual(schedule);
    let runs = suite::engine_scaling_runs();
    let (pgs_warm, pgs_budget) = runs[0].clone();
    let (si_warm, si_budget) = runs[1].clone();
    assert_eq!(pgs_warm.to_string(), "pgs+warm");
    assert_eq!(si_warm.to_string(), "si+warm");
    let mut rows = vec![
        scaling_run(
            &small,
            &pgs_warm,
            &pgs_budget,
            (10, 10),
            (4e-3, 5e-3),
            13_888.0,
        ),
        scaling_run(&small, &si_warm, &si_budget, (3, 2), (2e-3, 3e-3), 13_888.0),
        scaling_run(
            &huge,
            &si_warm,
            &si_budget,
            (0, 0),
            (0.5, f64::NAN),
            223_860.0,
        ),
    ];
    rows[2].measured_step_time_s = None;
    let mut refused = scaling_run(&huge, &pgs_warm, &pgs_budget, (0, 0), (0.4, 0.4), 0.0);
    refused.status = RunStatus::Unsupported;
    refused.converged = false;
    refused.reason = "the step's Delassus matrix would store 120950928 entries".into();
    refused.measured_step_time_s = None;
    rows.push(refused);
    write_csv(&out.join("data/results.csv"), &rows);
    let suite = Suite {
        engine_scaling_cases: vec![small, huge],
        engine_scaling_runs: runs,
        ..Suite::default()
    };
    let header = Header {
        cpu: "cpu".into(),
        cores: 2,
        os: "os".into(),
        commit: "abc".into(),
        date: "today".into(),
        command: "lcpbench report".into(),
        workers: 2,
    };
    let readme = write_report(out, &suite, &header, 3.0).unwrap();
    let md = std::fs::read_to_string(readme).unwrap();
    assert!(md.lines().any(|l| l == "## Engine scaling"), "{md}");
    assert!(
        md.contains("steps 0, 5 and 9 (`residual = sample=5`)"),
        "{md}"
    );
    let table = read(out, "engine_scaling");
    let lines: Vec<&str> = table.lines().collect();
    assert!(
        lines[0].starts_with("boxes,solver,budget,contacts,"),
        "{table}"
    );
    // 4 ms over 13,888 contacts is 288.0 µs per 1,000 contacts; 5 ms with the residual, 360.0.
    assert!(
        lines[1].starts_with("1015,pgs+warm,1e-6:20:5,13888,4.00 ms,288.0 µs,5.00 ms,360.0 µs,10 of 10 measured converged (10 taken)"),
        "{table}"
    );
    assert!(
        lines[2].starts_with("1015,si+warm,1e-6:8:5,13888,2.00 ms,144.0 µs,3.00 ms,216.0 µs,2 of 3 measured converged (10 taken)"),
        "{table}"
    );
    // Rapier's 1,015-box row (docs/peers/rapier.csv) follows lcpbench's, dated; its 5,525-box
    // row is not shown (no run of that pyramid here).
    assert!(
        lines[3].starts_with("1015,Rapier 0.36 (4 substeps),measured 2026-12-06,–,7.26 ms,"),
        "{table}"
    );
    assert!(!table.contains("5525"), "{table}");
    let huge_si = lines
        .iter()
        .find(|l| l.starts_with("14910,si+warm"))
        .unwrap();
    assert!(
        huge_si.contains(",500.00 ms,") && huge_si.contains(",no step measured,"),
        "{huge_si}"
    );
    let huge_pgs = lines
        .iter()
        .find(|l| l.starts_with("14910,pgs+warm"))
        .unwrap();
    assert!(
        huge_pgs.contains("refused: the step's Delassus matrix"),
        "{huge_pgs}"
    );
    assert!(huge_pgs.contains(",–,–,–,–,"), "{huge_pgs}");
    // The figure: without and with the residual per solver, Rapier's point; the refused run is
    // not drawn.
    let points = std::fs::read_to_string(out.join("plots/engine_scaling.csv")).unwrap();
    assert!(
        points.contains("\"pgs+warm, without residual\",1.015e3,4e-3"),
        "{points}"
    );
    assert!(
        points.contains("\"si+warm, without residual\",1.491e4,5e-1"),
        "{points}"
    );
    assert!(
        points.contains("\"si+warm, with residual (measured steps)\",1.015e3,3e-3"),
        "{points}"
    );
    assert!(
        points.contains("\"Rapier 0.36 (quoted, see table)\",1.015e3,7.26e-3"),
        "{points}"
    );
    assert!(
        !points.contains("pgs+warm, without residual\",1.491e4"),
        "{points}"
    );
    assert!(out.join("plots/engine_scaling.svg").exists());
}
