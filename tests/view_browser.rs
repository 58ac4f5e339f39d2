//! Generated pages opened in headless Chromium: they load without errors, draw something, move
//! with the timeline, and draw as many contact markers as the recording has contacts (and two
//! markers per joint).
//!
//! Needs Debian's `chromium` (`apt-get install chromium`); without it each test says so and
//! returns. `LCPBENCH_CHROMIUM` names another binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("LCPBENCH_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"));
    if path.exists() {
        Some(path)
    } else {
        eprintln!("chromium not found: skipping (apt-get install chromium)");
        None
    }
}

fn lcpbench(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_lcpbench"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs");
    assert!(
        o.status.success(),
        "lcpbench {args:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Run headless Chromium on `url` with `extra` flags; returns stdout.
fn run_chromium(browser: &Path, extra: &[String], url: &str) -> String {
    let profile = tempfile::tempdir().unwrap();
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--hide-scrollbars",
            "--window-size=1200,900",
            "--virtual-time-budget=15000",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(extra)
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromium starts");
    let start = Instant::now();
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stdout, &mut s).ok();
        s
    });
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(120) {
            child.kill().ok();
            panic!("chromium did not finish within 120 s on {url}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    reader.join().unwrap()
}

fn url(page: &Path, hash: &str) -> String {
    format!("file://{}{hash}", page.display())
}

/// Page state after load: the attributes of `#lcpbench-state` and the error text.
struct PageState {
    attrs: std::collections::HashMap<String, String>,
    errors: String,
}

impl PageState {
    fn get(&self, key: &str) -> &str {
        self.attrs
            .get(key)
            .map(String::as_str)
            .unwrap_or_else(|| panic!("no data-{key} in the page state: {:?}", self.attrs))
    }
}

fn page_state(browser: &Path, page: &Path, hash: &str) -> PageState {
    let dom = run_chromium(browser, &["--dump-dom".into()], &url(page, hash));
    let start = dom
        .find("id=\"lcpbench-state\"")
        .expect("the page has its state element");
    let tag_start = dom[..start].rfind('<').unwrap();
    let tag = &dom[tag_start..tag_start + dom[tag_start..].find('>').unwrap()];
    let mut attrs = std::collections::HashMap::new();
    for part in tag.split(" data-").skip(1) {
        if let Some((k, v)) = part.split_once("=\"") {
            attrs.insert(k.to_string(), v.split('"').next().unwrap().to_string());
        }
    }
    let errors = dom
        .find("id=\"lcpbench-errors\"")
        .map(|i| {
            let rest = &dom[i..];
            let open = rest.find('>').unwrap() + 1;
            let close = rest.find("</pre>").unwrap();
            rest[open..close].to_string()
        })
        .unwrap_or_default();
    PageState { attrs, errors }
}

/// RGB pixels of a screenshot.
struct Shot {
    width: usize,
    height: usize,
    rgb: Vec<[u8; 3]>,
}

fn screenshot(browser: &Path, page: &Path, hash: &str, dir: &Path, name: &str) -> Shot {
    let png = dir.join(name);
    run_chromium(
        browser,
        &[format!("--screenshot={}", png.display())],
        &url(page, hash),
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let rgb = buf[..info.buffer_size()]
        .chunks(channels)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    Shot {
        width: info.width as usize,
        height: info.height as usize,
        rgb,
    }
}

impl Shot {
    /// Pixels of the 3-D view region (below the header, above the controls).
    fn view_region(&self) -> Vec<[u8; 3]> {
        let mut out = Vec::new();
        for y in 90..(self.height.min(330)) {
            for x in 20..(self.width - 20) {
                out.push(self.rgb[y * self.width + x]);
            }
        }
        out
    }
}

/// Pixels with a clear hue (bodies are drawn in saturated colours, the background is white and
/// the ground grey).
fn saturated(pixels: &[[u8; 3]]) -> usize {
    pixels
        .iter()
        .filter(|p| {
            let max = *p.iter().max().unwrap() as i32;
            let min = *p.iter().min().unwrap() as i32;
            max - min > 40
        })
        .count()
}

fn distinct(pixels: &[[u8; 3]]) -> usize {
    pixels
        .iter()
        .collect::<std::collections::HashSet<_>>()
        .len()
}

/// The recording's contact count at `step` (line 0 is the header).
fn recorded_contacts(recording: &Path, step: usize) -> usize {
    let text = std::fs::read_to_string(recording).unwrap();
    let line = text
        .lines()
        .skip(1)
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|v| v["step"] == step)
        .expect("the step is recorded");
    line["contact_records"].as_array().unwrap().len()
}

fn assert_no_errors(state: &PageState) {
    assert!(
        state.errors.trim().is_empty(),
        "the page reported errors:\n{}",
        state.errors
    );
    assert_eq!(state.get("ready"), "1", "the page did not finish loading");
}

#[test]
fn tower_replay_loads_draws_and_shows_the_recorded_contacts() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("tower.html");
    let rec = dir.path().join("tower.jsonl");
    lcpbench(&[
        "simulate",
        "bench_scenes/tower_10.toml",
        "--solver",
        "dantzig",
        "--steps",
        "40",
        "--record",
        rec.to_str().unwrap(),
        "--html",
        page.to_str().unwrap(),
    ]);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(!html.contains("src=\"http"), "the page fetches nothing");
    for step in [0usize, 30] {
        let state = page_state(&browser, &page, &format!("#step={step}"));
        assert_no_errors(&state);
        assert_eq!(state.get("step"), step.to_string());
        assert_eq!(state.get("frame-step"), step.to_string());
        let expected = recorded_contacts(&rec, step);
        assert!(expected > 0, "the tower has contacts at step {step}");
        assert_eq!(state.get("markers"), expected.to_string(), "step {step}");
    }
    let shot = screenshot(&browser, &page, "#step=30", dir.path(), "tower.png");
    let region = shot.view_region();
    assert!(distinct(&region) > 20, "the 3-D view is blank");
    assert!(
        saturated(&region) > 500,
        "no coloured bodies in the 3-D view"
    );
}

/// The recording's joint count at `step`.
fn recorded_joints(recording: &Path, step: usize) -> usize {
    let text = std::fs::read_to_string(recording).unwrap();
    let line = text
        .lines()
        .skip(1)
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|v| v["step"] == step)
        .expect("the step is recorded");
    line["joint_records"].as_array().map_or(0, Vec::len)
}

#[test]
fn joint_replay_draws_both_anchors_of_each_joint_and_hides_them_on_request() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("chain.html");
    let rec = dir.path().join("chain.jsonl");
    lcpbench(&[
        "simulate",
        "bench_scenes/joints/chain_20_1e3.toml",
        "--solver",
        "dantzig",
        "--steps",
        "10",
        "--record",
        rec.to_str().unwrap(),
        "--html",
        page.to_str().unwrap(),
    ]);
    let joints = recorded_joints(&rec, 5);
    assert!(joints > 0, "the chain has joints");
    let state = page_state(&browser, &page, "#step=5");
    assert_no_errors(&state);
    assert_eq!(state.get("joints"), joints.to_string());
    assert_eq!(state.get("joint-markers"), (2 * joints).to_string());
    // The joints toggle, off from the URL: the joints are still counted, none drawn.
    let state = page_state(&browser, &page, "#step=5&hide=joints");
    assert_no_errors(&state);
    assert_eq!(state.get("joints"), joints.to_string());
    assert_eq!(state.get("joint-markers"), "0");
}

#[test]
fn timeline_moves_the_scene() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("drop.html");
    lcpbench(&[
        "simulate",
        "bench_scenes/ball_drop.toml",
        "--steps",
        "400",
        "--html",
        page.to_str().unwrap(),
    ]);
    let a = screenshot(&browser, &page, "#step=0", dir.path(), "a.png");
    let b = screenshot(&browser, &page, "#step=399", dir.path(), "b.png");
    let (ra, rb) = (a.view_region(), b.view_region());
    let changed = ra.iter().zip(&rb).filter(|(p, q)| p != q).count();
    assert!(
        changed > 200,
        "steps 0 and 399 look the same ({changed} pixels differ)"
    );
}

#[test]
fn two_recordings_side_by_side() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut recs = Vec::new();
    for solver in ["dantzig", "pgs"] {
        let rec = dir.path().join(format!("{solver}.jsonl"));
        lcpbench(&[
            "simulate",
            "bench_scenes/pyramid_5.toml",
            "--solver",
            solver,
            "--steps",
            "30",
            "--history",
            "--record",
            rec.to_str().unwrap(),
        ]);
        recs.push(rec);
    }
    let page = dir.path().join("cmp.html");
    lcpbench(&[
        "view",
        recs[0].to_str().unwrap(),
        recs[1].to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
    ]);
    let state = page_state(&browser, &page, "#step=20");
    assert_no_errors(&state);
    assert_eq!(state.get("runs"), "2");
    assert_eq!(
        state.get("markers"),
        recorded_contacts(&recs[0], 20).to_string()
    );
    assert_eq!(
        state.get("markers1"),
        recorded_contacts(&recs[1], 20).to_string()
    );
    let shot = screenshot(&browser, &page, "#step=20", dir.path(), "cmp.png");
    // Both halves draw bodies.
    let half = |left: bool| {
        let mut n = 0;
        for y in 90..330.min(shot.height) {
            for x in 0..shot.width / 2 {
                let x = if left { x } else { x + shot.width / 2 };
                let p = shot.rgb[y * shot.width + x];
                if (*p.iter().max().unwrap() as i32 - *p.iter().min().unwrap() as i32) > 40 {
                    n += 1;
                }
            }
        }
        n
    };
    assert!(
        half(true) > 200 && half(false) > 200,
        "one of the views is empty"
    );
}

#[test]
fn problem_page_shows_every_solver() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let problem = dir.path().join("spd.json");
    lcpbench(&[
        "gen",
        "spd",
        "--n",
        "30",
        "--cond",
        "1e3",
        "--seed",
        "3",
        "-o",
        problem.to_str().unwrap(),
    ]);
    let page = dir.path().join("spd.html");
    lcpbench(&[
        "view",
        problem.to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
    ]);
    let state = page_state(&browser, &page, "");
    assert_no_errors(&state);
    assert_eq!(
        state.get("solvers"),
        lcpbench_solvers::SolverKind::all().len().to_string()
    );
    assert_eq!(state.get("rows"), "30");
    let plotted: usize = state.get("plotted").parse().unwrap();
    assert!(plotted >= 3, "only {plotted} convergence curves");
    let shot = screenshot(&browser, &page, "", dir.path(), "spd.png");
    assert!(distinct(&shot.rgb) > 20, "the page is blank");
    assert!(saturated(&shot.rgb) > 300, "no coloured curves");
}

/// A scene and body named `<!--<script>` once left the HTML parser in its double-escaped script
/// state: the page drew no canvas and no plots. Now it loads and draws like any other.
#[test]
fn hostile_names_leave_the_page_working() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let name = "<!--<script>{{DATA}}";
    let scene = std::fs::read_to_string("bench_scenes/box_on_ground.toml").unwrap();
    let scene = format!(
        "{}\n",
        scene
            .replacen("name = \"box_on_ground\"", &format!("name = {name:?}"), 1)
            .replacen("name = \"box\"", &format!("name = \"{name} box\""), 1)
    );
    assert!(
        scene.contains("{{DATA}} box"),
        "the body is renamed:\n{scene}"
    );
    let path = dir.path().join("hostile.toml");
    std::fs::write(&path, scene).unwrap();
    let page = dir.path().join("hostile.html");
    lcpbench(&[
        "simulate",
        path.to_str().unwrap(),
        "--steps",
        "20",
        "--html",
        page.to_str().unwrap(),
    ]);
    let state = page_state(&browser, &page, "#step=10");
    assert_no_errors(&state);
    assert_eq!(state.get("step"), "10");
    let shot = screenshot(&browser, &page, "#step=10", dir.path(), "hostile.png");
    assert!(distinct(&shot.view_region()) > 20, "the 3-D view is blank");
}

/// Pixels of the tolerance line's colour (`#f0147a`, used by no curve), within a few units.
fn tolerance_pixels(shot: &Shot) -> usize {
    shot.rgb
        .iter()
        .filter(|p| {
            (p[0] as i32 - 0xf0).abs() < 12
                && (p[1] as i32 - 0x14).abs() < 12
                && (p[2] as i32 - 0x7a).abs() < 12
        })
        .count()
}

/// Every plot of a replay page keeps its tick labels inside the canvas, no axis repeats a
/// label (the energy of a resting box varies in its sixth digit), the residual plots draw the
/// tolerance line, and the header gives the step as a fraction and in milliseconds.
#[test]
fn replay_plots_keep_labels_inside_and_draw_the_tolerance_line() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("box.html");
    lcpbench(&[
        "simulate",
        "bench_scenes/box_on_ground.toml",
        "--solver",
        "pgs",
        "--steps",
        "60",
        "--html",
        page.to_str().unwrap(),
    ]);
    let state = page_state(&browser, &page, "#step=30");
    assert_no_errors(&state);
    let plots: usize = state.get("plots").parse().unwrap();
    assert!(plots >= 6, "{plots} plots");
    assert_eq!(state.get("empty"), "0", "every plot of this run has data");
    assert_eq!(
        state.get("clipped-labels"),
        "0",
        "a tick label leaves its canvas"
    );
    assert_eq!(
        state.get("repeated-ticks"),
        "0",
        "an axis repeats a tick label"
    );
    // The per-step residual plot and the selected step's history plot.
    assert_eq!(state.get("tolerance-lines"), "2");
    let dom = run_chromium(&browser, &["--dump-dom".into()], &url(&page, "#step=30"));
    assert!(
        dom.contains("steps of 1/100 s (10 ms)"),
        "the step is not shown as 1/100 s (10 ms)"
    );
    let shot = screenshot(&browser, &page, "#step=30", dir.path(), "box.png");
    assert!(
        tolerance_pixels(&shot) > 40,
        "no tolerance line in the screenshot ({} pixels of its colour)",
        tolerance_pixels(&shot)
    );
}

/// A plot with nothing to draw says "no data" (here the residual, not measured) instead of a
/// 0–100 frame.
#[test]
fn a_plot_without_data_says_so() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("si.html");
    lcpbench(&[
        "simulate",
        "bench_scenes/box_on_ground.toml",
        "--solver",
        "si",
        "--no-residuals",
        "--steps",
        "20",
        "--html",
        page.to_str().unwrap(),
    ]);
    let state = page_state(&browser, &page, "#step=10");
    assert_no_errors(&state);
    let empty: usize = state.get("empty").parse().unwrap();
    assert!(empty >= 1, "the unmeasured residual is drawn as a plot");
    let dom = run_chromium(&browser, &["--dump-dom".into()], &url(&page, "#step=10"));
    assert!(dom.contains("no data"), "no plot says \"no data\"");
    assert_eq!(state.get("clipped-labels"), "0");
}

/// On a box-friction problem of contact triples the solve page runs every matrix solver and
/// every cone solver, draws the convergence plot across the page with its labels inside and
/// the tolerance line, and shows friction bounds as ±mu·f of their normal row.
#[test]
fn problem_page_of_contact_triples_runs_the_cone_solvers_too() {
    let Some(browser) = chromium() else { return };
    let dir = tempfile::tempdir().unwrap();
    let problem = dir.path().join("step.json");
    lcpbench(&[
        "export",
        "bench_scenes/box_on_ground.toml",
        "--step",
        "5",
        "--friction-model",
        "box",
        "-o",
        problem.to_str().unwrap(),
    ]);
    let page = dir.path().join("step.html");
    lcpbench(&[
        "view",
        problem.to_str().unwrap(),
        "-o",
        page.to_str().unwrap(),
    ]);
    let state = page_state(&browser, &page, "");
    assert_no_errors(&state);
    assert_eq!(
        state.get("solvers"),
        (lcpbench_solvers::SolverKind::all().len() + lcpbench_solvers::ConeSolverKind::all().len())
            .to_string()
    );
    assert_eq!(state.get("clipped-labels"), "0");
    assert_eq!(state.get("repeated-ticks"), "0");
    assert_eq!(state.get("tolerance-lines"), "1");
    let dom = run_chromium(&browser, &["--dump-dom".into()], &url(&page, ""));
    for name in lcpbench_solvers::ConeSolverKind::all()
        .iter()
        .map(|k| k.name())
    {
        assert!(
            dom.contains(&format!(">{name}<")),
            "{name} is not on the page"
        );
    }
    assert!(
        dom.contains("−0.5·f0") && dom.contains("+0.5·f0"),
        "friction bounds not shown as ±mu·f"
    );
    let shot = screenshot(&browser, &page, "", dir.path(), "step.png");
    // The convergence plot spans the page: its tolerance line is longer than half the width.
    assert!(
        tolerance_pixels(&shot) > shot.width / 4,
        "tolerance line too short or missing: {} pixels",
        tolerance_pixels(&shot)
    );
}
