//! Loading a scene's world with the command line's overrides (solver, friction model,
//! tolerance, iteration cap, time budget) and the progress of long runs: shared by
//! `lcpbench simulate` and `lcpbench export`.

use crate::harness::SolverSpec;
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use lcpbench_contact::scene::{check_solver, LoadOptions, Scene, MAX_STEPS};
use lcpbench_contact::step::{ContactSolver, World};
use lcpbench_contact::FrictionModel;
use std::path::Path;

/// Refuse a step count beyond [`MAX_STEPS`] (or zero, for `--steps`).
pub(super) fn check_steps(flag: &str, steps: usize) -> Result<()> {
    let min = usize::from(flag == "--steps");
    if steps < min || steps > MAX_STEPS {
        bail!("{flag} must be between {min} and {MAX_STEPS}, got {steps}");
    }
    Ok(())
}

/// Steps after which a run counts as long work: a warning is printed and a progress bar drawn
/// (on a terminal).
const LONG_RUN_STEPS: u64 = 10_000;

/// A progress bar over `steps` steps, drawn on stderr for long runs only.
pub(super) fn step_progress(steps: u64, scene: &str) -> ProgressBar {
    if steps < LONG_RUN_STEPS {
        return ProgressBar::hidden();
    }
    eprintln!("simulating {steps} steps of {scene}; this may take a while");
    let bar = ProgressBar::new(steps);
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} steps ({eta} left)")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// Load a scene and build its world, applying solver and friction-model overrides.
pub(super) fn load_world(
    path: &Path,
    solver: Option<&str>,
    friction_model: Option<&str>,
    options: &LoadOptions,
) -> Result<(Scene, World)> {
    let mut scene = Scene::load_with(path, options)?;
    if let Some(model) = friction_model {
        let directions = match scene.settings.builder.friction_model {
            FrictionModel::Pyramid { directions } => directions,
            _ => 4,
        };
        scene.settings.builder.friction_model = FrictionModel::parse(model, directions)
            .map_err(|(_, m)| anyhow::anyhow!("{m}"))
            .with_context(|| {
                format!(
                    "unknown friction model `{model}` (known: {})",
                    FrictionModel::NAMES
                )
            })?;
    }
    if let Some(name) = solver {
        let spec: SolverSpec = name.parse()?;
        let choice = spec.contact_solver(&scene).with_context(|| {
            format!(
                "solver `{name}` has no stepper solver (known: {}; `NAME@key=value,…` sets a \
                 solver's parameters)",
                ContactSolver::all_names()
            )
        })?;
        scene.settings.solver = choice;
        // As in `bench` and the report's rows: `NAME` starts every step cold, `NAME+warm`
        // from the previous step's impulses (the scene's `warm_start` applies without `-s`).
        scene.settings.warm_start = spec.warm();
    }
    check_solver(
        &scene.settings.solver,
        scene.settings.builder.friction_model,
    )
    .map_err(|m| {
        anyhow::anyhow!(
            "{}: unsupported solver for this friction model: {m}{}",
            path.display(),
            if scene.settings.solver.is_cone() {
                " (--friction-model cone selects the cone)"
            } else {
                ""
            }
        )
    })?;
    let world = scene.world();
    Ok((scene, world))
}

/// Apply the `--tol`, `--max-iter` and `--time-budget` options to the world.
pub(super) fn apply_solver_overrides(
    tol: Option<f64>,
    max_iter: Option<usize>,
    time_budget: Option<f64>,
    world: &mut World,
) -> Result<()> {
    if let Some(tol) = tol {
        world.settings.tolerance =
            crate::harness::budget::tolerance(tol).map_err(|m| anyhow::anyhow!("--tol: {m}"))?;
    }
    if let Some(max_iter) = max_iter {
        if max_iter == 0 {
            bail!("--max-iter must be at least 1");
        }
        world.settings.max_iterations = max_iter;
    }
    if let Some(seconds) = time_budget {
        world.settings.step_time_budget = Some(
            crate::harness::budget::time_budget(seconds)
                .map_err(|m| anyhow::anyhow!("--time-budget: {m}"))?,
        );
    }
    Ok(())
}
