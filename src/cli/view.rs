//! `lcpbench view`: a self-contained HTML page of one or two recordings, or of every solver on
//! one problem.

use crate::harness::budget;
use crate::harness::outdir::check_outputs;
use crate::harness::Case;
use crate::view::recording::MAX_RECORDING_BYTES;
use crate::view::{self, Recording, DEFAULT_MAX_BYTES};
use anyhow::{bail, Context, Result};
use clap::Args;
use lcpbench_solvers::io::{
    input::{check_input_file, read_input_file},
    MAX_PROBLEM_FILE_BYTES,
};
use lcpbench_solvers::{
    is_cone_file, parse_cone_problem, parse_problem, read_problem, Problem, Settings,
};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Arguments of `lcpbench view`.
#[derive(Args)]
pub struct ViewArgs {
    /// A recording (`simulate --record`), two recordings of the same scene (side by side), a
    /// problem file (JSON), or a bench case key (such as `spd:n=50:cond=1e3:seed=1`).
    #[arg(required = true, num_args = 1..=2)]
    pub inputs: Vec<String>,
    /// Output HTML file.
    #[arg(long, short)]
    pub output: PathBuf,
    /// Size bound of the page in bytes: longer runs draw every k-th step in 3-D; a page that
    /// cannot fit (or a bound below what its scripts take) is an error.
    #[arg(long, default_value_t = DEFAULT_MAX_BYTES)]
    pub max_bytes: usize,
    /// Solver tolerance for a problem page.
    #[arg(long, default_value_t = 1e-8)]
    pub tol: f64,
    /// Iteration / pivot cap of each solver on a problem page.
    #[arg(long, default_value_t = 10_000)]
    pub max_iter: usize,
    /// Wall-time budget of a problem page's solves, seconds, shared by the solvers: each gets
    /// an equal share of what the ones before it left.
    #[arg(long, default_value_t = 60.0)]
    pub time_budget: f64,
}

/// What an input file holds: a recording starts with its header line, a problem file is one
/// JSON object with `A`. Only the start of a regular file is read.
fn is_recording(path: &Path) -> Result<bool> {
    check_input_file(path, MAX_RECORDING_BYTES.max(MAX_PROBLEM_FILE_BYTES))
        .with_context(|| format!("cannot read {}", path.display()))?;
    let file =
        std::fs::File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut start = Vec::new();
    file.take(4096)
        .read_to_end(&mut start)
        .with_context(|| format!("cannot read {}", path.display()))?;
    Ok(String::from_utf8_lossy(&start)
        .trim_start()
        .starts_with("{\"recording\""))
}

/// Run `lcpbench view`.
pub fn run(args: ViewArgs) -> Result<()> {
    budget::tolerance(args.tol).map_err(|m| anyhow::anyhow!("--tol: {m}"))?;
    if args.max_iter == 0 {
        bail!("--max-iter must be at least 1");
    }
    let time_budget =
        budget::time_budget(args.time_budget).map_err(|m| anyhow::anyhow!("--time-budget: {m}"))?;
    let inputs: Vec<(&str, &Path)> = args
        .inputs
        .iter()
        .map(|p| ("the input", Path::new(p)))
        .collect();
    check_outputs(&inputs, &[("--output", &args.output)])?;
    let started = std::time::Instant::now();
    let first = Path::new(&args.inputs[0]);
    let recording = first.exists() && is_recording(first)?;
    let min = view::min_page_bytes(recording);
    if args.max_bytes < min {
        bail!(
            "--max-bytes must be at least {min} (the page's scripts, styles and smallest data), \
             got {}",
            args.max_bytes
        );
    }
    let jsonl = first.extension().is_some_and(|e| e == "jsonl");
    if first.exists() && jsonl && !recording {
        bail!(
            "{}: not a recording: it does not start with the header line {{\"recording\": …}} \
             that `lcpbench simulate --record` writes",
            first.display()
        );
    }
    let html = if recording {
        let recordings = args
            .inputs
            .iter()
            .map(|p| Recording::read(Path::new(p)))
            .collect::<Result<Vec<_>, _>>()?;
        view::replay_page(&recordings, args.max_bytes)?
    } else {
        if args.inputs.len() > 1 {
            bail!("only recordings can be compared side by side; give one problem file or case");
        }
        let (problem, name) = if first.exists() {
            // A cone file (JSON with `W`, `q`, `mu`) is shown through its box form, whose rows
            // the cone solvers take back as contact triples.
            let p = read_view_problem(first)?;
            let name = p.name().map(str::to_owned).unwrap_or_else(|| {
                first
                    .file_stem()
                    .map_or("problem".into(), |s| s.to_string_lossy().into_owned())
            });
            (p, name)
        } else {
            let case: Case = args.inputs[0].parse().map_err(|e| {
                anyhow::anyhow!("{} is neither a file nor a case key: {e}", args.inputs[0])
            })?;
            // --time-budget covers reaching a scene step's problem too: the solves get
            // what is left of it.
            let loaded = case
                .load_lcp_within(Some(started + time_budget))
                .map_err(|e| anyhow::anyhow!("case {}: {e}", args.inputs[0]))?;
            (loaded.problem, args.inputs[0].clone())
        };
        let settings = Settings {
            tolerance: args.tol,
            max_iterations: args.max_iter,
            time_budget: Some(
                time_budget
                    .saturating_sub(started.elapsed())
                    .max(std::time::Duration::from_millis(1)),
            ),
            ..Settings::default()
        };
        view::problem_page(
            &view::problem_data(&problem, &name, &settings),
            args.max_bytes,
        )?
    };
    write_page(&args.output, &html)
}

/// The problem in the file at `path`, read once: a cone JSON file (`W`, `q`, `mu`) as its box
/// form, whose rows the cone solvers take back as contact triples; any other JSON file as an
/// LCP; other formats by [`read_problem`].
fn read_view_problem(path: &Path) -> Result<Problem> {
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    {
        return Ok(read_problem(path)?);
    }
    let bytes = read_input_file(path, MAX_PROBLEM_FILE_BYTES)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let Ok(text) = std::str::from_utf8(&bytes) else {
        return Ok(read_problem(path)?);
    };
    if is_cone_file(text) {
        Ok(parse_cone_problem(text, path)?.to_box())
    } else {
        Ok(parse_problem(text, path)?)
    }
}

/// Write a page and say where it went and how large it is.
pub fn write_page(path: &Path, html: &str) -> Result<()> {
    println!("{}", write_page_quietly(path, html)?);
    Ok(())
}

/// Write a page; returns the line saying where it went and how large it is.
pub fn write_page_quietly(path: &Path, html: &str) -> Result<String> {
    std::fs::write(path, html).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(format!(
        "wrote {} ({:.1} kB)",
        path.display(),
        html.len() as f64 / 1e3
    ))
}
