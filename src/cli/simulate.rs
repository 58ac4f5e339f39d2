//! `lcpbench simulate`: step a scene and print per-run figures.

use super::world::{apply_solver_overrides, check_steps, load_world, step_progress};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench_contact::collision::toi::ToiMethod;
use lcpbench_contact::discontinuity::{DiscontinuityMeter, DiscontinuityMetrics};
use lcpbench_contact::joint::{JointMetrics, JointSummary};
use lcpbench_contact::scene::DT_RANGE;
use lcpbench_contact::scene::{LoadOptions, Scene};
use lcpbench_contact::step::{PhaseTimes, ResidualSchedule, StepReport, World};
use lcpbench_contact::timewarp::{Stepper, Stepping};
use serde_json::json;
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

/// Arguments of `lcpbench simulate`.
#[derive(Args)]
pub struct SimulateArgs {
    /// Scene file (TOML; format in docs/scenes.md).
    pub scene: PathBuf,
    /// Contact solver (overrides the scene's): a matrix solver, a body-level one (on scenes
    /// with joints si or a substepping one; `NAME@key=value,…` sets a substepping solver's
    /// parameters), or, for friction model cone, a cone solver (listed below from the
    /// solver table; `lcpbench solvers` says what each takes). A solver that does not take the
    /// friction model is refused. `NAME` starts every step cold and `NAME+warm` from the
    /// previous step's impulses, as in `bench` (without `--solver`, the scene's `warm_start`
    /// applies).
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
    /// Solver iteration / pivot / sweep cap of each step's solve (overrides the scene's). With
    /// `islands = true` the islands of a step are solved in parallel, each up to this cap;
    /// `--time-budget` bounds the step as a whole.
    #[arg(long)]
    pub max_iter: Option<usize>,
    /// Wall-time budget of each step's solve, seconds: a step whose solve runs out of it ends
    /// `time_limit` with the solver's best point, and the run goes on (none by default).
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Which steps have the shared residual measured (overrides the scene's `residual`):
    /// `every`, `none`, or `sample=K` (steps 0, K, 2K, … and the last). The measurement visits
    /// every entry of `A`, which body-level solvers do not use; off the schedule a matrix or
    /// cone solver measures only what its own stopping rule needs. An unmeasured step is never
    /// `converged`.
    #[arg(long, value_name = "every|none|sample=K")]
    pub residual: Option<String>,
    /// The same as `--residual none`.
    #[arg(long, conflicts_with = "residual")]
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
    /// Size bound of the `--html` page in bytes: longer runs draw every k-th step in 3-D; a
    /// page that cannot fit (or a bound below what its scripts take) is an error.
    #[arg(long, default_value_t = crate::view::DEFAULT_MAX_BYTES)]
    pub max_bytes: usize,
    /// Print the run's figures as one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Stepping mode (overrides the scene's `stepping`): `fixed` steps, or `timewarp`
    /// (free bodies advance asynchronously between impacts; docs/scenes.md).
    #[arg(long)]
    pub stepping: Option<String>,
    /// Continuous collision detection of the fixed step (overrides the scene's `ccd`): `none`,
    /// `bisection` or `conservative`.
    #[arg(long)]
    pub ccd: Option<String>,
    /// Time step, s (overrides the scene's `dt`; without `--steps` the number of steps is
    /// scaled to keep the scene's duration). Within the scene file's limits on `dt`.
    #[arg(long)]
    pub dt: Option<f64>,
    /// Read mesh files outside the scene file's directory tree (absolute paths, `..`, links
    /// leading out), which are refused otherwise.
    #[arg(long)]
    pub allow_outside_paths: bool,
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
        let m = &scene.metrics;
        let expected = m.expected_top_height.or(m.expected_rest_height)?;
        let up = world.settings.up();
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

/// Apply the solver, `--residual` (`--no-residuals`) and history options to the world.
fn apply_overrides(args: &SimulateArgs, world: &mut World) -> Result<()> {
    apply_solver_overrides(args.tol, args.max_iter, args.time_budget, world)?;
    if let Some(text) = &args.residual {
        world.settings.residual = text.parse().map_err(|m| anyhow!("--residual: {m}"))?;
    }
    if args.no_residuals {
        world.settings.residual = ResidualSchedule::None;
    }
    world.settings.record_history = args.history || args.html.is_some();
    Ok(())
}

/// Where the recording lines go: the `--record` file and the `--html` page (kept in memory,
/// each step's convergence history already thinned to the page's form, so memory stays a few
/// kilobytes a step however many iterations a solve took).
struct Recorder {
    file: Option<BufWriter<std::fs::File>>,
    page_lines: Option<Vec<String>>,
}

impl Recorder {
    fn new(args: &SimulateArgs) -> Result<Self> {
        let file = match &args.record {
            Some(p) => Some(BufWriter::new(
                std::fs::File::create(p)
                    .with_context(|| format!("cannot create {}", p.display()))?,
            )),
            None => None,
        };
        Ok(Self {
            file,
            page_lines: args.html.as_ref().map(|_| Vec::new()),
        })
    }

    fn is_active(&self) -> bool {
        self.file.is_some() || self.page_lines.is_some()
    }

    fn push(&mut self, mut line: serde_json::Value) -> Result<()> {
        if let Some(w) = self.file.as_mut() {
            writeln!(w, "{line}")?;
        }
        if let Some(lines) = self.page_lines.as_mut() {
            crate::view::recording::compact_history(&mut line);
            lines.push(line.to_string());
        }
        Ok(())
    }

    /// Flush the file and write the replay page; returns the `wrote PATH` lines of what was
    /// written (printed after the run's summary, where a reader looks last).
    fn finish(self, args: &SimulateArgs) -> Result<Vec<String>> {
        let mut wrote = Vec::new();
        if let (Some(mut w), Some(path)) = (self.file, &args.record) {
            w.flush()
                .with_context(|| format!("cannot write {}", path.display()))?;
            wrote.push(format!("wrote {} (recording)", path.display()));
        }
        if let (Some(path), Some(lines)) = (&args.html, self.page_lines) {
            let recording =
                crate::view::Recording::from_lines(&args.scene, lines.into_iter().map(Ok))?;
            let html = crate::view::replay_page(&[recording], args.max_bytes)?;
            wrote.push(super::view::write_page_quietly(path, &html)?);
        }
        Ok(wrote)
    }
}

/// Totals over the steps of a `simulate` run.
#[derive(Default)]
struct SimTotals {
    statuses: BTreeMap<&'static str, usize>,
    /// Steps whose shared residual was measured (or that had no rows).
    steps_measured: usize,
    step_time: f64,
    solve_time: f64,
    max_step_time: f64,
    iters: usize,
    max_iters: usize,
    contacts: usize,
    rows: usize,
    max_pen: f64,
    max_cone: f64,
    max_res: Option<f64>,
    islands: usize,
    largest_island: usize,
    solve_wall: f64,
    max_solve_wall: f64,
    phases: PhaseTimes,
    energy0: f64,
    last_energy: f64,
    /// Substeps, row updates and body passes summed over the steps.
    substeps: usize,
    row_updates: u64,
    body_passes: u64,
    /// Which LCP the residuals are of, at the last step with rows (`None`: the step's LCP).
    residual_of: Option<String>,
}

impl SimTotals {
    fn new(world: &World) -> Self {
        let energy0: f64 = world
            .bodies
            .iter()
            .map(|b| {
                lcpbench_contact::integrate::kinetic_energy(b)
                    + lcpbench_contact::integrate::potential_energy(b, &world.settings.gravity)
            })
            .sum();
        Self {
            energy0,
            last_energy: energy0,
            ..Self::default()
        }
    }

    fn observe(&mut self, report: &StepReport) {
        *self.statuses.entry(report.status.name()).or_default() += 1;
        self.steps_measured += usize::from(report.residual_measured);
        self.step_time += report.step_time_s;
        self.max_step_time = self.max_step_time.max(report.step_time_s);
        self.solve_time += report.solve_time_s;
        self.solve_wall += report.solve_wall_s;
        self.max_solve_wall = self.max_solve_wall.max(report.solve_wall_s);
        self.phases.add(&report.phases);
        self.substeps += report.substeps;
        self.row_updates += report.cost.row_updates;
        self.body_passes += report.cost.body_passes;
        if report.rows > 0 {
            self.residual_of.clone_from(&report.residual_of);
        }
        self.islands += report.islands;
        self.largest_island = self
            .largest_island
            .max(report.island_rows.iter().copied().max().unwrap_or(0));
        self.iters += report.iterations;
        self.max_iters = self.max_iters.max(report.iterations);
        self.contacts += report.contacts;
        self.rows += report.rows;
        self.max_pen = self.max_pen.max(report.max_penetration);
        self.max_cone = self.max_cone.max(report.friction_cone_violation);
        if let Some(r) = report.residuals {
            if report.rows > 0 {
                self.max_res = Some(self.max_res.unwrap_or(0.0).max(r.natural_map_rel));
            }
        }
        self.last_energy = report.kinetic_energy + report.potential_energy;
    }
}

/// Stop at a step that was not solved (`unsupported`: the solver declined it, or it is past
/// one of the stepper's limits), naming the step, the reason and a way out.
fn check_supported(args: &SimulateArgs, report: &StepReport) -> Result<()> {
    if let lcpbench_solvers::Status::Unsupported { reason } = &report.status {
        bail!(
            "{}: step {} ({} rows) was not solved with {}: {reason}{}",
            args.scene.display(),
            report.step,
            report.rows,
            report.solver,
            if reason.contains("friction row") {
                " (try friction_model = \"pyramid\" or \"none\")"
            } else {
                ""
            }
        );
    }
    Ok(())
}

/// Run `lcpbench simulate`.
pub fn run_simulate(args: SimulateArgs) -> Result<()> {
    let outputs: Vec<(&str, &std::path::Path)> =
        [("--record", &args.record), ("--html", &args.html)]
            .into_iter()
            .filter_map(|(what, p)| p.as_deref().map(|p| (what, p)))
            .collect();
    crate::harness::outdir::check_outputs(&[("the scene", &args.scene)], &outputs)?;
    let (scene, mut world) = load_world(
        &args.scene,
        args.solver.as_deref(),
        args.friction_model.as_deref(),
        &LoadOptions {
            allow_outside_paths: args.allow_outside_paths,
        },
    )?;
    let steps = apply_clock(&args, &scene, &mut world)?;
    check_steps("--steps", steps)?;
    // The run's length: a residual schedule's `sample=K` measures its last step too.
    world.settings.steps = steps;
    apply_overrides(&args, &mut world)?;
    if let Some(name) = &args.ccd {
        world.settings.ccd = ToiMethod::from_ccd_name(name).map_err(|m| anyhow!("--ccd: {m}"))?;
    }
    let stepping = match &args.stepping {
        Some(name) => Stepping::from_name(name).map_err(|m| anyhow!("--stepping: {m}"))?,
        None => scene.stepping,
    };
    if stepping == Stepping::Timewarp {
        if let Some(why) = Stepper::one_group_reason(&world) {
            eprintln!(
                "{}: stepping \"timewarp\" runs the scene as one group, the fixed step: {why}",
                args.scene.display()
            );
        }
    }
    let mut stepper =
        Stepper::new(world, stepping).map_err(|m| anyhow!("{}: {m}", args.scene.display()))?;
    let min = crate::view::min_page_bytes(true);
    if args.html.is_some() && args.max_bytes < min {
        bail!(
            "--max-bytes must be at least {min} (the page's scripts, styles and smallest data), \
             got {}",
            args.max_bytes
        );
    }
    let mut recorder = Recorder::new(&args)?;
    recorder.push(crate::view::header(&scene.name, stepper.world()))?;
    let mut totals = SimTotals::new(stepper.world());
    let top = TopBody::of(&scene, stepper.world());
    let mut joints = JointMetrics::new(stepper.world(), scene.metrics.sag_body.as_deref());
    let duration = steps as f64 * stepper.world().settings.dt;
    let mut meter = DiscontinuityMeter::new(
        &stepper,
        scene.metrics.analytic_impacts == Some(true),
        duration,
    );
    let bar = step_progress(steps as u64, &scene.name);
    for _ in 0..steps {
        bar.inc(1);
        meter.before_step(&stepper);
        let report = stepper.step();
        check_supported(&args, &report)?;
        meter.after_step(&stepper, &report);
        let world = stepper.world();
        if recorder.is_active() {
            recorder.push(crate::view::recording::step_line(&report, world))?;
        }
        totals.observe(&report);
        joints.observe(&report, world);
    }
    bar.finish_and_clear();
    let discontinuity = meter.finish(&stepper);
    let world = stepper.world();
    let wrote = recorder.finish(&args)?;
    let top = top.as_ref().map_or((None, None), |t| t.measure(world));
    let run = SimRun {
        scene: &scene,
        world,
        discontinuity,
        steps,
        top,
        joints: joints.summary(),
    };
    if args.json {
        print_json(&run, &totals)?;
        // Standard output stays one JSON document; the files written go to standard error.
        for line in wrote {
            eprintln!("{line}");
        }
    } else {
        print_text(&run, &totals);
        for line in wrote {
            println!("{line}");
        }
    }
    Ok(())
}

/// A time step for people: `1/60 s (16.67 ms)` when `1/dt` is a whole number of steps per
/// second (to 1e-9 relative), else `16.67 ms`, or seconds for a step of a second or more. The
/// replay page writes it the same way (`formatStep` in replay.js).
pub fn format_step(dt: f64) -> String {
    if !dt.is_finite() || dt <= 0.0 {
        return format!("{dt} s");
    }
    if dt >= 1.0 {
        return format!("{} s", shortest(dt, 4));
    }
    let ms = format!("{} ms", shortest(dt * 1e3, 4));
    let rate = 1.0 / dt;
    if (rate - rate.round()).abs() <= 1e-9 * rate && rate.round() > 1.0 {
        format!("1/{} s ({ms})", rate.round() as u64)
    } else {
        ms
    }
}

/// `x` with at most `digits` significant digits, trailing zeros dropped.
fn shortest(x: f64, digits: usize) -> String {
    let text = format!("{:.*e}", digits.saturating_sub(1), x);
    let value: f64 = text.parse().unwrap_or(x);
    format!("{value}")
}

/// What the summary of a `simulate` run names besides the totals.
struct SimRun<'a> {
    scene: &'a Scene,
    world: &'a World,
    steps: usize,
    /// Sag and lateral drift of the top body.
    top: (Option<f64>, Option<f64>),
    /// Joint drift and the sag body's drop.
    joints: JointSummary,
    /// Impact timing, energy, penetration, tunnelling and cost of the stepping mode.
    discontinuity: DiscontinuityMetrics,
}

/// The largest distance any dynamic body ended from where the scene started it, the measure of
/// whether a resting structure held (`None` when events removed bodies, so the lists no longer
/// pair up).
fn max_displacement(run: &SimRun) -> Option<f64> {
    let start = &run.scene.bodies;
    (start.len() == run.world.bodies.len()).then(|| {
        start
            .iter()
            .zip(&run.world.bodies)
            .filter(|(a, _)| !a.is_static)
            .map(|(a, b)| (b.position - a.position).norm())
            .fold(0.0, f64::max)
    })
}

fn print_json(run: &SimRun, t: &SimTotals) -> Result<()> {
    let (world, steps) = (run.world, run.steps);
    let n = steps.max(1) as f64;
    let p = t.phases.scaled(1.0 / n);
    let mut out = json!({
        "scene": run.scene.name,
        "solver": world.settings.solver.name(),
        "warm_start": world.settings.warm_start,
        "bodies": world.bodies.len(),
        "steps": steps,
        "dt": world.settings.dt,
        "time_per_step_s": t.step_time / n,
        "time_per_step_without_residual_s": ((t.step_time - t.phases.residual) / n).max(0.0),
        "max_step_time_s": t.max_step_time,
        "solver_time_per_step_s": t.solve_time / n,
        "solve_wall_per_step_s": t.solve_wall / n,
        "max_solve_wall_s": t.max_solve_wall,
        "step_time_budget_s": world.settings.step_time_budget.map(|d| d.as_secs_f64()),
        "phases_per_step_s": {
            "collision": p.collision,
            "broad_phase": p.broad_phase,
            "narrow_phase": p.narrow_phase,
            "assembly": p.assembly,
            "islands": p.islands,
            "solve": p.solve,
            "residual": p.residual,
            "integration": p.integration,
        },
        "mean_islands": t.islands as f64 / n,
        "largest_island_rows": t.largest_island,
        "mean_iterations": t.iters as f64 / n,
        "substeps_per_step": t.substeps as f64 / n,
        "row_updates_per_step": t.row_updates as f64 / n,
        "body_passes_per_step": t.body_passes as f64 / n,
        "max_iterations": t.max_iters,
        "mean_contacts": t.contacts as f64 / n,
        "mean_rows": t.rows as f64 / n,
        "statuses": t.statuses,
        "max_penetration": t.max_pen,
        "max_relative_residual": t.max_res,
        "residual_of": t.residual_of,
        "max_friction_cone_violation": t.max_cone,
        "initial_energy": t.energy0,
        "final_energy": t.last_energy,
        "sag": run.top.0,
        "lateral_drift": run.top.1,
        "joints": run.joints.joints,
        "joint_drift_max": run.joints.drift_max,
        "joint_drift_mean": run.joints.drift_mean,
        "joint_angle_max": run.joints.angle_max,
        "sag_body_max": run.joints.sag_max,
        "sag_body_final": run.joints.sag_final,
        "energy_drift": t.last_energy - t.energy0,
        "stepping": run.discontinuity.stepping,
        "discontinuity": run.discontinuity,
    });
    out["max_displacement"] = json!(max_displacement(run));
    // Added after the literal: one more key in it passes `json!`'s recursion limit.
    out["steps_measured"] = json!(t.steps_measured);
    out["residual_schedule"] = json!(world.settings.residual.to_string());
    println!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}

fn print_text(run: &SimRun, t: &SimTotals) {
    let (world, steps) = (run.world, run.steps);
    let n = steps.max(1) as f64;
    let statuses: Vec<String> = t.statuses.iter().map(|(k, v)| format!("{k} {v}")).collect();
    println!(
        "scene {} ({} bodies), solver {}{}, {steps} steps of {}",
        run.scene.name,
        world.bodies.len(),
        world.settings.solver.name(),
        if world.settings.warm_start {
            " (warm-started)"
        } else {
            " (cold)"
        },
        format_step(world.settings.dt)
    );
    println!(
        "time per step     mean {:.3} ms, max {:.3} ms (mean without the residual phase {:.3} ms)",
        1e3 * t.step_time / n,
        1e3 * t.max_step_time,
        1e3 * ((t.step_time - t.phases.residual) / n).max(0.0)
    );
    println!(
        "solver time/step  mean {:.3} ms (solve phase wall time mean {:.3} ms, max {:.3} ms{})",
        1e3 * t.solve_time / n,
        1e3 * t.solve_wall / n,
        1e3 * t.max_solve_wall,
        world
            .settings
            .step_time_budget
            .map(|d| format!(", budget {:.3} ms per step", 1e3 * d.as_secs_f64()))
            .unwrap_or_default()
    );
    let p = t.phases.scaled(1.0 / n);
    let phases: Vec<String> = PhaseTimes::NAMES
        .iter()
        .zip(p.values())
        .map(|(name, v)| format!("{name} {:.3}", 1e3 * v))
        .collect();
    println!("phases, ms/step   mean {}", phases.join(", "));
    println!(
        "  of collision    mean broad phase {:.3}, narrow phase {:.3}",
        1e3 * p.broad_phase,
        1e3 * p.narrow_phase
    );
    println!(
        "islands           mean {:.1}, largest {} rows",
        t.islands as f64 / n,
        t.largest_island
    );
    println!(
        "iterations        mean {:.1}, max {} ({} per step)",
        t.iters as f64 / n,
        t.max_iters,
        crate::view::iteration_unit(world.settings.solver.name()).unwrap_or("iterations")
    );
    println!(
        "cost per step     mean {:.1} substeps, {:.0} row updates, {:.1} body passes",
        t.substeps as f64 / n,
        t.row_updates as f64 / n,
        t.body_passes as f64 / n
    );
    println!(
        "contacts, rows    mean {:.1}, mean {:.1}",
        t.contacts as f64 / n,
        t.rows as f64 / n
    );
    if t.steps_measured == steps {
        println!("status            {}", statuses.join(", "));
    } else {
        // Only a measured step can be `converged`: say how many were.
        let converged = t.statuses.get("converged").copied().unwrap_or(0);
        println!(
            "status            {} ({converged} converged of {} measured steps; residual {}, \
             an unmeasured step is never converged)",
            statuses.join(", "),
            t.steps_measured,
            world.settings.residual
        );
    }
    match t.max_res {
        Some(r) => println!(
            "max residual      {r:.3e} (relative natural map, on the LCP of {})",
            t.residual_of.as_deref().unwrap_or("the step")
        ),
        None => println!("max residual      not measured"),
    }
    println!("max penetration   {:.3e} m", t.max_pen);
    if let (Some(sag), Some(drift)) = run.top {
        println!("top body          sag {sag:.3e} m, lateral drift {drift:.3e} m");
    }
    let j = &run.joints;
    if j.joints > 0 {
        println!(
            "joint drift       max {:.3e} m, mean {:.3e} m, max angle {:.3e} rad ({} joints)",
            j.drift_max, j.drift_mean, j.angle_max, j.joints
        );
    }
    if let (Some(max), Some(last)) = (j.sag_max, j.sag_final) {
        println!(
            "sag of {:<11} max {max:.3e} m, final {last:.3e} m",
            run.scene.metrics.sag_body.as_deref().unwrap_or("")
        );
    }
    println!(
        "cone violation    max {:.3e} N s (over steps and contacts)",
        t.max_cone
    );
    println!(
        "energy            {:.6} J -> {:.6} J ({:+.3e} J)",
        t.energy0,
        t.last_energy,
        t.last_energy - t.energy0
    );
    print_discontinuity(&run.discontinuity);
}

/// The stepping mode's impact figures, as text.
fn print_discontinuity(d: &DiscontinuityMetrics) {
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3e}"));
    println!("stepping          {}", d.stepping);
    if d.analytic_impacts > 0 {
        println!(
            "impacts           {} analytic, {} found ({} missed, {} extra); time error max {} s, \
             mean {} s",
            d.analytic_impacts,
            d.detected_impacts,
            d.missed_impacts,
            d.extra_impacts,
            opt(d.impact_time_error_max),
            opt(d.impact_time_error_mean)
        );
        println!(
            "impact energy     relative error max {}, mean {}",
            opt(d.energy_error_max),
            opt(d.energy_error_mean)
        );
    }
    if let Some(n) = d.recorded_impacts {
        println!(
            "free flight       {n} impacts, {} rollbacks ({} body-steps undone), {} distance \
             queries",
            d.rollbacks,
            d.rolled_back_steps,
            d.distance_queries.unwrap_or(0)
        );
    }
    println!(
        "tunnelling        {} body-steps{}",
        d.tunnelling,
        if d.tunnelling_unchecked_steps > 0 {
            format!(" ({} steps not checked)", d.tunnelling_unchecked_steps)
        } else {
            String::new()
        }
    );
    println!(
        "queries           {} collision, {} time of impact{}",
        d.collision_queries,
        d.toi_queries,
        d.queries_per_impact
            .map(|q| format!(" ({q:.1} per impact)"))
            .unwrap_or_default()
    );
}

/// Apply `--dt` (scaling the scene's step count to keep its duration unless `--steps` is given)
/// and return the number of steps.
fn apply_clock(args: &SimulateArgs, scene: &Scene, world: &mut World) -> Result<usize> {
    let Some(dt) = args.dt else {
        return Ok(args.steps.unwrap_or(scene.settings.steps));
    };
    if !(dt.is_finite() && (DT_RANGE.0..=DT_RANGE.1).contains(&dt)) {
        bail!(
            "--dt must be between {} and {} s, got {dt}",
            DT_RANGE.0,
            DT_RANGE.1
        );
    }
    world.settings.dt = dt;
    let duration = scene.settings.dt * scene.settings.steps as f64;
    Ok(args
        .steps
        .unwrap_or_else(|| (duration / dt).round().max(1.0) as usize))
}
