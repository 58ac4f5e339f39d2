//! Process isolation: each run executes in a child process (`lcpbench bench-one …`, a hidden
//! subcommand), which prints its row and history on stdout in a small CSV-based protocol. A
//! child that panics, aborts, exits with an error or produces no row becomes a failure row; one
//! that outlives [`Budget::kill_after`](crate::harness::budget::Budget::kill_after) is killed and
//! recorded as `timeout`. An LCP or cone run's child writes [`READY_MARKER`] on stderr when
//! its problem is built and the solve starts ([`signal_ready`]); the kill limit then counts
//! from that moment, so building a large scene step (simulating its earlier steps, assembling
//! `W`) does not eat into the time its solve is given.
//!
//! The protocol (stdout of the child):
//!
//! ```text
//! #record
//! <CSV header of RunRecord>
//! <one CSV row>
//! #history
//! iteration,time_s,residual
//! …
//! ```
//!
//! CSV rather than JSON so infinite and NaN residuals survive the trip.

use crate::harness::case::Case;
use crate::harness::machine::Machine;
use crate::harness::record::{base_record, RunOutput, RunRecord, RunStatus};
use crate::harness::{NamedBudget, SolverSpec};
use lcpbench_solvers::HistoryPoint;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// Name of the hidden subcommand the child runs.
pub const CHILD_SUBCOMMAND: &str = "bench-one";

/// The stderr line of a child whose problem is built and whose solve starts now.
pub const READY_MARKER: &str = "#ready";

/// Set in the child process: [`signal_ready`] writes the marker only there.
static IS_CHILD: AtomicBool = AtomicBool::new(false);

/// Mark this process as an isolated child (the `bench-one` subcommand).
pub fn mark_child() {
    IS_CHILD.store(true, Ordering::Relaxed);
}

/// In a child, tell the parent that the problem is built and the solve starts: its kill limit
/// counts from here. Does nothing in any other process.
pub fn signal_ready() {
    if IS_CHILD.load(Ordering::Relaxed) {
        let mut err = std::io::stderr().lock();
        let _ = writeln!(err, "{READY_MARKER}");
        let _ = err.flush();
    }
}

/// Write a run's output in the child protocol.
pub fn write_protocol(out: &mut impl Write, output: &RunOutput) -> std::io::Result<()> {
    writeln!(out, "#record")?;
    {
        let mut w = csv::Writer::from_writer(&mut *out);
        w.serialize(&output.record).map_err(std::io::Error::other)?;
        w.flush()?;
    }
    writeln!(out, "#history")?;
    writeln!(out, "iteration,time_s,residual")?;
    for h in &output.history {
        writeln!(out, "{},{:e},{:e}", h.iteration, h.time_s, h.residual)?;
    }
    out.flush()
}

/// Parse the child protocol.
pub fn parse_protocol(text: &str) -> Result<RunOutput, String> {
    let rec_start = text
        .find("#record\n")
        .ok_or("child printed no #record section")?;
    let body = &text[rec_start + "#record\n".len()..];
    let (rec_text, hist_text) = match body.find("#history\n") {
        Some(i) => (&body[..i], &body[i + "#history\n".len()..]),
        None => (body, ""),
    };
    let mut reader = csv::Reader::from_reader(rec_text.as_bytes());
    let record: RunRecord = reader
        .deserialize()
        .next()
        .ok_or("empty #record section")?
        .map_err(|e| format!("bad #record row: {e}"))?;
    let mut history = Vec::new();
    for line in hist_text.lines().skip(1) {
        let mut parts = line.split(',');
        let (Some(i), Some(t), Some(r)) = (parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        if let (Ok(iteration), Ok(time_s), Ok(residual)) = (i.parse(), t.parse(), r.parse()) {
            history.push(HistoryPoint {
                iteration,
                time_s,
                residual,
            });
        }
    }
    Ok(RunOutput { record, history })
}

/// Run one (case, solver, budget) in a child process of `exe` and return its output, or a
/// failure row (`panic`, `crash`, `timeout`, `error`); either row records this machine (the
/// child's).
pub fn run_isolated(exe: &Path, case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let mut output = run_child(exe, case, spec, budget);
    output.record.set_machine(Machine::current());
    output
}

/// [`run_isolated`] without the machine columns.
fn run_child(exe: &Path, case: &Case, spec: &SolverSpec, budget: &NamedBudget) -> RunOutput {
    let start = Instant::now();
    let b = &budget.budget;
    let budget_spec = format!("{:e}:{}:{}", b.tolerance, b.max_iterations, b.time_s);
    let child = Command::new(exe)
        .arg(CHILD_SUBCOMMAND)
        .arg("--case")
        .arg(case.to_string())
        .arg("--solver")
        .arg(spec.to_string())
        .arg("--budget")
        .arg(&budget_spec)
        .arg("--budget-name")
        .arg(budget.name.to_string())
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let failure = |status: RunStatus, reason: String, wall: f64| {
        let mut record = base_record(case, spec, budget);
        record.wall_time_s = wall;
        RunOutput::failed(record, status, reason)
    };
    let mut child = match child {
        Ok(c) => c,
        Err(e) => {
            return failure(
                RunStatus::Error,
                format!("cannot start {}: {e}", exe.display()),
                0.0,
            )
        }
    };
    let limit = b.kill_after(case.planned_steps());
    let (exit, out, err) = wait_with_limit(&mut child, start, limit);
    let wall = start.elapsed().as_secs_f64();
    let Some(exit) = exit else {
        return failure(
            RunStatus::Timeout,
            format!("killed after {:.1} s (budget {} s)", wall, b.time_s),
            wall,
        );
    };
    let last_err = err
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.contains("RUST_BACKTRACE"))
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(" | ");
    if exit.success() {
        return match parse_protocol(&out) {
            Ok(mut output) => {
                output.record.wall_time_s = wall;
                output
            }
            Err(e) => failure(RunStatus::Error, e, wall),
        };
    }
    if err.contains("panicked") {
        return failure(RunStatus::Panic, last_err, wall);
    }
    match exit.code() {
        Some(code) => failure(
            RunStatus::Error,
            format!("exit code {code}: {last_err}"),
            wall,
        ),
        None => {
            #[cfg(unix)]
            let signal = std::os::unix::process::ExitStatusExt::signal(&exit);
            #[cfg(not(unix))]
            let signal: Option<i32> = None;
            failure(
                RunStatus::Crash,
                format!("terminated by signal {}", signal.unwrap_or(-1)),
                wall,
            )
        }
    }
}

/// Wait for `child` until `limit` after `start` (then kill it), draining its stdout and stderr
/// on threads so a chatty child never blocks on a full pipe. A [`READY_MARKER`] line on stderr
/// before that moment moves the limit to `limit` after the marker (the line is not kept).
/// Returns the exit status (`None` when it was killed or could not be waited for) and the two
/// outputs.
fn wait_with_limit(
    child: &mut std::process::Child,
    start: Instant,
    limit: Duration,
) -> (Option<std::process::ExitStatus>, String, String) {
    let ready: Arc<OnceLock<Instant>> = Arc::new(OnceLock::new());
    let stdout = child.stdout.take();
    let out_thread = std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(mut pipe) = stdout {
            let _ = pipe.read_to_string(&mut s);
        }
        s
    });
    let stderr = child.stderr.take();
    let seen = Arc::clone(&ready);
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let Some(pipe) = stderr else {
            return s;
        };
        // Bytes, not lines of text: a child writing invalid UTF-8 is still drained to the end.
        let mut reader = BufReader::new(pipe);
        let mut line = Vec::new();
        while matches!(reader.read_until(b'\n', &mut line), Ok(n) if n > 0) {
            let text = String::from_utf8_lossy(&line);
            if text.trim_end() == READY_MARKER {
                seen.get_or_init(Instant::now);
            } else {
                s.push_str(&text);
            }
            line.clear();
        }
        s
    });
    let deadline = || {
        let from = ready
            .get()
            .copied()
            .filter(|at| at.saturating_duration_since(start) < limit)
            .unwrap_or(start);
        from.checked_add(limit)
    };
    let mut poll = Duration::from_millis(1);
    let exit = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Some(status),
            Ok(None) if deadline().is_some_and(|d| Instant::now() >= d) => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => {
                std::thread::sleep(poll);
                poll = (poll * 2).min(Duration::from_millis(20));
            }
            Err(_) => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
        }
    };
    let out = out_thread.join().unwrap_or_default();
    let err = err_thread.join().unwrap_or_default();
    (exit, out, err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::run::run_in_process;

    /// A child that says it is ready gets the limit again from that moment; the same child
    /// without the marker is killed at the limit; the marker is not kept in its stderr.
    #[cfg(unix)]
    #[test]
    fn the_ready_marker_restarts_the_kill_limit() {
        let run = |marker: &str| {
            let script = format!("sleep 0.4; {marker} echo before >&2; sleep 0.4; echo finished");
            let mut child = Command::new("sh")
                .args(["-c", &script])
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap();
            wait_with_limit(&mut child, Instant::now(), Duration::from_millis(600))
        };
        let (exit, out, err) = run(&format!("echo '{READY_MARKER}' >&2;"));
        assert!(
            exit.is_some_and(|e| e.success()),
            "killed despite the marker"
        );
        assert_eq!(out, "finished\n");
        assert_eq!(err, "before\n");
        let (exit, out, _) = run("");
        assert!(exit.is_none(), "not killed without the marker");
        assert_eq!(out, "");
    }

    #[test]
    fn protocol_round_trips_infinite_residuals() {
        let case: Case = "spd:n=6:cond=1e2:seed=1".parse().unwrap();
        let spec: SolverSpec = "pgs".parse().unwrap();
        let budget: NamedBudget = "default".parse().unwrap();
        let mut output = run_in_process(&case, &spec, &budget);
        output.record.residual_abs = Some(f64::INFINITY);
        output.record.reason = "a, \"quoted\"\nreason".into();
        let mut buf = Vec::new();
        write_protocol(&mut buf, &output).unwrap();
        let back = parse_protocol(std::str::from_utf8(&buf).unwrap()).unwrap();
        assert_eq!(back.record.residual_abs, Some(f64::INFINITY));
        assert_eq!(back.record.reason, output.record.reason);
        assert_eq!(back.history.len(), output.history.len());
    }
}
