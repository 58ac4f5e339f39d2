//! `lcpbench solve` and `lcpbench solvers`.

use crate::harness::budget;
use crate::harness::case::json_warm_start;
use crate::harness::catalogue::{catalogue, SolverLevel};
use crate::harness::timing::{measure, Timed, TimingRule, WallClock, MIN_TOTAL_S};
use crate::harness::SolverSpec;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use lcpbench_solvers::io::{input::read_input_file, MAX_PROBLEM_FILE_BYTES};
use lcpbench_solvers::registry::Level;
use lcpbench_solvers::{
    cone_residuals, is_cone_file, parse_cone_problem, parse_problem, read_problem, Certificate,
    ConeProblem, ConeSolverKind, Problem, ProblemFileError, ProblemFormat, Settings, SolveResult,
    Status,
};
use serde_json::json;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Arguments of `lcpbench solve`.
#[derive(Args)]
pub struct SolveArgs {
    /// Problem file: JSON (format in the README), Siconos numerics LCP (`.dat`) or FCLIB
    /// (`.hdf5`, `.h5`); the format is chosen by extension, then by content. `-` reads a JSON
    /// problem (LCP or cone) from standard input.
    pub problem: PathBuf,
    /// Solver name, with parameters as `NAME@key=value,…` (`lcpbench solvers` says what each
    /// takes).
    #[arg(long, short)]
    pub solver: SolverSpec,
    /// Tolerance on the relative natural-map residual.
    #[arg(long, default_value_t = 1e-8)]
    pub tol: f64,
    /// Iteration / pivot cap of the whole solve: a solver that splits the problem into
    /// independent islands gives each what the islands before it left.
    #[arg(long, default_value_t = 10_000)]
    pub max_iter: usize,
    /// SOR relaxation factor (only with `--solver sor`).
    #[arg(long)]
    pub omega: Option<f64>,
    /// Wall-time budget in seconds.
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Print one JSON object instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Record and print the convergence history.
    #[arg(long)]
    pub history: bool,
    /// Start from the file's warm start (the JSON key `warm_start`, one value per row, which
    /// `lcpbench export` writes for a warm-started solver); solvers that take no warm start
    /// ignore it.
    #[arg(long)]
    pub warm: bool,
    /// Time exactly this many solves (each from the same start, after one untimed first solve
    /// that warms the caches) and report the median of their times. Without it the solve is
    /// timed as `lcpbench bench` times it (see `lcpbench bench --help`): one cold solve of a
    /// small problem measures page faults and cold caches rather than the solver.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub repeat: Option<u32>,
}

/// The solver of `--solver` with `--omega` applied: a matrix or cone solver of the registry
/// (`NAME` or `NAME@key=value,…`), checked before the file is read. `--omega` sets the `omega`
/// parameter of a solver that has one (`sor`).
fn solver_spec(args: &SolveArgs) -> Result<SolverSpec> {
    let mut spec = args.solver.clone();
    let SolverSpec::Solver {
        entry,
        params,
        warm,
    } = &mut spec
    else {
        bail!("--solver: a fault is a sweep's pseudo-solver, not a solver");
    };
    if *warm {
        bail!(
            "--solver: `+warm` is a sweep option; use --warm to start from the file's warm start"
        );
    }
    if entry.level() == Level::Body {
        bail!(
            "--solver: `{}` is a body-level solver, which runs in scenes (lcpbench simulate); \
             solve takes the matrix and cone solvers",
            entry.name
        );
    }
    if let Some(w) = args.omega {
        if !entry.params.iter().any(|p| p.key == "omega") {
            bail!("--omega applies only to --solver sor (a solver with an omega parameter)");
        }
        params.set("omega", w).map_err(|m| anyhow!("--{m}"))?;
    }
    Ok(spec)
}

fn describe(problem: &Problem) -> String {
    let class = if problem.is_standard() {
        "standard LCP".to_owned()
    } else if problem.friction().is_empty() {
        "boxed LCP".to_owned()
    } else {
        format!("boxed LCP, {} friction rows", problem.friction().len())
    };
    let sym = if problem.is_symmetric(1e-10) {
        "symmetric"
    } else {
        "non-symmetric"
    };
    format!("{} rows, {class}, {sym} A", problem.n())
}

/// Run `lcpbench solve`.
pub fn run(args: SolveArgs) -> Result<()> {
    budget::tolerance(args.tol).map_err(|m| anyhow!("--tol: {m}"))?;
    let time_budget = match args.time_budget {
        Some(t) => Some(budget::time_budget(t).map_err(|m| anyhow!("--time-budget: {m}"))?),
        None => None,
    };
    if args.max_iter == 0 {
        bail!("--max-iter must be at least 1");
    }
    // Solver options are checked before the file is read.
    let spec = solver_spec(&args)?;
    let lcp_solver = spec.create();
    let stdin = is_stdin(&args.problem);
    let bytes = if stdin {
        read_stdin(&mut std::io::stdin().lock(), MAX_PROBLEM_FILE_BYTES)?
    } else {
        read_input_file(&args.problem, MAX_PROBLEM_FILE_BYTES).map_err(|source| {
            ProblemFileError::Io {
                path: args.problem.clone(),
                source,
            }
        })?
    };
    let head = &bytes[..bytes.len().min(64)];
    let json = stdin
        || matches!(
            ProblemFormat::detect(&args.problem, head),
            ProblemFormat::Json
        );
    let warm_start = if args.warm {
        Some(file_warm_start(&args.problem, &bytes, json)?)
    } else {
        None
    };
    let settings = Settings {
        tolerance: args.tol,
        max_iterations: args.max_iter,
        time_budget,
        warm_start,
        record_history: args.history,
        measure_result: true,
    };
    // A JSON file with a `mu` key is a cone problem; everything else goes through the reader
    // of its format (JSON, Siconos .dat, FCLIB .hdf5).
    if let Some(text) = json.then(|| std::str::from_utf8(&bytes).ok()).flatten() {
        if is_cone_file(text) {
            let source = if stdin {
                Path::new(STDIN_NAME)
            } else {
                args.problem.as_path()
            };
            let cone = parse_cone_problem(text, source)?;
            return run_cone(&args, &spec, &cone, &settings);
        }
    }
    let problem = if stdin {
        let text = std::str::from_utf8(&bytes)
            .map_err(|e| anyhow!("standard input: the problem is not UTF-8 JSON ({e})"))?;
        parse_problem(text, Path::new(STDIN_NAME))?
    } else {
        read_problem(&args.problem)?
    };
    if let Some(ws) = settings
        .warm_start
        .as_ref()
        .filter(|ws| ws.len() != problem.n())
    {
        bail!(
            "{}: warm_start has {} values for {} rows",
            args.problem.display(),
            ws.len(),
            problem.n()
        );
    }
    let solver = match lcp_solver {
        Some(solver) => solver,
        None => {
            let cone = ConeProblem::from_box(&problem).with_context(|| {
                format!(
                    "{}: a cone solver needs rows in (normal, tangent, tangent) triples",
                    args.problem.display()
                )
            })?;
            return run_cone(&args, &spec, &cone, &settings);
        }
    };
    if let Some(ws) = &settings.warm_start {
        check_warm_velocity(&args.problem, ws, &problem.velocity(ws))?;
    }
    let timed = timed(&args, settings.time_budget, || {
        solver.clone().solve(&problem, &settings)
    });
    print_result(
        &args,
        problem.name(),
        &describe(&problem),
        solver.name(),
        &timed,
    )
}

/// How a problem read from standard input is named in messages.
const STDIN_NAME: &str = "<stdin>";

/// True when `path` is `-`, standard input.
fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Read a JSON problem from `input` (standard input), at most `max_bytes` bytes: a longer input
/// is refused once `max_bytes + 1` bytes have been read, before more is kept. Only JSON can
/// come this way (the Siconos and FCLIB readers take files by path).
fn read_stdin(input: &mut impl Read, max_bytes: u64) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    input
        .take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .context("cannot read the problem from standard input")?;
    if bytes.len() as u64 > max_bytes {
        bail!(
            "standard input: the problem is larger than the limit of {max_bytes} bytes \
             (MAX_PROBLEM_FILE_BYTES)"
        );
    }
    let start = bytes.iter().find(|b| !b.is_ascii_whitespace());
    match start {
        None => bail!("standard input: no problem (the input is empty)"),
        Some(b'{') => Ok(bytes),
        Some(_) => bail!(
            "standard input: not a JSON problem (it does not start with `{{`); `solve -` reads \
             the JSON formats (LCP or cone), give a Siconos .dat or FCLIB .hdf5 file by its path"
        ),
    }
}

/// Time `solve` by the harness's method ([`crate::harness::timing`]): the `--repeat` count
/// of timed solves, or the rule `bench` uses. `solve` gives each call a fresh copy of the
/// solver, so every repeat is the same computation. `--time-budget` bounds each solve and,
/// with `--repeat`, the repeats together: a repeat starts only while the longest solve so far
/// would still end within the budget from the start of the first solve.
fn timed(
    args: &SolveArgs,
    total_budget: Option<Duration>,
    solve: impl FnMut() -> SolveResult,
) -> Timed<SolveResult> {
    let rule = match args.repeat {
        Some(n) => TimingRule {
            max_wall_s: total_budget.map_or(f64::INFINITY, |b| b.as_secs_f64()),
            ..TimingRule::exactly(n as usize)
        },
        None => TimingRule::default(),
    };
    measure(&rule, &WallClock::new(), solve, |_| ())
}

/// Refuse a warm start at which the velocity overflows (`A f + b` for an LCP, `W r + q` for a
/// cone problem): finite entries such as `1e308` pass the file's number check, but no solver
/// can start from them. Names the file and the warm-start entry of the largest magnitude.
fn check_warm_velocity(path: &Path, warm_start: &[f64], velocity: &[f64]) -> Result<()> {
    if let Some(row) = velocity.iter().position(|v| !v.is_finite()) {
        let (i, v) = warm_start
            .iter()
            .enumerate()
            .fold((0, 0.0f64), |(k, m), (i, v)| {
                if v.abs() > m.abs() {
                    (i, *v)
                } else {
                    (k, m)
                }
            });
        bail!(
            "{}: warm_start[{i}] = {v:e}: the velocity overflows at the warm start (row {row} \
             is not finite); give a warm start of the size of the problem's impulses",
            path.display()
        );
    }
    Ok(())
}

/// The `warm_start` array of a JSON problem file: finite numbers.
fn file_warm_start(path: &std::path::Path, bytes: &[u8], json: bool) -> Result<Vec<f64>> {
    let display = path.display();
    if !json {
        bail!("{display}: --warm needs a JSON problem file with a `warm_start` key");
    }
    json_warm_start(bytes, path)
        .map_err(|m| anyhow!(m))?
        .with_context(|| {
            format!("{display}: --warm needs the key `warm_start` (an array of numbers)")
        })
}

/// Solve a cone problem: with a cone solver, or `unsupported` for an LCP solver (the box
/// approximation is a different problem; export it to solve it as an LCP).
fn run_cone(
    args: &SolveArgs,
    spec: &SolverSpec,
    cone: &ConeProblem,
    settings: &Settings,
) -> Result<()> {
    let describe = format!(
        "{} rows, {} contacts, Coulomb cone",
        cone.n(),
        cone.contacts()
    );
    let (name, r) = match spec.create_cone() {
        Some(solver) => {
            if let Some(ws) = &settings.warm_start {
                if ws.len() != cone.n() {
                    bail!(
                        "{}: warm_start has {} values for {} rows",
                        args.problem.display(),
                        ws.len(),
                        cone.n()
                    );
                }
                check_warm_velocity(&args.problem, ws, &cone.velocity(ws))?;
            }
            let r = timed(args, settings.time_budget, || {
                solver.clone().solve_cone(cone, settings)
            });
            (solver.name(), r)
        }
        None => {
            let f = vec![0.0; cone.n()];
            let reason = format!(
                "{} solves LCPs; this is a Coulomb cone (FC3D) problem: use a cone solver ({})",
                spec.base_name(),
                ConeSolverKind::names()
            );
            let r = Timed {
                times_s: Vec::new(),
                kept: Vec::new(),
                first_counted: false,
                result: SolveResult {
                    w: cone.velocity(&f),
                    residuals: cone_residuals(cone, &f),
                    f,
                    status: Status::Unsupported { reason },
                    iterations: 0,
                    time: std::time::Duration::ZERO,
                    history: Vec::new(),
                    active_sets: Vec::new(),
                    certificate: None,
                },
            };
            (spec.entry().map_or("", |e| e.name), r)
        }
    };
    print_result(args, cone.name(), &describe, name, &r)
}

fn print_result(
    args: &SolveArgs,
    problem_name: Option<&str>,
    describe: &str,
    solver_name: &str,
    timed: &Timed<SolveResult>,
) -> Result<()> {
    let r = &timed.result;
    if args.json {
        let out = json!({
            "problem": problem_name,
            "n": r.f.len(),
            "solver": solver_name,
            "status": r.status.name(),
            "reason": r.status.reason(),
            "iterations": r.iterations,
            "time_s": timed.median_s(),
            "repeat": args.repeat,
            "timed_solves": timed.count(),
            "time_min_s": timed.min_s(),
            "time_max_s": timed.max_s(),
            "residual": r.residuals.natural_map,
            "residual_rel": r.residuals.natural_map_rel,
            "complementarity_gap": r.residuals.complementarity_gap,
            "bound_violation": r.residuals.bound_violation,
            "f": r.f,
            "w": r.w,
            "history": if args.history { Some(&r.history) } else { None },
            "certificate": r.certificate.as_ref().map(certificate_json),
        });
        println!(
            "{}",
            serde_json::to_string(&out).context("serialising the result")?
        );
        return Ok(());
    }
    let name = problem_name.map(|n| format!("{n}: ")).unwrap_or_default();
    let source = if is_stdin(&args.problem) {
        STDIN_NAME.to_owned()
    } else {
        args.problem.display().to_string()
    };
    println!("problem     {name}{source} ({describe})");
    println!("solver      {solver_name}");
    println!("status      {}", r.status);
    println!(
        "iterations  {} ({})",
        r.iterations,
        crate::view::iteration_unit(solver_name).unwrap_or("iterations")
    );
    if timed.count() == 0 {
        println!("time        0 (not solved)");
    } else if timed.first_counted {
        let why = if timed.median_s() >= MIN_TOTAL_S {
            ", long enough to time alone"
        } else {
            ", too long in wall time to repeat"
        };
        println!(
            "time        {:.3} ms (one solve{why})",
            timed.median_s() * 1e3
        );
    } else {
        let cut = match args.repeat {
            Some(n) if timed.count() < n as usize => {
                format!("; {n} asked for, --time-budget bounds them together")
            }
            _ => String::new(),
        };
        println!(
            "time        {:.3} µs (median of {} timed solves after an untimed first; min {:.3} µs, \
             max {:.3} µs{cut})",
            timed.median_s() * 1e6,
            timed.count(),
            timed.min_s() * 1e6,
            timed.max_s() * 1e6
        );
    }
    println!(
        "residual    max over rows {:.3e} (relative {:.3e}); complementarity gap, sum over \
         rows {:.3e}; bound violation, max over rows {:.3e}",
        r.residuals.natural_map,
        r.residuals.natural_map_rel,
        r.residuals.complementarity_gap,
        r.residuals.bound_violation
    );
    let shown: Vec<String> = r.f.iter().take(8).map(|v| format!("{v:.6e}")).collect();
    let more = if r.f.len() > 8 { ", …" } else { "" };
    println!("f           [{}{more}]", shown.join(", "));
    if let Some(c) = &r.certificate {
        println!("certificate {}", describe_certificate(c));
        let shown: Vec<String> = c.y.iter().take(8).map(|v| format!("{v:.6e}")).collect();
        let more = if c.y.len() > 8 { ", …" } else { "" };
        println!("y           [{}{more}]", shown.join(", "));
    }
    if args.history {
        for h in &r.history {
            println!(
                "  iter {:>6}  t {:.3e} s  residual {:.3e}",
                h.iteration, h.time_s, h.residual
            );
        }
    }
    Ok(())
}

/// The certificate as JSON: its multipliers and checked quantities (`min_solution_norm` is
/// `null` when it proves there is no solution).
fn certificate_json(c: &Certificate) -> serde_json::Value {
    json!({
        "proves_no_solution": c.proves_no_solution,
        "min_solution_norm": c.min_solution_norm.is_finite().then_some(c.min_solution_norm),
        "b_dot_y": c.b_dot_y,
        "bounded_part": c.bounded_part,
        "slope": c.slope,
        "slope_rel": c.slope_rel,
        "y": c.y,
    })
}

/// One line on what a certificate proves.
fn describe_certificate(c: &Certificate) -> String {
    let what = if c.proves_no_solution {
        "so there is no solution".to_owned()
    } else {
        format!("so every solution has ‖f‖∞ >= {:.3e}", c.min_solution_norm)
    };
    format!(
        "Farkas multipliers y read off f: bᵀy = {:.3e}, bound part U = {:.3e}, slope S = {:.3e} \
         (relative {:.1e}), {what}",
        c.b_dot_y, c.bounded_part, c.slope, c.slope_rel
    )
}

/// The names of the solvers of the catalogue at `levels`, comma-separated, in catalogue order
/// (what the help texts list, so they cannot fall behind the solver table).
pub fn solver_names(levels: &[SolverLevel]) -> String {
    catalogue()
        .into_iter()
        .filter(|e| levels.contains(&e.level()))
        .map(|e| e.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The `lcpbench solvers` table: a header line and one line per solver, columns padded to
/// their widest entry; the last column (problem classes and limits) runs on. Then each
/// solver that takes parameters with its keys, defaults, ranges and meanings.
pub fn solvers_table() -> String {
    let header = [
        "solver",
        "level",
        "warm",
        "iterations count",
        "problem classes and limits",
    ];
    let rows: Vec<[String; 5]> = catalogue()
        .into_iter()
        .map(|e| {
            [
                e.name.to_owned(),
                e.level().name().to_owned(),
                if e.iterative { "+warm" } else { "-" }.to_owned(),
                e.iteration_unit.to_owned(),
                e.problem_classes.to_owned(),
            ]
        })
        .collect();
    let mut widths = header.map(|h| h.chars().count());
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: [&str; 5]| {
        let mut out = String::new();
        for (k, cell) in cells.iter().enumerate() {
            if k + 1 == cells.len() {
                out.push_str(cell);
            } else {
                out.push_str(cell);
                out.push_str(&" ".repeat(widths[k] - cell.chars().count() + 2));
            }
        }
        out
    };
    let mut out = line(header);
    out.push('\n');
    for row in &rows {
        out.push_str(&line(row.each_ref().map(String::as_str)));
        out.push('\n');
    }
    let with_params: Vec<_> = catalogue()
        .into_iter()
        .filter(|e| !e.params.is_empty())
        .collect();
    if !with_params.is_empty() {
        out.push_str(
            "\nparameters (NAME@key=value,... on --solver, in a scene's solver field and in \
             sweeps; NAME@VALUE sets a solver's only parameter):\n",
        );
        for e in with_params {
            out.push_str(&format!("{}\n", e.name));
            for p in e.params {
                out.push_str(&format!(
                    "  {:<18} default {:<8} in {}  {}\n",
                    p.key,
                    p.default,
                    p.range(),
                    p.doc
                ));
            }
        }
    }
    out
}

/// Run `lcpbench solvers`: every solver with its level (matrix, body, cone), whether `+warm`
/// applies, what its iteration count counts, and its problem classes and limits.
pub fn list_solvers() -> Result<()> {
    print!("{}", solvers_table());
    Ok(())
}
