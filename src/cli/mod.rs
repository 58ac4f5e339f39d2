//! The `lcpbench` command line, as a library: one module per subcommand, the scene loading
//! `simulate` and `export` share, and the entry points [`main`] and [`run_from_args`], which
//! the `lcpbench` binary calls and which a program adding its own solver calls after
//! registering it.

mod bench;
mod bench_one;
mod export;
mod gen;
mod import;
mod merge;
mod report;
mod simulate;
mod solve;
mod view;
mod world;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

/// Compare rigid-body contact solvers posed as linear complementarity problems.
#[derive(Parser)]
#[command(name = "lcpbench", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve one problem file with one solver.
    Solve(solve::SolveArgs),
    /// List the solvers and the problem classes each supports.
    Solvers,
    /// Write a random problem instance with a planted solution.
    Gen(gen::GenArgs),
    /// Run a scene and print per-run figures.
    Simulate(simulate::SimulateArgs),
    /// Write the contact LCP of one step of a scene as a problem file.
    Export(export::ExportArgs),
    /// Write an interactive HTML page of a recording (or two side by side) or of every solver
    /// on a problem.
    View(view::ViewArgs),
    /// Read a problem file (JSON, Siconos .dat, FCLIB .hdf5) and write it as JSON.
    Import(import::ImportArgs),
    /// Run solvers × scenes × budgets and write result rows as they finish.
    Bench(bench::BenchArgs),
    /// Run the default suite and write the comparison report.
    Report(report::ReportArgs),
    /// Join the output directories of the shards of a sweep (`--shard K/N`) into one.
    Merge(merge::MergeArgs),
    /// One isolated run of a sweep (used internally by `bench` and `report`).
    #[command(hide = true, name = "bench-one")]
    BenchOne(bench_one::BenchOneArgs),
}

/// Run the `lcpbench` command line on this process's arguments and return its exit code: what
/// the `lcpbench` binary's `main` does. A program that adds its own solver registers it
/// (`lcpbench::registry::register`) and then calls this from its `main`, first thing after
/// registering: it sets process-wide signal and allocator options, which must happen before
/// other threads exist. The sweep's isolated runs are child processes of the same program
/// (`std::env::current_exe()`), so they register the same solvers.
pub fn main() -> ExitCode {
    restore_default_sigpipe();
    keep_freed_memory();
    run_from_args(std::env::args_os())
}

/// Run the `lcpbench` command line on `args` (the first is the program name), returning its
/// exit code; errors are printed to standard error, help and usage errors as clap prints them.
/// Unlike [`main`], sets no process-wide options.
pub fn run_from_args<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let matches = match with_solver_lists(Cli::command()).try_get_matches_from(args) {
        Ok(m) => m,
        Err(e) => e.exit(),
    };
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Command::Solve(args) => solve::run(args),
        Command::Solvers => solve::list_solvers(),
        Command::Gen(args) => gen::run(args),
        Command::Simulate(args) => simulate::run_simulate(args),
        Command::Export(args) => export::run(args),
        Command::View(args) => view::run(args),
        Command::Import(args) => import::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Report(args) => report::run(args),
        Command::Merge(args) => merge::run(args),
        Command::BenchOne(args) => bench_one::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// The help of every option that takes a solver, completed with the solver names of the one
/// solver table ([`solve::solver_names`], the catalogue `lcpbench solvers` prints), so
/// that no help text lists solvers by hand or falls behind the table.
fn with_solver_lists(command: clap::Command) -> clap::Command {
    use crate::harness::catalogue::SolverLevel::{self, Body, Cone, Matrix};
    use solve::solver_names;
    let lists = |levels: &[SolverLevel]| {
        levels
            .iter()
            .map(|&level| format!("{}: {}", level.plural(), solver_names(&[level])))
            .collect::<Vec<_>>()
            .join("; ")
    };
    let complete = move |arg: clap::Arg, levels: &[SolverLevel]| {
        let base = arg
            .get_long_help()
            .or(arg.get_help())
            .map(|h| h.to_string())
            .unwrap_or_default();
        let text = format!("{base}\n\n[{}]", lists(levels));
        arg.help(text.clone()).long_help(text)
    };
    command
        .mut_subcommand("solve", |c| {
            c.mut_arg("solver", |a| complete(a, &[Matrix, Cone]))
        })
        .mut_subcommand("simulate", |c| {
            c.mut_arg("solver", |a| complete(a, &[Matrix, Body, Cone]))
        })
        .mut_subcommand("bench", |c| {
            c.mut_arg("solvers", |a| complete(a, &[Matrix, Body, Cone]))
        })
}

/// Let a write to a closed pipe end the process quietly, as it ends `cat` or `grep`: `lcpbench
/// solve … | head -1` stops when `head` has its line, with the shell's usual status for it (141,
/// killed by `SIGPIPE`), and no message.
///
/// The Rust runtime ignores `SIGPIPE`, which turns such a write into an `EPIPE` error that
/// `println!` (and `eprintln!`, and every progress bar) answers with a panic. Restoring the
/// default action before anything is printed covers every printing path at once, including
/// clap's help and error output. The sweep's parent process never writes to its children's
/// pipes, so it cannot be ended this way by a child that exits.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first in `main`, before any other thread exists; `signal` with `SIG_DFL`
    // only changes this process's disposition of `SIGPIPE`.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Let the allocator keep the memory a time step frees for the next step. A step of a large
/// scene allocates its contact system, Jacobian and solver workspaces anew, tens of megabytes
/// in blocks above glibc's mapping threshold; by default each such block is mapped on
/// allocation and unmapped when freed, so every step pays the kernel to fault in and zero the
/// same pages again (measured: a third of the assembly phase of `pyramid_3d_1015`). Serving
/// blocks up to 1 GiB from the heap and never trimming it makes the next step reuse them. The
/// resident size stays at the largest step's, which it reaches anyway.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: called in `main` before any other thread exists; `mallopt` only changes the
    // thresholds of glibc's allocator, and a refused value leaves the default in place.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 30);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

/// The error and its causes joined by `: `, leaving out a cause whose text the message already
/// contains (typed errors such as `ProblemFileError::Io` print their source themselves).
fn error_chain(e: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if message.is_empty() {
            message = text;
        } else if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    message
}
