//! `lcpbench simulate` and `lcpbench export` seen from outside.

use std::process::{Command, Output};

fn lcpbench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lcpbench"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn simulate_prints_figures_and_records_json_lines() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("run.jsonl");
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/box_on_ground.toml",
        "--solver",
        "si",
        "--steps",
        "20",
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    for needle in [
        "solver si",
        "20 steps",
        "time per step",
        "iterations",
        "max penetration",
        "energy",
    ] {
        assert!(out.contains(needle), "`{needle}` missing from:\n{out}");
    }
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(&rec)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 21, "a header line and one line per step");
    let header = &lines[0]["recording"];
    assert_eq!(header["scene"], "box_on_ground");
    assert_eq!(header["bodies"][1]["shape"]["type"], "box");
    let last = &lines[20];
    assert_eq!(last["step"], 19);
    assert_eq!(last["bodies"][1]["name"], "box");
    assert_eq!(last["contacts"], 4);
    let c = &last["contact_records"][0];
    for key in [
        "point",
        "normal",
        "impulse",
        "tangent_impulse",
        "relative_velocity",
    ] {
        assert_eq!(c[key].as_array().unwrap().len(), 3, "{key}");
    }
    // A box resting on the ground: each corner carries a quarter of the weight per step, with
    // complementarity holding (the separation rate is zero where the impulse is positive).
    let fn_sum: f64 = last["contact_records"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["normal_impulse"].as_f64().unwrap())
        .sum();
    let weight = 1000.0 * 9.81 * header["dt"].as_f64().unwrap(); // 1 m³ at 1000 kg/m³
    assert!(
        (fn_sum - weight).abs() < 0.05 * weight,
        "{fn_sum} vs {weight}"
    );
    assert!(c["complementarity"].as_f64().unwrap().abs() < 1e-3 * fn_sum);
}

#[test]
fn simulate_json_summary() {
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/cradle_3.toml",
        "--steps",
        "5",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["solver"], "pgs");
    assert_eq!(v["steps"], 5);
    assert!(v["time_per_step_s"].as_f64().unwrap() > 0.0);
}

/// The cost figures: a solver that does not substep takes one substep and one body pass per
/// step, and its row updates are its sweeps times the rows (box_on_ground: four contacts of
/// three rows each in every step, 7 PGS sweeps each, the tolerance 1e-14 out of their reach); the step time
/// without the residual phase is the step time less that phase.
#[test]
fn simulate_json_reports_the_cost_per_step() {
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/box_on_ground.toml",
        "--steps",
        "6",
        "--tol",
        "1e-14",
        "--max-iter",
        "7",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["mean_rows"], 12.0, "{v}");
    assert_eq!(v["mean_iterations"], 7.0, "{v}");
    assert_eq!(v["substeps_per_step"], 1.0, "{v}");
    assert_eq!(v["body_passes_per_step"], 1.0, "{v}");
    assert_eq!(v["row_updates_per_step"], 84.0, "{v}");
    assert!(v["residual_of"].is_null(), "{v}");
    let step = v["time_per_step_s"].as_f64().unwrap();
    let residual = v["phases_per_step_s"]["residual"].as_f64().unwrap();
    let without = v["time_per_step_without_residual_s"].as_f64().unwrap();
    assert!(
        (without - (step - residual)).abs() <= 1e-12 + 1e-9 * step,
        "{v}"
    );
    assert!(without > 0.0 && without <= step, "{v}");
}

/// `--time-budget` bounds each step's solve: steps that run out end `time_limit` and the run
/// takes every step; the phase keys name the phases and add up to the step time.
#[test]
fn simulate_time_budget_is_per_step_and_phases_add_up() {
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/pyramid_10.toml",
        "-s",
        "dantzig",
        "--steps",
        "4",
        "--tol",
        "1e-10",
        // The smallest budget: no step of pyramid_10 is solved within a microsecond on any
        // machine, loaded or not, so steps end `time_limit` whatever the clock does.
        "--time-budget",
        "1e-6",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["steps"], 4);
    assert_eq!(v["step_time_budget_s"], 1e-6);
    assert!(v["statuses"]["time_limit"].as_u64().unwrap() >= 1, "{v}");
    let phases = &v["phases_per_step_s"];
    let sum: f64 = [
        "collision",
        "assembly",
        "islands",
        "solve",
        "residual",
        "integration",
    ]
    .iter()
    .map(|k| {
        phases[k]
            .as_f64()
            .unwrap_or_else(|| panic!("no phase {k}: {v}"))
    })
    .sum();
    let step = v["time_per_step_s"].as_f64().unwrap();
    assert!((sum - step).abs() <= 0.05 * step, "{sum} vs {step}");
    let collision = phases["collision"].as_f64().unwrap();
    let parts = phases["broad_phase"].as_f64().unwrap() + phases["narrow_phase"].as_f64().unwrap();
    assert!(parts <= collision * 1.0001 + 1e-9, "{parts} vs {collision}");
}

/// The body-level solvers keep to the per-step budget too: with a tolerance they cannot reach
/// and an iteration cap they would take far longer to spend, every step ends `time_limit`.
#[test]
fn body_level_solvers_stop_at_the_step_budget() {
    for solver in ["si", "body-micro"] {
        let o = lcpbench(&[
            "simulate",
            "bench_scenes/pyramid_10.toml",
            "--solver",
            solver,
            "--steps",
            "2",
            "--tol",
            "1e-14",
            "--max-iter",
            "100000000",
            "--time-budget",
            "0.01",
            "--json",
        ]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(
            v["statuses"]["time_limit"], 2,
            "{solver}: {}",
            v["statuses"]
        );
    }
}

#[test]
fn export_writes_a_problem_that_solve_reads() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("step.json");
    let o = lcpbench(&[
        "export",
        "bench_scenes/tower_10.toml",
        "--step",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = lcpbench(&["solve", out.to_str().unwrap(), "--solver", "dantzig"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("120 rows"), "{}", text(&o.stdout));
}

#[test]
fn bad_scenes_and_solvers_fail_with_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[settings]\ndt = 0.01\nstepz = 3\n").unwrap();
    let o = lcpbench(&["simulate", bad.to_str().unwrap()]);
    assert!(!o.status.success());
    let e = text(&o.stderr);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.contains("bad.toml:3:1") && e.contains("unknown field `stepz`"),
        "{e}"
    );

    let o = lcpbench(&["simulate", "bench_scenes/cradle_3.toml", "--solver", "nope"]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("unknown solver `nope`"));

    // Enumeration takes no island of 120 rows: the run stops and says so.
    let o = lcpbench(&["simulate", "bench_scenes/tower_10.toml", "--solver", "enum"]);
    assert!(!o.status.success());
    let e = text(&o.stderr);
    assert!(
        e.contains("enum") && e.contains("dense limit of 64 rows"),
        "{e}"
    );

    let out = dir.path().join("x.json");
    let out = out.to_str().unwrap();
    let o = lcpbench(&[
        "export",
        "bench_scenes/ball_drop.toml",
        "--step",
        "0",
        "-o",
        out,
    ]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("no contacts"));
}

#[test]
fn simulate_a_cone_scene_with_a_cone_solver_converges_every_step() {
    // The resting stack's four contacts per face take Gauss–Seidel sweeps beyond the scene's
    // cap of 1000 (as for PGS on the box model), hence --max-iter.
    for solver in ["nsgs-cone", "newton-ac"] {
        let o = lcpbench(&[
            "simulate",
            "bench_scenes/tower_5.toml",
            "--friction-model",
            "cone",
            "--solver",
            solver,
            "--steps",
            "30",
            "--max-iter",
            "10000",
            "--json",
        ]);
        assert!(o.status.success(), "{solver}: {}", text(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["solver"], solver);
        assert_eq!(
            v["statuses"]["converged"], 30,
            "{solver}: {}",
            v["statuses"]
        );
        assert_eq!(
            v["statuses"].as_object().unwrap().len(),
            1,
            "{}",
            v["statuses"]
        );
        assert!(v["max_relative_residual"].as_f64().unwrap() <= 1e-6);
        assert!(v["max_friction_cone_violation"].as_f64().unwrap() < 1e-12);
        assert!(v["sag"].as_f64().unwrap().abs() < 1e-2, "{}", v["sag"]);
    }
    // A cone scene names no solver: nsgs-cone is its default.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("cone.toml");
    let text_of = std::fs::read_to_string("bench_scenes/diagonal_push.toml").unwrap();
    let cone = text_of
        .replace("friction_model = \"box\"", "friction_model = \"cone\"")
        .replace("solver = \"pgs\"\n", "");
    std::fs::write(&scene, cone).unwrap();
    let o = lcpbench(&["simulate", scene.to_str().unwrap(), "--steps", "10"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(
        out.contains("solver nsgs-cone") && out.contains("converged 10"),
        "{out}"
    );
}

#[test]
fn solvers_that_do_not_take_the_friction_model_are_unsupported() {
    // The refusal names every cone solver, as the registry lists them.
    let cone_solvers = format!(
        "cone solver ({})",
        lcpbench_solvers::ConeSolverKind::names()
    );
    for (model, solver, needle) in [
        ("cone", "pgs", cone_solvers.as_str()),
        ("cone", "si", cone_solvers.as_str()),
        ("box", "nsgs-cone", "--friction-model cone"),
        ("pyramid", "newton-ac", "--friction-model cone"),
    ] {
        let o = lcpbench(&[
            "simulate",
            "bench_scenes/incline_slide.toml",
            "--friction-model",
            model,
            "--solver",
            solver,
        ]);
        assert!(!o.status.success(), "{solver} on {model}");
        let e = text(&o.stderr);
        assert_eq!(e.lines().count(), 1, "{e}");
        assert!(e.contains("unsupported") && e.contains(needle), "{e}");
    }
    // `--help` names the cone solvers.
    let help = text(&lcpbench(&["simulate", "--help"]).stdout);
    assert!(
        help.contains("nsgs-cone") && help.contains("cone"),
        "{help}"
    );
}

#[test]
fn export_of_a_cone_scene_writes_a_cone_problem() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cone.json");
    let o = lcpbench(&[
        "export",
        "bench_scenes/diagonal_push.toml",
        "--friction-model",
        "cone",
        "--solver",
        "nsgs-cone",
        "--step",
        "5",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // Both cone solvers solve it; an LCP solver declines the cone file.
    for solver in ["nsgs-cone", "newton-ac"] {
        let o = lcpbench(&["solve", out.to_str().unwrap(), "--solver", solver, "--json"]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["status"], "converged", "{solver}: {v}");
    }
    let o = lcpbench(&["solve", out.to_str().unwrap(), "--solver", "pgs", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_default();
    assert_eq!(v["status"], "unsupported", "{}", text(&o.stderr));
}

/// A step of a sphere pile whose friction rows sit at round-off level (`1e-18`, next to
/// normals near 1) and are coupled to each other: Newton used to iterate 10 000 times on the
/// linear solve's error there; it now refines those rows on their own and converges.
#[test]
fn newton_converges_on_a_sphere_pile_step_with_round_off_level_friction_rows() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("step.json");
    let o = lcpbench(&[
        "export",
        "bench_scenes/sphere_pile_200.toml",
        "--step",
        "18",
        "--solver",
        "newton-fb+warm",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    for solver in ["newton-fb", "pgs"] {
        let o = lcpbench(&[
            "solve",
            out.to_str().unwrap(),
            "--solver",
            solver,
            "--tol",
            "1e-8",
            "--max-iter",
            "5000",
        ]);
        let stdout = text(&o.stdout);
        assert!(o.status.success(), "{}", text(&o.stderr));
        assert!(
            stdout.contains("status      converged"),
            "{solver}: {stdout}"
        );
    }
}

#[test]
fn the_warm_suffix_decides_warm_starting_as_in_bench() {
    let run = |solver: &str| -> serde_json::Value {
        let o = lcpbench(&[
            "simulate",
            "bench_scenes/tower_10.toml",
            "-s",
            solver,
            "--steps",
            "10",
            "--tol",
            "1e-3",
            "--json",
        ]);
        assert!(o.status.success(), "{}", text(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let (cold, warm) = (run("pgs"), run("pgs+warm"));
    assert_eq!(cold["warm_start"], false);
    assert_eq!(warm["warm_start"], true);
    // A resting tower: from the previous step's impulses PGS needs a fraction of the sweeps.
    let iters = |v: &serde_json::Value| v["mean_iterations"].as_f64().unwrap();
    assert!(
        iters(&warm) < 0.5 * iters(&cold),
        "warm {} vs cold {} sweeps per step",
        iters(&warm),
        iters(&cold)
    );
    // `+warm` on a pivoting solver is refused with the reason, not as an unknown solver.
    let o = lcpbench(&["simulate", "bench_scenes/tower_10.toml", "-s", "lemke+warm"]);
    assert!(!o.status.success());
    let e = text(&o.stderr);
    assert!(e.contains("+warm applies only to iterative solvers"), "{e}");
}

/// Never spin, body-level sequential impulses: on `heavy_removed` at `1e-8` with a cap of
/// 100,000 sweeps, steps 2 and 3 ran every sweep to the cap at a relative impulse change near
/// `1e-6`; they now stop `stalled` after 5,000 sweeps without a new low.
#[test]
fn sequential_impulses_stall_instead_of_sweeping_to_the_cap() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("run.jsonl");
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/heavy_removed.toml",
        "-s",
        "si",
        "--tol",
        "1e-8",
        "--max-iter",
        "100000",
        "--steps",
        "4",
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let lines = std::fs::read_to_string(&rec).unwrap();
    let stalled: Vec<(u64, u64)> = lines
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| {
            v["status"]["reason"]
                .as_str()
                .is_some_and(|r| r.contains("no progress"))
        })
        .map(|v| {
            (
                v["step"].as_u64().unwrap(),
                v["iterations"].as_u64().unwrap(),
            )
        })
        .collect();
    assert!(!stalled.is_empty(), "no step stalled");
    for (step, iterations) in stalled {
        assert!(iterations < 100_000, "step {step}: {iterations} sweeps");
    }
}

/// `wedged`: box A overlaps the static boxes B and C by 5 mm on each side, and Baumgarte
/// correction asks it to leave both at 0.08 m/s at once, so every step's LCP has no solution
/// (opposite normals cancel: a Farkas ray). An iterative solver's impulse meets a loose tolerance
/// by squeezing A ever harder from both sides; `simulate` reports those steps `diverged`, and
/// each step's recorded reason carries the certificate's bound on the size of any solution. A
/// pivoting solver reports no step `converged` either.
#[test]
fn a_wedged_box_has_steps_without_a_solution() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("run.jsonl");
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/wedged.toml",
        "--solver",
        "apgd",
        "--tol",
        "1e-4",
        "--steps",
        "5",
        "--json",
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["statuses"], serde_json::json!({"diverged": 5}), "{v}");
    let steps: Vec<serde_json::Value> = std::fs::read_to_string(&rec)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    for s in &steps {
        let reason = s["status"]["reason"].as_str().unwrap();
        let bound: f64 = reason
            .split("every solution has ‖f‖∞ >= ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|x| x.parse().ok())
            .unwrap_or_else(|| panic!("no bound in {reason}"));
        assert!(bound > 1e9, "{reason}");
    }
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/wedged.toml",
        "--solver",
        "lemke",
        "--steps",
        "5",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["statuses"].get("converged").is_none(), "{v}");
}

/// `simulate --html` (and `--record`) end with a `wrote PATH` line after the summary, as the
/// other writers do; with `--json` standard output stays one JSON document and the lines go to
/// standard error. Aggregates say whether they are a mean or a max.
#[test]
fn simulate_says_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("drop.html");
    let rec = dir.path().join("drop.jsonl");
    let run = |json: bool| {
        let mut args = vec![
            "simulate".to_owned(),
            "bench_scenes/box_on_ground.toml".into(),
            "--steps".into(),
            "5".into(),
            "--html".into(),
            page.to_str().unwrap().into(),
            "--record".into(),
            rec.to_str().unwrap().into(),
        ];
        if json {
            args.push("--json".into());
        }
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_lcpbench"))
            .args(&args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        (
            String::from_utf8(o.stdout).unwrap(),
            String::from_utf8(o.stderr).unwrap(),
        )
    };
    let (out, _) = run(false);
    let lines: Vec<&str> = out.lines().collect();
    let n = lines.len();
    assert_eq!(
        lines[n - 1],
        format!(
            "wrote {} ({:.1} kB)",
            page.display(),
            std::fs::metadata(&page).unwrap().len() as f64 / 1e3
        )
    );
    assert_eq!(lines[n - 2], format!("wrote {} (recording)", rec.display()));
    assert!(out.contains("steps of 1/100 s (10 ms)"), "{out}");
    assert!(out.contains("cone violation    max "), "{out}");
    assert!(out.contains("time per step     mean "), "{out}");
    let (out, err) = run(true);
    serde_json::from_str::<serde_json::Value>(&out).expect("stdout is one JSON document");
    assert!(err.contains(&format!("wrote {}", page.display())), "{err}");
}

/// `--stepping timewarp` on the bouncing balls: every analytic impact located to round-off in
/// the JSON summary; the 60 Hz fixed step misses by a good part of a step. `--dt` keeps the
/// scene's duration; bad modes and a Timewarp scene with events are refused by name.
#[test]
fn simulate_stepping_modes_report_their_impact_figures() {
    let json = |args: &[&str]| -> serde_json::Value {
        let o = lcpbench(args);
        assert!(o.status.success(), "{}", text(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let scene = "bench_scenes/impact/bouncing_10.toml";
    let tw = json(&["simulate", scene, "--stepping", "timewarp", "--json"]);
    assert_eq!(tw["stepping"], "timewarp");
    let d = &tw["discontinuity"];
    assert_eq!(d["missed_impacts"], 0);
    assert!(d["analytic_impacts"].as_u64().unwrap() >= 10);
    assert!(d["impact_time_error_max"].as_f64().unwrap() < 1e-9, "{d}");
    assert_eq!(d["tunnelling"], 0);
    let fixed = json(&["simulate", scene, "--dt", "0.004", "--json"]);
    assert_eq!(fixed["steps"], 500);
    assert_eq!(fixed["stepping"], "fixed");
    assert!(
        fixed["discontinuity"]["impact_time_error_max"]
            .as_f64()
            .unwrap()
            > 1e-4
    );
    let ccd = json(&["simulate", scene, "--ccd", "bisection", "--json"]);
    assert_eq!(ccd["stepping"], "bisection");

    let o = lcpbench(&["simulate", scene, "--stepping", "warp"]);
    assert!(!o.status.success());
    assert!(text(&o.stderr).contains("--stepping: unknown stepping \"warp\""));
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/heavy_removed.toml",
        "--stepping",
        "timewarp",
    ]);
    // Scheduled events tie the scene to one clock: Timewarp runs it as one group, the fixed
    // step, says so, and gives the fixed step's trajectory.
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("runs the scene as one group"),
        "{}",
        text(&o.stderr)
    );
    let warped = json(&[
        "simulate",
        "bench_scenes/heavy_removed.toml",
        "--stepping",
        "timewarp",
        "--steps",
        "150",
        "--json",
    ]);
    let fixed = json(&[
        "simulate",
        "bench_scenes/heavy_removed.toml",
        "--steps",
        "150",
        "--json",
    ]);
    assert_eq!(warped["final_energy"], fixed["final_energy"]);
    assert_eq!(warped["max_displacement"], fixed["max_displacement"]);
}

/// `--residual sample=4` over 11 steps of a resting box (contacts every step) measures steps 0,
/// 4, 8 and the last, 10, and no other, for a body-level, a substepping and a matrix solver:
/// an unmeasured step has no residual and is never `converged`, and the summary counts the
/// measured steps. `--no-residuals` is `--residual none`; a schedule that does not parse is
/// refused naming the option.
#[test]
fn a_residual_sample_measures_the_multiples_and_the_last_step_only() {
    let dir = tempfile::tempdir().unwrap();
    let run = |solver: &str, schedule: &[&str]| -> (serde_json::Value, Vec<serde_json::Value>) {
        let rec = dir.path().join(format!("{solver}.jsonl"));
        let mut args = vec![
            "simulate",
            "bench_scenes/box_on_ground.toml",
            "--solver",
            solver,
            "--steps",
            "11",
            "--json",
            "--record",
            rec.to_str().unwrap(),
        ];
        args.extend_from_slice(schedule);
        let o = lcpbench(&args);
        assert!(o.status.success(), "{solver}: {}", text(&o.stderr));
        let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let steps = std::fs::read_to_string(&rec)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        (summary, steps)
    };
    for solver in ["si", "soft-step", "pgs"] {
        let (summary, steps) = run(solver, &["--residual", "sample=4"]);
        assert_eq!(steps.len(), 11);
        let measured: Vec<u64> = steps
            .iter()
            .filter(|s| s["residual_measured"] == true)
            .map(|s| s["step"].as_u64().unwrap())
            .collect();
        assert_eq!(measured, [0, 4, 8, 10], "{solver}");
        for s in &steps {
            assert!(s["contacts"].as_u64().unwrap() > 0, "{s}");
            if s["residual_measured"] == true {
                assert!(s["residuals"]["natural_map_rel"].is_number(), "{s}");
            } else {
                assert!(s["residuals"].is_null(), "{s}");
                assert_ne!(s["status"]["status"], "converged", "{solver}: {s}");
            }
        }
        assert_eq!(summary["steps_measured"], 4, "{summary}");
        assert_eq!(summary["residual_schedule"], "sample=4", "{summary}");
    }
    let (none, steps) = run("si", &["--no-residuals"]);
    assert_eq!(none["steps_measured"], 0, "{none}");
    assert_eq!(none["residual_schedule"], "none", "{none}");
    assert!(steps.iter().all(|s| s["status"]["status"] != "converged"));
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/box_on_ground.toml",
        "--residual",
        "sample=0",
    ]);
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(
        err.contains("--residual") && err.contains("sample=K"),
        "{err}"
    );
}
