//! The machines the rows ran on (the `host`, `cpu_model` and `cores` columns), and the rows the
//! timing tables use: times measured on different machines do not compare, so when the rows come
//! from several, every table and figure that shows times uses the rows of one machine only, the
//! one with the most rows (ties: the first by host name), and the overview says so. The
//! robustness matrix, which counts statuses, uses every row.

use crate::harness::machine::Machine;
use crate::harness::{HistoryRow, RunKey, RunRecord};
use std::collections::{BTreeMap, HashSet};

/// The machines of a report's rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Machines {
    /// Each machine (`None`: rows that do not record one) with its row count, most rows first
    /// (ties by machine).
    pub(super) counts: Vec<(Option<Machine>, usize)>,
}

impl Machines {
    pub(super) fn of(rows: &[RunRecord]) -> Self {
        let mut by_machine: BTreeMap<Option<Machine>, usize> = BTreeMap::new();
        for r in rows {
            *by_machine.entry(r.machine()).or_default() += 1;
        }
        let mut counts: Vec<(Option<Machine>, usize)> = by_machine.into_iter().collect();
        // Stable: equal counts keep the machines' order.
        counts.sort_by_key(|(_, n)| std::cmp::Reverse(*n));
        Self { counts }
    }

    /// True when the rows come from more than one machine.
    pub(super) fn several(&self) -> bool {
        self.counts.len() > 1
    }

    /// The machine whose rows the timing tables use, and its row count (when there are several
    /// machines).
    pub(super) fn timing(&self) -> Option<(&Option<Machine>, usize)> {
        self.several()
            .then(|| self.counts.first().map(|(m, n)| (m, *n)))
            .flatten()
    }

    /// True when `r` is one of the rows the timing tables use.
    pub(super) fn timed(&self, r: &RunRecord) -> bool {
        self.timing().is_none_or(|(m, _)| r.machine() == *m)
    }

    /// The history rows of the runs the timing tables use (all of them with one machine).
    pub(super) fn timed_histories(
        &self,
        rows: &[RunRecord],
        histories: Vec<HistoryRow>,
    ) -> Vec<HistoryRow> {
        if !self.several() {
            return histories;
        }
        let timed: HashSet<RunKey> = rows
            .iter()
            .filter(|r| self.timed(r))
            .map(RunRecord::key)
            .collect();
        histories
            .into_iter()
            .filter(|h| timed.contains(&h.key()))
            .collect()
    }
}

/// A machine's name in the report.
pub(super) fn describe(machine: &Option<Machine>) -> String {
    match machine {
        Some(m) => m.to_string(),
        None => "rows without a recorded machine".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(case: &str, host: Option<&str>) -> RunRecord {
        let mut r = RunRecord {
            case: case.into(),
            solver: "pgs".into(),
            budget: "default".into(),
            ..RunRecord::default()
        };
        if let Some(h) = host {
            r.set_machine(&Machine {
                host: h.into(),
                cpu_model: "cpu".into(),
                cores: 4,
            });
        }
        r
    }

    #[test]
    fn the_timing_rows_are_those_of_the_machine_with_the_most_rows() {
        let one = [row("a", Some("x")), row("b", Some("x"))];
        let m = Machines::of(&one);
        assert!(!m.several() && m.timing().is_none());
        assert!(one.iter().all(|r| m.timed(r)));
        let rows = [
            row("a", Some("x")),
            row("b", Some("y")),
            row("c", Some("y")),
            row("d", None),
        ];
        let m = Machines::of(&rows);
        assert!(m.several());
        let (machine, count) = m.timing().unwrap();
        assert_eq!((machine.as_ref().unwrap().host.as_str(), count), ("y", 2));
        let timed: Vec<&str> = rows
            .iter()
            .filter(|r| m.timed(r))
            .map(|r| r.case.as_str())
            .collect();
        assert_eq!(timed, ["b", "c"]);
        let history = |case: &str| HistoryRow {
            case: case.into(),
            solver: "pgs".into(),
            budget: "default".into(),
            iteration: 1,
            time_s: 0.0,
            residual: 1.0,
        };
        let kept = m.timed_histories(&rows, vec![history("a"), history("c")]);
        assert_eq!(kept, vec![history("c")]);
        // Ties go to the first machine by host name.
        let tie = Machines::of(&[row("a", Some("y")), row("b", Some("x"))]);
        assert_eq!(tie.timing().unwrap().0.as_ref().unwrap().host, "x");
    }

    /// A report from rows of two machines: the overview names both and says whose rows the
    /// timing tables use; the fastest solver is the fastest on that machine, not the fastest
    /// row; the robustness matrix counts the other machine's rows too.
    #[test]
    fn timing_tables_use_one_machine_and_the_robustness_matrix_every_row() {
        use crate::harness::{Case, RunStatus};
        use crate::report::machine::Header;
        use crate::report::suite::Suite;

        let spd: Case = "spd:n=8:cond=1e2:seed=1".parse().unwrap();
        let run = |solver: &str, budget: &str, tta: f64, host: &str| {
            let mut r = row(&spd.to_string(), Some(host));
            r.class = spd.class().name().to_owned();
            r.solver = solver.into();
            r.solver_base = solver.into();
            r.budget = budget.into();
            r.status = RunStatus::Converged;
            r.converged = true;
            r.n = Some(8);
            r.solve_time_s = Some(tta);
            r.tta_1e4 = Some(tta);
            r.tta_1e8 = Some(tta);
            r
        };
        let rows = [
            run("pgs", "tight", 2e-3, "a"),
            run("lemke", "tight", 1e-3, "a"),
            run("lemke", "default", 1e-3, "a"),
            run("newton-fb", "tight", 1e-6, "b"),
            run("pgs", "default", 1e-3, "b"),
        ];
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("data")).unwrap();
        let mut w = csv::Writer::from_path(dir.path().join("data/results.csv")).unwrap();
        for r in &rows {
            w.serialize(r).unwrap();
        }
        w.flush().unwrap();
        let suite = Suite {
            matrix_cases: vec![spd],
            ..Suite::default()
        };
        let header = Header {
            cpu: "cpu".into(),
            cores: 2,
            os: "os".into(),
            commit: "abc".into(),
            date: "today".into(),
            command: "lcpbench report --no-run".into(),
            workers: 2,
        };
        let readme = crate::report::write_report(dir.path(), &suite, &header, 0.0).unwrap();
        let md = std::fs::read_to_string(readme).unwrap();
        assert!(
            md.contains("| machine | a (cpu, 4 cores): 3 rows; b (cpu, 4 cores): 2 rows |"),
            "{md}"
        );
        assert!(md.contains("**Timings from 2 machines.**"), "{md}");
        assert!(
            md.contains("only the 3 rows of the machine with the most rows, a (cpu, 4 cores);"),
            "{md}"
        );
        let fastest = std::fs::read_to_string(dir.path().join("tables/fastest.csv")).unwrap();
        let line = fastest.lines().nth(1).unwrap();
        assert!(
            line.contains(",lemke,") && !line.contains("newton-fb"),
            "{fastest}"
        );
        let robust = std::fs::read_to_string(dir.path().join("tables/robustness.csv")).unwrap();
        let pgs = robust.lines().find(|l| l.starts_with("pgs,")).unwrap();
        assert!(pgs.contains("✓ 1/1"), "{robust}");
    }
}
