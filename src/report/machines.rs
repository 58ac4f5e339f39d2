//! The machines the rows ran on (the `host`, `cpu_model` and `cores` columns), and the rows the
//! timing tables use. Times compare only on the same hardware, so rows are grouped by *kind of
//! machine*, a CPU model and core count: the hosts of one kind (the nodes of a homogeneous
//! cluster partition) count as one machine for timings. When the rows come from several kinds,
//! every table and figure that shows times uses the rows of one kind only, the one with the most
//! rows (ties: the first by CPU model), and the overview says so and lists the hosts. The
//! robustness matrix, which counts statuses, uses every row.

use super::machine::escape_cell;
use crate::harness::{HistoryRow, RunKey, RunRecord};
use std::collections::{BTreeMap, BTreeSet, HashSet};

/// A CPU model and core count: rows of one kind compare in time, whichever host ran them.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(super) struct MachineKind {
    cpu_model: String,
    cores: usize,
}

impl MachineKind {
    /// The kind of machine `r` ran on, when the row records it.
    fn of(r: &RunRecord) -> Option<Self> {
        r.machine().map(|m| MachineKind {
            cpu_model: m.cpu_model,
            cores: m.cores,
        })
    }
}

/// The rows of one kind of machine.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct MachineGroup {
    /// The kind (`None`: rows that record no machine).
    pub(super) kind: Option<MachineKind>,
    /// The hosts that ran them.
    pub(super) hosts: BTreeSet<String>,
    /// How many rows.
    pub(super) rows: usize,
}

impl MachineGroup {
    /// The group's name in the report: `CPU, N cores on HOST` (or `on K hosts (A, B, …)`).
    pub(super) fn describe(&self) -> String {
        let Some(kind) = &self.kind else {
            return "rows without a recorded machine".to_owned();
        };
        // Host and CPU model came from the rows (other machines, merged shards): escaped.
        let hosts: Vec<String> = self.hosts.iter().map(|h| escape_cell(h)).collect();
        let on = match &hosts[..] {
            [one] => one.clone(),
            few if few.len() <= 3 => format!("{} hosts ({})", few.len(), few.join(", ")),
            many => format!("{} hosts ({}, …)", many.len(), many[..3].join(", ")),
        };
        format!(
            "{}, {} cores on {on}",
            escape_cell(&kind.cpu_model),
            kind.cores
        )
    }
}

/// The machines of a report's rows.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Machines {
    /// The rows by kind of machine, most rows first (ties by kind).
    pub(super) groups: Vec<MachineGroup>,
}

impl Machines {
    pub(super) fn of(rows: &[RunRecord]) -> Self {
        let mut by_kind: BTreeMap<Option<MachineKind>, MachineGroup> = BTreeMap::new();
        for r in rows {
            let kind = MachineKind::of(r);
            let group = by_kind.entry(kind.clone()).or_insert(MachineGroup {
                kind,
                hosts: BTreeSet::new(),
                rows: 0,
            });
            group.rows += 1;
            if let Some(host) = &r.host {
                group.hosts.insert(host.clone());
            }
        }
        let mut groups: Vec<MachineGroup> = by_kind.into_values().collect();
        // Stable: equal counts keep the kinds' order.
        groups.sort_by_key(|g| std::cmp::Reverse(g.rows));
        Self { groups }
    }

    /// True when the rows come from more than one kind of machine.
    pub(super) fn several(&self) -> bool {
        self.groups.len() > 1
    }

    /// The group whose rows the timing tables use, when there are several kinds of machine.
    pub(super) fn timing(&self) -> Option<&MachineGroup> {
        self.groups.first().filter(|_| self.several())
    }

    /// True when `r` is one of the rows the timing tables use.
    pub(super) fn timed(&self, r: &RunRecord) -> bool {
        self.timing().is_none_or(|g| MachineKind::of(r) == g.kind)
    }

    /// The history rows of the runs the timing tables use (all of them with one kind).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::machine::Machine;
    use crate::harness::{BudgetName, SolverSpec};
    use crate::report::write_results_for_tests;
    use lcpbench_solvers::SolverKind;

    /// A row of `case` run on (host, CPU model), 4 cores.
    fn row(case: &str, machine: Option<(&str, &str)>) -> RunRecord {
        let mut r = RunRecord {
            case: case.into(),
            ..RunRecord::default()
        };
        if let Some((host, cpu)) = machine {
            r.set_machine(&Machine {
                host: host.into(),
                cpu_model: cpu.into(),
                cores: 4,
            });
        }
        r
    }

    #[test]
    fn the_timing_rows_are_those_of_the_kind_of_machine_with_the_most_rows() {
        let one = [row("a", Some(("x", "cpu"))), row("b", Some(("y", "cpu")))];
        let m = Machines::of(&one);
        assert!(!m.several() && m.timing().is_none());
        assert_eq!(m.groups[0].describe(), "cpu, 4 cores on 2 hosts (x, y)");
        let hosts: Vec<RunRecord> = ["h1", "h2", "h3", "h4"]
            .iter()
            .map(|h| row(h, Some((h, "cpu"))))
            .collect();
        let four = Machines::of(&hosts);
        assert_eq!(
            four.groups[0].describe(),
            "cpu, 4 cores on 4 hosts (h1, h2, h3, …)"
        );
        assert!(one.iter().all(|r| m.timed(r)));
        let rows = [
            row("a", Some(("x", "slow"))),
            row("b", Some(("y", "fast"))),
            row("c", Some(("z", "fast"))),
            row("d", None),
        ];
        let m = Machines::of(&rows);
        assert!(m.several());
        let timing = m.timing().unwrap();
        assert_eq!(
            (timing.describe(), timing.rows),
            ("fast, 4 cores on 2 hosts (y, z)".into(), 2)
        );
        let timed: Vec<&str> = rows
            .iter()
            .filter(|r| m.timed(r))
            .map(|r| r.case.as_str())
            .collect();
        assert_eq!(timed, ["b", "c"]);
        let history = |case: &str| HistoryRow {
            case: case.into(),
            solver: SolverSpec::plain(SolverKind::Pgs),
            budget: BudgetName::Default,
            iteration: 1,
            time_s: 0.0,
            residual: 1.0,
        };
        let kept = m.timed_histories(&rows, vec![history("a"), history("c")]);
        assert_eq!(kept, vec![history("c")]);
        // Ties go to the first kind by CPU model.
        let tie = Machines::of(&[row("a", Some(("x", "b"))), row("b", Some(("x", "a")))]);
        assert_eq!(tie.timing().unwrap().describe(), "a, 4 cores on x");
    }

    /// A report from rows of two kinds of machine: the overview names both and says whose rows
    /// the timing tables use; the fastest solver is the fastest on that machine, not the fastest
    /// row; the robustness matrix counts the other machine's rows too.
    #[test]
    fn timing_tables_use_one_kind_of_machine_and_the_robustness_matrix_every_row() {
        use crate::harness::{Case, RunStatus};
        use crate::report::machine::Header;
        use crate::report::suite::Suite;

        let spd: Case = "spd:n=8:cond=1e2:seed=1".parse().unwrap();
        let run = |solver: SolverKind, budget: BudgetName, tta: f64, cpu: &str| {
            let mut r = row(&spd.to_string(), Some(("node", cpu)));
            r.class = spd.class();
            r.solver = SolverSpec::plain(solver);
            r.solver_base = solver.name().into();
            r.budget = budget;
            r.status = RunStatus::Converged;
            r.converged = true;
            r.n = Some(8);
            r.solve_time_s = Some(tta);
            r.tta_1e4 = Some(tta);
            r.tta_1e8 = Some(tta);
            r
        };
        let rows = [
            run(SolverKind::Pgs, BudgetName::Tight, 2e-3, "a"),
            run(SolverKind::Lemke, BudgetName::Tight, 1e-3, "a"),
            run(SolverKind::Lemke, BudgetName::Default, 1e-3, "a"),
            run(SolverKind::NewtonFb, BudgetName::Tight, 1e-6, "b"),
            run(SolverKind::Pgs, BudgetName::Default, 1e-3, "b"),
        ];
        let dir = tempfile::tempdir().unwrap();
        write_results_for_tests(dir.path(), &rows);
        let suite = Suite {
            matrix_cases: vec![spd],
            ..Suite::default()
        };
        let header = Header::for_tests("lcpbench report --no-run", 2);
        let readme = crate::report::write_report(dir.path(), &suite, &header, 0.0).unwrap();
        let md = std::fs::read_to_string(readme).unwrap();
        assert!(
            md.contains("| machine | a, 4 cores on node: 3 rows; b, 4 cores on node: 2 rows |"),
            "{md}"
        );
        assert!(md.contains("**Timings from 2 kinds of machine.**"), "{md}");
        assert!(
            md.contains("only the 3 rows of the kind with the most rows, a, 4 cores on node;"),
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
