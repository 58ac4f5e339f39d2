//! Replay pages for the report: each scene simulated by the default solver comparison (Dantzig
//! principal pivoting on the assembled LCP against body-level sequential impulses) and written
//! as one side-by-side page (`lcpbench view`), plus the Markdown that links them.
//!
//! Kept apart from the sweep: the report calls [`write_replays`] and pastes
//! [`replay_section`] where it wants the links.

use super::suite::{is_large_scene, LARGE_SCENE_STEPS, SCENE_STEPS};
use crate::harness::SolverSpec;
use crate::view::{self, recording::step_line, Recording};
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_contact::scene::{check_solver, Scene};
use lcpbench_contact::ContactSolver;
use lcpbench_solvers::SolverKind;
use std::path::{Path, PathBuf};

/// Solvers of the replays: a pivoting matrix solver and a body-level one.
pub const REPLAY_SOLVERS: [SolverSpec; 2] = [
    SolverSpec::plain(SolverKind::Dantzig),
    SolverSpec::body(BodySolverKind::SequentialImpulses),
];

/// Size bound of one replay page, bytes.
pub const REPLAY_MAX_BYTES: usize = 1_500_000;

/// A scene's replay page, or why there is none.
#[derive(Debug, Clone)]
pub struct ReplayLink {
    /// Scene name.
    pub scene: String,
    /// The page, when written.
    pub page: Option<PathBuf>,
    /// Solvers shown.
    pub solvers: Vec<String>,
    /// Why there is no page.
    pub error: Option<String>,
}

/// Simulate `scene_path` with `solver` for `steps` steps, recording in memory.
fn record(
    scene: &Scene,
    scene_path: &Path,
    solver: ContactSolver,
    steps: usize,
) -> Result<Recording, String> {
    check_solver(&solver, scene.settings.builder.friction_model)?;
    let mut world = scene.world();
    world.set_solver(solver);
    world.settings.record_history = true;
    let mut lines = vec![view::header(&scene.name, &world).to_string()];
    for _ in 0..steps {
        let report = world.step();
        lines.push(step_line(&report, &world).to_string());
    }
    Recording::from_lines(scene_path, lines.into_iter().map(Ok)).map_err(|e| e.to_string())
}

/// Write `out_dir/replays/<scene>.html` for every scene (steps as in the report's scene runs:
/// [`SCENE_STEPS`], or [`LARGE_SCENE_STEPS`] for large scenes, at most the scene's own count).
pub fn write_replays(scenes: &[PathBuf], out_dir: &Path) -> Vec<ReplayLink> {
    let dir = out_dir.join("replays");
    scenes
        .iter()
        .map(|path| {
            let name = path
                .file_stem()
                .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            let mut link = ReplayLink {
                scene: name.clone(),
                page: None,
                solvers: Vec::new(),
                error: None,
            };
            let result = (|| -> Result<PathBuf, String> {
                let scene = Scene::load(path).map_err(|e| e.to_string())?;
                let cap = if is_large_scene(path) {
                    LARGE_SCENE_STEPS
                } else {
                    SCENE_STEPS
                };
                let steps = scene.settings.steps.min(cap);
                let mut recordings = Vec::new();
                for solver in &REPLAY_SOLVERS {
                    let choice = solver.contact_solver(&scene).ok_or("no stepper solver")?;
                    if let Ok(r) = record(&scene, path, choice, steps) {
                        link.solvers.push(solver.to_string());
                        recordings.push(r);
                    }
                }
                if recordings.is_empty() {
                    return Err("no replay solver supports this scene".into());
                }
                let html =
                    view::replay_page(&recordings, REPLAY_MAX_BYTES).map_err(|e| e.to_string())?;
                std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
                let page = dir.join(format!("{name}.html"));
                std::fs::write(&page, html).map_err(|e| format!("{}: {e}", page.display()))?;
                Ok(page)
            })();
            match result {
                Ok(p) => link.page = Some(p),
                Err(e) => link.error = Some(e),
            }
            link
        })
        .collect()
}

/// A Markdown section linking each scene to its replay (paths relative to `report_dir`).
pub fn replay_section(links: &[ReplayLink], report_dir: &Path) -> String {
    let mut md = String::from(
        "## Replays\n\nEach scene simulated by Dantzig and sequential impulses, side by side: \
         open the page in a browser (self-contained, no network).\n\n| scene | replay |\n| --- | --- |\n",
    );
    for l in links {
        let cell = match (&l.page, &l.error) {
            (Some(p), _) => {
                let rel = p.strip_prefix(report_dir).unwrap_or(p);
                format!("[{}]({})", l.solvers.join(" vs "), rel.display())
            }
            (None, Some(e)) => format!("none: {e}"),
            (None, None) => "none".into(),
        };
        md.push_str(&format!("| {} | {cell} |\n", l.scene));
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replays_are_written_and_linked() {
        let dir = tempfile::tempdir().unwrap();
        let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("bench_scenes/box_on_ground.toml");
        let links = write_replays(&[scene, PathBuf::from("missing.toml")], dir.path());
        assert_eq!(links.len(), 2);
        let page = links[0].page.as_ref().expect("a page for box_on_ground");
        assert_eq!(links[0].solvers, ["dantzig", "si"]);
        let html = std::fs::read_to_string(page).unwrap();
        assert!(html.contains("\"kind\":\"replay\""));
        assert!(links[1].error.is_some());
        let md = replay_section(&links, dir.path());
        assert!(
            md.contains("| box_on_ground | [dantzig vs si](replays/box_on_ground.html) |"),
            "{md}"
        );
        assert!(md.contains("| missing | none:"), "{md}");
    }
}
