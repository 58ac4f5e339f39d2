//! Exporting the problem of one step of a scene: the LCP (or, under friction model `cone`, the
//! Coulomb-cone problem) that the stepper assembled. Used by `lcpbench export` and by the
//! report's suite of exported LCPs ([`export_suite_lcps`]).

use lcpbench_contact::scene::Scene;
use lcpbench_contact::step::World;
use lcpbench_solvers::{write_problem, ConeProblem, Problem};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The problem of one step.
#[derive(Debug, Clone)]
pub enum StepProblem {
    /// A (boxed) LCP, named `SCENE step K`, with the warm start the step's solver was given
    /// (`None` for a solver started cold).
    Lcp {
        /// The problem.
        problem: Problem,
        /// The warm start.
        warm_start: Option<Vec<f64>>,
    },
    /// A Coulomb-cone problem (friction model `cone`), named `SCENE step K`, with the warm
    /// start the step's solver was given (`None` for a solver started cold).
    Cone {
        /// The problem.
        problem: ConeProblem,
        /// The warm start, one value per row of the cone problem.
        warm_start: Option<Vec<f64>>,
    },
    /// The step had no contacts.
    NoContacts,
    /// The step was not solved, for the reason given: past one of the stepper's limits (see
    /// [`World::step`]), or a solver that declined it.
    Refused(String),
}

/// The problem of step `step` (0-based) of `world`, and that step's contact count: the steps
/// before it are simulated first (`tick` is called after each), then the step is taken with
/// its problem kept. The problem is named `SCENE_NAME step STEP`.
pub fn step_problem(
    world: &mut World,
    scene_name: &str,
    step: usize,
    tick: impl FnMut(),
) -> (StepProblem, usize) {
    step_problem_within(world, scene_name, step, None, tick)
}

/// [`step_problem`] within a deadline: simulating the steps before `step` counts against it,
/// checked after each, and a deadline that passes before the step is reached gives
/// [`StepProblem::Refused`] with how far the run got (no contacts counted). The step itself is
/// solved under the world's own per-step budget.
pub fn step_problem_within(
    world: &mut World,
    scene_name: &str,
    step: usize,
    deadline: Option<Instant>,
    mut tick: impl FnMut(),
) -> (StepProblem, usize) {
    let started = Instant::now();
    for k in 0..step {
        if deadline.is_some_and(|d| Instant::now() >= d) {
            let reason = format!(
                "the time budget ran out after simulating {k} of the {step} steps before step \
                 {step} ({:.1} s); give a larger --time-budget or an earlier step",
                started.elapsed().as_secs_f64()
            );
            return (StepProblem::Refused(reason), 0);
        }
        world.step();
        tick();
    }
    world.settings.keep_problem = true;
    let report = world.step();
    let name = format!("{scene_name} step {step}");
    let problem = match (report.problem, report.cone_problem) {
        (_, Some(cone)) => StepProblem::Cone {
            problem: cone.with_name(name),
            warm_start: report.warm_start,
        },
        (Some(lcp), None) => StepProblem::Lcp {
            problem: lcp.with_name(name),
            warm_start: report.warm_start,
        },
        (None, None) => match report.status {
            lcpbench_solvers::Status::Unsupported { reason } => StepProblem::Refused(reason),
            _ => StepProblem::NoContacts,
        },
    };
    (problem, report.contacts)
}

/// Export one LCP per scene into `dir` (the step halfway through the run, at most step 30,
/// simulated with the scene's own solver), skipping scenes with more than `max_bodies` dynamic
/// bodies, scenes without an LCP at that step (no contacts, or a cone problem) and LCPs above
/// `max_rows` rows. Returns the files written.
pub fn export_suite_lcps(
    scenes: &[PathBuf],
    dir: &Path,
    max_rows: usize,
    max_bodies: usize,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    if scenes.is_empty() {
        return Ok(out);
    }
    std::fs::create_dir_all(dir)?;
    for path in scenes {
        let Ok(scene) = Scene::load(path) else {
            continue;
        };
        if scene.bodies.iter().filter(|b| !b.is_static).count() > max_bodies {
            continue;
        }
        let k = (scene.settings.steps / 2).min(30);
        let mut world = scene.world();
        let (StepProblem::Lcp { problem, .. }, _) = step_problem(&mut world, &scene.name, k, || {})
        else {
            continue;
        };
        if problem.n() == 0 || problem.n() > max_rows {
            continue;
        }
        let file = dir.join(format!("{}_step{k}.json", scene.name));
        write_problem(&problem, &file)?;
        out.push(file);
    }
    Ok(out)
}
