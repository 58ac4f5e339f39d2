//! `lcpbench export`: write the contact LCP (or cone problem) of one step of a scene.

use super::world::{apply_solver_overrides, check_steps, load_world, step_progress};
use crate::harness::export::{step_problem, StepProblem};
use crate::harness::outdir::check_outputs;
use anyhow::{bail, Context, Result};
use clap::Args;
use lcpbench_contact::scene::LoadOptions;
use lcpbench_solvers::{
    cone_problem_to_json, problem_to_json, write_fclib_local, write_problem, ConeProblem, Problem,
};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Arguments of `lcpbench export`.
#[derive(Args)]
pub struct ExportArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// The step whose LCP is written (0-based; earlier steps are simulated first).
    #[arg(long, default_value_t = 0)]
    pub step: usize,
    /// Solver used for the steps before `--step` (overrides the scene's; a cone solver for
    /// friction model cone; `NAME+warm` warm-starts them, `NAME` starts them cold).
    #[arg(long, short)]
    pub solver: Option<String>,
    /// Friction model (overrides the scene's): none, box, pyramid (4 directions), pyramid-K, or
    /// cone (writes the step's cone problem, which `lcpbench solve` reads too: cone JSON with
    /// `W` dense, or local FCLIB with `W` sparse when the output ends in `.hdf5` or `.h5`).
    #[arg(long)]
    pub friction_model: Option<String>,
    /// Solver tolerance for the steps before `--step` (overrides the scene's).
    #[arg(long)]
    pub tol: Option<f64>,
    /// Solver iteration / pivot / sweep cap per step for the steps before `--step` (overrides
    /// the scene's).
    #[arg(long)]
    pub max_iter: Option<usize>,
    /// Wall-time budget of each step's solve before `--step`, seconds (none by default).
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Output problem file (JSON, the `lcpbench solve` format). With a warm-started solver the
    /// file also holds the step's warm start (`warm_start`: the previous step's impulses,
    /// projected as the stepper passes them), which `lcpbench solve --warm` starts from.
    #[arg(long, short)]
    pub output: PathBuf,
    /// Read mesh files outside the scene file's directory tree (absolute paths, `..`, links
    /// leading out), which are refused otherwise.
    #[arg(long)]
    pub allow_outside_paths: bool,
}

/// Run `lcpbench export`.
pub fn run(args: ExportArgs) -> Result<()> {
    check_outputs(&[("the scene", &args.scene)], &[("--output", &args.output)])?;
    let (scene, mut world) = load_world(
        &args.scene,
        args.solver.as_deref(),
        args.friction_model.as_deref(),
        &LoadOptions {
            allow_outside_paths: args.allow_outside_paths,
        },
    )?;
    check_steps("--step", args.step)?;
    apply_solver_overrides(args.tol, args.max_iter, args.time_budget, &mut world)?;
    let bar = step_progress(args.step as u64, &scene.name);
    let (problem, contacts) = step_problem(&mut world, &scene.name, args.step, || bar.inc(1));
    bar.finish_and_clear();
    let (problem, warm_start) = match problem {
        StepProblem::Lcp {
            problem,
            warm_start,
        } => (problem, warm_start),
        StepProblem::Cone {
            problem,
            warm_start,
        } => return write_cone(&args, &scene.name, &problem, warm_start.as_deref()),
        StepProblem::NoContacts => bail!(
            "step {} of {} has no contacts, so there is no LCP to export",
            args.step,
            args.scene.display()
        ),
        StepProblem::Refused(reason) => bail!(
            "{}: step {} has no problem to export: {reason}",
            args.scene.display(),
            args.step
        ),
    };
    match &warm_start {
        Some(ws) => write_problem_with_warm_start(&problem, ws, &args.output)?,
        None => write_problem(&problem, &args.output)?,
    }
    println!(
        "wrote {}: {} rows ({contacts} contacts) of step {} of {}{}",
        args.output.display(),
        problem.n(),
        args.step,
        scene.name,
        if warm_start.is_some() {
            ", with its warm start"
        } else {
            ""
        }
    );
    Ok(())
}

/// Write `problem` as JSON with the key `warm_start` added.
fn write_problem_with_warm_start(problem: &Problem, warm_start: &[f64], path: &Path) -> Result<()> {
    let mut value: serde_json::Value = serde_json::from_str(&problem_to_json(problem))?;
    if let Some(object) = value.as_object_mut() {
        object.insert("warm_start".into(), json!(warm_start));
    }
    std::fs::write(path, serde_json::to_string(&value)?)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// Write the cone problem of `lcpbench export` (friction model `cone`): a local FCLIB file with
/// `W` sparse when the output ends in `.hdf5` or `.h5`, the cone JSON (`W` dense) otherwise.
///
/// The cone JSON carries the step's warm start (`warm_start`, as the LCP export does) when the
/// step's solver was warm-started, so `solve --warm` replays the step; FCLIB has no place for
/// one, and the message says it was left out.
fn write_cone(
    args: &ExportArgs,
    scene_name: &str,
    cone: &ConeProblem,
    warm_start: Option<&[f64]>,
) -> Result<()> {
    let fclib = args
        .output
        .extension()
        .is_some_and(|e| e == "hdf5" || e == "h5");
    if fclib {
        let d = cone.delassus();
        let triplets: Vec<_> = (0..cone.n())
            .flat_map(|i| {
                d.row(i)
                    .iter()
                    .filter(|&(_, v)| v != 0.0)
                    .map(move |(j, v)| faer::sparse::Triplet::new(i, j, v))
                    .collect::<Vec<_>>()
            })
            .collect();
        let w = faer::sparse::SparseColMat::try_new_from_triplets(cone.n(), cone.n(), &triplets)
            .map_err(|e| anyhow::anyhow!("cannot assemble W: {e:?}"))?;
        write_fclib_local(&args.output, 3, &w, cone.q(), cone.mu())?;
    } else {
        let mut value: serde_json::Value = serde_json::from_str(&cone_problem_to_json(cone))?;
        if let (Some(ws), Some(object)) = (warm_start, value.as_object_mut()) {
            object.insert("warm_start".into(), json!(ws));
        }
        std::fs::write(&args.output, serde_json::to_string(&value)?)
            .with_context(|| format!("cannot write {}", args.output.display()))?;
    }
    let warm = match (warm_start, fclib) {
        (None, _) => "",
        (Some(_), false) => ", with its warm start",
        (Some(_), true) => " (its warm start is not written: FCLIB files hold none)",
    };
    println!(
        "wrote {}: cone problem of {} contacts ({} rows) of step {} of {}{warm}",
        args.output.display(),
        cone.contacts(),
        cone.n(),
        args.step,
        scene_name
    );
    Ok(())
}
