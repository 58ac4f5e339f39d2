//! Hostile numbers, seen from outside: friction coefficients that blind the cone residual,
//! warm starts that overflow, vectors whose norm overflows. Each ends in a refusal naming the
//! file, field and limit, or in an honest status checked here independently.

use faer::Mat;
use lcpbench_solvers::{
    parse_cone_problem, read_problem, write_fclib_local, ConeProblem, ConeSolverKind, Settings,
    MAX_FILE_MU,
};
use std::path::Path;
use std::process::{Command, Output};

fn lcpbench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lcpbench"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A refusal: exit status 1, a last line `error: …` holding every `wanted` piece, no panic.
#[track_caller]
fn assert_refused(o: &Output, wanted: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "expected a refusal, got:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    let last = err.lines().last().unwrap_or_default();
    assert!(last.starts_with("error: "), "{err}");
    for w in wanted {
        assert!(last.contains(w), "`{w}` missing from:\n{err}");
    }
}

/// One contact, `W = 0.5 I`, `q = (-0.16, 0.08, 0)`: pressed into the obstacle and pushed
/// sideways. Its solution sticks (`u = 0`, `r = (0.32, -0.16, 0)`) for every `mu >= 0.5`.
fn pressed_contact(mu: f64) -> ConeProblem {
    let w = Mat::from_fn(3, 3, |i, j| if i == j { 0.5 } else { 0.0 });
    ConeProblem::new(w, vec![-0.16, 0.08, 0.0], vec![mu]).unwrap()
}

const PRESSED_JSON: &str = r#"{"W":[[0.5,0,0],[0,0.5,0],[0,0,0.5]],"q":[-0.16,0.08,0],"mu":[MU]}"#;

#[test]
fn no_cone_solver_converges_with_a_penetrating_normal_velocity() {
    // The normal velocity and the magnitudes of each row's terms are computed here from W and
    // q, not by the library. A converged answer may leave `u_N` negative only by the tolerance
    // times the contact's terms (the normal row's and the tangent rows', with a margin of 2).
    let w = [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.5]];
    let q = [-0.16, 0.08, 0.0];
    for mu in [0.5, 1e3, 1e4, 1e5] {
        let p = pressed_contact(mu);
        for tol in [1e-6, 1e-8, 1e-10] {
            let settings = Settings {
                tolerance: tol,
                max_iterations: 2000,
                ..Settings::default()
            };
            for kind in ConeSolverKind::all() {
                let r = kind.create().solve_cone(&p, &settings);
                if !r.status.is_converged() {
                    continue;
                }
                let mut u = [0.0; 3];
                let mut t = [0.0; 3];
                for i in 0..3 {
                    u[i] = q[i] + (0..3).map(|j| w[i][j] * r.f[j]).sum::<f64>();
                    t[i] = q[i].abs() + (0..3).map(|j| (w[i][j] * r.f[j]).abs()).sum::<f64>();
                }
                let allowed = 2.0 * tol * (t[0] + t[1] + t[2]);
                assert!(
                    u[0] >= -allowed,
                    "{} at mu = {mu:e}, tol = {tol:e}: converged with u_N = {:e} (r = {:?})",
                    kind.name(),
                    u[0],
                    r.f
                );
                assert!(r.f[0] >= -allowed, "{} at mu = {mu:e}", kind.name());
            }
        }
    }
    // The problem is not beyond reach: at mu = 0.5 the exact sticking answer is found.
    let settings = Settings {
        tolerance: 1e-10,
        ..Settings::default()
    };
    let r = ConeSolverKind::NsgsCone
        .create()
        .solve_cone(&pressed_contact(0.5), &settings);
    assert!(r.status.is_converged(), "{:?}", r.status);
    assert!((r.f[0] - 0.32).abs() < 1e-8 && (r.f[1] + 0.16).abs() < 1e-8);
}

#[test]
fn a_blind_cone_residual_gives_a_stalled_status_with_the_reason() {
    // At mu = 1e5, r = 0 meets a tolerance of 1e-8 on the cone residual alone.
    let p = pressed_contact(1e5);
    let res = lcpbench_solvers::cone_residuals(&p, &[0.0; 3]);
    assert!(res.natural_map_rel < 1e-8, "{res:?}");
    let settings = Settings {
        tolerance: 1e-8,
        ..Settings::default()
    };
    let r = ConeSolverKind::NsgsCone.create().solve_cone(&p, &settings);
    if r.f == [0.0; 3] {
        let s = r.status.to_string();
        assert!(!r.status.is_converged(), "{s}");
        assert!(s.contains("normal complementarity"), "{s}");
    }
}

#[test]
fn problem_files_refuse_friction_above_the_limit_in_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(MAX_FILE_MU, 1e3);
    // Cone JSON.
    let json = |mu: &str| PRESSED_JSON.replace("MU", mu);
    assert!(parse_cone_problem(&json("1000"), Path::new("c.json")).is_ok());
    let e = parse_cone_problem(&json("1e5"), Path::new("c.json"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("c.json: field `mu[0]`: contact 0: mu = 1e5") && e.contains("at most 1e3"),
        "{e}"
    );
    // Siconos friction-contact `.dat`: d = 3, two contacts, M = 0.5 I dense, q, mu.
    let dat = |mu: &str| {
        let mut s = String::from("3\n2\n0\n6\n6\n6 6\n");
        for i in 0..6 {
            let row: Vec<&str> = (0..6).map(|j| if i == j { "0.5" } else { "0" }).collect();
            s += &(row.join(" ") + "\n");
        }
        s + "-0.16 0.08 0 -0.16 0.08 0\n0.5 " + mu + "\n"
    };
    let ok = dir.path().join("ok.dat");
    std::fs::write(&ok, dat("1000")).unwrap();
    assert!(read_problem(&ok).is_ok());
    let bad = dir.path().join("bad.dat");
    std::fs::write(&bad, dat("1e5")).unwrap();
    let e = read_problem(&bad).unwrap_err().to_string();
    assert!(
        e.contains("bad.dat: field `mu[1]`: contact 1: mu = 1e5") && e.contains("at most 1e3"),
        "{e}"
    );
    // FCLIB HDF5 (local form).
    let w = faer::sparse::SparseColMat::<usize, f64>::try_new_from_triplets(
        3,
        3,
        &[
            faer::sparse::Triplet::new(0, 0, 0.5),
            faer::sparse::Triplet::new(1, 1, 0.5),
            faer::sparse::Triplet::new(2, 2, 0.5),
        ],
    )
    .unwrap();
    let h5 = dir.path().join("bad.hdf5");
    write_fclib_local(&h5, 3, &w, &[-0.16, 0.08, 0.0], &[1e5]).unwrap();
    let e = read_problem(&h5).unwrap_err().to_string();
    assert!(
        e.contains("field `/fclib_local/vectors/mu[0]`: contact 0: mu = 1e5")
            && e.contains("at most 1e3"),
        "{e}"
    );
    // The command line says the same, without a panic.
    let cone = dir.path().join("cone.json");
    std::fs::write(&cone, json("1e5")).unwrap();
    let o = lcpbench(&["solve", cone.to_str().unwrap(), "--solver", "nsgs-cone"]);
    assert_refused(&o, &["cone.json", "mu[0]", "1e3"]);
}

/// A small joint problem (two free rows coupled, one contact row), stored sparse so that the
/// pivoting and Newton solvers split it into islands.
const JOINT_WARM: &str = r#"{"A":{"n":3,"triplets":[[0,0,2],[0,1,1],[1,0,1],[1,1,2],[2,2,1]]},"b":[-1,0.5,-1],"lo":[null,null,0],"hi":[null,null,null],"warm_start":[WS]}"#;

#[test]
fn an_overflowing_warm_start_is_refused_and_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("joint.json");
    std::fs::write(&file, JOINT_WARM.replace("WS", "1e308,1e308,1e308")).unwrap();
    let path = file.to_str().unwrap();
    for solver in ["newton-fb", "newton-min", "dantzig", "lemke", "pgs"] {
        let o = lcpbench(&["solve", path, "--solver", solver, "--warm"]);
        assert_refused(&o, &["joint.json", "warm_start[0] = 1e308", "overflows"]);
    }
    // The library, given the same start without the command line's check, ends with a status.
    let p = read_problem(&file).unwrap();
    let settings = Settings {
        warm_start: Some(vec![1e308; 3]),
        ..Settings::default()
    };
    for kind in lcpbench_solvers::SolverKind::all() {
        let r = kind.create().solve(&p, &settings);
        assert_eq!(r.f.len(), 3, "{}", kind.name());
        if r.status.is_converged() {
            let w = p.velocity(&r.f);
            assert!(w.iter().all(|v| v.is_finite()), "{}", kind.name());
        }
    }
    // A warm start of the problem's size is used.
    std::fs::write(&file, JOINT_WARM.replace("WS", "0.5,0.1,1")).unwrap();
    let o = lcpbench(&["solve", path, "--solver", "newton-fb", "--warm"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A door on a hinge, with `AXIS`, `ANCHOR` and `VELOCITY` to fill in.
const DOOR: &str = r#"name = "door"
[settings]
dt = 0.01
steps = 2
solver = "pgs"

[[bodies]]
name = "door"
shape = { type = "box", half_extents = [0.5, 0.05, 1.0] }
position = [0.5, 0.0, 1.0]
velocity = VELOCITY

[[joints]]
type = "hinge"
bodies = ["world", "door"]
anchor = ANCHOR
axis = AXIS
"#;

#[test]
fn scene_vectors_whose_length_overflows_are_refused_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |axis: &str, anchor: &str, velocity: &str| {
        let p = dir.path().join("door.toml");
        let text = DOOR
            .replace("AXIS", axis)
            .replace("ANCHOR", anchor)
            .replace("VELOCITY", velocity);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let ok = scene("[0.0, 0.0, 1.0]", "[0.0, 0.0, 1.0]", "[0.0, 0.0, 0.0]");
    let o = lcpbench(&["simulate", &ok, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let huge = "[1e308, 1e308, 1e308]";
    let o = lcpbench(&[
        "simulate",
        &scene(huge, "[0.0, 0.0, 1.0]", "[0.0, 0.0, 0.0]"),
    ]);
    assert_refused(&o, &["door.toml", "axis", "length overflows"]);
    let o = lcpbench(&[
        "simulate",
        &scene("[0.0, 0.0, 1.0]", "[0.0, 0.0, 1.0]", huge),
    ]);
    assert_refused(&o, &["door.toml", "velocity", "at most"]);
}

#[test]
fn view_shows_a_cone_file_through_its_contact_triples() {
    // A cone file is not read as an LCP (which would say "missing field `A`"): the solve page
    // shows it through its box form, and the cone solvers run on its contact triples.
    let dir = tempfile::tempdir().unwrap();
    let cone = dir.path().join("cone.json");
    std::fs::write(&cone, PRESSED_JSON.replace("MU", "0.5")).unwrap();
    let out = dir.path().join("c.html");
    let o = lcpbench(&["view", cone.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = std::fs::read_to_string(&out).unwrap();
    assert!(page.contains("nsgs-cone"), "the page runs the cone solvers");
    assert!(!stderr(&o).contains("missing field"), "{}", stderr(&o));
}

#[test]
fn names_are_isolated_and_strides_are_ordinals_in_pages() {
    let dir = tempfile::tempdir().unwrap();
    let name = "door\u{202E}reversed";
    let scene = dir.path().join("rtl.toml");
    let text = DOOR
        .replace(
            "name = \"door\"\n[settings]",
            &format!("name = \"{name}\"\n[settings]"),
        )
        .replace("AXIS", "[0.0, 0.0, 1.0]")
        .replace("ANCHOR", "[0.0, 0.0, 1.0]")
        .replace("VELOCITY", "[0.0, 0.0, 0.0]");
    std::fs::write(&scene, text).unwrap();
    let html = dir.path().join("rtl.html");
    let o = lcpbench(&[
        "simulate",
        scene.to_str().unwrap(),
        "--html",
        html.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = std::fs::read_to_string(&html).unwrap();
    let title = page
        .split("<title>")
        .nth(1)
        .and_then(|t| t.split("</title>").next())
        .unwrap();
    assert!(
        title.starts_with(&format!("\u{2068}{name}\u{2069} · ")),
        "{title:?}"
    );
    // The scripts isolate the names they show and write strides as ordinals.
    assert!(page.contains("function iso(name)"));
    assert!(page.contains("iso(RUNS[0].scene)"));
    assert!(page.contains("every ${ordinal(r.stride)} of"));
    assert!(!page.contains("${r.stride}th"));
}

#[test]
fn a_warm_started_cone_export_carries_its_warm_start() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cone.json");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/bench_scenes/diagonal_push.toml"
    );
    let o = lcpbench(&[
        "export",
        scene,
        "--friction-model",
        "cone",
        "--solver",
        "nsgs-cone+warm",
        "--step",
        "5",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("with its warm start"));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    let ws = v["warm_start"].as_array().expect("warm_start");
    assert_eq!(ws.len(), v["q"].as_array().unwrap().len());
    // The previous step's reactions: not all zero on a resting, pushed block.
    assert!(ws.iter().any(|x| x.as_f64().unwrap() != 0.0), "{ws:?}");
    let o = lcpbench(&[
        "solve",
        out.to_str().unwrap(),
        "--solver",
        "nsgs-cone",
        "--warm",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn view_of_a_far_scene_step_keeps_to_its_time_budget() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("far.html");
    let case = concat!(
        "step:",
        env!("CARGO_MANIFEST_DIR"),
        "/bench_scenes/tower_5.toml?step=999999"
    );
    // Reaching step 999,999 of tower_5 takes minutes; the budget covers it.
    let o = lcpbench(&[
        "view",
        case,
        "--time-budget",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_refused(&o, &["step 999999", "time budget ran out after simulating"]);
    assert!(!out.exists());
}

#[test]
fn the_smallest_max_bytes_is_below_what_a_real_page_needs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("door.toml");
    let text = DOOR
        .replace("AXIS", "[0.0, 0.0, 1.0]")
        .replace("ANCHOR", "[0.0, 0.0, 1.0]")
        .replace("VELOCITY", "[0.0, 0.0, 0.0]");
    std::fs::write(&scene, text).unwrap();
    let rec = dir.path().join("door.jsonl");
    let o = lcpbench(&[
        "simulate",
        scene.to_str().unwrap(),
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = dir.path().join("door.html");
    let o = lcpbench(&["view", rec.to_str().unwrap(), "-o", page.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let size = std::fs::metadata(&page).unwrap().len();
    // The page's own size is an acceptable bound: the floor is below every real page.
    std::fs::remove_file(&page).unwrap();
    let o = lcpbench(&[
        "view",
        rec.to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
        "--max-bytes",
        &size.to_string(),
    ]);
    assert!(o.status.success(), "{size}: {}", stderr(&o));
    assert!(std::fs::metadata(&page).unwrap().len() <= size);
    // The floor says what it is made of.
    let o = lcpbench(&[
        "view",
        rec.to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
        "--max-bytes",
        "1000",
    ]);
    assert_refused(&o, &["--max-bytes must be at least"]);
}

#[test]
fn repeated_solves_keep_to_the_time_budget_together() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("spd.json");
    let f = file.to_str().unwrap();
    let o = lcpbench(&[
        "gen", "spd", "--n", "50", "--cond", "1e3", "--seed", "1", "-o", f,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A million solves of a 50-row problem take far longer than half a second; the budget
    // stops the repeats, and the output says how many ran.
    let o = lcpbench(&[
        "solve",
        f,
        "--solver",
        "pgs",
        "--repeat",
        "1000000",
        "--time-budget",
        "0.5",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["repeat"], 1_000_000);
    let solves = v["timed_solves"].as_u64().unwrap();
    assert!((1..1_000_000).contains(&solves), "{v}");
}
