//! `lcpbench view` and `simulate --html` seen from outside (no browser needed).

use std::process::{Command, Output};

fn lcpbench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lcpbench"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

/// The JSON data embedded in a page.
fn page_data(html: &str) -> serde_json::Value {
    let start = html
        .find("id=\"lcpbench-data\" type=\"application/json\">")
        .unwrap();
    let rest = &html[start..];
    let open = rest.find('>').unwrap() + 1;
    let close = rest.find("</script>").unwrap();
    serde_json::from_str(&rest[open..close].replace("<\\/", "</")).unwrap()
}

#[test]
fn long_runs_are_decimated_under_the_size_bound() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("drop.jsonl");
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/ball_drop.toml",
        "--steps",
        "1000",
        "--history",
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let full = dir.path().join("full.html");
    let small = dir.path().join("small.html");
    let max = 780_000;
    for (page, bound) in [(&full, 50_000_000), (&small, max)] {
        let o = lcpbench(&[
            "view",
            rec.to_str().unwrap(),
            "-o",
            page.to_str().unwrap(),
            "--max-bytes",
            &bound.to_string(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let full = std::fs::read_to_string(full).unwrap();
    let small = std::fs::read_to_string(small).unwrap();
    let (df, ds) = (page_data(&full), page_data(&small));
    assert_eq!(df["runs"][0]["stride"], 1);
    assert_eq!(df["runs"][0]["frames"].as_array().unwrap().len(), 1000);
    let stride = ds["runs"][0]["stride"].as_u64().unwrap();
    assert!(stride > 1, "no decimation at {} bytes", full.len());
    assert!(
        small.len() <= max,
        "{} bytes over the bound {max}",
        small.len()
    );
    // Every step stays in the plots; the last step stays in the frames.
    assert_eq!(
        ds["runs"][0]["series"]["step"].as_array().unwrap().len(),
        1000
    );
    let frames = ds["runs"][0]["frames"].as_array().unwrap();
    assert_eq!(frames.last().unwrap()["step"], 999);
    // Histories (PGS, the scene's solver) are recorded per step.
    let frames = df["runs"][0]["frames"].as_array().unwrap();
    assert!(frames.iter().any(|f| f["history"]["res"].is_array()));
}

/// A joint scene's frames carry their joints (10 numbers each) and still fit the size bound; a
/// contact-only scene's carry none.
#[test]
fn joint_runs_are_decimated_under_the_size_bound_with_their_joints() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("chain.jsonl");
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/joints/chain_20_1e3.toml",
        "--solver",
        "dantzig",
        "--steps",
        "300",
        "--record",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let max = 750_000;
    let page = dir.path().join("chain.html");
    let o = lcpbench(&[
        "view",
        rec.to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
        "--max-bytes",
        &max.to_string(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = std::fs::read_to_string(page).unwrap();
    assert!(
        html.len() <= max,
        "{} bytes over the bound {max}",
        html.len()
    );
    let run = &page_data(&html)["runs"][0];
    assert!(run["stride"].as_u64().unwrap() > 1, "no decimation");
    let joints = std::fs::read_to_string(&rec)
        .unwrap()
        .lines()
        .nth(1)
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["joints"].clone())
        .unwrap();
    let joints = joints.as_u64().unwrap() as usize;
    assert!(joints > 0);
    for frame in run["frames"].as_array().unwrap() {
        assert_eq!(frame["joints"].as_array().unwrap().len(), 10 * joints);
    }
    assert_eq!(run["series"]["joint_drift"].as_array().unwrap().len(), 300);

    let page = dir.path().join("box.html");
    let o = lcpbench(&[
        "simulate",
        "bench_scenes/box_on_ground.toml",
        "--steps",
        "5",
        "--html",
        page.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let data = page_data(&std::fs::read_to_string(page).unwrap());
    let run = &data["runs"][0];
    assert!(run["frames"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f.get("joints").is_none()));
    assert!(run["series"].get("joint_drift").is_none());
}

#[test]
fn problem_page_holds_every_solver_and_case_keys_work() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("case.html");
    let o = lcpbench(&[
        "view",
        "spd:n=12:cond=1e2:seed=2",
        "-o",
        page.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d = page_data(&std::fs::read_to_string(page).unwrap());
    assert_eq!(d["kind"], "problem");
    assert_eq!(d["n"], 12);
    let solvers = d["solvers"].as_array().unwrap();
    assert_eq!(solvers.len(), lcpbench_solvers::SolverKind::all().len());
    // An SPD LCP: every solver that converges agrees on f.
    let converged: Vec<&serde_json::Value> = solvers
        .iter()
        .filter(|s| s["status"] == "converged")
        .collect();
    assert!(converged.len() >= 4);
    for s in &converged {
        for i in 0..12 {
            let (a, b) = (
                s["f"][i].as_f64().unwrap(),
                converged[0]["f"][i].as_f64().unwrap(),
            );
            assert!(
                (a - b).abs() <= 1e-5 * (1.0 + b.abs()),
                "{} row {i}",
                s["name"]
            );
        }
    }
}

#[test]
fn bad_inputs_give_one_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.html");
    let o = lcpbench(&["view", "no-such-file.jsonl", "-o", out.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no-such-file.jsonl"), "{err}");
    // Two recordings of different scenes cannot be compared.
    let mut recs = Vec::new();
    for scene in ["box_on_ground", "ball_drop"] {
        let rec = dir.path().join(format!("{scene}.jsonl"));
        let o = lcpbench(&[
            "simulate",
            &format!("bench_scenes/{scene}.toml"),
            "--steps",
            "3",
            "--record",
            rec.to_str().unwrap(),
        ]);
        assert!(o.status.success());
        recs.push(rec);
    }
    let o = lcpbench(&[
        "view",
        recs[0].to_str().unwrap(),
        recs[1].to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("different scenes"));
    assert!(!out.exists());
}
