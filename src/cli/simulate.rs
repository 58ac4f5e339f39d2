//! `lcpbench simulate` and `lcpbench export`.

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lcpbench::harness::export::{step_problem, StepProblem};
use lcpbench_contact::scene::{check_solver, Scene, MAX_STEPS};
use lcpbench_contact::step::{SolverChoice, World};
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::{cone_problem_to_json, write_problem, ConeProblem};
use serde_json::json;
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Arguments of `lcpbench simulate`.
#[derive(Args)]
pub struct SimulateArgs {
    /// Scene file (TOML; format in docs/scenes.md).
    pub scene: PathBuf,
    /// Contact solver (overrides the scene's): a matrix solver (see `lcpbench solvers`), a
    /// body-level one (si, body-micro, penalty), or, for friction model cone, a cone solver
    /// (nsgs-cone, newton-ac). A solver that does not take the friction model is refused.
    #[arg(long, short)]
    pub solver: Option<String>,
    /// Friction model (overrides the scene's): none, box, pyramid (4 directions), pyramid-K
    /// (K directions), or cone (the exact Coulomb cone; needs a cone solver).
    #[arg(long)]
    pub friction_model: Option<String>,
    /// Number of steps (overrides the scene's).
    #[arg(long)]
    pub steps: Option<usize>,
    /// Solver tolerance (overrides the scene's).
    #[arg(long)]
    pub tol: Option<f64>,
    /// Solver iteration / pivot / sweep cap per step (overrides the scene's).
    #[arg(long)]
    pub max_iter: Option<usize>,
    /// Skip the shared residual for body-level solvers (it needs the assembled `A`, which they
    /// do not use), so the step time is theirs alone.
    #[arg(long)]
    pub no_residuals: bool,
    /// Write per-step body states and contacts (point, normal, impulse) as JSON lines, after a
    /// header line with the bodies' shapes.
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Keep the solver's convergence history of every step in the recording (on with `--html`).
    #[arg(long)]
    pub history: bool,
    /// Write the run as an interactive replay page (self-contained HTML; see `lcpbench view`).
    #[arg(long)]
    pub html: Option<PathBuf>,
    /// Size bound of the `--html` page in bytes: longer runs draw every k-th step in 3-D.
    #[arg(long, default_value_t = lcpbench::view::DEFAULT_MAX_BYTES)]
    pub max_bytes: usize,
    /// Print the run's figures as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `lcpbench export`.
#[derive(Args)]
pub struct ExportArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// The step whose LCP is written (0-based; earlier steps are simulated first).
    #[arg(long, default_value_t = 0)]
    pub step: usize,
    /// Solver used for the steps before `--step` (overrides the scene's; a cone solver for
    /// friction model cone).
    #[arg(long, short)]
    pub solver: Option<String>,
    /// Friction model (overrides the scene's): none, box, pyramid (4 directions), pyramid-K, or
    /// cone (writes the step's cone problem, which `lcpbench solve` reads too).
    #[arg(long)]
    pub friction_model: Option<String>,
    /// Output problem file (JSON, the `lcpbench solve` format).
    #[arg(long, short)]
    pub output: PathBuf,
}

/// Refuse a step count beyond [`MAX_STEPS`] (or zero, for `--steps`).
fn check_steps(flag: &str, steps: usize) -> Result<()> {
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
fn step_progress(steps: u64, scene: &str) -> ProgressBar {
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
fn load_world(
    path: &Path,
    solver: Option<&str>,
    friction_model: Option<&str>,
) -> Result<(Scene, World)> {
    let mut scene = Scene::load(path)?;
    if let Some(model) = friction_model {
        scene.settings.builder.friction_model =
            FrictionModel::from_name(model).with_context(|| {
                format!(
                    "unknown friction model `{model}` (known: {})",
                    FrictionModel::NAMES
                )
            })?;
    }
    if let Some(name) = solver {
        let choice = SolverChoice::from_name(name).with_context(|| {
            format!(
                "unknown solver `{name}` (known: {})",
                SolverChoice::all_names()
            )
        })?;
        scene.settings.solver = choice;
    }
    check_solver(scene.settings.solver, scene.settings.builder.friction_model).map_err(|m| {
        anyhow::anyhow!(
            "{}: unsupported solver for this friction model: {m}{}",
            path.display(),
            match scene.settings.solver {
                SolverChoice::Cone(_) => " (--friction-model cone selects the cone)",
                _ => "",
            }
        )
    })?;
    let world = scene.world();
    Ok((scene, world))
}

/// The highest dynamic body at the start and the height the scene expects it to keep
/// (`[metrics] expected_top_height` or `expected_rest_height`), for the sag and lateral drift
/// of stacks (the same measure as the harness's scene rows).
struct TopBody {
    name: String,
    start: nalgebra::Point3<f64>,
    expected: f64,
    up: nalgebra::Vector3<f64>,
}

impl TopBody {
    fn of(scene: &Scene, world: &World) -> Option<Self> {
        let expected = ["expected_top_height", "expected_rest_height"]
            .iter()
            .find_map(|k| match scene.metrics.get(*k)? {
                toml::Value::Float(v) => Some(*v),
                toml::Value::Integer(v) => Some(*v as f64),
                _ => None,
            })?;
        let g = world.settings.gravity;
        let up = if g.norm() > 0.0 {
            -g / g.norm()
        } else {
            nalgebra::Vector3::z()
        };
        let top = world
            .bodies
            .iter()
            .filter(|b| !b.is_static)
            .max_by(|a, b| {
                a.position
                    .coords
                    .dot(&up)
                    .total_cmp(&b.position.coords.dot(&up))
            })?;
        Some(Self {
            name: top.name.clone(),
            start: top.position,
            expected,
            up,
        })
    }

    /// `(sag, lateral drift)`: expected minus final height, and the horizontal displacement.
    fn measure(&self, world: &World) -> (Option<f64>, Option<f64>) {
        let Some(i) = world.body_index(&self.name) else {
            return (None, None);
        };
        let p = world.bodies[i].position;
        let d = p - self.start;
        (
            Some(self.expected - p.coords.dot(&self.up)),
            Some((d - d.dot(&self.up) * self.up).norm()),
        )
    }
}

/// Run `lcpbench simulate`.
pub fn run_simulate(args: SimulateArgs) -> Result<()> {
    let (scene, mut world) = load_world(
        &args.scene,
        args.solver.as_deref(),
        args.friction_model.as_deref(),
    )?;
    let steps = args.steps.unwrap_or(scene.settings.steps);
    check_steps("--steps", steps)?;
    if let Some(tol) = args.tol {
        world.settings.tolerance =
            lcpbench::harness::budget::tolerance(tol).map_err(|m| anyhow::anyhow!("--tol: {m}"))?;
    }
    if args.no_residuals {
        world.settings.residuals = false;
    }
    if let Some(max_iter) = args.max_iter {
        if max_iter == 0 {
            bail!("--max-iter must be at least 1");
        }
        world.settings.max_iterations = max_iter;
    }
    world.settings.record_history = args.history || args.html.is_some();
    let mut record = match &args.record {
        Some(p) => Some(BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?,
        )),
        None => None,
    };
    // The lines of the replay page, kept in memory.
    let mut page_lines: Option<Vec<String>> = args.html.as_ref().map(|_| Vec::new());
    let header = lcpbench::view::header(&scene.name, &world).to_string();
    if let Some(w) = record.as_mut() {
        writeln!(w, "{header}")?;
    }
    if let Some(lines) = page_lines.as_mut() {
        lines.push(header);
    }
    let energy0: f64 = world
        .bodies
        .iter()
        .map(|b| {
            lcpbench_contact::integrate::kinetic_energy(b)
                + lcpbench_contact::integrate::potential_energy(b, &world.settings.gravity)
        })
        .sum();
    let mut statuses: BTreeMap<&'static str, usize> = BTreeMap::new();
    let (mut step_time, mut solve_time, mut max_step_time) = (0.0, 0.0, 0.0f64);
    let (mut iters, mut max_iters, mut contacts, mut rows) = (0usize, 0usize, 0usize, 0usize);
    let (mut max_pen, mut max_cone) = (0.0f64, 0.0f64);
    let mut max_res: Option<f64> = None;
    let (mut islands, mut largest_island, mut solve_wall) = (0usize, 0usize, 0.0);
    let mut last_energy = energy0;
    let top = TopBody::of(&scene, &world);
    let bar = step_progress(steps as u64, &scene.name);
    for _ in 0..steps {
        bar.inc(1);
        let report = world.step();
        if let lcpbench_solvers::Status::Unsupported { reason } = &report.status {
            bail!(
                "{}: solver {} cannot solve step {} ({} rows): {reason}{}",
                args.scene.display(),
                report.solver,
                report.step,
                report.rows,
                if reason.contains("friction row") {
                    " (try friction_model = \"pyramid\" or \"none\")"
                } else {
                    ""
                }
            );
        }
        if record.is_some() || page_lines.is_some() {
            let line = lcpbench::view::recording::step_line(&report, &world).to_string();
            if let Some(w) = record.as_mut() {
                writeln!(w, "{line}")?;
            }
            if let Some(lines) = page_lines.as_mut() {
                lines.push(line);
            }
        }
        *statuses.entry(report.status.name()).or_default() += 1;
        step_time += report.step_time_s;
        max_step_time = max_step_time.max(report.step_time_s);
        solve_time += report.solve_time_s;
        solve_wall += report.solve_wall_s;
        islands += report.islands;
        largest_island = largest_island.max(report.island_rows.iter().copied().max().unwrap_or(0));
        iters += report.iterations;
        max_iters = max_iters.max(report.iterations);
        contacts += report.contacts;
        rows += report.rows;
        max_pen = max_pen.max(report.max_penetration);
        max_cone = max_cone.max(report.friction_cone_violation);
        if let Some(r) = report.residuals {
            if report.rows > 0 {
                max_res = Some(max_res.unwrap_or(0.0).max(r.natural_map_rel));
            }
        }
        last_energy = report.kinetic_energy + report.potential_energy;
    }
    bar.finish_and_clear();
    if let Some(mut w) = record {
        w.flush()?;
    }
    if let (Some(path), Some(lines)) = (&args.html, page_lines) {
        let recording =
            lcpbench::view::Recording::from_lines(&args.scene, lines.into_iter().map(Ok))?;
        let html = lcpbench::view::replay_page(&[recording], args.max_bytes)?;
        super::view::write_page(path, &html)?;
    }
    let n = steps.max(1) as f64;
    let (sag, drift) = top.as_ref().map_or((None, None), |t| t.measure(&world));
    if args.json {
        let out = json!({
            "scene": scene.name,
            "solver": world.settings.solver.name(),
            "bodies": world.bodies.len(),
            "steps": steps,
            "dt": world.settings.dt,
            "time_per_step_s": step_time / n,
            "max_step_time_s": max_step_time,
            "solver_time_per_step_s": solve_time / n,
            "solve_wall_per_step_s": solve_wall / n,
            "mean_islands": islands as f64 / n,
            "largest_island_rows": largest_island,
            "mean_iterations": iters as f64 / n,
            "max_iterations": max_iters,
            "mean_contacts": contacts as f64 / n,
            "mean_rows": rows as f64 / n,
            "statuses": statuses,
            "max_penetration": max_pen,
            "max_relative_residual": max_res,
            "max_friction_cone_violation": max_cone,
            "initial_energy": energy0,
            "final_energy": last_energy,
            "sag": sag,
            "lateral_drift": drift,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    let statuses: Vec<String> = statuses.iter().map(|(k, v)| format!("{k} {v}")).collect();
    println!(
        "scene {} ({} bodies), solver {}, {steps} steps of {} s",
        scene.name,
        world.bodies.len(),
        world.settings.solver.name(),
        world.settings.dt
    );
    println!(
        "time per step     {:.3} ms (max {:.3} ms)",
        1e3 * step_time / n,
        1e3 * max_step_time
    );
    println!(
        "solver time/step  {:.3} ms (solve phase wall time {:.3} ms)",
        1e3 * solve_time / n,
        1e3 * solve_wall / n
    );
    println!(
        "islands           mean {:.1}, largest {largest_island} rows",
        islands as f64 / n
    );
    println!(
        "iterations        mean {:.1}, max {max_iters}",
        iters as f64 / n
    );
    println!(
        "contacts, rows    mean {:.1}, {:.1}",
        contacts as f64 / n,
        rows as f64 / n
    );
    println!("status            {}", statuses.join(", "));
    match max_res {
        Some(r) => println!("max residual      {r:.3e} (relative natural map)"),
        None => println!("max residual      not measured"),
    }
    println!("max penetration   {max_pen:.3e} m");
    if let (Some(sag), Some(drift)) = (sag, drift) {
        println!("top body          sag {sag:.3e} m, lateral drift {drift:.3e} m");
    }
    println!("cone violation    {max_cone:.3e} N s");
    println!(
        "energy            {energy0:.6} J -> {last_energy:.6} J ({:+.3e} J)",
        last_energy - energy0
    );
    Ok(())
}

/// Run `lcpbench export`.
pub fn run_export(args: ExportArgs) -> Result<()> {
    let (scene, mut world) = load_world(
        &args.scene,
        args.solver.as_deref(),
        args.friction_model.as_deref(),
    )?;
    check_steps("--step", args.step)?;
    let bar = step_progress(args.step as u64, &scene.name);
    let (problem, contacts) = step_problem(&mut world, &scene.name, args.step, || bar.inc(1));
    bar.finish_and_clear();
    let problem = match problem {
        StepProblem::Lcp(problem) => problem,
        StepProblem::Cone(cone) => return write_cone(&args, &scene.name, &cone),
        StepProblem::NoContacts => bail!(
            "step {} of {} has no contacts, so there is no LCP to export",
            args.step,
            args.scene.display()
        ),
    };
    write_problem(&problem, &args.output)?;
    println!(
        "wrote {}: {} rows ({contacts} contacts) of step {} of {}",
        args.output.display(),
        problem.n(),
        args.step,
        scene.name
    );
    Ok(())
}

/// Write the cone problem of `lcpbench export` (friction model `cone`).
fn write_cone(args: &ExportArgs, scene_name: &str, cone: &ConeProblem) -> Result<()> {
    std::fs::write(&args.output, cone_problem_to_json(cone))
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    println!(
        "wrote {}: cone problem of {} contacts ({} rows) of step {} of {}",
        args.output.display(),
        cone.contacts(),
        cone.n(),
        args.step,
        scene_name
    );
    Ok(())
}
