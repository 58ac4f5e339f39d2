//! From result rows to the report: tables (Markdown + CSV) and figures (SVG + CSV).

use super::machine::Header;
use super::plots::{loglog_fit, plot, LegendAt, Mark, PlotSpec, Series};
use super::rel;
use super::suite::Suite;
use crate::harness::sweep::{read_histories, read_results};
use crate::harness::{
    Budget, Case, HistoryRow, ProblemClass, RunKey, RunRecord, RunStatus, TTA_LEVELS,
};
use anyhow::Result;
use lcpbench_contact::body_solvers::BodySolverKind;
use lcpbench_solvers::{ConeSolverKind, SolverKind};
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A table: header and rows of cells, written both as Markdown and as CSV.
pub(super) struct Table {
    pub(super) name: &'static str,
    pub(super) header: Vec<String>,
    pub(super) rows: Vec<Vec<String>>,
}

impl Table {
    pub(super) fn new(name: &'static str, header: &[&str]) -> Self {
        Self {
            name,
            header: header.iter().map(|s| s.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub(super) fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "| {} |", self.header.join(" | "));
        let _ = writeln!(
            s,
            "|{}|",
            self.header
                .iter()
                .map(|_| "---")
                .collect::<Vec<_>>()
                .join("|")
        );
        for r in &self.rows {
            let _ = writeln!(s, "| {} |", r.join(" | "));
        }
        s
    }

    pub(super) fn write_csv(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join(format!("{}.csv", self.name));
        let mut w = csv::Writer::from_path(&path)?;
        w.write_record(&self.header)?;
        for r in &self.rows {
            w.write_record(r)?;
        }
        w.flush()?;
        Ok(path)
    }
}

pub(super) fn fmt_time(s: Option<f64>) -> String {
    match s {
        None => "–".into(),
        Some(s) if s < 1e-3 => format!("{:.1} µs", s * 1e6),
        Some(s) if s < 1.0 => format!("{:.2} ms", s * 1e3),
        Some(s) => format!("{s:.2} s"),
    }
}

pub(super) fn fmt_sci(v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(0.0) => "0".into(),
        Some(v) => format!("{v:.1e}"),
    }
}

fn solver_names() -> Vec<&'static str> {
    SolverKind::ALL.iter().map(|k| k.name()).collect()
}

fn scene_solver_names() -> Vec<&'static str> {
    let mut v = solver_names();
    v.extend(BodySolverKind::ALL.iter().map(|k| k.name()));
    v
}

fn geo_mean(v: &[f64]) -> Option<f64> {
    let v: Vec<f64> = v.iter().copied().filter(|x| *x > 0.0).collect();
    (!v.is_empty()).then(|| (v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp())
}

pub(super) struct Data<'a> {
    by_key: HashMap<RunKey, &'a RunRecord>,
}

impl<'a> Data<'a> {
    pub(super) fn new(rows: &'a [RunRecord]) -> Self {
        let by_key = rows.iter().map(|r| (r.key(), r)).collect();
        Self { by_key }
    }

    pub(super) fn get(&self, case: &Case, solver: &str, budget: &str) -> Option<&'a RunRecord> {
        self.by_key
            .get(&RunKey::new(&case.to_string(), solver, budget))
            .copied()
    }
}

/// Write README.md, tables/ and plots/ from `out_dir/data`. Returns the README path.
pub fn write_report(
    out_dir: &Path,
    suite: &Suite,
    header: &Header,
    sweep_seconds: f64,
) -> Result<PathBuf> {
    let data_dir = out_dir.join("data");
    let tables_dir = out_dir.join("tables");
    let plots_dir = out_dir.join("plots");
    std::fs::create_dir_all(&tables_dir)?;
    std::fs::create_dir_all(&plots_dir)?;
    let rows = read_results(&data_dir.join("results.csv"))?;
    let hist_path = data_dir.join("histories.csv");
    let histories = if hist_path.exists() {
        read_histories(&hist_path)?
    } else {
        Vec::new()
    };
    let data = Data::new(&rows);
    let mut md = String::new();
    let mut figures: Vec<(String, PathBuf)> = Vec::new();

    // Header.
    let _ = writeln!(md, "# lcpbench report\n");
    let _ = writeln!(
        md,
        "Regenerate with `cargo run --release -- report` (about twenty minutes on two cores; \
         `--quick` for a small version); run the tests with `cargo test --workspace`.\n"
    );
    let failures = rows.iter().filter(|r| r.is_isolation_failure()).count();
    let mut h = Table::new("header", &["field", "value"]);
    for (k, v) in [
        ("date (UTC)", header.date.clone()),
        ("commit", header.commit.clone()),
        (
            "machine",
            format!("{}, {} cores, {}", header.cpu, header.cores, header.os),
        ),
        ("command", format!("`{}`", header.command)),
        (
            "runs",
            format!(
                "{} rows ({} isolation failures: panic, crash, timeout or error), sweep {:.0} s \
                 on {} worker processes",
                rows.len(),
                failures,
                sweep_seconds,
                header.workers
            ),
        ),
    ] {
        h.rows.push(vec![k.to_owned(), v]);
    }
    h.write_csv(&tables_dir)?;
    md.push_str(&h.markdown());
    let _ = writeln!(
        md,
        "\nEvery run is one child process (a panic, abort or hang is recorded, not fatal). \
         Residuals are the shared relative natural-map residual of the returned impulse, \
         `max_i |f_i − mid(lo_i, hi_i, f_i − w_i/A_ii)| / ((|b_i| + Σ_j |A_ij f_j|) / A_ii)`: \
         each row measured against the magnitudes its own velocity is made of, so no row, bound \
         or scale can hide another row's error (see the README); times are solver wall time with residual measurement excluded. Raw rows: \
         [`data/results.csv`](data/results.csv); convergence histories: \
         [`data/histories.csv`](data/histories.csv); every table below is also in `tables/`, \
         every figure's points next to it in `plots/`.\n"
    );
    let mut b = Table::new(
        "budgets",
        &["budget", "tolerance", "iteration cap", "time budget (s)"],
    );
    for (name, bud) in Budget::PRESETS.iter() {
        b.rows.push(vec![
            name.to_string(),
            format!("{:.0e}", bud.tolerance),
            bud.max_iterations.to_string(),
            format!("{}", bud.time_s),
        ]);
    }
    b.write_csv(&tables_dir)?;
    let _ = writeln!(md, "## Budgets\n\n{}", b.markdown());

    // Scenes.
    if !suite.scene_cases.is_empty() {
        scene_section(&mut md, &data, suite, &tables_dir, &plots_dir, &mut figures)?;
        md.push_str(&super::towers::section(&data, suite, &tables_dir)?);
    }

    // Friction models.
    if !suite.friction_cases.is_empty() {
        super::friction::friction_section(&mut md, &data, suite, &tables_dir)?;
    }

    // Robustness matrix.
    let mut classes: Vec<ProblemClass> = ProblemClass::MATRIX.to_vec();
    if suite.exported_cases.is_empty() {
        classes.retain(|c| *c != ProblemClass::Friction);
    }
    let mut header_cells = vec!["solver".to_owned()];
    header_cells.extend(classes.iter().map(|c| c.name().to_owned()));
    let mut robust = Table {
        name: "robustness",
        header: header_cells,
        rows: Vec::new(),
    };
    let lcp_cases: Vec<&Case> = suite
        .matrix_cases
        .iter()
        .chain(&suite.exported_cases)
        .collect();
    for solver in solver_names() {
        let mut row = vec![solver.to_owned()];
        for class in &classes {
            let runs: Vec<&RunRecord> = lcp_cases
                .iter()
                .filter_map(|c| data.get(c, solver, "default"))
                .filter(|r| r.class == class.name())
                .collect();
            let total = runs.len();
            let cell = if total == 0 {
                "–".to_owned()
            } else if *class == ProblemClass::Infeasible {
                let ok = runs
                    .iter()
                    .filter(|r| r.status == RunStatus::NoSolution)
                    .count();
                format!("{} {ok}/{total} detected", mark(ok, total))
            } else {
                let ok = runs.iter().filter(|r| r.converged).count();
                let unsupported = runs
                    .iter()
                    .filter(|r| r.status == RunStatus::Unsupported)
                    .count();
                let crashed = runs.iter().filter(|r| r.is_isolation_failure()).count();
                let mut s = format!("{} {ok}/{total}", mark(ok, total));
                if unsupported > 0 {
                    let _ = write!(s, " ({unsupported} unsupported)");
                }
                if crashed > 0 {
                    let _ = write!(s, " ({crashed} crashed)");
                }
                s
            };
            row.push(cell);
        }
        robust.rows.push(row);
    }
    robust.write_csv(&tables_dir)?;
    let _ = writeln!(
        md,
        "## Robustness matrix\n\nWhich solver solves which class (budget `default`: tolerance \
         1e-8, 10 000 iterations, 5 s), as Siconos' expected-failure matrix: converged runs / \
         runs; for the infeasible class, runs that *report* infeasibility (`no_solution`). \
         ✓ all, ~ some, ✗ none. Classes: SPD (cond 1e2–1e10), rank-deficient PSD, \
         non-symmetric P-matrices and Murty's example, degenerate (duplicated rows, weakly \
         complementary solutions, `b = 0`), infeasible{}.\n\n{}",
        if classes.contains(&ProblemClass::Friction) {
            ", friction (boxed LCPs exported from the scenes)"
        } else {
            ""
        },
        robust.markdown()
    );

    // Fastest solver per case, from the tight budget's histories.
    let mut fastest = Table::new(
        "fastest",
        &[
            "case",
            "n",
            "fastest to 1e-4",
            "time",
            "fastest to 1e-8",
            "time",
        ],
    );
    for case in &lcp_cases {
        if case.class() == ProblemClass::Infeasible {
            continue;
        }
        let mut row = vec![format!("`{case}`")];
        let n = solver_names()
            .iter()
            .find_map(|s| data.get(case, s, "tight").and_then(|r| r.n));
        row.push(n.map(|n| n.to_string()).unwrap_or_default());
        for level in [1e-4, 1e-8] {
            let best = solver_names()
                .into_iter()
                .filter_map(|s| data.get(case, s, "tight"))
                .filter_map(|r| r.tta(level).map(|t| (r.solver.clone(), t)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match best {
                Some((s, t)) => {
                    row.push(s);
                    row.push(fmt_time(Some(t)));
                }
                None => {
                    row.push("none".into());
                    row.push("–".into());
                }
            }
        }
        fastest.rows.push(row);
    }
    fastest.write_csv(&tables_dir)?;
    let _ = writeln!(
        md,
        "## Fastest solver per problem\n\nSolver time until the shared relative residual first \
         reached 1e-4 and 1e-8 (from the residual history of each solve under budget `tight`).\n\n{}",
        fastest.markdown()
    );

    // Time to accuracy summary.
    let mut tta = Table::new(
        "time_to_accuracy_summary",
        &["solver", "≤1e-4", "≤1e-6", "≤1e-8", "≤1e-10"],
    );
    let mut tta_full = Table::new(
        "time_to_accuracy",
        &[
            "case", "solver", "t_1e-4", "t_1e-6", "t_1e-8", "t_1e-10", "status",
        ],
    );
    let feasible: Vec<&Case> = lcp_cases
        .iter()
        .copied()
        .filter(|c| c.class() != ProblemClass::Infeasible)
        .collect();
    for solver in solver_names() {
        let runs: Vec<&RunRecord> = feasible
            .iter()
            .filter_map(|c| data.get(c, solver, "tight"))
            .collect();
        let mut row = vec![solver.to_owned()];
        for level in TTA_LEVELS {
            let times: Vec<f64> = runs.iter().filter_map(|r| r.tta(level)).collect();
            row.push(format!(
                "{}/{} (geo. mean {})",
                times.len(),
                runs.len(),
                fmt_time(geo_mean(&times))
            ));
        }
        tta.rows.push(row);
        for r in runs {
            let mut row = vec![r.case.clone(), r.solver.clone()];
            row.extend(
                TTA_LEVELS
                    .iter()
                    .map(|&l| r.tta(l).map(|t| format!("{t:e}")).unwrap_or_default()),
            );
            row.push(r.status.to_string());
            tta_full.rows.push(row);
        }
    }
    tta.write_csv(&tables_dir)?;
    tta_full.write_csv(&tables_dir)?;
    let _ = writeln!(
        md,
        "## Time to accuracy\n\nProblems (feasible ones of the matrix{}) on which each solver \
         reached the relative residual, and the geometric mean of the time it took on those; \
         per problem in [`tables/time_to_accuracy.csv`](tables/time_to_accuracy.csv).\n\n{}",
        if suite.exported_cases.is_empty() {
            ""
        } else {
            " and the exported scene LCPs"
        },
        tta.markdown()
    );

    // Performance profiles.
    let lcp_solvers = solver_names();
    for (level, label) in [(1e-4, "1e-4"), (1e-8, "1e-8")] {
        let path = plots_dir.join(format!("profile_{label}.svg"));
        let series = performance_profile(&data, &feasible, &lcp_solvers, level);
        profile_plot(
            &path,
            format!("Performance profile, time to relative residual {label}"),
            &series,
        )?;
        figures.push((format!("Dolan–Moré performance profile at {label}"), path));
    }
    md.push_str(&cone_profiles(
        &data,
        suite,
        &tables_dir,
        &plots_dir,
        &mut figures,
    )?);

    // Convergence histories.
    for case in &suite.history_cases {
        let slug = slug(&case.to_string());
        let hs: Vec<&HistoryRow> = histories
            .iter()
            .filter(|h| h.case == case.to_string() && h.budget == "tight")
            .collect();
        let mut by_solver: BTreeMap<String, Vec<&HistoryRow>> = BTreeMap::new();
        for h in hs {
            if SolverKind::from_name(&h.solver).is_some() {
                by_solver.entry(h.solver.clone()).or_default().push(h);
            }
        }
        for (axis, x_label, log_x) in [
            (
                "iter",
                "iterations (sweeps, pivots, interior-point steps)",
                true,
            ),
            ("time", "solver time (s)", true),
        ] {
            let series: Vec<Series> = by_solver
                .iter()
                .map(|(s, pts)| Series {
                    name: s.clone(),
                    color_key: s.clone(),
                    points: pts
                        .iter()
                        .map(|h| {
                            let x = if axis == "iter" {
                                h.iteration as f64
                            } else {
                                h.time_s
                            };
                            (x, h.residual.max(1e-17))
                        })
                        .collect(),
                    mark: Mark::Line,
                })
                .collect();
            let path = plots_dir.join(format!("convergence_{slug}_{axis}.svg"));
            plot(
                &path,
                &PlotSpec {
                    title: format!("Convergence on {case}"),
                    x_label: x_label.into(),
                    y_label: "relative natural-map residual".into(),
                    log_x,
                    log_y: true,
                    y_range: None,
                    legend: LegendAt::UpperRight,
                },
                &series,
            )?;
            figures.push((
                format!("Residual against {axis} on `{case}` (budget tight)"),
                path,
            ));
        }
    }

    // Warm versus cold.
    let mut warm = Table::new(
        "warm_vs_cold",
        &[
            "case",
            "solver",
            "iterations cold",
            "iterations warm",
            "time cold",
            "time warm",
            "status cold / warm",
        ],
    );
    for case in &suite.warm_cases {
        for kind in SolverKind::ALL.iter().filter(|k| k.is_iterative()) {
            let cold = data.get(case, kind.name(), "default");
            let hot = data.get(case, &format!("{}+warm", kind.name()), "default");
            if cold.is_none() && hot.is_none() {
                continue;
            }
            let it = |r: Option<&RunRecord>| {
                r.and_then(|r| r.iterations)
                    .map(|i| i.to_string())
                    .unwrap_or("–".into())
            };
            let st = |r: Option<&RunRecord>| r.map(|r| r.status.to_string()).unwrap_or("–".into());
            warm.rows.push(vec![
                format!("`{case}`"),
                kind.name().to_owned(),
                it(cold),
                it(hot),
                fmt_time(cold.and_then(|r| r.solve_time_s)),
                fmt_time(hot.and_then(|r| r.solve_time_s)),
                format!("{} / {}", st(cold), st(hot)),
            ]);
        }
    }
    warm.write_csv(&tables_dir)?;
    let _ = writeln!(
        md,
        "## Warm start versus cold start\n\nIterative solvers, budget `default`. The warm start \
         of a generated problem is its planted solution perturbed by 1 % (as from the previous \
         step of a slowly changing scene); of a problem file, 20 cold PGS sweeps.\n\n{}",
        warm.markdown()
    );

    // SOR omega sweep.
    let mut omega_header = vec!["omega".to_owned()];
    omega_header.extend(
        suite
            .omega_cases
            .iter()
            .map(|c| format!("`{c}` iterations")),
    );
    let mut omega_t = Table {
        name: "sor_omega",
        header: omega_header,
        rows: Vec::new(),
    };
    let mut omega_series: Vec<Series> = suite
        .omega_cases
        .iter()
        .map(|c| Series {
            name: c.to_string(),
            color_key: c.to_string(),
            points: Vec::new(),
            mark: Mark::LinePoints,
        })
        .collect();
    for &w in &suite.omegas {
        let mut row = vec![format!("{w}")];
        for (i, case) in suite.omega_cases.iter().enumerate() {
            let r = data.get(case, &format!("sor@{w}"), "default");
            let cell = match r {
                Some(r) if r.converged => {
                    let it = r.iterations.unwrap_or(0);
                    omega_series[i].points.push((w, it as f64));
                    it.to_string()
                }
                Some(r) => format!("{} ({})", r.iterations.unwrap_or(0), r.status),
                None => "–".into(),
            };
            row.push(cell);
        }
        omega_t.rows.push(row);
    }
    omega_t.write_csv(&tables_dir)?;
    let _ = writeln!(
        md,
        "## SOR relaxation sweep\n\nSweeps to relative residual 1e-8 (budget `default`) \
         against the relaxation factor `omega` (`omega = 1` is PGS).\n\n{}",
        omega_t.markdown()
    );
    let path = plots_dir.join("sor_omega.svg");
    plot(
        &path,
        &PlotSpec {
            title: "SOR: sweeps to 1e-8 against omega".into(),
            x_label: "omega".into(),
            y_label: "sweeps".into(),
            log_x: false,
            log_y: true,
            y_range: None,
            legend: LegendAt::UpperRight,
        },
        &omega_series,
    )?;
    figures.push(("SOR sweeps against omega".into(), path));

    // Scaling.
    let mut scaling_series = Vec::new();
    let mut slopes = Table::new(
        "scaling_slopes",
        &[
            "solver",
            "time ∝ n^k (SPD LCPs, budget default)",
            "time/step ∝ contacts^k (scene scaling family)",
        ],
    );
    let mut scene_slope: HashMap<String, String> = HashMap::new();
    // The scaling family when it ran, otherwise every scene.
    let scaling_scenes = if suite.scene_scaling_cases.is_empty() {
        &suite.scene_cases
    } else {
        &suite.scene_scaling_cases
    };
    if !scaling_scenes.is_empty() {
        let mut series = Vec::new();
        for solver in scene_solver_names() {
            let pts: Vec<(f64, f64)> = scaling_scenes
                .iter()
                .filter_map(|c| data.get(c, solver, "default"))
                .filter(|r| {
                    r.blow_up != Some(true)
                        && !r.is_isolation_failure()
                        && r.fallback_steps == Some(0)
                })
                .filter_map(|r| Some((r.contacts_mean?, r.time_per_step_s?)))
                .filter(|(c, t)| *c > 0.0 && *t > 0.0)
                .collect();
            push_fit(&mut series, solver, pts, &mut scene_slope);
        }
        let path = plots_dir.join("scaling_scenes.svg");
        plot(
            &path,
            &PlotSpec {
                title: "Scenes: solver time per step against contacts".into(),
                x_label: "mean contacts per step".into(),
                y_label: "solver time per step (s)".into(),
                log_x: true,
                log_y: true,
                y_range: None,
                legend: LegendAt::LowerRight,
            },
            &series,
        )?;
        figures.push((
            "Solver time per step against contacts (log–log, fitted slopes)".into(),
            path,
        ));
    }
    let mut lcp_slope = HashMap::new();
    for solver in solver_names() {
        let pts: Vec<(f64, f64)> = suite
            .scaling_cases
            .iter()
            .filter_map(|c| data.get(c, solver, "default"))
            .filter(|r| r.converged)
            .filter_map(|r| Some((r.n? as f64, r.solve_time_s?)))
            .collect();
        push_fit(&mut scaling_series, solver, pts, &mut lcp_slope);
    }
    for solver in scene_solver_names() {
        slopes.rows.push(vec![
            solver.to_owned(),
            lcp_slope.get(solver).cloned().unwrap_or("–".into()),
            scene_slope.get(solver).cloned().unwrap_or("–".into()),
        ]);
    }
    let path = plots_dir.join("scaling_lcp.svg");
    plot(
        &path,
        &PlotSpec {
            title: "SPD LCPs (cond 1e3): solver time against rows".into(),
            x_label: "rows n".into(),
            y_label: "solver time to 1e-8 (s)".into(),
            log_x: true,
            log_y: true,
            y_range: None,
            legend: LegendAt::LowerRight,
        },
        &scaling_series,
    )?;
    figures.push((
        "Solver time against problem size (log–log, fitted slopes)".into(),
        path,
    ));
    slopes.write_csv(&tables_dir)?;
    let _ = writeln!(
        md,
        "## Scaling\n\nLeast-squares slopes of log time against log size (converged runs only).\n\n{}",
        slopes.markdown()
    );

    // Figures.
    let _ = writeln!(md, "## Figures\n");
    for (caption, path) in &figures {
        let r = rel(path, out_dir);
        let _ = writeln!(
            md,
            "**{caption}** ([data]({}))\n\n![{caption}]({r})\n",
            rel(&path.with_extension("csv"), out_dir)
        );
    }
    let readme = out_dir.join("README.md");
    std::fs::write(&readme, md)?;
    Ok(readme)
}

fn mark(ok: usize, total: usize) -> &'static str {
    if ok == total {
        "✓"
    } else if ok == 0 {
        "✗"
    } else {
        "~"
    }
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .trim_matches('_')
        .to_owned()
}

fn push_fit(
    series: &mut Vec<Series>,
    solver: &str,
    mut pts: Vec<(f64, f64)>,
    slopes: &mut HashMap<String, String>,
) {
    if pts.is_empty() {
        return;
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let fit = loglog_fit(&pts);
    let name = match fit {
        Some((k, _)) => {
            slopes.insert(solver.to_owned(), format!("{k:.2}"));
            format!("{solver} (slope {k:.2})")
        }
        None => solver.to_owned(),
    };
    if let Some((k, c)) = fit {
        let (x0, x1) = (pts[0].0, pts[pts.len() - 1].0);
        series.push(Series {
            name: String::new(),
            color_key: solver.to_owned(),
            points: vec![
                (x0, 10f64.powf(c) * x0.powf(k)),
                (x1, 10f64.powf(c) * x1.powf(k)),
            ],
            mark: Mark::Line,
        });
    }
    series.push(Series {
        name,
        color_key: solver.to_owned(),
        points: pts,
        mark: Mark::Points,
    });
}

/// Dolan–Moré profile: for each solver, the fraction of problems it solves within `τ` times the
/// best solver's time, over the problems at least one solver solved.
fn performance_profile(
    data: &Data,
    cases: &[&Case],
    solvers: &[&'static str],
    level: f64,
) -> Vec<Series> {
    let mut ratios: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    let mut problems = 0usize;
    for case in cases {
        let times: Vec<Option<f64>> = solvers
            .iter()
            .map(|s| data.get(case, s, "tight").and_then(|r| r.tta(level)))
            .collect();
        let Some(best) = times.iter().flatten().copied().reduce(f64::min) else {
            continue;
        };
        problems += 1;
        let best = best.max(1e-9);
        for (s, t) in solvers.iter().zip(&times) {
            if let Some(t) = t {
                ratios.entry(s).or_default().push(t.max(1e-9) / best);
            }
        }
    }
    let mut out = Vec::new();
    for &s in solvers {
        let mut r = ratios.remove(s).unwrap_or_default();
        r.sort_by(f64::total_cmp);
        let points: Vec<(f64, f64)> = r
            .iter()
            .enumerate()
            .map(|(i, &tau)| (tau.max(1.0), (i + 1) as f64 / problems.max(1) as f64))
            .collect();
        let reached = r.len();
        out.push(Series {
            name: format!("{s} ({reached}/{problems})"),
            color_key: s.to_owned(),
            points,
            mark: Mark::Step,
        });
    }
    out
}

/// A Dolan–Moré profile figure (log τ, fraction solved).
fn profile_plot(path: &Path, title: String, series: &[Series]) -> Result<()> {
    plot(
        path,
        &PlotSpec {
            title,
            x_label: "τ (time / best time)".into(),
            y_label: "fraction of problems solved within τ × best".into(),
            log_x: true,
            log_y: false,
            y_range: Some((0.0, 1.02)),
            legend: LegendAt::LowerRight,
        },
        series,
    )
}

/// The cone solvers on the cone form of the exported scene steps (budget `tight`): how many
/// each brought to the cone residual 1e-4 and 1e-8, and Dolan–Moré profiles at both levels.
fn cone_profiles(
    data: &Data,
    suite: &Suite,
    tables_dir: &Path,
    plots_dir: &Path,
    figures: &mut Vec<(String, PathBuf)>,
) -> Result<String> {
    let mut md = String::new();
    let cases: Vec<&Case> = suite.exported_cases.iter().collect();
    if cases.is_empty() {
        return Ok(md);
    }
    let solvers: Vec<&'static str> = ConeSolverKind::ALL.iter().map(|k| k.name()).collect();
    let mut t = Table::new(
        "cone_time_to_accuracy",
        &[
            "solver",
            "reached 1e-4",
            "geo-mean time to 1e-4",
            "reached 1e-8",
            "geo-mean time to 1e-8",
            "converged at 1e-10",
        ],
    );
    for &s in &solvers {
        let runs: Vec<&RunRecord> = cases
            .iter()
            .filter_map(|c| data.get(c, s, "tight"))
            .collect();
        let mut row = vec![s.to_owned()];
        for level in [1e-4, 1e-8] {
            let times: Vec<f64> = runs.iter().filter_map(|r| r.tta(level)).collect();
            row.push(format!("{} of {}", times.len(), cases.len()));
            row.push(fmt_time(geo_mean(&times)));
        }
        row.push(format!(
            "{} of {}",
            runs.iter().filter(|r| r.converged).count(),
            cases.len()
        ));
        t.rows.push(row);
    }
    t.write_csv(tables_dir)?;
    let _ = writeln!(
        md,
        "## Cone solvers on the exported scene steps\n\nThe exported scene LCPs above in their \
         exact Coulomb cone form (each contact's normal and two tangent rows as one cone), solved \
         by every cone solver under budget `tight`; times to the relative cone residual (the \
         natural map with the cone projection, measured contact by contact). `clarabel-socp` \
         solves Anitescu's convex relaxation, so a sliding contact keeps it from converging \
         (its lift-off is in the run's reason). Profiles at 1e-4 and 1e-8 are in the figures.\n\n{}",
        t.markdown()
    );
    for (level, label) in [(1e-4, "1e-4"), (1e-8, "1e-8")] {
        let path = plots_dir.join(format!("profile_cone_{label}.svg"));
        let series = performance_profile(data, &cases, &solvers, level);
        profile_plot(
            &path,
            format!("Cone solvers: performance profile, cone residual {label}"),
            &series,
        )?;
        figures.push((
            format!("Dolan–Moré performance profile of the cone solvers at {label}"),
            path,
        ));
    }
    Ok(md)
}

fn scene_section(
    md: &mut String,
    data: &Data,
    suite: &Suite,
    tables_dir: &Path,
    plots_dir: &Path,
    figures: &mut Vec<(String, PathBuf)>,
) -> Result<()> {
    let _ = writeln!(
        md,
        "## Scenes\n\nEach scene stepped with each solver (budget `default` per step: tolerance \
         1e-8, 10 000 iterations; time budget for the whole run). Time/step is solver time; \
         residual is the largest shared relative residual over the steps; penetration the \
         largest depth; drift the relative change of total energy; failures count \
         non-converged steps / NaN steps / blow-up; lift-off is the largest separating normal \
         speed at a sliding contact after a solve (what a convex relaxation of friction \
         causes; Baumgarte correction of a penetrating contact shows up here too).\n"
    );
    // At a glance: scene × solver.
    let mut header = vec!["scene".to_owned()];
    header.extend(scene_solver_names().iter().map(|s| s.to_string()));
    let mut glance = Table {
        name: "scenes_at_a_glance",
        header,
        rows: Vec::new(),
    };
    for case in &suite.scene_cases {
        let mut row = vec![case.short_name()];
        for solver in scene_solver_names() {
            row.push(match data.get(case, solver, "default") {
                None => "–".into(),
                Some(r) => glance_cell(r),
            });
        }
        glance.rows.push(row);
    }
    glance.write_csv(tables_dir)?;
    let _ = writeln!(
        md,
        "### At a glance\n\nSolver time per step under budget `default`, cold start. ✓ every \
         step converged; ~ some steps did not (count in brackets); ✗ none did or the solver \
         declined the problem; `blow-up`, `time limit` (steps done in brackets: the run stops \
         after half the budget's time), `timeout`, `crash` and `panic` as recorded.\n\n{}",
        glance.markdown()
    );
    let mut all = Table::new(
        "scenes",
        &[
            "scene",
            "solver",
            "status",
            "steps",
            "contacts",
            "time/step",
            "iters/step",
            "residual max",
            "penetration max (m)",
            "energy drift",
            "failures",
            "lift-off (m/s)",
            "analytic error",
        ],
    );
    let mut fastest = Table::new(
        "scenes_fastest",
        &[
            "scene",
            "fastest at 1e-4 (budget loose)",
            "time/step",
            "fastest at 1e-8 (budget default)",
            "time/step",
        ],
    );
    for case in &suite.scene_cases {
        let mut t = Table::new(
            "scene",
            &all.header.iter().map(|s| s.as_str()).collect::<Vec<_>>()[1..],
        );
        let mut pareto = Vec::new();
        for solver in scene_solver_names() {
            if let Some(r) = data.get(case, solver, "default") {
                let cells = scene_cells(r);
                t.rows.push(cells.clone());
                let mut full = vec![case.to_string()];
                full.extend(cells);
                all.rows.push(full);
            }
            let pts: Vec<(f64, f64)> = ["realtime", "loose", "default"]
                .iter()
                .filter_map(|b| data.get(case, solver, b))
                .filter_map(|r| Some((r.time_per_step_s?, r.residual_rel_mean?)))
                .collect();
            if !pts.is_empty() {
                pareto.push(Series {
                    name: solver.to_owned(),
                    color_key: solver.to_owned(),
                    points: pts,
                    mark: Mark::Points,
                });
            }
        }
        let name = case.short_name();
        let _ = writeln!(md, "### {name}\n\n{}", t.markdown());
        let mut row = vec![name.clone()];
        for budget in ["loose", "default"] {
            let best = scene_solver_names()
                .into_iter()
                .filter_map(|s| data.get(case, s, budget))
                .filter(|r| r.converged && r.blow_up != Some(true))
                .filter_map(|r| Some((r.solver.clone(), r.time_per_step_s?)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match best {
                Some((s, tm)) => {
                    row.push(s);
                    row.push(fmt_time(Some(tm)));
                }
                None => {
                    row.push("none converged".into());
                    row.push("–".into());
                }
            }
        }
        fastest.rows.push(row);
        // Pareto front over all solvers and budgets.
        let mut every: Vec<(f64, f64)> = pareto.iter().flat_map(|s| s.points.clone()).collect();
        every.retain(|(x, y)| *x > 0.0 && *y >= 0.0);
        every.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut front = Vec::new();
        let mut best = f64::INFINITY;
        for (x, y) in every {
            if y < best {
                best = y;
                front.push((x, y.max(1e-17)));
            }
        }
        if front.len() > 1 {
            pareto.push(Series {
                name: "Pareto front".into(),
                color_key: "front".into(),
                points: front,
                mark: Mark::Reference,
            });
        }
        for s in &mut pareto {
            for p in &mut s.points {
                p.1 = p.1.max(1e-17);
            }
        }
        let path = plots_dir.join(format!("pareto_{}.svg", slug(&name)));
        plot(
            &path,
            &PlotSpec {
                title: format!("{name}: speed against accuracy (budgets realtime, loose, default)"),
                x_label: "solver time per step (s)".into(),
                y_label: "mean relative residual per step".into(),
                log_x: true,
                log_y: true,
                y_range: None,
                legend: LegendAt::LowerLeft,
            },
            &pareto,
        )?;
        figures.push((format!("Speed–accuracy on scene {name}"), path));
    }
    all.write_csv(tables_dir)?;
    fastest.write_csv(tables_dir)?;
    let _ = writeln!(
        md,
        "### Fastest solver per scene\n\nAmong runs whose every step converged.\n\n{}",
        fastest.markdown()
    );
    Ok(())
}

fn glance_cell(r: &RunRecord) -> String {
    let t = fmt_time(r.time_per_step_s);
    let steps = r.steps.unwrap_or(0);
    let nc = r.nonconverged_steps.unwrap_or(0);
    match r.status {
        _ if r.is_isolation_failure() => r.status.to_string(),
        RunStatus::BlowUp => format!("blow-up ({steps} steps)"),
        RunStatus::TimeLimit => format!("time limit ({steps} steps, {t})"),
        RunStatus::Unsupported if steps == 0 => "✗ unsupported".into(),
        _ if nc == 0 => format!("✓ {t}"),
        _ if nc >= steps => format!("✗ {t} ({})", r.status),
        _ => format!("~ {t} ({nc} nc)"),
    }
}

fn scene_cells(r: &RunRecord) -> Vec<String> {
    let failures = format!(
        "{} / {} / {}",
        r.nonconverged_steps.unwrap_or(0),
        r.nan_steps.unwrap_or(0),
        if r.blow_up == Some(true) { "yes" } else { "no" }
    );
    let analytic = match r.analytic_error {
        Some(e) => format!("{} {}", r.analytic_metric, fmt_sci(Some(e))),
        None => "–".into(),
    };
    vec![
        r.solver.clone(),
        if r.reason.is_empty() {
            r.status.to_string()
        } else {
            format!(
                "{} ({})",
                r.status,
                r.reason.chars().take(60).collect::<String>()
            )
        },
        r.steps.map(|s| s.to_string()).unwrap_or("–".into()),
        r.contacts_mean
            .map(|c| format!("{c:.1}"))
            .unwrap_or("–".into()),
        fmt_time(r.time_per_step_s),
        r.iterations_per_step
            .map(|i| format!("{i:.1}"))
            .unwrap_or("–".into()),
        fmt_sci(r.residual_rel),
        fmt_sci(r.penetration_max),
        fmt_sci(r.energy_drift),
        failures,
        fmt_sci(r.liftoff_speed),
        analytic,
    ]
}
