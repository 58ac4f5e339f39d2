//! Reports: run the default [`suite`], then turn `results.csv` and `histories.csv` into
//! Markdown tables (each also written as CSV under `tables/`) and SVG plots (each with the CSV of
//! its points under `plots/`), under a header that records the machine, the commit, the date
//! and the command.
//!
//! Layout of the output directory (default `reports/`):
//!
//! ```text
//! README.md            the report
//! data/results.csv     one row per run (see RunRecord)
//! data/histories.csv   convergence histories of the LCP runs
//! tables/*.csv         the data of every table
//! plots/*.svg, *.csv   every figure and its points
//! lcps/*.json          LCPs exported from the scenes (when scenes are available)
//! replays/*.html       self-contained replay pages of the scenes that are not large
//! ```
//!
//! Layout of the module, in the order data flows through it:
//!
//! ```text
//! suite.rs             which cases × solvers × budgets the report runs
//! context.rs           ReportContext (the rows indexed once by run key) and the Section trait
//! sections/            one module per section of the README, listed in sections/mod.rs:
//!   overview           title, header table (machine, commit, command, sweep), how to read it,
//!                      the timing method
//!   findings           the best solver and runner-up per family of cases and accuracy
//!   per_case           (`report --from` only) every case of a sweep: runs, times, figures
//!   budgets            the budget presets
//!   scenes             scenes at a glance, solver × budget and details per scene, best per
//!                      scene and accuracy, speed–accuracy plots (worst step residual)
//!   large_scenes       best solver per budget on the large scenes, worst-residual plots
//!   pipeline           phase times of a step on the large scenes, stacked bars
//!   towers             60 Hz towers under low iteration budgets: sag, drift, time, steps short
//!   engine_solvers     the substepping solvers and the Gauss–Seidel baselines at equal cost
//!                      (row updates per step) on Solver2D's scenes, with a peer engine's rows
//!   friction           box, pyramid and cone friction on the same scenes
//!   robustness         converged / runs per solver and problem class
//!   fastest            fastest solver to 1e-4 and 1e-8 per problem
//!   time_to_accuracy   problems reaching 1e-4 … 1e-10 and geometric-mean times
//!   profiles           Dolan–Moré performance profiles of the matrix solvers
//!   cone_profiles      the cone solvers on the exported scene steps, with profiles
//!   convergence        residual against iterations and time
//!   warm_start         warm against cold start of the iterative solvers
//!   sor_omega          SOR sweeps against omega
//!   scaling            log–log slopes of time against rows and against contacts
//!   fclib              the FCLIB problems of Siconos' test data: time to 1e-6 per solver
//! table.rs, plots.rs   Markdown/CSV tables and cell formats; SVG figures with their points
//! peers.rs             peer engines' figures (`docs/peers/*.csv`), read and checked
//! summary.rs           the one rule that ranks solvers over a group of cases, and its means
//! palette.rs           the plots' (colour, marker) pairs: fixed per shipped solver, distinct
//!                      for any number of series
//! status.rs            the run-status predicates the sections use
//! machine.rs           the header's machine, commit and date
//! machines.rs          the machines the rows ran on; the rows the timing tables use
//! replays.rs           the replay pages and the section linking them (appended after a run)
//! shard.rs             `report --shard K/N`: one part of the suite, no README
//! ```
//!
//! A new table is a new module under `sections/` and one line in its `SECTIONS` list.

mod context;
pub mod machine;
mod machines;
pub mod palette;
pub mod peers;
pub mod plots;
pub mod replays;
mod sections;
pub mod shard;
mod status;
pub mod suite;
pub mod summary;
mod table;

pub use machine::Header;
pub use sections::{write_report, write_report_from};

use crate::harness::outdir::{check_own_table, table_origin, TableOrigin};
use crate::harness::sweep::{history_columns, lock_dir, result_columns, run_sweep_locked};
use crate::harness::{SweepConfig, SweepSummary};
use anyhow::{bail, Context, Result};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `lcpbench report`.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Output directory. Default `reports`.
    pub out_dir: PathBuf,
    /// Run the small suite (tests). Default `false`.
    pub quick: bool,
    /// Keep rows of an earlier, interrupted run of the same suite. Default `false`: start fresh.
    pub resume: bool,
    /// Scene files of the suite.
    pub scenes: Vec<PathBuf>,
    /// Problem files exported from scenes.
    pub exported: Vec<PathBuf>,
    /// Sweep settings (executable, worker count, progress bar).
    pub sweep: SweepConfig,
    /// The command line, for the header.
    pub command: String,
}

/// What `run` did.
#[derive(Debug, Clone)]
pub struct ReportSummary {
    /// The sweep.
    pub sweep: SweepSummary,
    /// Seconds spent running the suite.
    pub sweep_seconds: f64,
    /// The README path.
    pub readme: PathBuf,
}

/// The time-of-impact runs' table in the data directory.
pub const IMPACT_TABLE: &str = "impact.csv";

/// Run the default suite into `out_dir/data` and write the report.
pub fn run(options: &ReportOptions) -> Result<ReportSummary> {
    let data = options.out_dir.join("data");
    // Locked before anything in it is removed, and until the sweep ends.
    let lock = lock_dir(&data)?;
    if !options.resume {
        // A fresh report replaces the tables of an earlier one (of any lcpbench version), and
        // nothing else: both are checked before either is removed.
        let tables = [
            (data.join("results.csv"), result_columns()),
            (data.join("histories.csv"), history_columns()),
        ];
        for (p, columns) in &tables {
            if let TableOrigin::Foreign { .. } = table_origin(p, columns)? {
                check_own_table(p, columns, "replace it with a fresh report's")?;
            }
        }
        for (p, columns) in &tables {
            if table_origin(p, columns)? != TableOrigin::Absent {
                std::fs::remove_file(p).with_context(|| format!("removing {}", p.display()))?;
            }
        }
    }
    let suite = suite::default_suite(options.quick, &options.scenes, &options.exported);
    let mut config = options.sweep.clone();
    config.out_dir = data;
    config.keep_histories = true;
    let start = Instant::now();
    let sweep = run_sweep_locked(&config, suite.jobs.clone(), &lock)?;
    // The time-of-impact runs, in this process after the sweep (section "Time of impact").
    crate::harness::impact::run_cases(
        &suite.impact_cases,
        &config.out_dir.join(IMPACT_TABLE),
        options.resume,
    )?;
    drop(lock);
    let sweep_seconds = start.elapsed().as_secs_f64();
    let header = Header::collect(&options.command, options.sweep.jobs, &options.out_dir);
    let readme = write_report(&options.out_dir, &suite, &header, sweep_seconds)?;
    append_replays(
        &options.out_dir,
        &suite::suite_scenes(options.quick, &options.scenes),
        &readme,
    )?;
    Ok(ReportSummary {
        sweep,
        sweep_seconds,
        readme,
    })
}

/// Write the replay pages of the scenes that are not large (a large scene's page would exceed
/// the size a committed report should carry; `lcpbench simulate SCENE --html` makes one) and
/// append the section that links them to the README.
fn append_replays(out_dir: &Path, scenes: &[PathBuf], readme: &Path) -> Result<()> {
    let small: Vec<PathBuf> = scenes
        .iter()
        .filter(|p| !suite::is_large_scene(p))
        .cloned()
        .collect();
    let links = replays::write_replays(&small, out_dir);
    let mut md =
        std::fs::read_to_string(readme).with_context(|| format!("reading {}", readme.display()))?;
    md.push('\n');
    md.push_str(&replays::replay_section(&links, out_dir));
    let large = scenes.len() - small.len();
    if large > 0 {
        md.push_str(&format!(
            "\n{large} large scenes have no committed replay (a page of theirs would be several \
             megabytes); make one with `lcpbench simulate SCENE --html page.html`.\n"
        ));
    }
    std::fs::write(readme, md).with_context(|| format!("writing {}", readme.display()))
}

/// First line of every README a report writes: how a later report knows the file is its own.
pub const README_TITLE: &str = "# lcpbench report";

/// The directories under a report's output directory whose files a report rewrites.
const REPORT_SUBDIRS: [&str; 3] = ["tables", "plots", "replays"];

/// Refuse to write a report into `out_dir` when that would overwrite files lcpbench did not
/// write: a `README.md` whose first line is not [`README_TITLE`], or files in `tables/`,
/// `plots/` or `replays/` of a directory that holds no report of lcpbench's (no README of its
/// own and no `data/results.csv` with lcpbench's header). Tables in `data/` are checked where
/// they are read ([`crate::harness::outdir`]); other files in the directory are never touched.
pub fn check_output_dir(out_dir: &Path) -> Result<()> {
    let readme = out_dir.join("README.md");
    let ours = match std::fs::symlink_metadata(&readme) {
        Err(_) => false,
        Ok(meta) if !meta.is_file() => bail!(
            "{} is not a regular file; a report writes its README there: choose another output \
             directory",
            readme.display()
        ),
        Ok(_) => {
            let mut head = String::new();
            std::fs::File::open(&readme)
                .and_then(|f| f.take(256).read_to_string(&mut head))
                .with_context(|| format!("reading {}", readme.display()))?;
            if head.lines().next().map(str::trim_end) != Some(README_TITLE) {
                bail!(
                    "{} is not a report lcpbench wrote (its first line is not `{README_TITLE}`); \
                     lcpbench never overwrites a file it did not write: choose another output \
                     directory, or move the file away",
                    readme.display()
                );
            }
            true
        }
    };
    if ours {
        return Ok(());
    }
    let results = out_dir.join("data").join("results.csv");
    let has_our_data = matches!(
        table_origin(&results, &result_columns()),
        Ok(TableOrigin::Current | TableOrigin::Older { .. })
    );
    if has_our_data {
        return Ok(());
    }
    for sub in REPORT_SUBDIRS {
        let dir = out_dir.join(sub);
        let occupied = std::fs::read_dir(&dir).is_ok_and(|mut entries| entries.next().is_some());
        if occupied {
            bail!(
                "{} holds files and {} holds no lcpbench report (no README.md of its own, no \
                 data/results.csv of its own); a report rewrites the files there, and lcpbench \
                 never overwrites a file it did not write: choose another output directory",
                dir.display(),
                out_dir.display()
            );
        }
    }
    Ok(())
}

/// Write `rows` as `out_dir/data/results.csv`, the table a report reads (for tests of the
/// report's sections).
#[cfg(test)]
pub(crate) fn write_results_for_tests(out_dir: &Path, rows: &[crate::harness::RunRecord]) {
    std::fs::create_dir_all(out_dir.join("data")).unwrap();
    let mut w = csv::Writer::from_path(out_dir.join("data/results.csv")).unwrap();
    for r in rows {
        w.serialize(r).unwrap();
    }
    w.flush().unwrap();
}

/// Files matching a glob pattern, sorted.
pub fn scenes_matching(pattern: &str) -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = glob::glob(pattern)
        .with_context(|| format!("bad glob `{pattern}`"))?
        .filter_map(|p| p.ok())
        .collect();
    v.sort();
    Ok(v)
}

/// The exported LCPs of an earlier run in `out_dir/lcps/*.json`, each named as that run's data
/// names it. A `file:` case is keyed by the path the run was given (`reports/lcps/x.json` for the
/// default `--out reports`), so tables rebuilt from a copy of the data in another directory look
/// the file up under its recorded path: the recorded `file:` case whose path ends in
/// `lcps/<name>` is used when there is exactly one, the listed path otherwise.
pub fn recorded_exports(out_dir: &Path) -> Result<Vec<PathBuf>> {
    let listed = scenes_matching(&out_dir.join("lcps").join("*.json").to_string_lossy())?;
    let results = out_dir.join("data").join("results.csv");
    if !results.exists() {
        return Ok(listed);
    }
    let mut recorded: Vec<PathBuf> = crate::harness::sweep::read_results(&results)?
        .into_iter()
        .filter_map(|r| r.case.strip_prefix("file:").map(PathBuf::from))
        .collect();
    recorded.sort();
    recorded.dedup();
    let in_lcps = |p: &Path| {
        p.parent()
            .and_then(Path::file_name)
            .is_some_and(|d| d == "lcps")
    };
    Ok(listed
        .into_iter()
        .map(|path| {
            let mut same = recorded
                .iter()
                .filter(|r| in_lcps(r) && r.file_name() == path.file_name());
            match (same.next(), same.next()) {
                (Some(r), None) => r.clone(),
                _ => path,
            }
        })
        .collect())
}

/// A path relative to `base` for links in the README (falls back to the path itself).
pub(crate) fn rel(path: &Path, base: &Path) -> String {
    path.strip_prefix(base)
        .unwrap_or(path)
        .to_string_lossy()
        .into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::record::RunRecord;

    #[test]
    fn recorded_exports_use_the_path_the_data_was_recorded_under() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("copy");
        std::fs::create_dir_all(out.join("lcps")).unwrap();
        std::fs::create_dir_all(out.join("data")).unwrap();
        for name in ["a_step3.json", "b_step3.json", "c_step3.json"] {
            std::fs::write(out.join("lcps").join(name), "{}").unwrap();
        }
        // Without data, the listed files as they are.
        let listed = recorded_exports(&out).unwrap();
        assert_eq!(listed.len(), 3);
        assert!(listed[0].starts_with(&out));
        // `a` recorded once under the default output, `b` under two directories (ambiguous),
        // `c` not at all: only `a` takes its recorded path.
        let mut w = csv::Writer::from_path(out.join("data").join("results.csv")).unwrap();
        for case in [
            "file:reports/lcps/a_step3.json",
            "file:reports/lcps/a_step3.json",
            "file:x/lcps/b_step3.json",
            "file:y/lcps/b_step3.json",
            "file:reports/elsewhere/c_step3.json",
            "spd:n=10:cond=1e2:seed=1",
        ] {
            let record = RunRecord {
                case: case.into(),
                ..RunRecord::default()
            };
            w.serialize(&record).unwrap();
        }
        w.flush().unwrap();
        drop(w);
        let got = recorded_exports(&out).unwrap();
        assert_eq!(
            got,
            vec![
                PathBuf::from("reports/lcps/a_step3.json"),
                out.join("lcps").join("b_step3.json"),
                out.join("lcps").join("c_step3.json"),
            ]
        );
    }
}
