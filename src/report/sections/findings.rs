//! Findings: for each family of cases and each accuracy of [`ACCURACIES`], the best solver by
//! the one rule of [`crate::report::summary`], its cost, the runner-up, and a link to the
//! section whose tables are the evidence. It comes first, after the header; the other sections
//! that name a best solver use the same rule and link back here.
//!
//! Families are derived from the rows' case keys ([`family_of`]), so a report of any sweep
//! (`report --from`) has the families of the cases it ran and no others.

use crate::harness::{Case, ProblemClass, RunRecord, SolverSpec};
use crate::report::context::{Figure, ReportContext, Section};
use crate::report::summary::{rank, Candidate, ACCURACIES, RULE, SHIFT_S};
use crate::report::table::{fmt_time, Table};
use anyhow::Result;
use lcpbench_contact::step::ResidualSchedule;
use lcpbench_contact::FrictionModel;
use lcpbench_solvers::registry::Level;
use std::fmt::Write as _;

pub(super) struct Findings;

/// The families, in the order Findings lists them, each with its evidence section's heading
/// in the full report.
const FAMILIES: [(&str, &str); 16] = [
    ("towers", "Fastest solver per scene"),
    ("pyramids", "Fastest solver per scene"),
    ("piles", "Fastest solver per scene"),
    ("walls", "Fastest solver per scene"),
    ("chains and joints", "Joints"),
    ("mass ratios", "Fastest solver per scene"),
    ("other scenes", "Fastest solver per scene"),
    ("scenes under friction model none", "Friction models"),
    ("scenes under friction model box", "Friction models"),
    ("scenes under friction model pyramid", "Friction models"),
    ("scenes under friction model cone", "Friction models"),
    ("FCLIB (box-friction LCPs)", "FCLIB problems"),
    ("FC3D (cone solvers)", "Cone solvers on the FC3D collection"),
    ("scene-step LCPs", "Time to accuracy"),
    ("problem files", "Time to accuracy"),
    ("generated LCPs", "Time to accuracy"),
];

/// The family of a row's case (with its solver: a cone solver's problems are the FC3D family):
/// scenes by their file name (`tower…`, `pyramid…`, `…pile…`/`sphere…`, `wall…`,
/// `chain…`/`rope…`/`ragdoll…`/`pendulum…`/`cradle…`, `mass_ratio…`), a scene under a
/// friction model of the run's choosing, FCLIB files (`.hdf5`), other problem files, scene
/// steps and generated LCPs (the infeasible ones left out: no solver can reach an accuracy).
/// Scene runs whose residual schedule left steps unmeasured (`residual=sample=K`, `none`) are
/// in no family: Findings ranks by converged steps, which such a run does not count.
pub(crate) fn family_of(r: &RunRecord) -> Option<&'static str> {
    let case: Case = r.case.parse().ok()?;
    if matches!(&case, Case::Scene { residual: Some(s), .. } if *s != ResidualSchedule::Every) {
        return None;
    }
    // A cone solver's problems are the FC3D family; its scene runs (under the cone friction
    // model) stay with the scenes.
    if r.solver.level() == Some(Level::Cone) && !matches!(case, Case::Scene { .. }) {
        return Some("FC3D (cone solvers)");
    }
    Some(match &case {
        // One family per model: each model is its own problem, solved by its own solvers.
        Case::Scene {
            friction: Some(model),
            ..
        } => match model {
            FrictionModel::None => "scenes under friction model none",
            FrictionModel::Box => "scenes under friction model box",
            FrictionModel::Pyramid { .. } => "scenes under friction model pyramid",
            FrictionModel::Cone => "scenes under friction model cone",
        },
        Case::Scene { path, .. } => {
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().to_lowercase())
                .unwrap_or_default();
            let has = |w: &str| stem.contains(w);
            if has("tower") || has("stack") {
                "towers"
            } else if has("pyramid") {
                "pyramids"
            } else if has("pile") || has("sphere") || has("rush") {
                "piles"
            } else if has("wall") {
                "walls"
            } else if ["chain", "rope", "ragdoll", "pendulum", "cradle"]
                .iter()
                .any(|w| has(w))
            {
                "chains and joints"
            } else if has("mass_ratio") {
                "mass ratios"
            } else {
                "other scenes"
            }
        }
        Case::File(p) if p.extension().is_some_and(|e| e == "hdf5") => "FCLIB (box-friction LCPs)",
        Case::File(_) => "problem files",
        Case::SceneStep { .. } => "scene-step LCPs",
        Case::Generated { .. } if case.class() == ProblemClass::Infeasible => return None,
        Case::Generated { .. } => "generated LCPs",
    })
}

/// A GitHub-style anchor of a heading: lower case, spaces to `-`, punctuation dropped.
pub(crate) fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The heading of this section, for the links back to it.
pub(crate) const HEADING: &str = "Findings";

/// A candidate's cost: time per step (scenes) or per solve, with what it solved.
pub(crate) fn cost_cell(c: &Candidate) -> String {
    let scene = c.runs.iter().any(|r| r.steps.is_some());
    let what = if scene { "steps" } else { "problems" };
    let time = if c.no_work {
        "no contacts".to_owned()
    } else if c.solved == 0 {
        "—".to_owned()
    } else {
        format!(
            "{}{}",
            fmt_time(Some(c.mean_s)),
            if scene { "/step" } else { "" }
        )
    };
    let mut cell = format!("{time} ({}/{} {what}", c.solved, c.total);
    if c.ran < c.cases {
        let _ = write!(cell, "; ran {} of {} cases", c.ran, c.cases);
    }
    cell.push(')');
    if let Some(w) = warm_cell(c) {
        let _ = write!(cell, "; {w}");
    }
    cell
}

/// Where a warm-started candidate's start came from and what it cost, when the rows say.
fn warm_cell(c: &Candidate) -> Option<String> {
    if !c.solver.warm() {
        return None;
    }
    let r = c.runs.iter().find(|r| !r.warm_source.is_empty())?;
    Some(match r.warm_time_s {
        Some(t) => format!("warm start: {}, {}", r.warm_source, fmt_time(Some(t))),
        None => format!("warm start: {}", r.warm_source),
    })
}

/// A solver's name in a table, with `†` when it solves a relaxed problem (see the footnote).
pub(crate) fn solver_cell(s: &SolverSpec) -> String {
    match relaxation(s) {
        Some(_) => format!("{s} †"),
        None => s.to_string(),
    }
}

/// The relaxed problem a solver specification solves instead of the posed one, if any.
pub(crate) fn relaxation(s: &SolverSpec) -> Option<&'static str> {
    s.relaxation()
}

/// The footnote of `†`, naming each relaxed solver among `solvers` and its problem.
pub(crate) fn relaxation_footnote<'a>(solvers: impl IntoIterator<Item = &'a SolverSpec>) -> String {
    let mut names: Vec<(String, &'static str)> = solvers
        .into_iter()
        .filter_map(|s| Some((s.base_name(), relaxation(s)?)))
        .collect();
    names.sort();
    names.dedup();
    if names.is_empty() {
        return String::new();
    }
    let list: Vec<String> = names
        .iter()
        .map(|(n, what)| format!("`{n}`: {what}"))
        .collect();
    format!(
        "† solves a relaxed problem, not the one posed ({}); its `converged` is judged by the \
         shared residual of the posed problem all the same.\n",
        list.join("; ")
    )
}

impl Section for Findings {
    fn title(&self) -> &'static str {
        HEADING
    }

    fn render(&self, ctx: &ReportContext, md: &mut String) -> Result<Vec<Figure>> {
        let rows = ctx.timed_rows();
        let mut t = Table::new(
            "findings",
            &[
                "family",
                "cases",
                "accuracy",
                "best",
                "its cost",
                "runner-up",
                "its cost",
                "evidence",
            ],
        );
        let mut shown: Vec<SolverSpec> = Vec::new();
        for (family, evidence) in FAMILIES {
            let members: Vec<&RunRecord> = rows
                .iter()
                .copied()
                .filter(|r| family_of(r) == Some(family))
                .collect();
            if members.is_empty() {
                continue;
            }
            let mut cases: Vec<&str> = members.iter().map(|r| r.case.as_str()).collect();
            cases.sort_unstable();
            cases.dedup();
            let link = if ctx.from_sweep {
                format!("[per case](#{})", anchor(super::per_case::HEADING))
            } else {
                format!("[{evidence}](#{})", anchor(evidence))
            };
            for level in ACCURACIES {
                let ranked = rank(&members, level);
                let mut row = vec![
                    family.to_owned(),
                    cases.len().to_string(),
                    format!("{level:.0e}"),
                ];
                match ranked.first() {
                    Some(best) if best.no_work => row.extend([
                        "no contacts in any case".to_owned(),
                        "—".to_owned(),
                        "—".to_owned(),
                        "—".to_owned(),
                    ]),
                    Some(best) if best.solved > 0 => {
                        row.push(solver_cell(&best.solver));
                        row.push(cost_cell(best));
                        shown.push(best.solver.clone());
                        match ranked.get(1) {
                            Some(next) => {
                                row.push(solver_cell(&next.solver));
                                row.push(cost_cell(next));
                                shown.push(next.solver.clone());
                            }
                            None => row.extend(["—".to_owned(), "—".to_owned()]),
                        }
                    }
                    Some(_) => row.extend([
                        "none reached it".to_owned(),
                        "—".to_owned(),
                        "—".to_owned(),
                        "—".to_owned(),
                    ]),
                    None => row.extend([
                        "no run at this accuracy".to_owned(),
                        "—".to_owned(),
                        "—".to_owned(),
                        "—".to_owned(),
                    ]),
                }
                row.push(link.clone());
                t.rows.push(row);
            }
        }
        if t.rows.is_empty() {
            return Ok(Vec::new());
        }
        let _ = writeln!(
            md,
            "## {HEADING}\n\nFor each family of cases and each accuracy, the best solver by one \
             rule, used by every section that names a best solver: {RULE}. A run counts at an \
             accuracy when its budget's tolerance is that accuracy or tighter (of a solver's \
             runs on a case, its best by the same rule); the cost is the shifted geometric mean \
             (shift {:.0} µs) over every case of the family, time per step for scenes and time \
             to the accuracy for LCP and cone problems, with the steps or problems solved. \
             Families by case name: scenes `tower*`, `pyramid*`, `*pile*`/`sphere*`, `wall*`, \
             `chain*`/`rope*`/`ragdoll*`/`pendulum*`/`cradle*`, `mass_ratio*`, the rest; scenes \
             under a friction model chosen by the run, one family per model; FCLIB files (`.hdf5`) with the matrix \
             solvers; every problem the cone solvers ran (FC3D; their scene runs stay with the scenes); scene steps, other problem files, \
             generated LCPs (the infeasible ones left out).\n\n{}\n{}",
            SHIFT_S * 1e6,
            ctx.table(&t)?,
            relaxation_footnote(&shown),
        );
        Ok(Vec::new())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(case: &str, solver: &str) -> RunRecord {
        RunRecord {
            case: case.into(),
            solver: solver.parse().unwrap(),
            ..RunRecord::default()
        }
    }

    #[test]
    fn families_come_from_case_names() {
        let f = |case: &str, solver: &str| family_of(&row(case, solver));
        assert_eq!(
            f("scene:bench_scenes/tower_40_60hz.toml", "pgs"),
            Some("towers")
        );
        assert_eq!(
            f("scene:x/pyramid_3d_1015.toml?steps=10", "si"),
            Some("pyramids")
        );
        assert_eq!(f("scene:x/sphere_pile_100.toml", "pgs"), Some("piles"));
        assert_eq!(f("scene:x/sphere_stack.toml", "pgs"), Some("towers"));
        assert_eq!(f("scene:x/rush.toml", "pgs"), Some("piles"));
        assert_eq!(f("scene:x/scaling/wall_5x3.toml", "pgs"), Some("walls"));
        assert_eq!(
            f("scene:x/joints/chain_20_1e3.toml", "si"),
            Some("chains and joints")
        );
        assert_eq!(
            f("scene:x/mass_ratio_heavy_on_light_10.toml", "lemke"),
            Some("mass ratios")
        );
        assert_eq!(f("scene:x/ball_drop.toml", "pgs"), Some("other scenes"));
        assert_eq!(
            f(
                "scene:x/tower_10_60hz.toml?steps=5&friction=cone",
                "nsgs-cone+warm"
            ),
            Some("scenes under friction model cone")
        );
        assert_eq!(
            f(
                "scene:x/tower_10_60hz.toml?steps=5&friction=box",
                "pgs+warm"
            ),
            Some("scenes under friction model box")
        );
        assert_eq!(
            f("file:a/b.hdf5", "lemke"),
            Some("FCLIB (box-friction LCPs)")
        );
        assert_eq!(f("file:a/b.hdf5", "newton-ac"), Some("FC3D (cone solvers)"));
        assert_eq!(f("file:a/b.json", "lemke"), Some("problem files"));
        assert_eq!(f("spd:n=8:cond=1e2:seed=1", "pgs"), Some("generated LCPs"));
        assert_eq!(f("infeasible:n=8:seed=1", "pgs"), None);
    }

    #[test]
    fn anchors_are_githubs() {
        assert_eq!(
            anchor("Fastest solver per scene"),
            "fastest-solver-per-scene"
        );
        assert_eq!(
            anchor("Towers at 60 Hz, low budgets"),
            "towers-at-60-hz-low-budgets"
        );
        assert_eq!(anchor("FCLIB problems"), "fclib-problems");
    }

    #[test]
    fn relaxed_solvers_are_marked() {
        let clarabel: SolverSpec = "clarabel".parse().unwrap();
        let penalty: SolverSpec = "penalty".parse().unwrap();
        let socp: SolverSpec = "clarabel-socp".parse().unwrap();
        let pgs: SolverSpec = "pgs".parse().unwrap();
        assert_eq!(solver_cell(&clarabel), "clarabel †");
        assert_eq!(solver_cell(&penalty), "penalty †");
        assert_eq!(solver_cell(&socp), "clarabel-socp †");
        assert_eq!(solver_cell(&pgs), "pgs");
        let note = relaxation_footnote([&clarabel, &pgs, &penalty]);
        assert!(
            note.contains("`clarabel`: on friction rows, Anitescu"),
            "{note}"
        );
        assert!(
            note.contains("`penalty`: a soft spring-damper penalty model"),
            "{note}"
        );
        assert!(!note.contains("`pgs`"));
    }
}
